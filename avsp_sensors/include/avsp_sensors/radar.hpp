#pragma once
/**
 * @file radar.hpp
 * @brief Radar (docs/MODELS.md section 4): a fan of rays over the field of view (HFOV 30 deg,
 *        VFOV 4.4 deg by default), each hit a detection with its Doppler range rate from the
 *        relative velocity of what it hit; DBSCAN groups the detections and each cluster is
 *        reported as a target (centroid, range, azimuth, elevation, range rate, point count,
 *        extent), the fields of avsp_msgs/RadarTarget.
 */
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/dbscan.hpp"
#include "avsp_sensors/point_types.hpp"
#include "avsp_sensors/primitives.hpp"
#include "avsp_sensors/scene.hpp"

namespace avsp
{
namespace sensors
{
/// Radar configuration. Angles in rad, lengths in m.
struct RadarConfig
{
  double horizontal_fov = 30.0 * 3.14159265358979323846 / 180.0;  ///< rad, (0, 2 pi)
  double vertical_fov = 4.4 * 3.14159265358979323846 / 180.0;     ///< rad, [0, pi)
  std::size_t azimuth_rays = 61;   ///< rays across the HFOV (0.5 deg apart by default), >= 1
  std::size_t elevation_rays = 9;  ///< rays across the VFOV (0.55 deg apart), >= 1
  double min_range = 0.5;          ///< m, >= 0
  double max_range = 150.0;        ///< m, > min_range
  double range_noise = 0.0;        ///< m, standard deviation, >= 0
  double range_rate_noise = 0.0;   ///< m/s, standard deviation, >= 0
  /// Ground hits become detections only when true: a radar's CFAR processing normally
  /// suppresses the ground's spread clutter, and left in, the ground forms clusters of its own.
  bool terrain_returns = false;
  double cluster_eps = 1.0;            ///< m, DBSCAN eps
  std::size_t cluster_min_points = 3;  ///< DBSCAN min_points
};

/// @throw std::invalid_argument naming the field that is out of range or not finite
void validateRadarConfig(const RadarConfig& config);

/// One ray's hit.
struct RadarDetection
{
  Eigen::Vector3d position;  ///< m, radar frame
  double range = 0.0;        ///< m
  double azimuth = 0.0;      ///< rad, + left of x
  double elevation = 0.0;    ///< rad, + above the x-y plane
  double range_rate = 0.0;   ///< m/s, + moving away
  HitKind kind = HitKind::kNone;
  std::uint32_t id = 0;  ///< object or body id
};

/// One cluster of detections (avsp_msgs/RadarTarget).
struct RadarTarget
{
  Eigen::Vector3d centroid;  ///< m, radar frame: mean of the cluster's detections
  double range = 0.0;        ///< m, |centroid|
  double azimuth = 0.0;      ///< rad, of the centroid, + left
  double elevation = 0.0;    ///< rad, of the centroid, + up
  double range_rate = 0.0;   ///< m/s, mean of the detections' range rates, + receding
  std::uint32_t point_count = 0;
  Eigen::Vector3d extent;  ///< m, size of the detections' axis-aligned box in the radar frame
};

/// What to scan: where the radar is and how it moves.
struct RadarScanRequest
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< radar frame -> map
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      ///< m/s, map, of the radar's origin
  std::uint64_t scan = 0;                                  ///< scan number (random streams)
  unsigned threads = 1;                                    ///< 0 = all cores
  std::uint32_t ignore_body = PrimitiveBvh::kNoId;         ///< the vehicle carrying the radar
};

/// One scan.
struct RadarScan
{
  std::vector<RadarDetection> detections;  ///< ray order (elevation rows, azimuth within a row)
  DbscanResult clusters;                   ///< per detection
  std::vector<RadarTarget> targets;        ///< one per cluster, in cluster order
};

/**
 * @brief Range rate of a point moving at `point_velocity` seen from a sensor at `sensor_origin`
 *        moving at `sensor_velocity`: (v_point - v_sensor) . (p - o) / |p - o|; + = receding.
 */
double rangeRate(const Eigen::Vector3d& sensor_origin, const Eigen::Vector3d& sensor_velocity,
                 const Eigen::Vector3d& point, const Eigen::Vector3d& point_velocity);

/**
 * @brief The scan's detections as a PCL cloud (what `radar/points` publishes): positions and
 *        range rates rounded to float, each with its DBSCAN cluster (-1: noise), in ray order.
 *        DBSCAN itself clusters the double positions (RadarScan::clusters): rounding them first
 *        could move a pair at exactly eps across the threshold.
 */
RadarCloud radarCloud(const RadarScan& scan);

/// Targets from clustered detections (one per cluster, in cluster order).
std::vector<RadarTarget> clusterTargets(const std::vector<RadarDetection>& detections, const DbscanResult& clusters);

/// A radar with a fixed configuration and random seed.
class Radar
{
public:
  /// @throw std::invalid_argument (validateRadarConfig)
  Radar(RadarConfig config, std::uint64_t seed);

  const RadarConfig& config() const { return config_; }

  /// @throw std::invalid_argument naming the field for a non-finite pose or velocity
  RadarScan scan(const Scene& scene, const RadarScanRequest& request) const;

private:
  RadarConfig config_;
  std::uint64_t seed_;
};

}  // namespace sensors
}  // namespace avsp
