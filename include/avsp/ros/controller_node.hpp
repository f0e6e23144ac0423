#pragma once
/**
 * @file controller_node.hpp
 * @brief controller_node as a class (README.md, "Controller node"): one vehicle's controller in
 *        the vehicle's namespace, from its avt_341/odometry (and, as a follower, its radio's
 *        v2v/in) to avt_341/cmd_vel: waypoints (pure pursuit + speed PID) or leader_follower;
 *        with ~lockstep, a cmd_drive answering every odometry on its grid.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
class ControllerNode
{
public:
  /**
   * @brief Reads the parameters (mode, waypoints or leader, the vehicle's model), subscribes,
   *        advertises.
   * @throw avsp::node::StartupError naming the parameter
   */
  ControllerNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~ControllerNode();
  ControllerNode(const ControllerNode&) = delete;
  ControllerNode& operator=(const ControllerNode&) = delete;

  /// Until shutdown (ros::spin()). @return 0
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace avsp
