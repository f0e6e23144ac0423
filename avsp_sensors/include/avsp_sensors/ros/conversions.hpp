#pragma once
/**
 * @file conversions.hpp
 * @brief sensors_node's conversions between ROS messages and the core's types, as plain
 *        functions (no node state): odometry and weather in (rut patches through avsp_terrain's
 *        heightPatchFromMessage()); point clouds, radar targets, fixes, IMU and magnetometer
 *        samples, ranges, occupancy markers and grids out.
 */
#include <string>

#include <avsp_msgs/Environment.h>
#include <avsp_msgs/LidarClusterArray.h>
#include <avsp_msgs/RadarTargetArray.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include "avsp_sensors/sensor_suite.hpp"

namespace avsp
{
namespace sensors
{
namespace node
{
/**
 * @brief Sim time of a stamp in s, rounded to the microsecond: stamps written from a world time
 *        in double seconds (e.g. 0.1 -> 99,999,999 ns) land back on the sensors' time grid.
 */
double stampSeconds(const ros::Time& stamp);

/// The ros::Time of sim time t (s) as stampSeconds() rounds it (whole microseconds).
ros::Time toStamp(double t);

/**
 * @brief The vehicle state of an odometry message: pose in the world frame, twist (given in
 *        the child frame, as nav_msgs/Odometry defines it) rotated into the world frame.
 *        A quaternion whose norm is within 1e-3 of 1 is normalised.
 * @param frame expected header.frame_id; @param child expected child_frame_id ("" = any)
 * @return false, `why` saying what, for another frame, a non-finite field or a bad quaternion
 */
bool stateFromOdometry(const nav_msgs::Odometry& msg, const std::string& frame, const std::string& child,
                       VehicleState& state, std::string& why);

/**
 * @brief The lidar weather of an avsp_msgs/Environment: fog visibility, rain and snow rates;
 *        snow is wet at an air temperature above -1 deg C (272.15 K).
 * @return false, `why` naming the field, for a value validateWeather() refuses
 */
bool weatherFromEnvironment(const avsp_msgs::Environment& msg, Weather& weather, std::string& why);

/**
 * @brief A lidar scan as PointCloud2, its PCL cloud through pcl::toROSMsg: float32 x, y, z,
 *        intensity at offsets 0, 4, 8, 12, uint16 ring at 16, float32 time at 20 (s after
 *        header.stamp, the sweep start); 24-byte points, one row, dense, little-endian, padding
 *        zeroed (LidarPoint, point_types.hpp).
 */
sensor_msgs::PointCloud2 toPointCloud2(const LidarScan& scan, const std_msgs::Header& header);

/**
 * @brief A radar scan's detections as PointCloud2 in the radar frame (radarCloud() through
 *        pcl::toROSMsg): float32 x, y, z, range_rate (m/s, + receding) at 0, 4, 8, 12 and int32
 *        cluster (-1: noise) at 16; 20-byte points, one row, dense, little-endian.
 */
sensor_msgs::PointCloud2 radarPoints(const RadarScan& scan, const std_msgs::Header& header);

/// A radar scan's DBSCAN targets (avsp_msgs/RadarTarget per cluster, in cluster order).
avsp_msgs::RadarTargetArray radarTargets(const RadarScan& scan, const std_msgs::Header& header);

/**
 * @brief RViz markers of the targets: DELETEALL, then per target a CUBE at its centroid the size
 *        of its extent (at least 0.2 m) and a TEXT_VIEW_FACING with its range and range rate.
 */
visualization_msgs::MarkerArray radarMarkers(const RadarScan& scan, const std_msgs::Header& header);

/**
 * @brief A sweep's clusters as avsp_msgs/LidarClusterArray (order kept: largest first):
 *        centroid, min, max, extent, range, point_count; header as given (frame: the world frame
 *        the clusters are in).
 */
avsp_msgs::LidarClusterArray lidarClusters(const LidarClustering& clustering, const std_msgs::Header& header);

/**
 * @brief RViz markers of the clusters: DELETEALL, then per cluster (ns "lidar_clusters") a CUBE
 *        filling its box (at least 0.1 m per side) and a TEXT_VIEW_FACING with its point count
 *        and range above it.
 */
visualization_msgs::MarkerArray lidarClusterMarkers(const LidarClustering& clustering, const std_msgs::Header& header);

/// A GPS fix as NavSatFix (STATUS_FIX, SERVICE_GPS, ENU covariance, DIAGONAL_KNOWN).
sensor_msgs::NavSatFix toNavSatFix(const GpsFix& fix, const std_msgs::Header& header);

/// An IMU sample as sensor_msgs/Imu (orientation IMU frame -> map, covariances row-major).
sensor_msgs::Imu toImu(const ImuSample& sample, const std_msgs::Header& header);

/// A magnetometer sample as sensor_msgs/MagneticField (T).
sensor_msgs::MagneticField toMagneticField(const MagSample& sample, const std_msgs::Header& header);

/// An ultrasonic reading as sensor_msgs/Range (ULTRASOUND; +inf / -inf as REP 117).
sensor_msgs::Range toRange(const UltrasonicReading& reading, const std_msgs::Header& header);

/**
 * @brief Occupied voxels as RViz markers in the world frame: DELETEALL, then one CUBE_LIST per
 *        voxel size (ns "occupied_cells", id = the size's rank), coloured by height from `z_low`
 *        (blue) to `z_high` (red).
 */
visualization_msgs::MarkerArray occupiedCellMarkers(const std::vector<OccupiedCell>& cells,
                                                    const std_msgs::Header& header, double z_low, double z_high);

/// The 2-D grid as nav_msgs/OccupancyGrid (origin at the grid's corner, z 0, no rotation).
nav_msgs::OccupancyGrid toOccupancyGrid(const OccupancyGrid2D& grid, const std_msgs::Header& header);

}  // namespace node
}  // namespace sensors
}  // namespace avsp
