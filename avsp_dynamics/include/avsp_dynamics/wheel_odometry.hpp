#pragma once
/**
 * @file wheel_odometry.hpp
 * @brief Dead reckoning as a vehicle's own odometry would do it (dynamics_node's
 *        `<v>/wheel_odometry`): the forward speed from the running gear (wheel rim speeds or
 *        track belt speeds) and the yaw rate of a body-fixed gyro, integrated on the plane. It
 *        drifts the way a real one does: a slipping wheel turns faster than the vehicle moves, a
 *        sunken one rolls on a smaller radius than its nominal one, a slope shortens the
 *        distance over the map.
 */
#include <Eigen/Geometry>

#include "avsp_dynamics/vehicle_model.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

namespace avsp
{
namespace dynamics
{
/**
 * @brief The forward speed the running gear reports, m/s: the mean over the wheels of
 *        spin rate x nominal radius, or the mean of the two tracks' belt speeds.
 * @throw std::invalid_argument if the state does not match the model (wheel or track count)
 */
double runningGearSpeed(const VehicleModel& model, const VehicleState& state);

/// The yaw rate a gyro fixed to base_link reads, rad/s (the angular velocity's body z).
double bodyYawRate(const VehicleState& state);

/// Planar dead reckoning from a forward speed and a yaw rate.
class WheelOdometry
{
public:
  /// @param start base_link in the odometry frame at the start (its x, y, z and heading are kept)
  explicit WheelOdometry(const Eigen::Isometry3d& start = Eigen::Isometry3d::Identity());

  /**
   * @brief Integrates `dt` s at forward speed `speed` (m/s) and yaw rate `yaw_rate` (rad/s),
   *        both held over the step: exact arcs (a straight line when the yaw rate is 0).
   * @throw std::invalid_argument if an input is not finite or dt < 0
   */
  void step(double speed, double yaw_rate, double dt);

  double x() const { return x_; }
  double y() const { return y_; }
  double z() const { return z_; }
  double yaw() const { return yaw_; }
  /// m driven (|speed| integrated), for the covariance
  double distance() const { return distance_; }
  /// rad turned (|yaw rate| integrated), for the covariance
  double turned() const { return turned_; }
  /// base_link in the odometry frame: (x, y, z), level, heading yaw.
  Eigen::Isometry3d pose() const;

private:
  double x_ = 0.0, y_ = 0.0, z_ = 0.0, yaw_ = 0.0;
  double distance_ = 0.0, turned_ = 0.0;
};

/// The covariance dynamics_node publishes with `<v>/wheel_odometry` (README): standard deviations
/// of a wheel odometry on unprepared ground.
struct WheelOdometryCovariance
{
  static constexpr double kSpeedShare = 0.1;     ///< of |speed|: slip on soft soil
  static constexpr double kSpeedFloor = 0.01;    ///< m/s
  static constexpr double kLateralSpeed = 0.01;  ///< m/s: the running gear cannot measure it
  static constexpr double kYawRate = 0.01;       ///< rad/s, the gyro
  static constexpr double kPositionShare = 0.1;  ///< of the distance driven
  static constexpr double kHeadingShare = 0.05;  ///< of the angle turned
  static constexpr double kUnmeasured = 1e6;     ///< variance of what it does not measure (z, roll, pitch)
};

}  // namespace dynamics
}  // namespace avsp
