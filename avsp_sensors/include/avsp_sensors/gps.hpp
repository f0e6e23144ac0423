#pragma once
/**
 * @file gps.hpp
 * @brief GPS receiver model (docs/MODELS.md section 4): the antenna's ENU position in `map` becomes a
 *        WGS-84 fix through the scenario's geodetic reference (exact ellipsoid math,
 *        geodetic.hpp), with a slowly varying bias (first-order Gauss-Markov per ENU axis) plus
 *        white noise, at a configurable rate, with the covariance NavSatFix reports.
 *        Parameters and their sources: README.md, "GPS".
 */
#include <cstdint>

#include <Eigen/Core>

#include "avsp_sensors/geodetic.hpp"
#include "avsp_sensors/noise.hpp"

namespace avsp
{
namespace sensors
{
/**
 * @brief GPS error parameters. Lengths in m (1 sigma, per axis), times in s, rates in Hz.
 *
 * Defaults: a single-frequency consumer receiver (u-blox NEO-M8 class: 2.5 m CEP horizontal,
 * i.e. sigma = 2.5 / 1.1774 = 2.12 m per horizontal axis, split into a 2.0 m slowly varying bias
 * and 0.7 m white noise; vertical 3.5 m bias and 1.0 m white, about 1.7 times the horizontal
 * error). The split, the vertical figures and the 300 s time constant are assumptions
 * (README.md, "GPS").
 */
struct GpsConfig
{
  double rate = 10.0;                  ///< Hz, fixes per second, > 0
  double horizontal_noise = 0.7;       ///< m, white noise per east/north axis, >= 0
  double vertical_noise = 1.0;         ///< m, white noise on up, >= 0
  double horizontal_bias_sigma = 2.0;  ///< m, stationary sigma of the east/north bias, >= 0
  double vertical_bias_sigma = 3.5;    ///< m, stationary sigma of the up bias, >= 0
  double bias_time_constant = 300.0;   ///< s, correlation time of the bias, > 0 (+inf: constant bias)
};

/// @throw std::invalid_argument naming the field ("GpsConfig: rate must be ...")
void validateGpsConfig(const GpsConfig& config);

/// One fix, what sensor_msgs/NavSatFix carries.
struct GpsFix
{
  double time = 0.0;                   ///< s, simulation time of the fix
  Geodetic position{ 0.0, 0.0, 0.0 };  ///< degrees, degrees, m above the WGS-84 ellipsoid
  /// m^2, east-north-up (NavSatFix position_covariance, COVARIANCE_TYPE_DIAGONAL_KNOWN):
  /// diag(sigma_bias^2 + sigma_white^2) per axis, the stationary variance of the error.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  Eigen::Vector3d error = Eigen::Vector3d::Zero();  ///< m, ENU, reported minus true position (for tests, diagnostics)
};

/**
 * @brief A GPS receiver with a fixed configuration, reference origin and seed.
 *
 * Error per ENU axis: e = b + w, w ~ N(0, sigma_white^2) new at every fix, b a first-order
 * Gauss-Markov process with stationary sigma_bias and time constant tau, stepped exactly over
 * the time between fixes: b(t + dt) = b e^(-dt/tau) + sigma_bias sqrt(1 - e^(-2 dt/tau)) n.
 * The bias starts from its stationary distribution. Fix = EnuFrame::toGeodetic(p + e).
 * Same seed and same calls, same fixes.
 */
class Gps
{
public:
  /// @throw std::invalid_argument (validateGpsConfig)
  Gps(GpsConfig config, EnuFrame frame, std::uint64_t seed);

  const GpsConfig& config() const { return config_; }
  const EnuFrame& frame() const { return frame_; }

  /// True when a fix is due at time t (s) at the configured rate (the first one at once).
  bool due(double t) const { return clock_.due(t); }

  /**
   * @brief A fix of the antenna at ENU position `enu` (m, map) at time t (s); advances the bias
   *        to t and schedules the next fix.
   * @throw std::invalid_argument when t or enu is not finite or t is earlier than the last fix
   */
  GpsFix measure(double t, const Eigen::Vector3d& enu);

  /// Current bias, m, ENU (zero before the first fix).
  const Eigen::Vector3d& bias() const { return bias_; }

private:
  GpsConfig config_;
  EnuFrame frame_;
  NormalSource normal_;
  SampleClock clock_;
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  bool started_ = false;
  double last_time_ = 0.0;
};

}  // namespace sensors
}  // namespace avsp
