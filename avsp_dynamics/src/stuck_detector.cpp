#include "avsp_dynamics/stuck_detector.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace dynamics
{
bool meanDrivenSlip(const VehicleModel& model, const VehicleState& state, double& slip)
{
  double sum = 0.0;
  int driven = 0;
  for (std::size_t w = 0; w < state.wheels.size() && w < model.wheels.size(); ++w)
  {
    if (model.wheels[w].driven && state.wheels[w].in_contact)
    {
      sum += state.wheels[w].slip;
      ++driven;
    }
  }
  // A track is driven as a whole (its sprocket): its slip (T8 with T10's speed) counts once,
  // while any of its segments touches the ground.
  for (const TrackState& t : state.tracks)
  {
    const bool touching =
        std::any_of(t.segments.begin(), t.segments.end(), [](const TrackSegmentState& g) { return g.in_contact; });
    if (touching)
    {
      sum += t.slip;
      ++driven;
    }
  }
  if (driven == 0)
    return false;
  slip = sum / driven;
  return true;
}

StuckDetector::StuckDetector(double slip_threshold, double hold_time)
  : slip_threshold_(slip_threshold), hold_time_(hold_time)
{
  if (!(slip_threshold > 0.0 && slip_threshold <= 1.0))
    throw std::invalid_argument("StuckDetector: slip_threshold must be in (0, 1], got " +
                                std::to_string(slip_threshold));
  if (!(hold_time > 0.0 && std::isfinite(hold_time)))
    throw std::invalid_argument("StuckDetector: hold_time must be > 0 s, got " + std::to_string(hold_time));
}

bool highCentred(const VehicleModel& model, const VehicleState& state)
{
  const Eigen::Vector3d v = state.linear_velocity;
  return state.hull_normal_force > kHighCentredLoadShare * model.total_mass * 9.81 &&
         std::hypot(v.x(), v.y()) < kHighCentredSpeed;
}

bool StuckDetector::update(const VehicleModel& model, const VehicleState& state, double time)
{
  double slip = 0.0;
  const bool spinning = state.command.throttle > 0.0 &&
                        ((meanDrivenSlip(model, state, slip) && slip >= slip_threshold_) || highCentred(model, state));
  if (!spinning)
    since_ = -1.0;
  else if (since_ < 0.0)
    since_ = time;
  stuck_ = spinning && time - since_ >= hold_time_;
  return stuck_;
}

}  // namespace dynamics
}  // namespace avsp
