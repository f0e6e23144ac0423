#include "avsp/results/vehicle_record.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace avsp
{
namespace results
{
void validateVehicles(const std::vector<VehicleSpec>& vehicles)
{
  if (vehicles.empty())
    throw std::invalid_argument("vehicles must list at least one vehicle");
  std::set<std::string> names;
  for (std::size_t k = 0; k < vehicles.size(); ++k)
  {
    const std::string where = "vehicles[" + std::to_string(k) + "]";
    if (vehicles[k].name.empty())
      throw std::invalid_argument(where + ".name must not be empty");
    if (!names.insert(vehicles[k].name).second)
      throw std::invalid_argument(where + ".name '" + vehicles[k].name + "' is listed twice");
  }
  for (std::size_t k = 0; k < vehicles.size(); ++k)
  {
    const VehicleSpec& v = vehicles[k];
    const std::string where = "vehicles[" + std::to_string(k) + "].leader '" + v.leader + "'";
    if (v.leader.empty())
      continue;
    if (v.leader == v.name)
      throw std::invalid_argument(where + " is the vehicle itself");
    if (names.count(v.leader) == 0)
      throw std::invalid_argument(where + " is not a listed vehicle");
  }
}

std::optional<double> maxDrivenSlip(const std::vector<ContactSlip>& contacts)
{
  std::optional<double> out;
  for (const ContactSlip& c : contacts)
  {
    if (!c.driven || !(c.normal_force > 0.0))
      continue;
    if (!std::isfinite(c.slip))
      return std::nullopt;
    out = out ? std::max(*out, c.slip) : c.slip;
  }
  return out;
}

OdometryAdded VehicleRecord::addOdometry(double t, double x, double y, double z, double speed)
{
  if (!std::isfinite(t) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || !std::isfinite(speed))
    return OdometryAdded::kRefused;
  OdometrySample s{ t, x, y, z, std::abs(speed), 0.0 };
  if (count_ > 0)
  {
    const OdometrySample& p = last_;
    if (t < p.t)
      return OdometryAdded::kRefused;
    if (t == p.t)
      return OdometryAdded::kRepeat;
    s.distance = p.distance + std::sqrt((x - p.x) * (x - p.x) + (y - p.y) * (y - p.y) + (z - p.z) * (z - p.z));
    bounds_ = { std::min(bounds_[0], x), std::min(bounds_[1], y), std::max(bounds_[2], x), std::max(bounds_[3], y) };
  }
  else
  {
    first_ = s;
    bounds_ = { x, y, x, y };
  }
  max_speed_ = std::max(max_speed_, s.speed);
  last_ = s;
  ++count_;
  return OdometryAdded::kSample;
}

std::optional<OdometrySample> VehicleRecord::first() const
{
  return count_ ? std::optional<OdometrySample>(first_) : std::nullopt;
}

std::optional<OdometrySample> VehicleRecord::last() const
{
  return count_ ? std::optional<OdometrySample>(last_) : std::nullopt;
}

std::optional<std::array<double, 4>> VehicleRecord::bounds() const
{
  return count_ ? std::optional<std::array<double, 4>>(bounds_) : std::nullopt;
}

std::optional<double> VehicleRecord::meanSpeed() const
{
  if (count_ < 2 || !(last_.t > first_.t))
    return std::nullopt;
  return distance() / (last_.t - first_.t);
}

bool VehicleRecord::addTelemetry(double t, std::optional<double> max_slip, bool stuck, std::uint32_t collisions)
{
  if (!std::isfinite(t) || (telemetry_count_ > 0 && t < last_telemetry_t_))
    return false;
  if (telemetry_count_ > 0 && last_stuck_)
    time_stuck_ += t - last_telemetry_t_;
  if (max_slip && std::isfinite(*max_slip))
    max_slip_ = max_slip_ ? std::max(*max_slip_, *max_slip) : *max_slip;
  last_telemetry_t_ = t;
  last_stuck_ = stuck;
  collisions_ = collisions;
  ++telemetry_count_;
  return true;
}

std::optional<std::uint32_t> VehicleRecord::collisions() const
{
  if (telemetry_count_ == 0)
    return std::nullopt;
  return collisions_;
}

}  // namespace results
}  // namespace avsp
