#pragma once
/**
 * @file pure_pursuit.hpp
 * @brief Pure pursuit path tracking (Coulter, "Implementation of the Pure Pursuit Path
 *        Tracking Algorithm", CMU-RI-TR-92-01), no ROS.
 *
 * The vehicle's reference point (the rear axle of an Ackermann vehicle, the centre of a
 * skid-steer or tracked one: the point whose path is a circle for a constant command)
 * steers onto the circular arc, tangent to its heading, through a target point on the path
 * a lookahead distance ahead. For a target at distance L_d seen at angle alpha from the
 * heading, that arc's curvature is
 *
 *     kappa = 2 sin(alpha) / L_d     (1/m, + = left)
 *
 * The lookahead grows with speed, L_d = clamp(min + gain |v|, min, max): short at low speed
 * for tight tracking, long at speed so the steering stays smooth (the time to reach the
 * target, L_d / v, stays near `gain` seconds).
 */
#include "avsp/control/path.hpp"

namespace avsp
{
namespace control
{
/// Speed-dependent lookahead distance L_d = clamp(min + gain |v|, min, max).
struct LookaheadOptions
{
  double min = 4.0;   ///< m, > 0: lookahead at standstill
  double gain = 0.8;  ///< s, >= 0: added lookahead per m/s of speed
  double max = 20.0;  ///< m, >= min
};

/**
 * @brief Checks the options.
 * @throw std::invalid_argument naming the field ("lookahead_min", "lookahead_gain",
 *        "lookahead_max") when it is not finite or out of range
 */
void validate(const LookaheadOptions& options);

/// m, the lookahead distance at `speed` (m/s, sign ignored).
double lookaheadDistance(const LookaheadOptions& options, double speed);

/**
 * @brief Curvature (1/m, + = left) of the arc from `pose`, tangent to its heading, through
 *        `target`: 2 sin(alpha) / L_d with L_d = |target - pose| and alpha the target's
 *        bearing from the heading. 0 when the target coincides with the pose.
 */
double purePursuitCurvature(const Pose2& pose, const Vec2& target);

/// Where pure pursuit aims on a path.
struct PursuitTarget
{
  double s = 0.0;          ///< m, arc length of the target on the path
  Vec2 point;              ///< m, map: the target (offset from the path by the normal offset)
  double curvature = 0.0;  ///< 1/m, purePursuitCurvature(pose, point)
};

/**
 * @brief The pure pursuit target `lookahead` metres of arc length ahead of `s_reference`
 *        (the reference point's projection on the path), moved `offset` m along the path's
 *        left normal there (formations), and the curvature to reach it from `pose`.
 */
PursuitTarget pursue(const Path& path, const Pose2& pose, double s_reference, double lookahead, double offset = 0.0);

}  // namespace control
}  // namespace avsp
