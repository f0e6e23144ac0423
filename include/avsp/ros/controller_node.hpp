#pragma once
/**
 * @file controller_node.hpp
 * @brief controller_node as a class (README.md, "Controller node"): one vehicle's controller in
 *        the vehicle's namespace, from its avt_341/odometry (and, as a follower, its radio's
 *        v2v/in) to avt_341/cmd_vel: waypoints (pure pursuit + speed PID) or leader_follower;
 *        with ~lockstep, a cmd_drive answering every odometry on its grid.
 */
#include <memory>
#include <string>

#include <avsp_terrain/ros/node_params.hpp>
#include <ros/node_handle.h>

#include "avsp/control/leader_follower.hpp"
#include "avsp/control/steering.hpp"
#include "avsp/control/waypoint_follower.hpp"

namespace avsp
{
namespace node
{
/// controller_node's parameters as it reads them, its controller built from them.
struct ControllerSetup
{
  std::string mode;        ///< ~mode: waypoints | leader_follower
  std::string model_name;  ///< ~model
  control::SteeringGeometry geometry;
  double rate = 20.0;  ///< Hz, ~rate
  std::string frame_id = "map";
  bool lockstep = false;
  std::string leader;                                    ///< ~leader (leader_follower)
  std::unique_ptr<control::WaypointFollower> waypoints;  ///< mode waypoints
  std::unique_ptr<control::LeaderFollower> follower;     ///< mode leader_follower
};

/**
 * @brief controller_node's parameter parser, over the master or a tree (ParamSource): the node
 *        runs it at start-up, `scenario_launch --check` on what the generated launch file would
 *        set (node_checks.hpp). Loads ~config_dir/<~model>.yaml for the steering geometry.
 * @throw avsp::node::StartupError naming the first bad parameter
 */
ControllerSetup readControllerParams(const ParamSource& params);

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
