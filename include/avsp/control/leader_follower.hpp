#pragma once
/**
 * @file leader_follower.hpp
 * @brief The leader–follower pursuit controller and formations (docs/MODELS.md section 5), no ROS.
 *
 * The follower knows its leader only from the leader's V2V broadcasts (position, heading,
 * speed, stamp). It keeps them as breadcrumbs: a path through the leader's positions, one
 * point every `breadcrumb_spacing` metres plus a tip at the latest position, continued
 * beyond the tip along the leader's heading. The follower then
 *
 *  - steers by pure pursuit along the breadcrumbs, moved `offset` metres along the path's
 *    left normal (0 = in the leader's tracks; line and diamond formations use offsets);
 *  - measures the gap along the path: g = s_leader - s_follower, s_follower the arc length
 *    of its base_link's projection on the breadcrumbs, s_leader the tip's arc length plus
 *    the leader's speed times the age of its latest broadcast (V2V latency, at most
 *    `leader_timeout`);
 *  - commands the speed v = clamp(v_leader + accel_lead_time a_leader + gap_gain (g - gap),
 *    0, max_speed): the leader's speed, and its acceleration over the speed loop's lag, as
 *    feedforward plus a proportional gap correction. With the speed loop lagging by a time
 *    constant tau the gap error obeys tau e'' + e' + gap_gain e = 0, damping ratio
 *    1 / (2 sqrt(gap_gain tau)): gap_gain = 0.3 1/s keeps it near 0.75 for tau around 1.5 s
 *    (a loaded 4x4's response), with a gap time constant of about 3 s. Without the
 *    acceleration term a leader speeding up by dv opens the gap by about dv tau before the
 *    correction catches up;
 *  - brakes fully when the leader is closer than `safety_distance` in a straight line, or
 *    when no broadcast newer than `leader_timeout` has arrived.
 *
 * Breadcrumbs more than kKeepBehind metres behind the follower are dropped, and the path is
 * cut to `max_path_length` metres.
 */
#include <cstddef>
#include <string>
#include <vector>

#include "avsp/control/path.hpp"
#include "avsp/control/path_tracker.hpp"
#include "avsp/control/steering.hpp"

namespace avsp
{
namespace control
{
/// What a leader's V2V broadcast tells the follower (avsp_msgs/VehicleState).
struct LeaderState
{
  double stamp = 0.0;         ///< s, time of the state
  double x = 0.0;             ///< m, map
  double y = 0.0;             ///< m, map
  double heading = 0.0;       ///< rad, map, 0 = east, counter-clockwise +
  double speed = 0.0;         ///< m/s, along the leader's body x axis
  double acceleration = 0.0;  ///< m/s^2, along the leader's body x axis
};

/// Options of the leader–follower controller.
struct LeaderFollowerOptions
{
  /// Pursuit and speed loop; the speed ramp defaults to 2 m/s^2 (not 1): a follower must be
  /// able to out-accelerate a leader ramping at 1 m/s^2 to close the gap it lost meanwhile.
  TrackingOptions tracking = TrackingOptions{ LookaheadOptions{}, PidGains{}, 0.05, 1.0, 2.0 };
  double gap = 15.0;                ///< m, desired distance along the path behind the leader, >= 0
  double offset = 0.0;              ///< m, normal offset from the leader's path, + left
  double gap_gain = 0.3;            ///< 1/s, speed per metre of gap error, > 0
  double accel_lead_time = 0.7;     ///< s, >= 0: the leader's acceleration times this is added to its speed
  double max_speed = 10.0;          ///< m/s, > 0: the follower never goes faster
  double safety_distance = 3.0;     ///< m, >= 0: full brake when the leader is closer (straight line)
  double leader_timeout = 1.0;      ///< s, > 0: full brake when the latest broadcast is older
  double breadcrumb_spacing = 0.5;  ///< m, > 0: distance between breadcrumbs
  double max_path_length = 2000.0;  ///< m, > 0: breadcrumbs kept behind the tip at most
};

/// @throw std::invalid_argument naming the field (gap, offset, gap_gain, max_speed, ...)
void validate(const LeaderFollowerOptions& options);

/// What the follower knows about its leader and the gap, after a step.
struct FollowerStatus
{
  TrackingStatus tracking;
  bool leader_known = false;  ///< a broadcast has arrived
  bool leader_fresh = false;  ///< the latest is at most leader_timeout old
  bool too_close = false;     ///< within safety_distance (braking)
  double gap = 0.0;           ///< m, measured gap along the path (0 when the leader is unknown)
  double desired_gap = 0.0;   ///< m
  double leader_speed = 0.0;  ///< m/s, latest broadcast
};

/// Leader–follower pursuit on V2V breadcrumbs (see file comment).
class LeaderFollower
{
public:
  static constexpr double kKeepBehind = 50.0;  ///< m of breadcrumbs kept behind the follower

