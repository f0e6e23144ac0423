#include "avsp_dynamics/drivetrain.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace avsp
{
namespace dynamics
{
namespace
{
// Checks one field; appends to `why` when it is non-finite or outside [lo, hi].
void checkField(const char* name, double value, double lo, double hi, bool& non_finite, bool& clamped,
                std::ostringstream& why)
{
  if (!std::isfinite(value))
  {
    non_finite = true;
    why << (why.tellp() > 0 ? "; " : "") << name << " is " << value;
  }
  else if (value < lo || value > hi)
  {
    clamped = true;
    why << (why.tellp() > 0 ? "; " : "") << name << "=" << value << " outside [" << lo << ", " << hi << "]";
  }
}
}  // namespace

CommandCheck checkCommand(DriveCommand& command, std::string& why)
{
  why.clear();
  // The usual case, every physics step: no stream built (a NaN fails these comparisons).
  if (command.throttle >= 0.0 && command.throttle <= 1.0 && command.brake >= 0.0 && command.brake <= 1.0 &&
      command.steering >= -1.0 && command.steering <= 1.0)
    return CommandCheck::kAccepted;
  bool non_finite = false;
  bool clamped = false;
  std::ostringstream reasons;
  checkField("throttle", command.throttle, 0.0, 1.0, non_finite, clamped, reasons);
  checkField("brake", command.brake, 0.0, 1.0, non_finite, clamped, reasons);
  checkField("steering", command.steering, -1.0, 1.0, non_finite, clamped, reasons);
  why = reasons.str();
  if (non_finite)
    return CommandCheck::kRejected;
  command.throttle = std::clamp(command.throttle, 0.0, 1.0);
  command.brake = std::clamp(command.brake, 0.0, 1.0);
  command.steering = std::clamp(command.steering, -1.0, 1.0);
  return clamped ? CommandCheck::kClamped : CommandCheck::kAccepted;
}

DriveCommand clampedCommand(const DriveCommand& command)
{
  DriveCommand out = command;
  std::string why;
  if (checkCommand(out, why) != CommandCheck::kRejected)
    return out;
  // Every offending field named as DriveCommand.<field>: "DriveCommand.throttle is nan; DriveCommand.brake=2 ...".
  std::string fields = "DriveCommand." + why;
  for (std::size_t at = fields.find("; "); at != std::string::npos; at = fields.find("; ", at + 2))
    fields.insert(at + 2, "DriveCommand.");
  throw CommandError(fields + ": the command is rejected (finite values are clamped to their range)");
}

double governorFactor(double engine_speed, double governed_engine_speed)
{
  // A 5 % ramp instead of a cut: a step in torque at the governed speed would make the
  // speed chatter around it from one physics step to the next.
  const double band = 0.05 * governed_engine_speed;
  return std::clamp((governed_engine_speed - std::abs(engine_speed)) / band, 0.0, 1.0);
}

double engineTorqueLimit(const DrivetrainSpec& drivetrain, double engine_speed)
{
  const double w = std::abs(engine_speed);
  if (w * drivetrain.engine_max_torque <= drivetrain.engine_max_power)
    return drivetrain.engine_max_torque;
  return drivetrain.engine_max_power / w;
}

double wheelTorqueAvailable(const DrivetrainSpec& drivetrain, double wheel_speed, double radius)
{
  const double engine_speed = drivetrain.gear_ratio * wheel_speed;
  const double governed = drivetrain.gear_ratio * drivetrain.max_speed / radius;
  return drivetrain.efficiency * drivetrain.gear_ratio * engineTorqueLimit(drivetrain, engine_speed) *
         governorFactor(engine_speed, governed);
}

double driveTorque(const DrivetrainSpec& drivetrain, double throttle, bool reverse, double wheel_speed, double radius)
{
  if (!reverse)
    return throttle * wheelTorqueAvailable(drivetrain, wheel_speed, radius);
  DrivetrainSpec backwards = drivetrain;
  backwards.max_speed = drivetrain.reverse_max_speed;
  return -throttle * wheelTorqueAvailable(backwards, wheel_speed, radius);
}

AckermannGeometry::AckermannGeometry(const VehicleModel& model)
{
  double unsteered_x = 0.0;
  int unsteered = 0;
  for (const WheelSpec& w : model.wheels)
  {
    positions_.emplace_back(w.rest_position.x(), w.rest_position.y());
    steered_.push_back(!w.steering_joint.empty());
    if (w.steering_joint.empty())
    {
      unsteered_x += w.rest_position.x();
      ++unsteered;
    }
  }
  if (unsteered == 0 || unsteered == static_cast<int>(model.wheels.size()))
    throw ConfigError(model.yaml_path + ": key 'wheels': Ackermann steering needs steered and unsteered wheels " +
                      "(the unsteered axle is the turning centre's line)");
  x_ref_ = unsteered_x / unsteered;
  const double tan_max = std::tan(model.steering.max_angle);
  double kappa_max = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < positions_.size(); ++i)
  {
    if (!steered_[i])
      continue;
    const double a = positions_[i].x() - x_ref_;
    wheelbase_ = std::max(wheelbase_, std::abs(a));
    // Full lock in either direction is where this wheel, on the inner side, reaches max_angle.
    const double inner = std::abs(a) + std::abs(positions_[i].y()) * tan_max;
    kappa_max = std::min(kappa_max, tan_max / inner);
  }
  if (!(wheelbase_ > 0.0))
    throw ConfigError(model.yaml_path + ": key 'wheels': steered wheels sit on the unsteered axle (wheelbase 0)");
  max_centre_angle_ = std::atan(wheelbase_ * kappa_max);
}

double AckermannGeometry::wheelAngle(std::size_t index, double centre_angle) const
{
  if (!steered_.at(index))
    return 0.0;
  const double kappa = std::tan(centre_angle) / wheelbase_;
  const double a = positions_[index].x() - x_ref_;
  return std::atan(a * kappa / (1.0 - positions_[index].y() * kappa));
}

std::pair<double, double> skidSteerSides(double throttle, double steering)
{
  const double inner = throttle * (1.0 - 2.0 * std::abs(steering));
  // + steering turns left: the left side is the inner one.
  return steering >= 0.0 ? std::make_pair(inner, throttle) : std::make_pair(throttle, inner);
}

std::pair<double, double> trackedSides(double throttle, double steering, double pivot)
{
  return skidSteerSides(std::max(throttle, pivot * std::abs(steering)), steering);
}

}  // namespace dynamics
}  // namespace avsp
