#pragma once
/**
 * @file dynamics_node.hpp
 * @brief dynamics_node as a class (avsp_dynamics/README.md, "dynamics_node"): one or more
 *        vehicles in one World on the deformable soil, driven through each vehicle's
 *        avt_341/cmd_vel or cmd_drive, publishing odometry, TF odom -> <vehicle>/base_link,
 *        joint_states, telemetry and the ruts; the clock source, a follower of /clock, or one
 *        partition of a run behind lockstep_clock (the exchange protocol: PartitionRunner).
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace dynamics
{
namespace node
{
class DynamicsNode
{
public:
  /**
   * @brief Reads the parameters, loads the terrain, the vehicles and the agents, advertises and
   *        subscribes (with ~peers: the exchange topics).
   * @param nh the node's namespace (vehicles' topics under nh/<vehicle>/)
   * @param pnh its private namespace (parameters)
   * @throw avsp::node::StartupError naming the parameter, vehicle or file
   */
  DynamicsNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~DynamicsNode();
  DynamicsNode(const DynamicsNode&) = delete;
  DynamicsNode& operator=(const DynamicsNode&) = delete;

  /**
   * @brief Runs until shutdown.
   * @return 0, or 1 after a fatal error stopped the run (a silent lockstep vehicle or peer, a bad
   *         exchange; logged, and ros::shutdown() called)
   */
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
