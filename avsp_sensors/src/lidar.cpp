#include "avsp_sensors/lidar.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "avsp_sensors/parallel.hpp"
#include "avsp_sensors/random.hpp"
#include "avsp_sensors/scene.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
/// Sub-rays per pulse beyond which a configuration is surely a mistake (and too slow to cast).
constexpr std::size_t kMaxSubRays = 1024;

[[noreturn]] void badConfig(const LidarConfig& c, const std::string& what)
{
  throw std::invalid_argument("LidarConfig '" + c.name + "': " + what);
}

bool finiteAtLeast(double v, double lo)
{
  return std::isfinite(v) && v >= lo;
}

}  // namespace

namespace detail
{
/// One sub-ray's hit as the echo builder needs it.
struct SubHit
{
  double range;      ///< m
  double intensity;  ///< rho cos(i) T^2 / N
  double power;      ///< intensity / range^2
};

/// What one pulse produced.
struct PulseResult
{
  bool valid = false;
  bool clutter = false;
  bool dropped = false;
  std::uint32_t rays = 0;
  LidarPoint point{};
};
}  // namespace detail
using detail::PulseResult;
using detail::SubHit;

std::size_t subRayCount(const LidarConfig& c)
{
  if (c.sub_rays > 0)
    return c.sub_rays;
  const double theta = std::max(c.divergence_horizontal, c.divergence_vertical);
  const double n = 2.0 * (c.aperture_radius + c.max_range * std::tan(0.5 * theta)) / c.target_scale;
  if (!std::isfinite(n))
    return kMaxSubRays + 1;
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(n - 1e-9)));
}

void validateLidarConfig(const LidarConfig& c)
{
  if (c.channels.empty())
    badConfig(c, "channels is empty");
  if (c.channels.size() > 65536)
    badConfig(c, "channels has more than 65536 entries (ring is uint16)");
  for (std::size_t k = 0; k < c.channels.size(); ++k)
  {
    const LidarChannel& ch = c.channels[k];
    const std::string at = "channels[" + std::to_string(k) + "].";
    if (!std::isfinite(ch.elevation) || std::abs(ch.elevation) > 0.5 * kPi)
      badConfig(c, at + "elevation must be finite within [-pi/2, pi/2] rad");
    if (!std::isfinite(ch.azimuth_offset))
      badConfig(c, at + "azimuth_offset must be finite");
    if (!finiteAtLeast(ch.time_offset, 0.0))
      badConfig(c, at + "time_offset must be finite and >= 0 s");
  }
  if (!(c.rotation_rate > 0.0) || !std::isfinite(c.rotation_rate))
    badConfig(c, "rotation_rate must be finite and > 0 Hz, got " + std::to_string(c.rotation_rate));
  if (c.columns < 1)
    badConfig(c, "columns must be >= 1");
  if (!std::isfinite(c.start_azimuth))
    badConfig(c, "start_azimuth must be finite");
  if (!finiteAtLeast(c.min_range, 0.0))
    badConfig(c, "min_range must be finite and >= 0 m, got " + std::to_string(c.min_range));
  if (!std::isfinite(c.max_range) || !(c.max_range > c.min_range))
    badConfig(c, "max_range must be finite and > min_range, got " + std::to_string(c.max_range));
  if (!(c.reference_range > 0.0) || !std::isfinite(c.reference_range))
    badConfig(c, "reference_range must be finite and > 0 m");
  if (!(c.reference_reflectivity > 0.0 && c.reference_reflectivity <= 1.0))
    badConfig(c, "reference_reflectivity must be in (0, 1]");
  if (!finiteAtLeast(c.range_noise, 0.0))
    badConfig(c, "range_noise must be finite and >= 0 m, got " + std::to_string(c.range_noise));
  if (!(c.dropout >= 0.0 && c.dropout <= 1.0))
    badConfig(c, "dropout must be in [0, 1]");
  if (!finiteAtLeast(c.divergence_horizontal, 0.0) || c.divergence_horizontal >= kPi)
    badConfig(c, "divergence_horizontal must be in [0, pi) rad");
  if (!finiteAtLeast(c.divergence_vertical, 0.0) || c.divergence_vertical >= kPi)
    badConfig(c, "divergence_vertical must be in [0, pi) rad");
  if (!finiteAtLeast(c.aperture_radius, 0.0))
    badConfig(c, "aperture_radius must be finite and >= 0 m");
  if (!(c.target_scale > 0.0) || !std::isfinite(c.target_scale))
    badConfig(c, "target_scale must be finite and > 0 m");
  if (!finiteAtLeast(c.echo_separation, 0.0))
    badConfig(c, "echo_separation must be finite and >= 0 m");
  if (!(c.wavelength > 0.0) || !std::isfinite(c.wavelength))
    badConfig(c, "wavelength must be finite and > 0 m");
  if (!finiteAtLeast(c.clutter_max_range, 0.0))
    badConfig(c, "clutter_max_range must be finite and >= 0 m");
  if (!(c.clutter_efficiency >= 0.0 && c.clutter_efficiency <= 1.0))
    badConfig(c, "clutter_efficiency must be in [0, 1]");
  if (!(c.clutter_reflectivity >= 0.f && c.clutter_reflectivity <= 1.f))
    badConfig(c, "clutter_reflectivity must be in [0, 1]");
  if (subRayCount(c) > kMaxSubRays)
    badConfig(c, "sub_rays (given or from the divergence formula) exceeds " + std::to_string(kMaxSubRays));
}

