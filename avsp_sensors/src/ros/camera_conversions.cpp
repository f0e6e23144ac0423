#include "avsp_sensors/ros/camera_conversions.hpp"

#include <cmath>
#include <cstring>
#include <ctime>

namespace avsp
{
namespace sensors
{
namespace node
{
sensor_msgs::Image toImage(const CameraFrame& frame, ImageKind kind, const std_msgs::Header& header)
{
  sensor_msgs::Image img;
  img.header = header;
  img.width = static_cast<std::uint32_t>(frame.width);
  img.height = static_cast<std::uint32_t>(frame.height);
  img.is_bigendian = 0;
  switch (kind)
  {
    case ImageKind::kRgb:
      img.encoding = "rgb8";
      img.step = 3 * img.width;
      img.data = frame.rgb;
      break;
    case ImageKind::kDepth:
      img.encoding = "32FC1";
      img.step = 4 * img.width;
      img.data.resize(4 * frame.depth.size());
      std::memcpy(img.data.data(), frame.depth.data(), img.data.size());  // x86: little-endian
      break;
    case ImageKind::kSemantic:
      img.encoding = "mono8";
      img.step = img.width;
      img.data = frame.semantic;
      break;
    case ImageKind::kThermal:
      img.encoding = "mono8";
      img.step = img.width;
      img.data = frame.thermal;
      break;
  }
  return img;
}

sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& in, const std_msgs::Header& header)
{
  sensor_msgs::CameraInfo ci;
  ci.header = header;
  ci.width = static_cast<std::uint32_t>(in.width);
  ci.height = static_cast<std::uint32_t>(in.height);
  ci.distortion_model = in.distortion_model;
  ci.D = in.D;
  for (int k = 0; k < 9; ++k)
  {
    ci.K[k] = in.K[k];
    ci.R[k] = in.R[k];
  }
  for (int k = 0; k < 12; ++k)
    ci.P[k] = in.P[k];
  return ci;
}

avsp_msgs::ClassTable toClassTable(const std::vector<ClassEntry>& table, const std_msgs::Header& header)
{
  avsp_msgs::ClassTable m;
  m.header = header;
  for (const ClassEntry& e : table)
  {
    m.ids.push_back(e.id);
    m.names.push_back(e.name);
  }
  return m;
}

bool cameraEnvironmentFromMessage(const avsp_msgs::Environment& msg, const Weather& weather, double latitude_deg,
                                  CameraEnvironment& env, std::string& why)
{
  CameraEnvironment e = env;
  auto direction = [&why](const geometry_msgs::Vector3& v, const char* name, Eigen::Vector3d& out) {
    const Eigen::Vector3d d(v.x, v.y, v.z);
    if (d.isZero(0.0))
      return true;  // not filled: keep
    if (!d.allFinite() || std::abs(d.norm() - 1.0) > 1e-3)
    {
      why = std::string(name) + " must be a unit vector";
      return false;
    }
    out = d.normalized();
    return true;
  };
  const bool sun_given = !Eigen::Vector3d(msg.sun_direction.x, msg.sun_direction.y, msg.sun_direction.z).isZero(0.0);
  const bool moon_given =
      !Eigen::Vector3d(msg.moon_direction.x, msg.moon_direction.y, msg.moon_direction.z).isZero(0.0);
  if (!direction(msg.sun_direction, "sun_direction", e.sun_direction) ||
      !direction(msg.moon_direction, "moon_direction", e.moon_direction))
    return false;
  if (sun_given)
  {
    if (!std::isfinite(msg.sun_elevation))
    {
      why = "sun_elevation is not finite";
      return false;
    }
    e.sun_elevation = msg.sun_elevation;
  }
  if (moon_given)
  {
    if (!std::isfinite(msg.moon_elevation) || !(msg.moon_illumination >= 0.0 && msg.moon_illumination <= 1.0))
    {
      why = "moon_elevation must be finite and moon_illumination in [0, 1]";
      return false;
    }
    e.moon_elevation = msg.moon_elevation;
    e.moon_illumination = msg.moon_illumination;
  }
  if (msg.air_temperature > 0.0 && std::isfinite(msg.air_temperature))
    e.air_temperature = msg.air_temperature;
  e.weather = weather;
  if (!msg.utc.isZero())
  {
    const std::time_t t = static_cast<std::time_t>(msg.utc.sec);
    std::tm tm{};
    gmtime_r(&t, &tm);
    e.season = seasonOf(tm.tm_mon + 1, latitude_deg);
  }
  e.snow_cover = (e.air_temperature < 273.15 && (weather.snow_rate > 0.0 || e.season == Season::kWinter)) ? 1.0 : 0.0;
  e.surface_wetness = std::min(1.0, weather.rain_rate / 5.0);
  try
  {
    validateCameraEnvironment(e);
  }
  catch (const std::invalid_argument& x)
  {
    why = x.what();
    return false;
  }
  env = e;
  return true;
}

}  // namespace node
}  // namespace sensors
}  // namespace avsp
