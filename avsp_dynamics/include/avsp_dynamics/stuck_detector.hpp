#pragma once
/**
 * @file stuck_detector.hpp
 * @brief When a vehicle counts as stuck (VehicleTelemetry.stuck): throttle on and, continuously
 *        for 2 s of world time, its driven running gear in contact slipping at >= 0.95 on
 *        average, or the vehicle high-centred (highCentred()). The core owns the rule so the
 *        node's flag and the core's tests agree.
 */
#include "avsp_dynamics/vehicle_model.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

namespace avsp
{
namespace dynamics
{
/**
 * @brief Mean longitudinal slip (T8) of the driven wheels that touch the ground, or of the
 *        tracks (T8 with T10's speed) with a segment on the ground.
 * @return false when nothing driven is in contact (the vehicle cannot be spinning its wheels)
 */
bool meanDrivenSlip(const VehicleModel& model, const VehicleState& state, double& slip);

/// Of the vehicle's weight, what its hull must carry to count as high-centred.
constexpr double kHighCentredLoadShare = 0.25;
/// m/s: ... while it moves slower than this over the ground.
constexpr double kHighCentredSpeed = 0.1;

/// High-centred: the ground carries more than kHighCentredLoadShare of the weight on the hull's
/// underside and the vehicle moves slower than kHighCentredSpeed (its running gear cannot push
/// it on, whatever it slips).
bool highCentred(const VehicleModel& model, const VehicleState& state);

/// Stuck = throttle > 0 and (mean driven slip >= `slip_threshold` or highCentred()) for
/// `hold_time` seconds.
class StuckDetector
{
public:
  /// @throw std::invalid_argument if slip_threshold is not in (0, 1] or hold_time is not > 0
  explicit StuckDetector(double slip_threshold = 0.95, double hold_time = 2.0);

  /**
   * @brief Feeds one step's state at world time `time` (s, non-decreasing).
   * @return whether the vehicle is stuck now
   */
  bool update(const VehicleModel& model, const VehicleState& state, double time);

  bool stuck() const { return stuck_; }
  /// s the stuck condition has held so far (0 when it does not hold).
  double heldFor(double time) const { return since_ < 0.0 ? 0.0 : time - since_; }

private:
  double slip_threshold_;
  double hold_time_;
  double since_ = -1.0;  ///< world time the condition began, s; < 0: it does not hold
  bool stuck_ = false;
};

}  // namespace dynamics
}  // namespace avsp
