#include "avsp_sensors/gps.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace sensors
{
void validateGpsConfig(const GpsConfig& c)
{
  const std::string ctx = "GpsConfig";
  check::positive(ctx, "rate", c.rate);
  check::nonNegative(ctx, "horizontal_noise", c.horizontal_noise);
  check::nonNegative(ctx, "vertical_noise", c.vertical_noise);
  check::nonNegative(ctx, "horizontal_bias_sigma", c.horizontal_bias_sigma);
  check::nonNegative(ctx, "vertical_bias_sigma", c.vertical_bias_sigma);
  check::positiveOrInfinite(ctx, "bias_time_constant", c.bias_time_constant);
}

namespace
{
const GpsConfig& validated(const GpsConfig& c)
{
  validateGpsConfig(c);
  return c;
}
}  // namespace

Gps::Gps(GpsConfig config, EnuFrame frame, std::uint64_t seed)
  : config_(validated(config)), frame_(frame), normal_(seed), clock_(config_.rate)
{
}

GpsFix Gps::measure(double t, const Eigen::Vector3d& enu)
{
  if (!std::isfinite(t))
    throw std::invalid_argument("Gps::measure: time is not finite");
  if (!enu.allFinite())
    throw std::invalid_argument("Gps::measure: enu position is not finite");
  if (started_ && t < last_time_)
    throw std::invalid_argument("Gps::measure: time " + std::to_string(t) + " s is earlier than the last fix (" +
                                std::to_string(last_time_) + " s)");
  const Eigen::Vector3d bias_sigma(config_.horizontal_bias_sigma, config_.horizontal_bias_sigma,
                                   config_.vertical_bias_sigma);
  const Eigen::Vector3d white_sigma(config_.horizontal_noise, config_.horizontal_noise, config_.vertical_noise);
  // Fixed draw order per fix: three bias innovations, then three white deviates.
  const Eigen::Vector3d n_bias = normal_.vector3();
  const Eigen::Vector3d n_white = normal_.vector3();
  if (!started_)
  {
    bias_ = bias_sigma.cwiseProduct(n_bias);  // the stationary distribution
    started_ = true;
  }
  else
  {
    const double dt = t - last_time_;
    for (int k = 0; k < 3; ++k)
      bias_[k] = gaussMarkovStep(bias_[k], bias_sigma[k], config_.bias_time_constant, dt, n_bias[k]);
  }
  last_time_ = t;
  clock_.taken(t);

  GpsFix fix;
  fix.time = t;
  fix.error = bias_ + white_sigma.cwiseProduct(n_white);
  fix.position = frame_.toGeodetic(enu + fix.error);
  fix.covariance = (bias_sigma.cwiseAbs2() + white_sigma.cwiseAbs2()).asDiagonal();
  return fix;
}

}  // namespace sensors
}  // namespace avsp
