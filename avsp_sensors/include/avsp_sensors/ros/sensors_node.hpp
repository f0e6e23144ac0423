#pragma once
/**
 * @file sensors_node.hpp
 * @brief sensors_node as a class (avsp_sensors/README.md, "sensors_node"): the sensors of one or
 *        more vehicles over the shared terrain, sampled on each vehicle's odometry stamps (sim
 *        time): lidar, radar, GPS, IMU, magnetometer, ultrasonics, cameras, OctoMap; the scene
 *        kept current from /terrain/ruts, /terrain/toppled and the vehicles' poses.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace sensors
{
namespace node
{
class SensorsNode
{
public:
  /**
   * @brief Reads the parameters (vehicles, sensors, terrain, agents), builds the scene, advertises.
   * @throw avsp::node::StartupError naming the parameter, vehicle or file
   */
  SensorsNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~SensorsNode();
  SensorsNode(const SensorsNode&) = delete;
  SensorsNode& operator=(const SensorsNode&) = delete;

  /// Senses every time whose vehicle states are complete, in time order (after the callbacks
  /// that were waiting have queued their states).
  void drain();

  /// One line per vehicle on stdout: wall time per sweep, scan, state and map publication.
  void reportCosts() const;

  /**
   * @brief Until shutdown: all waiting callbacks, then the complete times sensed (so a node
   *        lagging behind the simulation sees every vehicle's queued states together); then the
   *        costs on stdout.
   * @return 0
   */
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace sensors
}  // namespace avsp
