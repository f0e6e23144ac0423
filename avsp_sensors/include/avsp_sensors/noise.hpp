#pragma once
/**
 * @file noise.hpp
 * @brief Building blocks shared by the sampled sensors (GPS, IMU, magnetometer, ultrasonic):
 *        a seeded normal source, the exact discrete step of a first-order Gauss-Markov process,
 *        a sample clock for a fixed output rate, and config-checking helpers whose messages
 *        name the field.
 */
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include <Eigen/Core>

namespace avsp
{
namespace sensors
{
/**
 * @brief Standard normal deviates from a seeded std::mt19937_64 (whose output sequence the C++
 *        standard fixes), turned into normals by Box-Muller here rather than by
 *        std::normal_distribution (whose algorithm is implementation-defined): the same seed gives
 *        the same numbers with any standard library. Each call consumes exactly two 64-bit draws.
 */
class NormalSource
{
public:
  explicit NormalSource(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }

  /// One standard normal deviate.
  double operator()()
  {
    const double u1 = 1.0 - uniform();  // (0, 1]: safe under the logarithm
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

  /// Three independent standard normal deviates.
  Eigen::Vector3d vector3()
  {
    const double x = (*this)();
    const double y = (*this)();
    const double z = (*this)();
    return { x, y, z };
  }

private:
  std::mt19937_64 engine_;
};

/**
 * @brief Exact step of a first-order Gauss-Markov (Ornstein-Uhlenbeck) process
 *        db/dt = -b / tau + w, stationary standard deviation sigma, over dt >= 0:
 *        b(t + dt) = b(t) e^(-dt/tau) + sigma sqrt(1 - e^(-2 dt/tau)) n, n ~ N(0, 1).
 *        Its autocorrelation is sigma^2 e^(-|lag|/tau) whatever the steps. tau = +inf gives a
 *        constant b.
 */
inline double gaussMarkovStep(double b, double sigma, double tau, double dt, double n)
{
  if (!std::isfinite(tau))
    return b;
  const double phi = std::exp(-dt / tau);
  return b * phi + sigma * std::sqrt(std::max(0.0, 1.0 - phi * phi)) * n;
}

/**
 * @brief When a sensor with a fixed output rate is due. The first sample is due at once; sample
 *        k is due at t_0 + k / rate (no drift from late polling: a late sample does not move the
 *        following ones).
 */
class SampleClock
{
public:
  /// @param rate Hz, > 0 and finite (checked by the sensors' config validation)
  explicit SampleClock(double rate) : period_(1.0 / rate) {}

  /// True when a sample is due at time t (s).
  bool due(double t) const { return !started_ || t >= next_ - 1e-9 * period_; }

  /// Records a sample taken at t: the next one is the first grid time t_0 + k period after t.
  void taken(double t)
  {
    if (!started_)
    {
      started_ = true;
      first_ = t;
      count_ = 0;
    }
    const double k = std::floor((t - first_) / period_ + 1e-9);
    count_ = static_cast<std::uint64_t>(std::max(0.0, k)) + 1;
    next_ = first_ + static_cast<double>(count_) * period_;
  }

  double period() const { return period_; }
  /// Time of the next due sample (the first one: -inf).
  double next() const { return started_ ? next_ : -std::numeric_limits<double>::infinity(); }

private:
  double period_;
  bool started_ = false;
  double first_ = 0.0, next_ = 0.0;
  std::uint64_t count_ = 0;
};

/// Config checks whose std::invalid_argument names "<context>: <field> ...".
namespace check
{
[[noreturn]] inline void fail(const std::string& context, const std::string& field, const std::string& rule,
                              double value)
{
  throw std::invalid_argument(context + ": " + field + " must be " + rule + " (got " + std::to_string(value) + ")");
}

/// finite and > 0
inline void positive(const std::string& context, const std::string& field, double v)
{
  if (!(v > 0.0) || !std::isfinite(v))
    fail(context, field, "finite and > 0", v);
}

/// finite and >= 0
inline void nonNegative(const std::string& context, const std::string& field, double v)
{
  if (!(v >= 0.0) || !std::isfinite(v))
    fail(context, field, "finite and >= 0", v);
}

/// > 0, +inf allowed (a time constant "forever")
inline void positiveOrInfinite(const std::string& context, const std::string& field, double v)
{
  if (!(v > 0.0))
    fail(context, field, "> 0 (+inf allowed)", v);
}

/// finite and within [lo, hi]
inline void within(const std::string& context, const std::string& field, double v, double lo, double hi)
{
  if (!(v >= lo && v <= hi))
    fail(context, field, "within [" + std::to_string(lo) + ", " + std::to_string(hi) + "]", v);
}

/// finite
inline void finite(const std::string& context, const std::string& field, double v)
{
  if (!std::isfinite(v))
    fail(context, field, "finite", v);
}
}  // namespace check

}  // namespace sensors
}  // namespace avsp
