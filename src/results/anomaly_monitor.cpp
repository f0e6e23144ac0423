// Physically implausible vehicle states in a run (anomaly_monitor.hpp).
#include "avsp/results/anomaly_monitor.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace avsp
{
namespace results
{
namespace
{
std::string format(const char* fmt, double a, double b, double c)
{
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, fmt, a, b, c);
  return buffer;
}
}  // namespace

void AnomalyMonitor::addVehicle(const std::string& name, const VehicleLimits& limits)
{
  if (!(std::isfinite(limits.max_speed) && limits.max_speed > 0.0) ||
      !(std::isfinite(limits.wheel_radius) && limits.wheel_radius > 0.0) || !std::isfinite(limits.rest_height))
    throw std::invalid_argument("vehicle '" + name +
                                "': max_speed and wheel_radius must be finite and > 0, rest_height finite");
  vehicles_[name] = Entry{ limits, AnomalyCounts() };
}

std::string AnomalyMonitor::sample(const std::string& vehicle, double t, double x, double y, double z, double speed,
                                   std::optional<double> ground)
{
  const auto it = vehicles_.find(vehicle);
  if (it == vehicles_.end())
    return "";
  Entry& e = it->second;
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || !std::isfinite(speed))
    return e.counts.non_finite++ == 0 ? vehicle + format(": non-finite state at %.3f s (%g, %g)", t, x, y) : "";
  std::string first;
  if (speed > kOverspeedFactor * e.limits.max_speed && e.counts.overspeed++ == 0)
    first = vehicle + format(": %.2f m/s at %.3f s, above 1.5 x its governed %.2f m/s", speed, t, e.limits.max_speed);
  if (ground)
  {
    const double above = z - *ground - e.limits.rest_height;
    if (above > e.limits.wheel_radius && e.counts.airborne++ == 0)
      first += (first.empty() ? "" : "; ") + vehicle +
               format(": base_link %.2f m above its rest height at %.3f s (wheel radius %.2f m)", above, t,
                      e.limits.wheel_radius);
  }
  return first;
}

const AnomalyCounts& AnomalyMonitor::counts(const std::string& vehicle) const
{
  static const AnomalyCounts none;
  const auto it = vehicles_.find(vehicle);
  return it == vehicles_.end() ? none : it->second.counts;
}

std::size_t AnomalyMonitor::total() const
{
  std::size_t n = 0;
  for (const auto& [name, e] : vehicles_)
    n += e.counts.total();
  return n;
}

}  // namespace results
}  // namespace avsp
