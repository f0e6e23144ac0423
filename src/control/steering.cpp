#include "avsp/control/steering.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "avsp_dynamics/drivetrain.hpp"
#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace control
{
SteeringGeometry steeringGeometry(const dynamics::VehicleModel& model, double track_width_factor)
{
  if (!std::isfinite(track_width_factor) || track_width_factor < 1.0)
    throw std::invalid_argument("track_width_factor = " + std::to_string(track_width_factor) +
                                " must be finite and >= 1");
  SteeringGeometry g;
  g.max_speed = model.drivetrain.max_speed;
  if (model.drive_type == dynamics::DriveType::kAckermann)
  {
    const dynamics::AckermannGeometry ackermann(model);
    g.kind = SteeringKind::kAckermann;
    g.wheelbase = ackermann.wheelbase();
    g.max_angle = ackermann.maxCentreAngle();
    g.reference_x = ackermann.referenceX();
  }
  else
  {
    g.kind = SteeringKind::kDifferential;
    g.effective_track_width = model.trackWidth() * track_width_factor;
    g.reference_x = 0.0;
  }
  return g;
}

double steeringForCurvature(const SteeringGeometry& g, double curvature)
{
  if (!std::isfinite(curvature))
    return 0.0;
  double s = 0.0;
  if (g.kind == SteeringKind::kAckermann)
    s = std::atan(curvature * g.wheelbase) / g.max_angle;
  else
    s = curvature * g.effective_track_width / (2.0 + std::abs(curvature) * g.effective_track_width);
  return std::clamp(s, -1.0, 1.0);
}

double curvatureForSteering(const SteeringGeometry& g, double steering)
{
  steering = std::clamp(steering, -1.0, 1.0);
  if (g.kind == SteeringKind::kAckermann)
    return std::tan(steering * g.max_angle) / g.wheelbase;
  if (std::abs(steering) >= 1.0)
    return std::copysign(std::numeric_limits<double>::infinity(), steering);
  return 2.0 * steering / (g.effective_track_width * (1.0 - std::abs(steering)));
}

double throttleFeedforward(const SteeringGeometry& g, double speed, double steering)
{
  if (g.kind == SteeringKind::kAckermann || speed <= 0.0)
    return 0.0;
  const double centre_fraction = 1.0 - std::min(std::abs(steering), 1.0);
  if (centre_fraction <= 1e-6)
    return 1.0;
  return std::min(1.0, speed / (g.max_speed * centre_fraction));
}

const char* toString(SteeringKind kind)
{
  return kind == SteeringKind::kAckermann ? "ackermann" : "differential";
}

}  // namespace control
}  // namespace avsp
