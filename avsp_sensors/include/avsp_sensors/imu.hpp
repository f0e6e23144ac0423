#pragma once
/**
 * @file imu.hpp
 * @brief Inertial measurement unit (docs/MODELS.md section 4: linear acceleration and angular
 *        velocity of a point on the vehicle): specific force (gravity included, so a level IMU
 *        at rest reads +g on z), angular rate and orientation, in the IMU frame, with white noise
 *        and bias random walk per axis (the Allan-variance noise density and random walk).
 *        Defaults and sources: README.md, "IMU".
 */
#include <cstdint>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/noise.hpp"

namespace avsp
{
namespace sensors
{
/**
 * @brief IMU parameters: continuous-time Allan-variance coefficients (noise density N, bias
 *        random walk K) per axis.
 *
 * Defaults: the Analog Devices ADIS16448 data sheet (Rev. D): gyro angle random walk
 * 0.66 deg/sqrt(h) = 1.92e-4 rad/s/sqrt(Hz); accelerometer velocity random walk 0.11 m/s/sqrt(h)
 * = 1.83e-3 m/s^2/sqrt(Hz). The sheet gives in-run bias stability (gyro 14.5 deg/h =
 * 7.03e-5 rad/s, accelerometer 0.25 mg = 2.45e-3 m/s^2), not a random walk; K is set so that the
 * bias wanders by that much in 1000 s (K = B / sqrt(1000 s)), an assumption (README.md, "IMU").
 */
struct ImuConfig
{
  double rate = 100.0;                   ///< Hz, samples per second, > 0
  double gyro_noise_density = 1.92e-4;   ///< rad/s/sqrt(Hz), N of the gyro, >= 0
  double gyro_random_walk = 2.22e-6;     ///< rad/s^2/sqrt(Hz), K of the gyro bias, >= 0
  double accel_noise_density = 1.83e-3;  ///< m/s^2/sqrt(Hz), N of the accelerometer, >= 0
  double accel_random_walk = 7.75e-5;    ///< m/s^3/sqrt(Hz), K of the accelerometer bias, >= 0
  double gyro_turn_on_bias = 0.0;        ///< rad/s, sigma of the bias at start, >= 0
  double accel_turn_on_bias = 0.0;       ///< m/s^2, sigma of the bias at start, >= 0
  double orientation_noise = 0.01;       ///< rad, white noise per axis on the orientation (assumed AHRS grade), >= 0
  double gravity = 9.81;                 ///< m/s^2, along -z of the map (avsp_dynamics' value), >= 0
  /// Pose of the IMU in the body frame (IMU frame -> body frame); the lever arm makes a turning
  /// body's IMU feel centripetal and tangential acceleration.
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
};

/// @throw std::invalid_argument naming the field ("ImuConfig: rate must be ...")
void validateImuConfig(const ImuConfig& config);

/**
 * @brief The body's state at one instant, as the dynamics knows it (map frame, ENU).
 *
 * Accelerations are optional: when absent they are the backward differences of the velocities
 * of successive measure() calls (zero on the first call).
 */
struct ImuInput
{
  double time = 0.0;                                           ///< s
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();      ///< body frame -> map
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< m/s, map, of the body origin
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, map
  std::optional<Eigen::Vector3d> linear_acceleration;          ///< m/s^2, map, of the body origin
  std::optional<Eigen::Vector3d> angular_acceleration;         ///< rad/s^2, map
};

/// One sample, what sensor_msgs/Imu carries (all in the IMU frame).
struct ImuSample
{
  double time = 0.0;                                                         ///< s
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();           ///< IMU frame -> map (ENU, REP 145)
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();                ///< rad/s, IMU frame
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();             ///< m/s^2, specific force, IMU frame
  Eigen::Matrix3d orientation_covariance = Eigen::Matrix3d::Zero();          ///< rad^2 (white part)
  Eigen::Matrix3d angular_velocity_covariance = Eigen::Matrix3d::Zero();     ///< (rad/s)^2 (white part)
  Eigen::Matrix3d linear_acceleration_covariance = Eigen::Matrix3d::Zero();  ///< (m/s^2)^2 (white part)
};

/**
 * @brief An IMU with a fixed configuration and seed.
 *
 * With R the IMU's orientation (R_body * R_mount), r = R_body * t_mount the lever arm in the
 * map, a and alpha the body origin's linear and angular acceleration and omega its angular
 * velocity:
 *   a_imu = a + alpha x r + omega x (omega x r)
 *   specific force f = R^T (a_imu - g), g = (0, 0, -gravity)  (at rest: R^T (0, 0, +gravity))
 *   rate = R^T omega
 * Measured: f + b_a + N_a sqrt(rate) n, rate + b_g + N_g sqrt(rate) n (white noise of a sample
 * at the configured rate), biases stepped as random walks b += K sqrt(dt) n over the time dt
 * between samples, starting from N(0, turn_on^2). Orientation: R exp([sigma_o n]x).
 */
class Imu
{
public:
  /// @throw std::invalid_argument (validateImuConfig)
  Imu(ImuConfig config, std::uint64_t seed);

  const ImuConfig& config() const { return config_; }

  /// True when a sample is due at time t (s) at the configured rate (the first one at once).
  bool due(double t) const { return clock_.due(t); }

  /**
   * @brief One sample of the body's state; advances the biases to input.time and schedules the
   *        next sample.
   * @throw std::invalid_argument naming the field: a non-finite value, a pose whose rotation is
   *        not orthonormal, or a time earlier than the last sample
   */
  ImuSample measure(const ImuInput& input);

  /// The noise-free specific force and rate of the last measure() (IMU frame), for tests.
  const Eigen::Vector3d& trueSpecificForce() const { return true_force_; }
  const Eigen::Vector3d& trueAngularVelocity() const { return true_rate_; }
  /// Current biases (IMU frame).
  const Eigen::Vector3d& gyroBias() const { return gyro_bias_; }
  const Eigen::Vector3d& accelBias() const { return accel_bias_; }

private:
  ImuConfig config_;
  NormalSource normal_;
  SampleClock clock_;
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d true_force_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d true_rate_ = Eigen::Vector3d::Zero();
  bool started_ = false;
  double last_time_ = 0.0;
  Eigen::Vector3d last_velocity_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_angular_velocity_ = Eigen::Vector3d::Zero();
};

}  // namespace sensors
}  // namespace avsp
