#pragma once
/**
 * @file waypoint_follower.hpp
 * @brief The waypoint controller (docs/MODELS.md section 5): pure pursuit along the polyline
 *        through the waypoints, each segment at its prescribed speed, slowing down in time
 *        for slower segments and stopping at the last waypoint (no ROS).
 *
 * Waypoint k's speed is prescribed from waypoint k to waypoint k+1; the last waypoint's
 * speed is not used (the vehicle stops there). The goal is reached, once and for good, when
 * base_link comes within `goal_tolerance` of the last waypoint while the reference point is
 * on the path's last stretch (goal_tolerance + |reference_x| + kGoalStretch metres: a path
 * may pass its goal earlier), or when the reference point passes the goal along the path
 * (its projection reaches the path's end); from then on the command is the full brake.
 *
 * The target speed is the SpeedProfile's `lead_time` x speed metres ahead of the reference
 * point: the speed loop lags its target by about a second, so reading the profile that far
 * ahead makes the vehicle reach each segment's speed at its waypoint rather than after it.
 */
#include <string>
#include <vector>

#include "avsp/control/path.hpp"
#include "avsp/control/path_tracker.hpp"
#include "avsp/control/speed_control.hpp"
#include "avsp/control/steering.hpp"

namespace avsp
{
namespace control
{
/// A waypoint in map (m) and the speed (m/s) prescribed from it to the next one.
struct Waypoint
{
  double x = 0.0;
  double y = 0.0;
  double speed = 0.0;
};

/// Options of the waypoint follower.
struct WaypointFollowerOptions
{
  TrackingOptions tracking;
  double decel = 1.0;           ///< m/s^2, > 0: braking ahead of slower segments and the goal
  double approach_speed = 0.7;  ///< m/s, > 0: lowest target speed before the goal
  double goal_tolerance = 1.5;  ///< m, > 0: base_link this close to the last waypoint = arrived
  double lead_time = 1.0;       ///< s, >= 0: the profile is read lead_time x speed ahead (speed-loop lag)
};

/**
 * @brief Checks a waypoint list.
 * @throw std::invalid_argument naming the entry and key, e.g. "waypoints[2].speed = -1 must
 *        be finite and > 0 (m/s)": fewer than 2 waypoints, a non-finite coordinate, a speed
 *        not > 0 (the last one: not >= 0), a waypoint within 1 cm of the previous one
 */
void validateWaypoints(const std::vector<Waypoint>& waypoints);

/// Pure pursuit + speed profile along waypoints (see file comment).
class WaypointFollower
{
public:
  static constexpr double kGoalStretch = 5.0;  ///< m, see the file comment

  /// @throw std::invalid_argument for bad waypoints (validateWaypoints), geometry or options
  WaypointFollower(const std::vector<Waypoint>& waypoints, const SteeringGeometry& geometry,
                   const WaypointFollowerOptions& options);

  /**
   * @brief One control step from the vehicle's own odometry.
   * @param base base_link pose in map
   * @param speed m/s along the body x axis
   * @param t s, time of the measurement
   */
  TrackingStatus update(const Pose2& base, double speed, double t);

  bool goalReached() const { return goal_reached_; }
  const Path& path() const { return path_; }
  const SpeedProfile& profile() const { return profile_; }
  const std::vector<Waypoint>& waypoints() const { return waypoints_; }

private:
  std::vector<Waypoint> waypoints_;
  WaypointFollowerOptions options_;
  Path path_;
  SpeedProfile profile_;
  PathTracker tracker_;
  bool goal_reached_ = false;
};

}  // namespace control
}  // namespace avsp
