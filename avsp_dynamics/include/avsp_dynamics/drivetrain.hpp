#pragma once
/**
 * @file drivetrain.hpp
 * @brief The vehicle's command-to-actuator math as pure functions (no ODE): engine torque
 *        and power limit through the gear ratio, Ackermann wheel angles, skid-steer side
 *        mixing, the driver command's ranges. VehicleSim applies them every step; the unit
 *        tests check them against their closed forms.
 */
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace dynamics
{
/// Driver command, the contract's DriveCommand (docs/ARCHITECTURE.md).
struct DriveCommand
{
  double throttle = 0.0;  ///< [0, 1]: Ackermann: fraction of the available engine torque;
                          ///< skid-steer and tracked: fraction of max_speed for the faster side
  double brake = 0.0;     ///< [0, 1]: fraction of brakes.max_torque on every wheel
  double steering = 0.0;  ///< [-1, 1], + = left: fraction of the full-lock steering angle
  /// Reverse gear: the throttle drives backwards (Ackermann: the engine's torque reversed,
  /// governed at reverse_max_speed; skid-steer and tracked: both sides' speeds reversed, the
  /// steering turning the vehicle as a reversing car's does).
  bool reverse = false;
};

/// A command that cannot reach the physics (NaN or infinite field); what() names the field.
class CommandError : public std::invalid_argument
{
public:
  using std::invalid_argument::invalid_argument;
};

/// Outcome of checkCommand().
enum class CommandCheck
{
  kAccepted,  ///< every field was finite and in range
  kClamped,   ///< some field was out of range and was clamped; `why` says which
  kRejected   ///< some field was NaN or infinite; the command must not be used
};

/**
 * @brief The driver command's one rule, applied on every way into the physics (World::setCommand
 *        through clampedCommand(), dynamics_node's cmd_vel and cmd_drive): a NaN or infinite
 *        field rejects the command (a clamp would invent a value; the caller decides, e.g. holds
 *        the last command); finite fields are clamped to throttle [0, 1], brake [0, 1],
 *        steering [-1, 1].
 * @param[in,out] command clamped in place; unchanged when rejected
 * @param[out] why each offending field and its value, "; "-separated ("throttle=1.5 outside
 *        [0, 1]; brake is nan"); empty when accepted
 */
CommandCheck checkCommand(DriveCommand& command, std::string& why);

/**
 * @brief The command with each field clamped to its range (checkCommand()).
 * @throw CommandError naming the field ("DriveCommand.throttle is nan") when a field is NaN or
 *        infinite
 */
DriveCommand clampedCommand(const DriveCommand& command);

/// Fraction of the engine torque left by the speed governor: 1 below 95 % of the governed
/// engine speed, falling linearly to 0 at the governed speed (no torque beyond it).
double governorFactor(double engine_speed, double governed_engine_speed);

/**
 * @brief Largest engine torque (N m) at engine speed omega_e (rad/s): the torque limit, and
 *        above the corner speed P / T the power limit P / |omega_e|.
 */
double engineTorqueLimit(const DrivetrainSpec& drivetrain, double engine_speed);

/**
 * @brief Total torque (N m) the driveline delivers to the driven wheels (or one sprocket side)
 *        at full throttle: efficiency * gear_ratio * engineTorqueLimit(gear_ratio * |omega|)
 *        times the governor factor at max_speed, for mean driven-wheel spin rate omega (rad/s)
 *        and rolling radius (m).
 */
double wheelTorqueAvailable(const DrivetrainSpec& drivetrain, double wheel_speed, double radius);

/**
 * @brief Signed torque (N m) to the driven wheels for `throttle` in [0, 1]: forward,
 *        throttle x wheelTorqueAvailable(); in reverse, minus that with the governor at
 *        reverse_max_speed for the wheels turning backwards.
 */
double driveTorque(const DrivetrainSpec& drivetrain, double throttle, bool reverse, double wheel_speed, double radius);

/**
 * @brief Ackermann steering geometry of a wheeled vehicle.
 *
 * The steering actuator sets the bicycle-model angle delta of a virtual wheel on the
 * centreline, at wheelbase L ahead of the reference axle (the unsteered wheels' mean x):
 * path curvature kappa = tan(delta) / L about a centre on the reference axle line. Each
 * steered wheel at (x_i, y_i) then points at that centre:
 *
 *     tan(delta_i) = (x_i - x_ref) kappa / (1 - y_i kappa)
 *
 * so every wheel rolls without side slip on the same circle centre (turning radius
 * L / tan(delta) at the reference axle). Full lock is where the inner wheel reaches the
 * YAML's max_angle.
 */
class AckermannGeometry
{
public:
  /// @throw ConfigError (naming the model's YAML) if no wheel steers or none is unsteered
  explicit AckermannGeometry(const VehicleModel& model);

  double wheelbase() const { return wheelbase_; }              ///< m, L
  double referenceX() const { return x_ref_; }                 ///< m, x of the reference axle in base_link
  double maxCentreAngle() const { return max_centre_angle_; }  ///< rad, delta at full lock
  /// rad, angle of model.wheels[index] for centre angle delta (0 for unsteered wheels).
  double wheelAngle(std::size_t index, double centre_angle) const;

private:
  std::vector<Eigen::Vector2d> positions_;  ///< (x, y) per model wheel, base_link
  std::vector<bool> steered_;
  double x_ref_ = 0.0;
  double wheelbase_ = 0.0;
  double max_centre_angle_ = 0.0;
};

/**
 * @brief Skid-steer mixing: speed fractions (left, right) in [-1, 1] for throttle t in
 *        [0, 1] and steering s in [-1, 1]. The outer side runs at t, the inner side at
 *        t (1 - 2 |s|): s = +-0.5 pivots about the inner side, s = +-1 turns in place.
 */
std::pair<double, double> skidSteerSides(double throttle, double steering);

/**
 * @brief Tracked-vehicle mixing: sprocket speed fractions (left, right) in [-1, 1] for throttle
 *        t in [0, 1], steering s in [-1, 1] and pivot fraction p in [0, 1]:
 *        skidSteerSides(max(t, p |s|), s). As skid-steer while t >= p |s|; below that the outer
 *        track runs at p |s|, so that steering alone still turns the vehicle: in place at
 *        |s| = 1 (tracks at -+p), about the inner track at |s| = 0.5.
 */
std::pair<double, double> trackedSides(double throttle, double steering, double pivot);

}  // namespace dynamics
}  // namespace avsp