Eigen::Isometry3d SensorMotion::at(double t) const
{
  Eigen::Isometry3d p = pose;
  const double w = angular_velocity.norm();
  if (w > 0.0)
    p.linear() = Eigen::AngleAxisd(w * t, angular_velocity / w).toRotationMatrix() * pose.linear();
  p.translation() = pose.translation() + linear_velocity * t;
  return p;
}

void validateMotion(const SensorMotion& m, const char* context)
{
  if (!m.pose.matrix().allFinite())
    throw std::invalid_argument(std::string(context) + ": motion.pose is not finite");
  const Eigen::Matrix3d R = m.pose.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0.0)
    throw std::invalid_argument(std::string(context) + ": motion.pose rotation is not a rotation matrix");
  if (!m.linear_velocity.allFinite())
    throw std::invalid_argument(std::string(context) + ": motion.linear_velocity is not finite");
  if (!m.angular_velocity.allFinite())
    throw std::invalid_argument(std::string(context) + ": motion.angular_velocity is not finite");
}

Lidar::Lidar(LidarConfig config, std::uint64_t seed) : config_(std::move(config)), seed_(seed)
{
  validateLidarConfig(config_);
  // Ring = rank by elevation; equal elevations keep firing order.
  const std::size_t n = config_.channels.size();
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k)
    order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return config_.channels[a].elevation < config_.channels[b].elevation;
  });
  rings_.resize(n);
  for (std::size_t r = 0; r < n; ++r)
    rings_[order[r]] = static_cast<std::uint16_t>(r);
  // Sub-rays at the centroids of N equal-area parts of the footprint (a Vogel spiral): each
  // stands for 1/N of a uniformly lit beam. One sub-ray is the beam's axis.
  const std::size_t ns = subRayCount(config_);
  if (ns == 1)
    sub_offsets_.emplace_back(0.0, 0.0);
  else
  {
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    for (std::size_t m = 0; m < ns; ++m)
    {
      const double rho = std::sqrt((static_cast<double>(m) + 0.5) / static_cast<double>(ns));
      const double phi = golden * static_cast<double>(m);
      sub_offsets_.emplace_back(rho * std::cos(phi), rho * std::sin(phi));
    }
  }
}

/// What every pulse of a sweep shares.
struct Lidar::SweepConstants
{
  double alpha;          ///< 1/m, extinction at the wavelength
  double kappa;          ///< 1/m, rate of falling particles along a beam
  double threshold;      ///< the weakest detectable echo's power
  double column_period;  ///< s between columns
  double spin;           ///< rad/s, signed
  double tan_h, tan_v;   ///< tangents of the half divergences
  double inv_n;          ///< 1 / sub-rays
};

