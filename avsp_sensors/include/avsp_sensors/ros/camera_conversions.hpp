#pragma once
/**
 * @file camera_conversions.hpp
 * @brief Camera frames as ROS messages (sensors_node): sensor_msgs/Image (rgb8, 32FC1 depth,
 *        mono8 semantic and thermal), sensor_msgs/CameraInfo, avsp_msgs/ClassTable, and the
 *        camera part of avsp_msgs/Environment.
 */
#include <string>

#include <avsp_msgs/ClassTable.h>
#include <avsp_msgs/Environment.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "avsp_sensors/camera.hpp"

namespace avsp
{
namespace sensors
{
namespace node
{
/// Which image of a frame.
enum class ImageKind
{
  kRgb,       ///< rgb8
  kDepth,     ///< 32FC1, m along the optical axis (+inf: nothing within max_range)
  kSemantic,  ///< mono8 class ids
  kThermal,   ///< mono8 over [thermal_min, thermal_max] K
};

/// The image (its output must be in the frame). Little-endian, dense rows.
sensor_msgs::Image toImage(const CameraFrame& frame, ImageKind kind, const std_msgs::Header& header);

/// CameraInfo from the intrinsics (K, D, R, P, distortion model; binning 0, full ROI).
sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& intrinsics, const std_msgs::Header& header);

/// The class table (ids and names).
avsp_msgs::ClassTable toClassTable(const std::vector<ClassEntry>& table, const std_msgs::Header& header);

/**
 * @brief Updates `env` from an Environment message. Sun and moon directions that are all zero
 *        (not filled by the publisher) keep their previous values, as does an air_temperature
 *        <= 0; the weather is the lidar's (fog, rain, snow). Season from the message's UTC month
 *        at `latitude_deg`; snow cover 1 below 0 deg C with snow falling or in winter, else 0;
 *        surface wetness min(1, rain / 5 mm/h).
 * @return false with `why` for a non-unit (non-zero) direction, a non-finite elevation or an
 *         illumination outside [0, 1] (env unchanged)
 */
bool cameraEnvironmentFromMessage(const avsp_msgs::Environment& msg, const Weather& weather, double latitude_deg,
                                  CameraEnvironment& env, std::string& why);

}  // namespace node
}  // namespace sensors
}  // namespace avsp
