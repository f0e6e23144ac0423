#pragma once
/**
 * @file speed_control.hpp
 * @brief Speed control (no ROS): a PID on the speed error whose output, the effort in
 *        [-1, 1], becomes throttle (effort > 0) or brake (effort < 0, over speed), and the
 *        speed profile along a waypoint path (per-segment speeds, slowing down in time for
 *        slower segments and the goal).
 *
 * PID: effort = feedforward + kp e + I - kd dv/dt, e = target - measured speed (m/s), I the
 * integral term (effort units, I += ki e dt). Anti-windup by conditional integration: while
 * the effort is saturated (|effort| > 1) I does not grow further in the saturating
 * direction, and |I| <= integral_limit always; so a large step (starting from rest, a hill)
 * does not leave a large integral behind that overshoots the target once it is reached.
 * The derivative acts on the measured speed, so a setpoint step does not kick the pedals.
 */
#include <cstddef>
#include <vector>

namespace avsp
{
namespace control
{
/// Gains of the speed PID. Effort 1 = full throttle, -1 = full brake (before brake_gain).
struct PidGains
{
  double kp = 0.5;              ///< effort per m/s of speed error, >= 0
  double ki = 0.1;              ///< effort per m of accumulated speed error (per m/s per s), >= 0
  double kd = 0.0;              ///< effort per m/s^2 of measured acceleration, >= 0
  double integral_limit = 0.6;  ///< |I| bound (effort), (0, 1]
  bool anti_windup = true;      ///< false: plain PID (I integrates without bound; for comparison)
};

/// @throw std::invalid_argument naming the field (speed_kp, speed_ki, speed_kd,
///        speed_integral_limit) when not finite or out of range
void validate(const PidGains& gains);

/// Speed PID with anti-windup (see file comment).
class SpeedPid
{
public:
  /// @throw std::invalid_argument for bad gains (validate())
  explicit SpeedPid(const PidGains& gains);

  /**
   * @brief One control step.
   * @param target desired speed (m/s)
   * @param measured measured speed (m/s)
   * @param dt s since the previous step; 0 (first step, or after a reset) integrates nothing
   *        and uses no derivative
   * @param feedforward effort added before saturation (e.g. throttleFeedforward())
   * @param integrate false freezes the integral this step (while the caller ramps the target)
   * @return effort in [-1, 1]
   */
  double update(double target, double measured, double dt, double feedforward = 0.0, bool integrate = true);

  /// Forgets the integral and the previous measurement.
  void reset();

  double integralTerm() const { return integral_; }  ///< effort units
  const PidGains& gains() const { return gains_; }

private:
  PidGains gains_;
  double integral_ = 0.0;
  double previous_measured_ = 0.0;
  bool has_previous_ = false;
};

/// Throttle and brake, each in [0, 1].
struct Pedals
{
  double throttle = 0.0;
  double brake = 0.0;
};

/**
 * @brief Pedals for an effort: throttle = effort when > 0; below -coast_band the brake,
 *        brake_gain (-effort - coast_band) capped at 1; in between coasting (both 0).
 * @param coast_band >= 0, effort band below 0 where the vehicle coasts instead of braking
 * @param brake_gain > 0, brake per unit of effort beyond the band
 */
Pedals pedalsForEffort(double effort, double coast_band, double brake_gain);

/**
 * @brief Target speed along a waypoint path.
 *
 * Segment k runs from waypoint k (arc length s_k) to waypoint k+1 at prescribed speed v_k.
 * Ahead of a slower segment j the target follows the braking curve sqrt(v_j^2 + 2 a (s_j - s))
 * with deceleration a, so the vehicle enters segment j at v_j; towards the goal (s_n) it
 * follows sqrt(2 a (s_n - s)) but never below `approach_speed` (the vehicle creeps the last
 * metres and the goal test stops it). Speeding up to a faster segment starts at its waypoint.
 */
class SpeedProfile
{
public:
  SpeedProfile() = default;

  /**
   * @param waypoint_s arc lengths of the waypoints (m), increasing, at least 2
   * @param segment_speeds one per segment (waypoint_s.size() - 1), m/s, > 0
   * @param decel m/s^2, > 0
   * @param approach_speed m/s, > 0: lowest target before the goal
   * @throw std::invalid_argument naming the argument when inconsistent
   */
  SpeedProfile(std::vector<double> waypoint_s, std::vector<double> segment_speeds, double decel, double approach_speed);

  /// m/s, the prescribed speed of the segment holding arc length s (first before it, last beyond).
  double segmentSpeed(double s) const;

  /// m/s, the target at arc length s (see class comment); approach_speed beyond the goal.
  double targetSpeed(double s) const;

  /// Index of the segment holding arc length s.
  std::size_t segmentAt(double s) const;

private:
  std::vector<double> s_;
  std::vector<double> v_;
  double decel_ = 1.0;
  double approach_speed_ = 0.5;
};

}  // namespace control
}  // namespace avsp