namespace
{
/// The echo a pulse reports.
struct Echo
{
  double range = -1.0, power = -1.0, intensity = 0.0;
  bool clutter = false;
};

/// The strongest (or last) echo among the pulse's sub-ray echoes, runs of sub-ray ranges with
/// gaps <= echo_separation, and the clutter (a falling particle), if any; none: range < 0.
Echo chooseEcho(const LidarConfig& c, double threshold, std::vector<SubHit>& subs, const SubHit* clutter)
{
  std::sort(subs.begin(), subs.end(), [](const SubHit& a, const SubHit& b) { return a.range < b.range; });
  Echo best;
  auto consider = [&](double range, double power, double intensity, bool is_clutter) {
    if (power < threshold || range < c.min_range || range > c.max_range)
      return;
    const bool better = c.return_mode == ReturnMode::kStrongest ? power > best.power : range > best.range;
    if (better)
      best = { range, power, intensity, is_clutter };
  };
  for (std::size_t a = 0; a < subs.size();)
  {
    std::size_t b = a + 1;
    while (b < subs.size() && subs[b].range - subs[b - 1].range <= c.echo_separation)
      ++b;
    double power = 0.0, intensity = 0.0, weighted = 0.0;
    for (std::size_t m = a; m < b; ++m)
    {
      power += subs[m].power;
      intensity += subs[m].intensity;
      weighted += subs[m].power * subs[m].range;
    }
    const double range = power > 0.0 ? weighted / power : subs[a].range;
    consider(range, power, intensity, false);
    a = b;
  }
  if (clutter)
    consider(clutter->range, clutter->power, clutter->intensity, true);
  return best;
}

/// The sweep's points in pulse order, with its counts.
LidarScan gatherScan(const std::vector<PulseResult>& results, const LidarConfig& c, bool registered)
{
  LidarScan scan;
  scan.pulses = results.size();
  scan.duration = 1.0 / c.rotation_rate;
  scan.registered = registered;
  std::size_t valid = 0;
  for (const PulseResult& r : results)
    valid += r.valid;
  scan.points.reserve(valid);
  scan.particle_echo.reserve(valid);
  for (const PulseResult& r : results)
  {
    scan.rays += r.rays;
    scan.dropped += r.dropped;
    if (!r.valid)
      continue;
    scan.clutter += r.clutter;
    scan.points.push_back(r.point);
    scan.particle_echo.push_back(r.clutter);
  }
  return scan;
}
}  // namespace

LidarScan Lidar::scan(const Scene& scene, const LidarScanRequest& req) const
{
  validateMotion(req.motion, "Lidar::scan");
  validateWeather(req.weather);
  const LidarConfig& c = config_;
  SweepConstants k;
  k.alpha = extinction(req.weather, c.wavelength);
  k.kappa = clutterRate(req.weather, c.wavelength, c.clutter_efficiency);
  k.threshold = c.reference_reflectivity / (c.reference_range * c.reference_range);
  const std::size_t nch = c.channels.size(), ncol = c.columns, ns = sub_offsets_.size();
  k.column_period = 1.0 / (c.rotation_rate * static_cast<double>(ncol));
  k.spin = (c.clockwise ? -2.0 : 2.0) * kPi * c.rotation_rate;
  k.tan_h = std::tan(0.5 * c.divergence_horizontal);
  k.tan_v = std::tan(0.5 * c.divergence_vertical);
  k.inv_n = 1.0 / static_cast<double>(ns);

  std::vector<PulseResult> results(nch * ncol);
  // Columns handed out in small chunks as threads come free (their costs differ with what
  // they face); every pulse depends on its index alone, so the schedule does not show.
  parallelForDynamic(ncol, req.threads, 16, [&](std::size_t col_begin, std::size_t col_end) {
    std::vector<SubHit> subs;
    subs.reserve(ns + 1);
    for (std::size_t col = col_begin; col < col_end; ++col)
      for (std::size_t ch = 0; ch < nch; ++ch)
        firePulse(scene, req, k, col, ch, subs, results[col * nch + ch]);
  });
  return gatherScan(results, c, req.registered);
}

