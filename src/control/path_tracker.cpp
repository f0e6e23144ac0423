#include "avsp/control/path_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace control
{
void validate(const TrackingOptions& o)
{
  validate(o.lookahead);
  validate(o.pid);
  if (!std::isfinite(o.coast_band) || o.coast_band < 0.0 || o.coast_band >= 1.0)
    throw std::invalid_argument("coast_band = " + std::to_string(o.coast_band) + " must be finite and in [0, 1)");
  if (!std::isfinite(o.brake_gain) || o.brake_gain <= 0.0 || o.brake_gain > 100.0)
    throw std::invalid_argument("brake_gain = " + std::to_string(o.brake_gain) + " must be finite and in (0, 100]");
  if (!std::isfinite(o.max_accel) || o.max_accel <= 0.0 || o.max_accel > 100.0)
    throw std::invalid_argument("max_accel = " + std::to_string(o.max_accel) +
                                " must be finite and in (0, 100] (m/s^2)");
}

void validate(const SteeringGeometry& g)
{
  if (!std::isfinite(g.max_speed) || g.max_speed <= 0.0)
    throw std::invalid_argument("max_speed = " + std::to_string(g.max_speed) + " must be finite and > 0 (m/s)");
  if (!std::isfinite(g.reference_x))
    throw std::invalid_argument("reference_x must be finite (m)");
  if (g.kind == SteeringKind::kAckermann)
  {
    if (!std::isfinite(g.wheelbase) || g.wheelbase <= 0.0)
      throw std::invalid_argument("wheelbase = " + std::to_string(g.wheelbase) + " must be finite and > 0 (m)");
    if (!std::isfinite(g.max_angle) || g.max_angle <= 0.0 || g.max_angle >= M_PI / 2.0)
      throw std::invalid_argument("max_angle = " + std::to_string(g.max_angle) + " must be in (0, pi/2) (rad)");
  }
  else if (!std::isfinite(g.effective_track_width) || g.effective_track_width <= 0.0)
  {
    throw std::invalid_argument("effective_track_width = " + std::to_string(g.effective_track_width) +
                                " must be finite and > 0 (m)");
  }
}

namespace
{
const SteeringGeometry& checked(const SteeringGeometry& g, const TrackingOptions& o)
{
  validate(g);
  validate(o);
  return g;
}
}  // namespace

PathTracker::PathTracker(const SteeringGeometry& geometry, const TrackingOptions& options)
  : geometry_(checked(geometry, options)), options_(options), pid_(options.pid)
{
}

Vec2 PathTracker::referencePoint(const Pose2& base) const
{
  return { base.x + geometry_.reference_x * std::cos(base.yaw), base.y + geometry_.reference_x * std::sin(base.yaw) };
}

TrackingStatus PathTracker::track(const Path& path, const Pose2& base, double speed, double target_speed, double offset,
                                  double t)
{
  TrackingStatus st;
  st.speed = speed;
  st.target_speed = std::max(0.0, target_speed);
  double dt = 0.0;
  if (has_t_ && t > t_)
    dt = t - t_;
  if (dt > 1.0)  // a gap in the measurements: do not integrate over it
    dt = 0.0;
  has_t_ = true;
  t_ = t;
  if (path.empty())
  {
    st.command = stop();
    return st;
  }

  const Vec2 ref = referencePoint(base);
  PathProjection proj;
  if (has_s_)
    proj = path.project(ref, s_ - kSearchBehind, s_ + kSearchAhead + 2.0 * std::abs(speed) * dt);
  else
    proj = path.projectFirst(ref);
  s_ = proj.s;
  has_s_ = true;
  st.s = proj.s;
  st.cross_track = proj.lateral - offset;

  Pose2 ref_pose{ ref.x, ref.y, base.yaw };
  st.lookahead = lookaheadDistance(options_.lookahead, speed);
  const PursuitTarget target = pursue(path, ref_pose, proj.s, st.lookahead, offset);
  st.target = target.point;
  st.curvature = target.curvature;
  const double steering = steeringForCurvature(geometry_, target.curvature);

  if (st.target_speed <= kStandstillSpeed && std::abs(speed) < kHoldSpeed)
  {
    st.command = stop();
    st.command.steering = steering;
  }
  else
  {
    const double ramp_limit = std::max(ramp_, speed) + options_.max_accel * dt;
    const bool ramping = st.target_speed > ramp_limit;
    ramp_ = std::min(st.target_speed, ramp_limit);
    st.commanded_speed = ramp_;
    const double feedforward = throttleFeedforward(geometry_, ramp_, steering);
    // While ramping the P term alone follows the ramp: an integral built up to accelerate
    // would have to unwind after it, overshooting the new speed.
    const double effort = pid_.update(ramp_, speed, dt, feedforward, !ramping);
    const Pedals pedals = pedalsForEffort(effort, options_.coast_band, options_.brake_gain);
    st.command.throttle = pedals.throttle;
    st.command.brake = pedals.brake;
    st.command.steering = steering;
  }
  return st;
}

Command PathTracker::stop()
{
  pid_.reset();
  ramp_ = 0.0;
  Command c;
  c.throttle = 0.0;
  c.brake = 1.0;
  c.steering = 0.0;
  return c;
}

}  // namespace control
}  // namespace avsp
