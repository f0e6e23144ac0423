#pragma once
/**
 * @file steering.hpp
 * @brief From a path curvature to the contract's normalised steering command, per drive
 *        type, and back (no ROS; the vehicle figures come from avsp_dynamics' VehicleModel).
 *
 * - Ackermann (avsp_dynamics' AckermannGeometry): the steering command s is the fraction of
 *   the full-lock centre angle delta_max of a bicycle wheel a wheelbase L ahead of the
 *   unsteered (reference) axle, whose centre then runs on a circle of curvature
 *   kappa = tan(delta) / L. So s = atan(kappa L) / delta_max, and the reference point of
 *   pure pursuit is that axle's centre.
 * - Skid-steer and tracked (avsp_dynamics' skidSteerSides / trackedSides): the outer side
 *   runs at speed fraction t, the inner at t (1 - 2|s|). Without side slip the centre
 *   moves at t (1 - |s|) v_max and turns at 2 |s| t v_max / B (B the track width), so
 *   kappa = 2 |s| / (B (1 - |s|)) and s = kappa B / (2 + |kappa| B) (sign of kappa).
 *   Skidding makes real turns wider than that; `effective_track_width` (B times a factor
 *   >= 1) accounts for it. The reference point is the base_link origin (midway along the
 *   wheelbase or the track contact).
 */
#include <string>

namespace avsp
{
namespace dynamics
{
struct VehicleModel;
}

namespace control
{
/// How the steering command turns the vehicle.
enum class SteeringKind
{
  kAckermann,    ///< steered wheels: s = fraction of the full-lock centre angle
  kDifferential  ///< skid-steer or tracked: s = side speed difference (skidSteerSides)
};

/// The figures a controller needs to turn a curvature into a command.
struct SteeringGeometry
{
  SteeringKind kind = SteeringKind::kAckermann;
  double wheelbase = 0.0;              ///< m, Ackermann L (> 0)
  double max_angle = 0.0;              ///< rad, Ackermann centre angle at full lock, (0, pi/2)
  double reference_x = 0.0;            ///< m, x in base_link of the point whose path the arc is
  double effective_track_width = 0.0;  ///< m, differential B (> 0)
  double max_speed = 0.0;              ///< m/s, drivetrain max speed (> 0)
};

/**
 * @brief The geometry of a loaded vehicle model: Ackermann wheelbase, full-lock centre
 *        angle and reference axle from avsp_dynamics' AckermannGeometry; skid-steer and
 *        tracked vehicles' track width times `track_width_factor`.
 * @param track_width_factor >= 1, differential drive only: effective / geometric track width
 * @throw std::invalid_argument for a factor < 1 or not finite;
 *        avsp::dynamics::ConfigError from the model's geometry
 */
SteeringGeometry steeringGeometry(const dynamics::VehicleModel& model, double track_width_factor = 1.0);

/// Normalised steering command in [-1, 1] (+ = left) for path curvature `curvature` (1/m, + = left).
double steeringForCurvature(const SteeringGeometry& geometry, double curvature);

/// Path curvature (1/m) of the reference point for steering command `steering` (the inverse).
double curvatureForSteering(const SteeringGeometry& geometry, double steering);

/**
 * @brief Throttle that holds `speed` (m/s) with `steering` when nothing resists, added to
 *        the speed PID's output: for differential drive the throttle is the outer side's
 *        speed fraction, so speed / (v_max (1 - |s|)) (capped at 1); for Ackermann (throttle
 *        = torque fraction) 0: the PID's integral finds the torque.
 */
double throttleFeedforward(const SteeringGeometry& geometry, double speed, double steering);

/// "ackermann" or "differential".
const char* toString(SteeringKind kind);

}  // namespace control
}  // namespace avsp
