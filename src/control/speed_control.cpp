#include "avsp/control/speed_control.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace avsp
{
namespace control
{
namespace
{
void requireFinite(double value, double min, double max, const char* name, const char* unit)
{
  if (!std::isfinite(value) || value < min || value > max)
    throw std::invalid_argument(std::string(name) + " = " + std::to_string(value) + " must be finite and in [" +
                                std::to_string(min) + ", " + std::to_string(max) + "] (" + unit + ")");
}
}  // namespace

void validate(const PidGains& g)
{
  requireFinite(g.kp, 0.0, 100.0, "speed_kp", "1 per m/s");
  requireFinite(g.ki, 0.0, 100.0, "speed_ki", "1 per m");
  requireFinite(g.kd, 0.0, 100.0, "speed_kd", "1 per m/s^2");
  if (!std::isfinite(g.integral_limit) || g.integral_limit <= 0.0 || g.integral_limit > 1.0)
    throw std::invalid_argument("speed_integral_limit = " + std::to_string(g.integral_limit) +
                                " must be finite and in (0, 1]");
}

SpeedPid::SpeedPid(const PidGains& gains) : gains_(gains)
{
  validate(gains_);
}

double SpeedPid::update(double target, double measured, double dt, double feedforward, bool integrate)
{
  const double error = target - measured;
  double derivative = 0.0;
  if (dt > 0.0 && has_previous_)
    derivative = (measured - previous_measured_) / dt;
  previous_measured_ = measured;
  has_previous_ = true;

  const double without_integral = feedforward + gains_.kp * error - gains_.kd * derivative;
  if (dt > 0.0 && integrate)
  {
    const double step = gains_.ki * error * dt;
    if (gains_.anti_windup)
    {
      // Conditional integration: no growth in the direction that is already saturated.
      const double effort = without_integral + integral_;
      const bool saturated_high = effort >= 1.0 && step > 0.0;
      const bool saturated_low = effort <= -1.0 && step < 0.0;
      if (!saturated_high && !saturated_low)
        integral_ += step;
      integral_ = std::clamp(integral_, -gains_.integral_limit, gains_.integral_limit);
    }
    else
    {
      integral_ += step;
    }
  }
  return std::clamp(without_integral + integral_, -1.0, 1.0);
}

void SpeedPid::reset()
{
  integral_ = 0.0;
  has_previous_ = false;
}

Pedals pedalsForEffort(double effort, double coast_band, double brake_gain)
{
  Pedals p;
  if (!std::isfinite(effort))
  {
    p.brake = 1.0;
    return p;
  }
  if (effort > 0.0)
    p.throttle = std::min(effort, 1.0);
  else if (-effort > coast_band)
    p.brake = std::min(1.0, brake_gain * (-effort - coast_band));
  return p;
}

SpeedProfile::SpeedProfile(std::vector<double> waypoint_s, std::vector<double> segment_speeds, double decel,
                           double approach_speed)
  : s_(std::move(waypoint_s)), v_(std::move(segment_speeds)), decel_(decel), approach_speed_(approach_speed)
{
  if (s_.size() < 2)
    throw std::invalid_argument("SpeedProfile: at least 2 waypoints are needed");
  if (v_.size() + 1 != s_.size())
    throw std::invalid_argument("SpeedProfile: one speed per segment (" + std::to_string(s_.size() - 1) +
                                ") is needed, got " + std::to_string(v_.size()));
  for (std::size_t k = 0; k + 1 < s_.size(); ++k)
    if (!(s_[k + 1] > s_[k]))
      throw std::invalid_argument("SpeedProfile: waypoint arc lengths must increase (segment " + std::to_string(k) +
                                  ")");
  for (std::size_t k = 0; k < v_.size(); ++k)
    if (!std::isfinite(v_[k]) || v_[k] <= 0.0)
      throw std::invalid_argument("SpeedProfile: segment " + std::to_string(k) + " speed " + std::to_string(v_[k]) +
                                  " must be finite and > 0 (m/s)");
  if (!std::isfinite(decel_) || decel_ <= 0.0)
    throw std::invalid_argument("decel = " + std::to_string(decel_) + " must be finite and > 0 (m/s^2)");
  if (!std::isfinite(approach_speed_) || approach_speed_ <= 0.0)
    throw std::invalid_argument("approach_speed = " + std::to_string(approach_speed_) +
                                " must be finite and > 0 (m/s)");
}

std::size_t SpeedProfile::segmentAt(double s) const
{
  if (s_.size() < 2)
    return 0;
  const auto it = std::upper_bound(s_.begin(), s_.end(), s);
  const std::ptrdiff_t i = (it - s_.begin()) - 1;
  return static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(i, 0, static_cast<std::ptrdiff_t>(v_.size()) - 1));
}

double SpeedProfile::segmentSpeed(double s) const
{
  return v_.empty() ? 0.0 : v_[segmentAt(s)];
}

double SpeedProfile::targetSpeed(double s) const
{
  if (v_.empty())
    return 0.0;
  const std::size_t k = segmentAt(s);
  double target = v_[k];
  for (std::size_t j = k + 1; j < v_.size(); ++j)
    if (v_[j] < target)
      target = std::min(target, std::sqrt(v_[j] * v_[j] + 2.0 * decel_ * std::max(0.0, s_[j] - s)));
  const double to_goal = std::sqrt(2.0 * decel_ * std::max(0.0, s_.back() - s));
  return std::min(target, std::max(to_goal, std::min(approach_speed_, v_[k])));
}

}  // namespace control
}  // namespace avsp
