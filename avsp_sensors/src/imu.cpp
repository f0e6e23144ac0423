#include "avsp_sensors/imu.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace sensors
{
void validateImuConfig(const ImuConfig& c)
{
  const std::string ctx = "ImuConfig";
  check::positive(ctx, "rate", c.rate);
  check::nonNegative(ctx, "gyro_noise_density", c.gyro_noise_density);
  check::nonNegative(ctx, "gyro_random_walk", c.gyro_random_walk);
  check::nonNegative(ctx, "accel_noise_density", c.accel_noise_density);
  check::nonNegative(ctx, "accel_random_walk", c.accel_random_walk);
  check::nonNegative(ctx, "gyro_turn_on_bias", c.gyro_turn_on_bias);
  check::nonNegative(ctx, "accel_turn_on_bias", c.accel_turn_on_bias);
  check::nonNegative(ctx, "orientation_noise", c.orientation_noise);
  check::nonNegative(ctx, "gravity", c.gravity);
  const Eigen::Matrix3d r = c.mount.linear();
  if (!c.mount.matrix().allFinite())
    throw std::invalid_argument("ImuConfig: mount must be finite");
  if (!(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || r.determinant() < 0.0)
    throw std::invalid_argument("ImuConfig: mount rotation must be a rotation matrix");
}

namespace
{
const ImuConfig& validated(const ImuConfig& c)
{
  validateImuConfig(c);
  return c;
}

/// exp([v]x) for a small rotation vector v.
Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& v)
{
  const double angle = v.norm();
  if (angle < 1e-300)
    return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
}
}  // namespace

Imu::Imu(ImuConfig config, std::uint64_t seed) : config_(validated(config)), normal_(seed), clock_(config_.rate)
{
}

ImuSample Imu::measure(const ImuInput& in)
{
  const std::string ctx = "Imu::measure";
  if (!std::isfinite(in.time))
    throw std::invalid_argument(ctx + ": time is not finite");
  if (!in.pose.matrix().allFinite())
    throw std::invalid_argument(ctx + ": pose is not finite");
  const Eigen::Matrix3d rb = in.pose.linear();
  if (!(rb.transpose() * rb).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || rb.determinant() < 0.0)
    throw std::invalid_argument(ctx + ": pose rotation is not a rotation matrix");
  if (!in.linear_velocity.allFinite())
    throw std::invalid_argument(ctx + ": linear_velocity is not finite");
  if (!in.angular_velocity.allFinite())
    throw std::invalid_argument(ctx + ": angular_velocity is not finite");
  if (in.linear_acceleration && !in.linear_acceleration->allFinite())
    throw std::invalid_argument(ctx + ": linear_acceleration is not finite");
  if (in.angular_acceleration && !in.angular_acceleration->allFinite())
    throw std::invalid_argument(ctx + ": angular_acceleration is not finite");
  if (started_ && in.time < last_time_)
    throw std::invalid_argument(ctx + ": time " + std::to_string(in.time) + " s is earlier than the last sample (" +
                                std::to_string(last_time_) + " s)");

  const double dt = started_ ? in.time - last_time_ : 0.0;
  // Accelerations: given, or backward differences of the successive velocities.
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), alpha = Eigen::Vector3d::Zero();
  if (in.linear_acceleration)
    a = *in.linear_acceleration;
  else if (started_ && dt > 0.0)
    a = (in.linear_velocity - last_velocity_) / dt;
  if (in.angular_acceleration)
    alpha = *in.angular_acceleration;
  else if (started_ && dt > 0.0)
    alpha = (in.angular_velocity - last_angular_velocity_) / dt;

  const Eigen::Vector3d& w = in.angular_velocity;
  const Eigen::Vector3d r = rb * config_.mount.translation();  // lever arm, map
  const Eigen::Vector3d a_imu = a + alpha.cross(r) + w.cross(w.cross(r));
  const Eigen::Matrix3d rot = rb * config_.mount.linear();  // IMU frame -> map
  const Eigen::Vector3d g(0.0, 0.0, -config_.gravity);
  true_force_ = rot.transpose() * (a_imu - g);
  true_rate_ = rot.transpose() * w;

  // Fixed draw order per sample: gyro bias, accel bias, gyro white, accel white, orientation.
  const Eigen::Vector3d n_gb = normal_.vector3();
  const Eigen::Vector3d n_ab = normal_.vector3();
  const Eigen::Vector3d n_gw = normal_.vector3();
  const Eigen::Vector3d n_aw = normal_.vector3();
  const Eigen::Vector3d n_o = normal_.vector3();
  if (!started_)
  {
    gyro_bias_ = config_.gyro_turn_on_bias * n_gb;
    accel_bias_ = config_.accel_turn_on_bias * n_ab;
  }
  else
  {
    gyro_bias_ += config_.gyro_random_walk * std::sqrt(dt) * n_gb;
    accel_bias_ += config_.accel_random_walk * std::sqrt(dt) * n_ab;
  }
  const double sqrt_rate = std::sqrt(config_.rate);
  const double sigma_g = config_.gyro_noise_density * sqrt_rate;
  const double sigma_a = config_.accel_noise_density * sqrt_rate;

  ImuSample s;
  s.time = in.time;
  s.angular_velocity = true_rate_ + gyro_bias_ + sigma_g * n_gw;
  s.linear_acceleration = true_force_ + accel_bias_ + sigma_a * n_aw;
  s.orientation = Eigen::Quaterniond(rot * rotationFromVector(config_.orientation_noise * n_o)).normalized();
  s.orientation_covariance = Eigen::Matrix3d::Identity() * (config_.orientation_noise * config_.orientation_noise);
  s.angular_velocity_covariance = Eigen::Matrix3d::Identity() * (sigma_g * sigma_g);
  s.linear_acceleration_covariance = Eigen::Matrix3d::Identity() * (sigma_a * sigma_a);

  started_ = true;
  last_time_ = in.time;
  last_velocity_ = in.linear_velocity;
  last_angular_velocity_ = in.angular_velocity;
  clock_.taken(in.time);
  return s;
}

}  // namespace sensors
}  // namespace avsp