  /// @throw std::invalid_argument for a bad geometry or options
  LeaderFollower(const SteeringGeometry& geometry, const LeaderFollowerOptions& options);

  /**
   * @brief Records a leader broadcast. States older than the latest are ignored; so are
   *        states with a non-finite field (returns false for those).
   */
  bool addLeaderState(const LeaderState& state);

  /**
   * @brief One control step from the vehicle's own odometry and the broadcasts so far.
   * @param base base_link pose in map
   * @param speed m/s along the body x axis
   * @param t s, time of the measurement (same clock as the broadcasts' stamps)
   */
  FollowerStatus update(const Pose2& base, double speed, double t);

  /// @throw std::invalid_argument unless finite and >= 0 (m)
  void setGap(double gap);
  /// @throw std::invalid_argument unless finite (m)
  void setOffset(double offset);

  double desiredGap() const { return options_.gap; }
  double offset() const { return options_.offset; }
  const Path& breadcrumbs() const { return crumbs_; }
  const LeaderFollowerOptions& options() const { return options_; }

private:
  LeaderFollowerOptions options_;
  PathTracker tracker_;
  Path crumbs_;
  bool leader_known_ = false;
  LeaderState leader_;
  bool has_own_ = false;
  Vec2 own_;  ///< the follower's latest base_link position (seeds the breadcrumbs)
  bool has_base_s_ = false;
  double base_s_ = 0.0;  ///< the follower base_link's arc length at the last step
};

/// Formation shapes (docs/MODELS.md section 5).
enum class FormationType
{
  kColumn,  ///< single file: each vehicle behind the one before it
  kLine,    ///< abreast of the leader, alternately right and left of it
  kDiamond  ///< leader ahead, two abreast behind it, one behind them (more: a column behind)
};

/// @throw std::invalid_argument for anything but "column", "line", "diamond"
FormationType formationFromString(const std::string& name);

/// Where one vehicle of a formation drives.
struct FormationSlot
{
  int leader = -1;      ///< index of the vehicle it follows; -1 for the formation's leader
  double gap = 0.0;     ///< m, along the path behind that vehicle
  double offset = 0.0;  ///< m, normal offset from that vehicle's path, + left
};

/**
 * @brief The slots of `count` vehicles (index 0 leads) in a formation.
 *
 * - column: vehicle k follows k-1 at `spacing`, offset 0;
 * - line: every vehicle follows vehicle 0 at gap 0, offsets -w, +w, -2w, +2w, ... (w = `width`,
 *   first to the right);
 * - diamond: 1 and 2 follow 0 at `spacing`, offsets +w and -w; 3 follows 0 at 2 `spacing`,
 *   offset 0; from 4 on a column behind the one before, at `spacing`.
 * @param spacing m, > 0; @param width m, > 0
 * @throw std::invalid_argument for count 0 or a bad spacing or width
 */
std::vector<FormationSlot> formationSlots(FormationType type, std::size_t count, double spacing, double width);

}  // namespace control
}  // namespace avsp
