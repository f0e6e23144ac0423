#include "avsp_sensors/ultrasonic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "avsp_sensors/scene.hpp"

namespace avsp
{
namespace sensors
{
void validateUltrasonicConfig(const UltrasonicConfig& c)
{
  const std::string ctx = "UltrasonicConfig";
  check::positive(ctx, "rate", c.rate);
  if (!(c.field_of_view > 0.0 && c.field_of_view < M_PI))
    check::fail(ctx, "field_of_view", "within (0, pi) rad", c.field_of_view);
  check::nonNegative(ctx, "min_range", c.min_range);
  check::positive(ctx, "max_range", c.max_range);
  if (!(c.max_range > c.min_range))
    check::fail(ctx, "max_range", "> min_range (" + std::to_string(c.min_range) + " m)", c.max_range);
  check::nonNegative(ctx, "noise", c.noise);
  if (c.rings < 1 || c.rings > 64)
    check::fail(ctx, "rings", "within [1, 64]", static_cast<double>(c.rings));
  if (c.rays_per_ring < 3 || c.rays_per_ring > 256)
    check::fail(ctx, "rays_per_ring", "within [3, 256]", static_cast<double>(c.rays_per_ring));
}

namespace
{
const UltrasonicConfig& validated(const UltrasonicConfig& c)
{
  validateUltrasonicConfig(c);
  return c;
}
}  // namespace

Ultrasonic::Ultrasonic(UltrasonicConfig config, std::uint64_t seed)
  : config_(validated(config)), normal_(seed), clock_(config_.rate)
{
  directions_.push_back(Eigen::Vector3d::UnitX());
  const double half = 0.5 * config_.field_of_view;
  for (std::size_t k = 1; k <= config_.rings; ++k)
  {
    const double theta = half * static_cast<double>(k) / static_cast<double>(config_.rings);
    const double shift = (k % 2 == 0) ? 0.5 : 0.0;
    for (std::size_t m = 0; m < config_.rays_per_ring; ++m)
    {
      const double phi = 2.0 * M_PI * (static_cast<double>(m) + shift) / static_cast<double>(config_.rays_per_ring);
      directions_.emplace_back(std::cos(theta), std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi));
    }
  }
}

UltrasonicReading Ultrasonic::measure(const Scene& scene, double t, const Eigen::Isometry3d& pose,
                                      std::uint32_t ignore_body)
{
  const std::string ctx = "Ultrasonic::measure";
  if (!std::isfinite(t))
    throw std::invalid_argument(ctx + ": time is not finite");
  if (!pose.matrix().allFinite())
    throw std::invalid_argument(ctx + ": sensor_pose is not finite");
  const Eigen::Matrix3d r = pose.linear();
  if (!(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || r.determinant() < 0.0)
    throw std::invalid_argument(ctx + ": sensor_pose rotation is not a rotation matrix");
  if (started_ && t < last_time_)
    throw std::invalid_argument(ctx + ": time " + std::to_string(t) + " s is earlier than the last reading (" +
                                std::to_string(last_time_) + " s)");

  double nearest = std::numeric_limits<double>::infinity();
  Ray ray;
  ray.origin = pose.translation();
  ray.max_range = config_.max_range;
  ray.ignore_body = ignore_body;
  for (const Eigen::Vector3d& d : directions_)
  {
    ray.direction = (r * d).normalized();
    const RayHit hit = scene.cast(ray);
    if (hit.hit())
      nearest = std::min(nearest, hit.range);
  }
  const double n = normal_();  // one draw per reading, whatever was hit

  UltrasonicReading out;
  out.time = t;
  out.field_of_view = config_.field_of_view;
  out.min_range = config_.min_range;
  out.max_range = config_.max_range;
  if (!std::isfinite(nearest))
    out.range = std::numeric_limits<double>::infinity();
  else if (nearest < config_.min_range)
    out.range = -std::numeric_limits<double>::infinity();
  else
  {
    out.range = std::clamp(nearest + config_.noise * n, config_.min_range, config_.max_range);
    out.detected = true;
  }
  started_ = true;
  last_time_ = t;
  clock_.taken(t);
  return out;
}

}  // namespace sensors
}  // namespace avsp
