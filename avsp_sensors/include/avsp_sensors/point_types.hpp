#pragma once
/**
 * @file point_types.hpp
 * @brief The point types of the sensors' clouds, registered with PCL
 *        (POINT_CLOUD_REGISTER_POINT_STRUCT), so that every cloud is a `pcl::PointCloud<>` that
 *        PCL's algorithms read and pcl_conversions turns into a sensor_msgs/PointCloud2 whose
 *        fields and bytes are the ones the node published before PCL (docs/ARCHITECTURE.md,
 *        `avt_341/points` and `radar/points`).
 *
 * pcl::toPCLPointCloud2 copies each struct whole, padding included: every byte of these
 * structs is a named member with a default, so no uninitialised byte reaches a message.
 * No ROS types here: the core stays ROS-free (PCL is a plain C++ library, as Eigen is).
 */
#include <cstdint>

#include <pcl/point_cloud.h>
#include <pcl/register_point_struct.h>

namespace avsp
{
namespace sensors
{
/**
 * @brief One lidar point: the velodyne "XYZIRT" fields, laid out as the PointCloud2 of
 *        `avt_341/points`: float32 x, y, z, intensity at offsets 0, 4, 8, 12; uint16 ring at 16;
 *        float32 time at 20; 24 bytes. (Velodyne's own PointXYZIRT pads x, y, z to 16 bytes for
 *        SSE and is 32 bytes long; AVSP keeps its published 24-byte layout.)
 */
struct LidarPoint
{
  float x = 0.0f;          ///< m, in the frame the scan was asked for
  float y = 0.0f;          ///< m
  float z = 0.0f;          ///< m
  float intensity = 0.0f;  ///< 100 x apparent reflectivity (rho cos(i) T^2 summed over sub-rays), like
                           ///< Velodyne's calibrated reflectivity: 0-100 for diffuse targets
  std::uint16_t ring = 0;  ///< channel rank by elevation, 0 = lowest
  /// Bytes 18-19, not a field: zero, so that the copied message bytes are deterministic.
  std::uint16_t padding = 0;
  float time = 0.0f;  ///< s after the sweep start
};
static_assert(sizeof(LidarPoint) == 24, "LidarPoint must keep the 24-byte PointCloud2 layout");

/// A lidar sweep's points (one row: width = size, height = 1).
using LidarCloud = pcl::PointCloud<LidarPoint>;

/**
 * @brief One radar detection as published on `radar/points`: float32 x, y, z, range_rate at
 *        0, 4, 8, 12; int32 cluster at 16 (-1: noise); 20 bytes, no padding.
 */
struct RadarPoint
{
  float x = 0.0f;             ///< m, radar frame
  float y = 0.0f;             ///< m
  float z = 0.0f;             ///< m
  float range_rate = 0.0f;    ///< m/s, + receding
  std::int32_t cluster = -1;  ///< DBSCAN cluster index, -1 noise
};
static_assert(sizeof(RadarPoint) == 20, "RadarPoint must keep the 20-byte PointCloud2 layout");

/// A radar scan's detections.
using RadarCloud = pcl::PointCloud<RadarPoint>;

}  // namespace sensors
}  // namespace avsp

// The field lists (name, type) PCL's conversions and algorithms use, in offset order.
// clang-format off
POINT_CLOUD_REGISTER_POINT_STRUCT(avsp::sensors::LidarPoint,
                                  (float, x, x)
                                  (float, y, y)
                                  (float, z, z)
                                  (float, intensity, intensity)
                                  (std::uint16_t, ring, ring)
                                  (float, time, time))
POINT_CLOUD_REGISTER_POINT_STRUCT(avsp::sensors::RadarPoint,
                                  (float, x, x)
                                  (float, y, y)
                                  (float, z, z)
                                  (float, range_rate, range_rate)
                                  (std::int32_t, cluster, cluster))
// clang-format on
