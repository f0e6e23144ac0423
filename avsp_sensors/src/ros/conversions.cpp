#include "avsp_sensors/ros/conversions.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <stdexcept>

#include <pcl_conversions/pcl_conversions.h>

namespace avsp
{
namespace sensors
{
namespace node
{
namespace
{
void fillCovariance(boost::array<double, 9>& out, const Eigen::Matrix3d& c)
{
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      out[3 * r + k] = c(r, k);
}

geometry_msgs::Vector3 vector3(const Eigen::Vector3d& v)
{
  geometry_msgs::Vector3 out;
  out.x = v.x();
  out.y = v.y();
  out.z = v.z();
  return out;
}

geometry_msgs::Point point(const Eigen::Vector3d& v)
{
  geometry_msgs::Point out;
  out.x = v.x();
  out.y = v.y();
  out.z = v.z();
  return out;
}

bool finite(const geometry_msgs::Vector3& v)
{
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// A DELETEALL in `ns`: an array of boxes replaces the last one whole.
visualization_msgs::Marker deleteAll(const std_msgs::Header& header, const std::string& ns)
{
  visualization_msgs::Marker clear;
  clear.header = header;
  clear.ns = ns;
  clear.action = visualization_msgs::Marker::DELETEALL;
  return clear;
}

/// A CUBE of `size` at `centre` in `colour`, then a white label 0.4 m above it (ids id, id + 1).
void appendLabelledBox(visualization_msgs::MarkerArray& out, const std_msgs::Header& header, const std::string& ns,
                       int& id, const Eigen::Vector3d& centre, const Eigen::Vector3d& size, float r, float g, float b,
                       float a, const std::string& label)
{
  visualization_msgs::Marker box;
  box.header = header;
  box.ns = ns;
  box.id = id++;
  box.type = visualization_msgs::Marker::CUBE;
  box.action = visualization_msgs::Marker::ADD;
  box.pose.position = point(centre);
  box.pose.orientation.w = 1.0;
  box.scale = vector3(size);
  box.color.r = r;
  box.color.g = g;
  box.color.b = b;
  box.color.a = a;
  out.markers.push_back(box);
  visualization_msgs::Marker text = box;
  text.id = id++;
  text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
  text.pose.position.z += 0.5 * box.scale.z + 0.4;
  text.scale.x = text.scale.y = 0.0;
  text.scale.z = 0.5;
  text.color.r = text.color.g = text.color.b = 1.0f;
  text.color.a = 1.0f;
  text.text = label;
  out.markers.push_back(text);
}
}  // namespace

double stampSeconds(const ros::Time& stamp)
{
  const std::int64_t ns = static_cast<std::int64_t>(stamp.sec) * 1000000000LL + stamp.nsec;
  const std::int64_t us = (ns + 500) / 1000;
  return static_cast<double>(us) / 1e6;  // division: the nearest double to the decimal
}

ros::Time toStamp(double t)
{
  const std::int64_t us = std::llround(t * 1e6);
  ros::Time stamp;
  stamp.sec = static_cast<std::uint32_t>(us / 1000000);
  stamp.nsec = static_cast<std::uint32_t>((us % 1000000) * 1000);
  return stamp;
}

bool stateFromOdometry(const nav_msgs::Odometry& msg, const std::string& frame, const std::string& child,
                       VehicleState& state, std::string& why)
{
  if (msg.header.frame_id != frame)
  {
    why = "header.frame_id '" + msg.header.frame_id + "', expected '" + frame + "'";
    return false;
  }
  if (!child.empty() && msg.child_frame_id != child)
  {
    why = "child_frame_id '" + msg.child_frame_id + "', expected '" + child + "'";
    return false;
  }
  const auto& p = msg.pose.pose.position;
  const auto& q = msg.pose.pose.orientation;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
  {
    why = "pose.position is not finite";
    return false;
  }
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w))
  {
    why = "pose.orientation is not finite";
    return false;
  }
  Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  if (std::abs(rotation.norm() - 1.0) > 1e-3)
  {
    why = "pose.orientation is not a unit quaternion (norm " + std::to_string(rotation.norm()) + ")";
    return false;
  }
  rotation.normalize();
  if (!finite(msg.twist.twist.linear) || !finite(msg.twist.twist.angular))
  {
    why = "twist is not finite";
    return false;
  }
  state.time = stampSeconds(msg.header.stamp);
  state.pose = Eigen::Isometry3d::Identity();
  state.pose.linear() = rotation.toRotationMatrix();
  state.pose.translation() = Eigen::Vector3d(p.x, p.y, p.z);
  const auto& l = msg.twist.twist.linear;
  const auto& a = msg.twist.twist.angular;
  state.linear_velocity = state.pose.linear() * Eigen::Vector3d(l.x, l.y, l.z);
  state.angular_velocity = state.pose.linear() * Eigen::Vector3d(a.x, a.y, a.z);
  return true;
}

bool weatherFromEnvironment(const avsp_msgs::Environment& msg, Weather& weather, std::string& why)
{
  Weather w;
  w.fog_visibility = msg.fog_visibility;
  w.rain_rate = msg.rain_rate_mm_h;
  w.snow_rate = msg.snow_rate_mm_h;
  w.wet_snow = std::isfinite(msg.air_temperature) && msg.air_temperature > 272.15;
  try
  {
    validateWeather(w);
  }
  catch (const std::invalid_argument& e)
  {
    why = e.what();
    return false;
  }
  weather = w;
  return true;
}

sensor_msgs::PointCloud2 toPointCloud2(const LidarScan& scan, const std_msgs::Header& header)
{
  // pcl::toROSMsg takes the fields from LidarPoint's registration and copies the points whole
  // (point_types.hpp): x, y, z, intensity, ring, time at 0, 4, 8, 12, 16, 20, 24-byte steps.
  sensor_msgs::PointCloud2 cloud;
  pcl::toROSMsg(scan.points, cloud);
  // The PCL header keeps whole microseconds and no frame here: the message's header is ours.
  cloud.header = header;
  cloud.is_bigendian = false;
  return cloud;
}

sensor_msgs::PointCloud2 radarPoints(const RadarScan& scan, const std_msgs::Header& header)
{
  sensor_msgs::PointCloud2 cloud;
  pcl::toROSMsg(radarCloud(scan), cloud);
  cloud.header = header;
  cloud.is_bigendian = false;
  return cloud;
}

avsp_msgs::RadarTargetArray radarTargets(const RadarScan& scan, const std_msgs::Header& header)
{
  avsp_msgs::RadarTargetArray out;
  out.header = header;
  for (const RadarTarget& t : scan.targets)
  {
    avsp_msgs::RadarTarget m;
    m.centroid.x = t.centroid.x();
    m.centroid.y = t.centroid.y();
    m.centroid.z = t.centroid.z();
    m.range = t.range;
    m.azimuth = t.azimuth;
    m.elevation = t.elevation;
    m.range_rate = t.range_rate;
    m.point_count = t.point_count;
    m.extent = vector3(t.extent);
    out.targets.push_back(m);
  }
  return out;
}

visualization_msgs::MarkerArray radarMarkers(const RadarScan& scan, const std_msgs::Header& header)
{
  visualization_msgs::MarkerArray out;
  out.markers.push_back(deleteAll(header, "radar_targets"));
  int id = 0;
  for (const RadarTarget& t : scan.targets)
  {
    // Receding targets green, approaching ones red, by up to 10 m/s.
    const double s = std::clamp(t.range_rate / 10.0, -1.0, 1.0);
    char label[64];
    std::snprintf(label, sizeof(label), "%.1f m %+.1f m/s", t.range, t.range_rate);
    appendLabelledBox(out, header, "radar_targets", id, t.centroid, t.extent.cwiseMax(0.2),
                      static_cast<float>(0.5 - 0.5 * s), static_cast<float>(0.5 + 0.5 * s), 0.2f, 0.6f, label);
  }
  return out;
}

avsp_msgs::LidarClusterArray lidarClusters(const LidarClustering& clustering, const std_msgs::Header& header)
{
  avsp_msgs::LidarClusterArray out;
  out.header = header;
  out.clusters.reserve(clustering.clusters.size());
  for (const LidarCluster& c : clustering.clusters)
  {
    avsp_msgs::LidarCluster m;
    m.centroid = point(c.centroid);
    m.min = point(c.min);
    m.max = point(c.max);
    m.extent = vector3(c.extent());
    m.range = c.range;
    m.point_count = static_cast<std::uint32_t>(c.size());
    out.clusters.push_back(m);
  }
  return out;
}

visualization_msgs::MarkerArray lidarClusterMarkers(const LidarClustering& clustering, const std_msgs::Header& header)
{
  visualization_msgs::MarkerArray out;
  out.markers.push_back(deleteAll(header, "lidar_clusters"));
  int id = 0;
  for (const LidarCluster& c : clustering.clusters)
  {
    char label[64];
    std::snprintf(label, sizeof(label), "%zu pts %.1f m", c.size(), c.range);
    // The box's middle, not the centroid; a flat or single-line cluster still shows as a box.
    appendLabelledBox(out, header, "lidar_clusters", id, 0.5 * (c.min + c.max), c.extent().cwiseMax(0.1), 1.0f, 0.6f,
                      0.1f, 0.5f, label);
  }
  return out;
}

sensor_msgs::NavSatFix toNavSatFix(const GpsFix& fix, const std_msgs::Header& header)
{
  sensor_msgs::NavSatFix m;
  m.header = header;
  m.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
  m.status.service = sensor_msgs::NavSatStatus::SERVICE_GPS;
  m.latitude = fix.position.latitude_deg;
  m.longitude = fix.position.longitude_deg;
  m.altitude = fix.position.altitude;
  fillCovariance(m.position_covariance, fix.covariance);
  m.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_DIAGONAL_KNOWN;
  return m;
}

sensor_msgs::Imu toImu(const ImuSample& s, const std_msgs::Header& header)
{
  sensor_msgs::Imu m;
  m.header = header;
  m.orientation.w = s.orientation.w();
  m.orientation.x = s.orientation.x();
  m.orientation.y = s.orientation.y();
  m.orientation.z = s.orientation.z();
  fillCovariance(m.orientation_covariance, s.orientation_covariance);
  m.angular_velocity = vector3(s.angular_velocity);
  fillCovariance(m.angular_velocity_covariance, s.angular_velocity_covariance);
  m.linear_acceleration = vector3(s.linear_acceleration);
  fillCovariance(m.linear_acceleration_covariance, s.linear_acceleration_covariance);
  return m;
}

sensor_msgs::MagneticField toMagneticField(const MagSample& s, const std_msgs::Header& header)
{
  sensor_msgs::MagneticField m;
  m.header = header;
  m.magnetic_field = vector3(s.field);
  fillCovariance(m.magnetic_field_covariance, s.covariance);
  return m;
}

sensor_msgs::Range toRange(const UltrasonicReading& r, const std_msgs::Header& header)
{
  sensor_msgs::Range m;
  m.header = header;
  m.radiation_type = sensor_msgs::Range::ULTRASOUND;
  m.field_of_view = static_cast<float>(r.field_of_view);
  m.min_range = static_cast<float>(r.min_range);
  m.max_range = static_cast<float>(r.max_range);
  m.range = static_cast<float>(r.range);
  return m;
}

visualization_msgs::MarkerArray occupiedCellMarkers(const std::vector<OccupiedCell>& cells,
                                                    const std_msgs::Header& header, double z_low, double z_high)
{
  visualization_msgs::MarkerArray out;
  visualization_msgs::Marker clear;
  clear.header = header;
  clear.ns = "occupied_cells";
  clear.action = visualization_msgs::Marker::DELETEALL;
  out.markers.push_back(clear);
  // One CUBE_LIST per voxel size (pruned blocks are 2^k voxels wide), smallest first.
  std::map<double, std::size_t> by_size;
  for (const OccupiedCell& c : cells)
    if (!by_size.count(c.size))
    {
      const std::size_t index = out.markers.size();
      by_size[c.size] = index;
      visualization_msgs::Marker m;
      m.header = header;
      m.ns = "occupied_cells";
      m.type = visualization_msgs::Marker::CUBE_LIST;
      m.action = visualization_msgs::Marker::ADD;
      m.pose.orientation.w = 1.0;
      m.scale.x = m.scale.y = m.scale.z = c.size;
      m.color.a = 1.0f;
      out.markers.push_back(m);
    }
  int id = 0;
  for (auto& [size, index] : by_size)
    out.markers[index].id = id++;
  const double span = std::max(1e-6, z_high - z_low);
  for (const OccupiedCell& c : cells)
  {
    visualization_msgs::Marker& m = out.markers[by_size[c.size]];
    geometry_msgs::Point p;
    p.x = c.centre.x();
    p.y = c.centre.y();
    p.z = c.centre.z();
    m.points.push_back(p);
    const double s = std::clamp((c.centre.z() - z_low) / span, 0.0, 1.0);
    std_msgs::ColorRGBA colour;
    colour.r = static_cast<float>(s);
    colour.g = static_cast<float>(1.0 - std::abs(2.0 * s - 1.0));
    colour.b = static_cast<float>(1.0 - s);
    colour.a = 1.0f;
    m.colors.push_back(colour);
  }
  return out;
}

nav_msgs::OccupancyGrid toOccupancyGrid(const OccupancyGrid2D& grid, const std_msgs::Header& header)
{
  nav_msgs::OccupancyGrid m;
  m.header = header;
  m.info.map_load_time = header.stamp;
  m.info.resolution = static_cast<float>(grid.resolution);
  m.info.width = static_cast<std::uint32_t>(grid.width);
  m.info.height = static_cast<std::uint32_t>(grid.height);
  m.info.origin.position.x = grid.origin_x;
  m.info.origin.position.y = grid.origin_y;
  m.info.origin.orientation.w = 1.0;
  m.data = grid.data;
  return m;
}

}  // namespace node
}  // namespace sensors
}  // namespace avsp
