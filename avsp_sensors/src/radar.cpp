#include "avsp_sensors/radar.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "avsp_sensors/parallel.hpp"
#include "avsp_sensors/random.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kPi = 3.14159265358979323846;

[[noreturn]] void bad(const std::string& what)
{
  throw std::invalid_argument("RadarConfig: " + what);
}

/// Angle of ray k of n spread evenly over [-fov / 2, fov / 2] (the centre for n = 1).
double fanAngle(std::size_t k, std::size_t n, double fov)
{
  return n == 1 ? 0.0 : -0.5 * fov + fov * static_cast<double>(k) / static_cast<double>(n - 1);
}
}  // namespace

void validateRadarConfig(const RadarConfig& c)
{
  if (!(c.horizontal_fov > 0.0 && c.horizontal_fov < 2.0 * kPi))
    bad("horizontal_fov must be in (0, 2 pi) rad, got " + std::to_string(c.horizontal_fov));
  if (!(c.vertical_fov >= 0.0 && c.vertical_fov < kPi))
    bad("vertical_fov must be in [0, pi) rad, got " + std::to_string(c.vertical_fov));
  if (c.azimuth_rays < 1)
    bad("azimuth_rays must be >= 1");
  if (c.elevation_rays < 1)
    bad("elevation_rays must be >= 1");
  if (!(c.min_range >= 0.0) || !std::isfinite(c.min_range))
    bad("min_range must be finite and >= 0 m, got " + std::to_string(c.min_range));
  if (!std::isfinite(c.max_range) || !(c.max_range > c.min_range))
    bad("max_range must be finite and > min_range, got " + std::to_string(c.max_range));
  if (!(c.range_noise >= 0.0) || !std::isfinite(c.range_noise))
    bad("range_noise must be finite and >= 0 m");
  if (!(c.range_rate_noise >= 0.0) || !std::isfinite(c.range_rate_noise))
    bad("range_rate_noise must be finite and >= 0 m/s");
  if (!(c.cluster_eps > 0.0) || !std::isfinite(c.cluster_eps))
    bad("cluster_eps must be finite and > 0 m");
  if (c.cluster_min_points < 1)
    bad("cluster_min_points must be >= 1");
}

double rangeRate(const Eigen::Vector3d& sensor_origin, const Eigen::Vector3d& sensor_velocity,
                 const Eigen::Vector3d& point, const Eigen::Vector3d& point_velocity)
{
  const Eigen::Vector3d line = point - sensor_origin;
  const double r = line.norm();
  if (r == 0.0)
    return 0.0;
  return (point_velocity - sensor_velocity).dot(line) / r;
}

std::vector<RadarTarget> clusterTargets(const std::vector<RadarDetection>& detections, const DbscanResult& clusters)
{
  std::vector<RadarTarget> targets(clusters.clusters);
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<Eigen::Vector3d> lo(clusters.clusters, Eigen::Vector3d::Constant(inf));
  std::vector<Eigen::Vector3d> hi(clusters.clusters, Eigen::Vector3d::Constant(-inf));
  for (auto& t : targets)
  {
    t.centroid.setZero();
    t.extent.setZero();
  }
  for (std::size_t k = 0; k < detections.size(); ++k)
  {
    const int label = clusters.labels[k];
    if (label < 0)
      continue;
    RadarTarget& t = targets[static_cast<std::size_t>(label)];
    t.centroid += detections[k].position;
    t.range_rate += detections[k].range_rate;
    ++t.point_count;
    lo[static_cast<std::size_t>(label)] = lo[static_cast<std::size_t>(label)].cwiseMin(detections[k].position);
    hi[static_cast<std::size_t>(label)] = hi[static_cast<std::size_t>(label)].cwiseMax(detections[k].position);
  }
  for (std::size_t c = 0; c < targets.size(); ++c)
  {
    RadarTarget& t = targets[c];
    const double n = static_cast<double>(t.point_count);
    t.centroid /= n;
    t.range_rate /= n;
    t.range = t.centroid.norm();
    t.azimuth = std::atan2(t.centroid.y(), t.centroid.x());
    t.elevation = std::atan2(t.centroid.z(), std::hypot(t.centroid.x(), t.centroid.y()));
    t.extent = hi[c] - lo[c];
  }
  return targets;
}

RadarCloud radarCloud(const RadarScan& scan)
{
  RadarCloud cloud;
  cloud.reserve(scan.detections.size());
  for (std::size_t k = 0; k < scan.detections.size(); ++k)
  {
    const RadarDetection& d = scan.detections[k];
    RadarPoint p;
    p.x = static_cast<float>(d.position.x());
    p.y = static_cast<float>(d.position.y());
    p.z = static_cast<float>(d.position.z());
    p.range_rate = static_cast<float>(d.range_rate);
    p.cluster = k < scan.clusters.labels.size() ? scan.clusters.labels[k] : kNoiseLabel;
    cloud.push_back(p);
  }
  return cloud;
}

Radar::Radar(RadarConfig config, std::uint64_t seed) : config_(config), seed_(seed)
{
  validateRadarConfig(config_);
}

RadarScan Radar::scan(const Scene& scene, const RadarScanRequest& req) const
{
  if (!req.pose.matrix().allFinite())
    throw std::invalid_argument("Radar::scan: pose is not finite");
  const Eigen::Matrix3d R = req.pose.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0.0)
    throw std::invalid_argument("Radar::scan: pose rotation is not a rotation matrix");
  if (!req.velocity.allFinite())
    throw std::invalid_argument("Radar::scan: velocity is not finite");
  const RadarConfig& c = config_;
  const std::size_t na = c.azimuth_rays, ne = c.elevation_rays, n = na * ne;
  struct Slot
  {
    bool valid = false;
    RadarDetection det;
  };
  std::vector<Slot> slots(n);
  const Eigen::Vector3d origin = req.pose.translation();
  parallelFor(n, req.threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k)
    {
      const std::size_t row = k / na, col = k % na;
      const double az = fanAngle(col, na, c.horizontal_fov), el = fanAngle(row, ne, c.vertical_fov);
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      StreamRng rng(streamKey(seed_, req.scan, k));
      const double n_range = rng.normal(), n_rate = rng.normal();
      Ray ray;
      ray.origin = origin;
      ray.direction = R * d;
      ray.max_range = c.max_range;
      ray.ignore_body = req.ignore_body;
      const RayHit hit = scene.cast(ray);
      if (!hit.hit() || hit.range < c.min_range || (hit.kind == HitKind::kTerrain && !c.terrain_returns))
        continue;
      Slot& s = slots[k];
      s.valid = true;
      RadarDetection& det = s.det;
      det.range = hit.range + c.range_noise * n_range;
      det.position = det.range * d;
      det.azimuth = az;
      det.elevation = el;
      det.range_rate = rangeRate(origin, req.velocity, hit.point, hit.velocity) + c.range_rate_noise * n_rate;
      det.kind = hit.kind;
      det.id = hit.id;
    }
  });
  RadarScan out;
  for (const Slot& s : slots)
    if (s.valid)
      out.detections.push_back(s.det);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(out.detections.size());
  for (const RadarDetection& d : out.detections)
    pts.push_back(d.position);
  out.clusters = dbscan(pts, c.cluster_eps, c.cluster_min_points);
  out.targets = clusterTargets(out.detections, out.clusters);
  return out;
}

}  // namespace sensors
}  // namespace avsp
