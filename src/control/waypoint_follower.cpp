#include "avsp/control/waypoint_follower.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace control
{
namespace
{
std::string entry(std::size_t k, const char* key)
{
  return "waypoints[" + std::to_string(k) + "]." + key;
}

std::vector<Waypoint> checkedWaypoints(const std::vector<Waypoint>& waypoints)
{
  validateWaypoints(waypoints);
  return waypoints;
}

Path pathThrough(const std::vector<Waypoint>& waypoints)
{
  Path path;
  for (const Waypoint& w : waypoints)
    path.append({ w.x, w.y });
  return path;
}
}  // namespace

void validateWaypoints(const std::vector<Waypoint>& waypoints)
{
  if (waypoints.size() < 2)
    throw std::invalid_argument("waypoints must hold at least 2 entries, got " + std::to_string(waypoints.size()));
  for (std::size_t k = 0; k < waypoints.size(); ++k)
  {
    const Waypoint& w = waypoints[k];
    if (!std::isfinite(w.x))
      throw std::invalid_argument(entry(k, "x") + " must be finite (m)");
    if (!std::isfinite(w.y))
      throw std::invalid_argument(entry(k, "y") + " must be finite (m)");
    const bool last = k + 1 == waypoints.size();
    if (!std::isfinite(w.speed) || w.speed < 0.0 || (!last && w.speed == 0.0))
      throw std::invalid_argument(entry(k, "speed") + " = " + std::to_string(w.speed) + " must be finite and " +
                                  (last ? ">= 0" : "> 0") + " (m/s)");
    if (k > 0 && std::hypot(w.x - waypoints[k - 1].x, w.y - waypoints[k - 1].y) < 0.01)
      throw std::invalid_argument(entry(k, "x") + ", y: within 1 cm of waypoints[" + std::to_string(k - 1) + "]");
  }
}

WaypointFollower::WaypointFollower(const std::vector<Waypoint>& waypoints, const SteeringGeometry& geometry,
                                   const WaypointFollowerOptions& options)
  : waypoints_(checkedWaypoints(waypoints)),
    options_(options),
    path_(pathThrough(waypoints_)),
    tracker_(geometry, options.tracking)
{
  if (!std::isfinite(options_.lead_time) || options_.lead_time < 0.0 || options_.lead_time > 100.0)
    throw std::invalid_argument("lead_time = " + std::to_string(options_.lead_time) +
                                " must be finite and in [0, 100] (s)");
  if (!std::isfinite(options_.goal_tolerance) || options_.goal_tolerance <= 0.0)
    throw std::invalid_argument("goal_tolerance = " + std::to_string(options_.goal_tolerance) +
                                " must be finite and > 0 (m)");
  std::vector<double> s;
  std::vector<double> v;
  for (std::size_t k = 0; k < waypoints_.size(); ++k)
  {
    s.push_back(path_.sAt(k));
    if (k + 1 < waypoints_.size())
      v.push_back(waypoints_[k].speed);
  }
  profile_ = SpeedProfile(s, v, options_.decel, options_.approach_speed);
}

TrackingStatus WaypointFollower::update(const Pose2& base, double speed, double t)
{
  const Waypoint& goal = waypoints_.back();
  // Near the goal only counts on the last stretch of the path (it may pass the goal earlier).
  const double last_stretch = options_.goal_tolerance + std::abs(tracker_.geometry().reference_x) + kGoalStretch;
  if (!goal_reached_ && tracker_.hasProgress() && tracker_.progress() >= path_.endS() - last_stretch &&
      std::hypot(base.x - goal.x, base.y - goal.y) <= options_.goal_tolerance)
    goal_reached_ = true;
  if (!goal_reached_ && tracker_.hasProgress() && tracker_.progress() >= path_.endS())
    goal_reached_ = true;
  if (goal_reached_)
  {
    TrackingStatus st;
    st.speed = speed;
    st.s = tracker_.progress();
    st.target = { goal.x, goal.y };
    st.command = tracker_.stop();
    return st;
  }
  // The profile at the reference point's arc length (the previous projection before the first step).
  const double s = tracker_.hasProgress() ? tracker_.progress() : path_.projectFirst(tracker_.referencePoint(base)).s;
  const double target = profile_.targetSpeed(s + options_.lead_time * std::max(speed, 0.0));
  TrackingStatus st = tracker_.track(path_, base, speed, target, 0.0, t);
  if (st.s >= path_.endS())
  {
    goal_reached_ = true;
    st.command = tracker_.stop();
  }
  return st;
}

}  // namespace control
}  // namespace avsp
