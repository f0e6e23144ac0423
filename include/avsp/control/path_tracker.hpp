#pragma once
/**
 * @file path_tracker.hpp
 * @brief One control step of a vehicle on a path at a target speed (no ROS): pure pursuit
 *        for the steering, the speed PID for throttle and brake. Both the waypoint follower
 *        and the leader–follower use it; they differ in the path and the target speed.
 *
 * Each step:
 *  1. the reference point (SteeringGeometry::reference_x ahead of base_link: the rear axle
 *     of an Ackermann vehicle) is projected on the path, searching a window around its
 *     previous arc length (so a path that loops back does not capture it);
 *  2. the target is the path point a speed-dependent lookahead further on, moved by the
 *     normal offset; curvature = 2 sin(alpha) / L_d to it, steering from the curvature;
 *  3. the target speed rises at most at `max_accel` (a ramp from the previous commanded
 *     speed, or the measured speed if higher; decreases pass at once: the speed profiles
 *     shape them), so the PID tracks a reachable reference instead of integrating a large
 *     error that would overshoot; the PID turns (ramped target - speed) plus the drive's
 *     throttle feedforward into the pedals;
 *  4. at a standstill target (target speed <= kStandstillSpeed) with the vehicle nearly
 *     stopped (< kHoldSpeed) it holds the vehicle with the full brake.
 */
#include "avsp/control/path.hpp"
#include "avsp/control/pure_pursuit.hpp"
#include "avsp/control/speed_control.hpp"
#include "avsp/control/steering.hpp"

namespace avsp
{
namespace control
{
/// The contract's drive command (docs/ARCHITECTURE.md): throttle, brake [0, 1], steering [-1, 1] + left.
struct Command
{
  double throttle = 0.0;
  double brake = 1.0;
  double steering = 0.0;
};

/// Options shared by both controllers.
struct TrackingOptions
{
  LookaheadOptions lookahead;
  PidGains pid;
  double coast_band = 0.05;  ///< effort below 0 where the vehicle coasts before braking, [0, 1)
  double brake_gain = 1.0;   ///< brake per unit of (negative) effort beyond the coast band, > 0
  double max_accel = 1.0;    ///< m/s^2, > 0: fastest rise of the commanded speed
};

/// @throw std::invalid_argument naming the field (lookahead_*, speed_*, coast_band, brake_gain, max_accel)
void validate(const TrackingOptions& options);

/// @throw std::invalid_argument naming the field of a geometry that cannot steer
void validate(const SteeringGeometry& geometry);

/// What one step decided, and why (for diagnostics, markers and tests).
struct TrackingStatus
{
  Command command;
  double s = 0.0;                ///< m, arc length of the reference point's projection
  double cross_track = 0.0;      ///< m, lateral distance of the reference point from its slot (path + offset), + left
  double lookahead = 0.0;        ///< m, L_d used
  Vec2 target;                   ///< m, map: the pure pursuit target
  double curvature = 0.0;        ///< 1/m, commanded
  double target_speed = 0.0;     ///< m/s, what the caller asked for
  double commanded_speed = 0.0;  ///< m/s, the ramped target the PID tracked
  double speed = 0.0;            ///< m/s, measured
};

/// Pure pursuit + speed PID on a path (see file comment).
class PathTracker
{
public:
  static constexpr double kStandstillSpeed = 0.05;  ///< m/s: targets at or below are "stop"
  static constexpr double kHoldSpeed = 0.3;         ///< m/s: below this a stop target holds the full brake
  static constexpr double kSearchBehind = 10.0;     ///< m of arc length searched behind the previous projection
  static constexpr double kSearchAhead = 20.0;      ///< m searched ahead of it (plus twice the distance travelled)

  /// @throw std::invalid_argument for a bad geometry or options (validate())
  PathTracker(const SteeringGeometry& geometry, const TrackingOptions& options);

  /// m, map: the reference point of a vehicle whose base_link is at `base`.
  Vec2 referencePoint(const Pose2& base) const;

  /**
   * @brief One control step.
   * @param path the path (at least one point)
   * @param base base_link pose in map
   * @param speed m/s, signed, along the body x axis
   * @param target_speed m/s, >= 0
   * @param offset m, normal offset from the path, + left
   * @param t s, time of the measurement (the PID's dt is the difference to the previous step)
   */
  TrackingStatus track(const Path& path, const Pose2& base, double speed, double target_speed, double offset, double t);

  /// A braked command (throttle 0, brake 1, steering 0); resets the PID's integral.
  Command stop();

  /// Forgets the progress along the path (the next step searches the whole path).
  void resetProgress() { has_s_ = false; }

  bool hasProgress() const { return has_s_; }
  double progress() const { return s_; }  ///< m, the reference point's last arc length
  const SteeringGeometry& geometry() const { return geometry_; }
  const TrackingOptions& options() const { return options_; }

private:
  SteeringGeometry geometry_;
  TrackingOptions options_;
  SpeedPid pid_;
  bool has_s_ = false;
  double s_ = 0.0;
  bool has_t_ = false;
  double t_ = 0.0;
  double ramp_ = 0.0;  ///< m/s, the last commanded speed
};

}  // namespace control
}  // namespace avsp
