#pragma once
/**
 * @file vehicle_frames.hpp
 * @brief What sensors_node needs of a vehicle's description: the rest pose of every URDF link
 *        in base_link (the sensor mounts; robot_state_publisher broadcasts the same transforms)
 *        and the chassis collision boxes that other vehicles' sensors see. Loaded through
 *        avsp_dynamics' loadVehicleModel (config/vehicles/<model>.yaml and its URDF), so the
 *        sensors see the same body as the dynamics collides with.
 */
#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "avsp_sensors/sensor_suite.hpp"

namespace avsp
{
namespace sensors
{
namespace node
{
/// A vehicle description reduced to frames and boxes.
struct VehicleFrames
{
  std::string urdf_path;
  std::string root_link;                           ///< the URDF's root (base_link)
  std::map<std::string, Eigen::Isometry3d> links;  ///< link -> its pose in the root link, joints at 0
  std::vector<BodyBox> boxes;                      ///< collision boxes of the chassis links, in the root link

  /// Pose of `link` in the root link. @throw std::invalid_argument naming the link and the URDF
  const Eigen::Isometry3d& link(const std::string& name) const;
  bool hasLink(const std::string& name) const { return links.count(name) > 0; }
};

/**
 * @brief Loads a vehicle's YAML (avsp_dynamics' format) and its URDF.
 * @throw std::runtime_error naming the file and what is wrong
 */
VehicleFrames loadVehicleFrames(const std::string& yaml_path);

}  // namespace node
}  // namespace sensors
}  // namespace avsp
