#include "avsp_dynamics/wheel_odometry.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace dynamics
{
double runningGearSpeed(const VehicleModel& model, const VehicleState& state)
{
  if (!state.tracks.empty())
  {
    if (state.tracks.size() != model.tracks.size())
      throw std::invalid_argument("runningGearSpeed: " + std::to_string(state.tracks.size()) + " track states for " +
                                  std::to_string(model.tracks.size()) + " tracks");
    double sum = 0.0;
    for (const TrackState& t : state.tracks)
      sum += t.track_speed;
    return sum / static_cast<double>(state.tracks.size());
  }
  if (state.wheels.size() != model.wheels.size() || state.wheels.empty())
    throw std::invalid_argument("runningGearSpeed: " + std::to_string(state.wheels.size()) + " wheel states for " +
                                std::to_string(model.wheels.size()) + " wheels");
  double sum = 0.0;
  for (std::size_t w = 0; w < state.wheels.size(); ++w)
    sum += state.wheels[w].spin_rate * model.wheels[w].radius;
  return sum / static_cast<double>(state.wheels.size());
}

double bodyYawRate(const VehicleState& state)
{
  return (state.pose.linear().transpose() * state.angular_velocity).z();
}

WheelOdometry::WheelOdometry(const Eigen::Isometry3d& start)
{
  x_ = start.translation().x();
  y_ = start.translation().y();
  z_ = start.translation().z();
  const Eigen::Vector3d forward = start.linear() * Eigen::Vector3d::UnitX();
  yaw_ = std::atan2(forward.y(), forward.x());
}

void WheelOdometry::step(double speed, double yaw_rate, double dt)
{
  if (!std::isfinite(speed) || !std::isfinite(yaw_rate) || !std::isfinite(dt) || dt < 0.0)
    throw std::invalid_argument("WheelOdometry::step: speed, yaw rate and dt must be finite, dt >= 0");
  const double turn = yaw_rate * dt;
  if (std::abs(turn) > 1e-12)
  {
    // Exact arc of radius speed / yaw_rate.
    const double r = speed / yaw_rate;
    x_ += r * (std::sin(yaw_ + turn) - std::sin(yaw_));
    y_ -= r * (std::cos(yaw_ + turn) - std::cos(yaw_));
  }
  else
  {
    x_ += speed * dt * std::cos(yaw_);
    y_ += speed * dt * std::sin(yaw_);
  }
  yaw_ = std::remainder(yaw_ + turn, 2.0 * M_PI);
  distance_ += std::abs(speed) * dt;
  turned_ += std::abs(turn);
}

Eigen::Isometry3d WheelOdometry::pose() const
{
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x_, y_, z_);
  p.linear() = Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

}  // namespace dynamics
}  // namespace avsp
