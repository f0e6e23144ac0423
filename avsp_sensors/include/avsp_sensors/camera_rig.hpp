#pragma once
/**
 * @file camera_rig.hpp
 * @brief One vehicle's cameras on their sim-time grids (what sensors_node runs per vehicle,
 *        without ROS): each camera renders at the first vehicle state at or after each time
 *        k / rate, from its mount on the vehicle at that state.
 */
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "avsp_sensors/camera.hpp"
#include "avsp_sensors/sensor_suite.hpp"

namespace avsp
{
namespace sensors
{
/// A frame ready to publish.
struct CameraOutput
{
  std::size_t index = 0;  ///< camera index in the rig
  double time = 0.0;      ///< s, sim time of the state it was rendered at (its stamp)
  CameraFrame frame;
  Eigen::Isometry3d optical_pose = Eigen::Isometry3d::Identity();  ///< optical frame -> map
  double cost = 0.0;  ///< wall s spent rendering (cost report; not simulation data)
};

/// Cameras of one vehicle with their grid clocks.
class CameraRig
{
public:
  /**
   * @param cameras each with its mount (camera body frame in base_link)
   * @param body_id the vehicle's body id (its own cameras do not see it)
   * @param seed rain streaks and snowflakes of camera k's frame n come from streamKey(seed, k, n)
   * @throw std::invalid_argument naming the camera: a bad config (validateCameraConfig) or a
   *        name used twice
   */
  CameraRig(const std::vector<CameraConfig>& cameras, std::uint32_t body_id, std::uint64_t seed = 0);

  const std::vector<Camera>& cameras() const { return cameras_; }
  /// Optical frame of camera k in base_link: mount * opticalFromBody().
  Eigen::Isometry3d opticalMount(std::size_t k) const;

  /**
   * @brief Renders every camera due at state.time (validateState first).
   * @throw std::invalid_argument for a bad state or a bad environment
   */
  std::vector<CameraOutput> update(const VehicleState& state, const Scene& scene, const CameraMaterials& materials,
                                   const CameraEnvironment& env, unsigned threads);

private:
  std::vector<Camera> cameras_;
  std::vector<GridClock> clocks_;
  std::uint32_t body_id_;
  std::uint64_t seed_;
};

}  // namespace sensors
}  // namespace avsp