void Lidar::firePulse(const Scene& scene, const LidarScanRequest& req, const SweepConstants& k, std::size_t col,
                      std::size_t channel, std::vector<SubHit>& subs, PulseResult& out) const
{
  const LidarConfig& c = config_;
  const LidarChannel& ch = c.channels[channel];
  const std::size_t index = col * c.channels.size() + channel;
  // Every draw is taken, in this order, whatever happens to the pulse: the stream of a pulse
  // is then the same under any weather, which makes weather effects monotonic for a fixed seed.
  StreamRng rng(streamKey(seed_, req.sweep, index));
  const double u_drop = rng.uniform();
  const double n_range = rng.normal();
  const double u_clutter = rng.uniformPositive();

  const double t = static_cast<double>(col) * k.column_period + ch.time_offset;
  const double az = c.start_azimuth + k.spin * t + ch.azimuth_offset;
  const double ca = std::cos(az), sa = std::sin(az), ce = std::cos(ch.elevation), se = std::sin(ch.elevation);
  const Eigen::Vector3d d(ce * ca, ce * sa, se);
  const Eigen::Vector3d e_h(-sa, ca, 0.0);
  const Eigen::Vector3d e_v(-se * ca, -se * sa, ce);
  const Eigen::Isometry3d pose = req.motion.at(t);

  subs.clear();
  double first_hit = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector2d& s : sub_offsets_)
  {
    Ray ray;
    ray.origin = pose * (c.aperture_radius * (s.x() * e_h + s.y() * e_v));
    ray.direction = pose.linear() * (d + k.tan_h * s.x() * e_h + k.tan_v * s.y() * e_v).normalized();
    ray.max_range = c.max_range;
    ray.ignore_body = req.ignore_body;
    const RayHit hit = scene.cast(ray);
    ++out.rays;
    if (!hit.hit())
      continue;
    first_hit = std::min(first_hit, hit.range);
    const double cos_i = std::max(0.0, -ray.direction.dot(hit.normal));
    const double intensity = hit.reflectivity * cos_i * k.inv_n * twoWayTransmission(k.alpha, hit.range);
    // A sub-ray starting inside the ground (range 0) has no echo to speak of.
    if (hit.range > 0.0)
      subs.push_back({ hit.range, intensity, intensity / (hit.range * hit.range) });
  }
  // A falling particle nearer than the first hit: the first event of a Poisson process of rate
  // kappa along the beam, from min_range on.
  bool have_clutter = false;
  SubHit clutter{};
  if (k.kappa > 0.0)
  {
    const double r = c.min_range - std::log(u_clutter) / k.kappa;
    if (r <= c.clutter_max_range && r < first_hit && r > 0.0)
    {
      have_clutter = true;
      const double intensity = c.clutter_reflectivity * twoWayTransmission(k.alpha, r);
      clutter = { r, intensity, intensity / (r * r) };
    }
  }
  const Echo best = chooseEcho(c, k.threshold, subs, have_clutter ? &clutter : nullptr);
  if (best.range < 0.0)
    return;
  if (u_drop < c.dropout)
  {
    out.dropped = true;
    return;
  }
  const double range = best.range + c.range_noise * n_range;
  if (range < c.min_range)
    return;
  Eigen::Vector3d p = range * d;  // along the beam's axis from the sensor's origin
  if (req.registered)
    p = pose * p;
  out.valid = true;
  out.clutter = best.clutter;
  out.point.x = static_cast<float>(p.x());
  out.point.y = static_cast<float>(p.y());
  out.point.z = static_cast<float>(p.z());
  out.point.intensity = static_cast<float>(100.0 * best.intensity);
  out.point.ring = rings_[channel];
  out.point.time = static_cast<float>(t);
}

}  // namespace sensors
}  // namespace avsp
