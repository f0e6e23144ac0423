#pragma once
/**
 * @file start_gate.hpp
 * @brief start_gate as a class (README.md, "Scenarios"): holds a scenario's physics until every
 *        node of the run is up (each node in ~nodes has advertised or subscribed a topic other
 *        than /rosout and /clock) and every publisher holds a connection to every subscriber the
 *        master lists, then publishes one latched std_msgs/Empty on ~open (dynamics_node's
 *        ~start_topic) and stays until /clock moves. Nothing in a vehicle's namespace: its
 *        avt_341/cmd_vel belongs to whatever drives it.
 */
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <ros/wall_timer.h>

namespace avsp
{
namespace node
{
class StartGate
{
public:
  /**
   * @brief Reads ~nodes (required list of names), ~timeout, ~grace, ~connect_timeout.
   * @throw std::runtime_error naming the parameter
   */
  StartGate(ros::NodeHandle& nh, ros::NodeHandle& pnh);

  /// Waits for the nodes and their connections, releases the physics, waits for /clock to move.
  /// @return 0, or 1 when a node is still not up after ~timeout (wall)
  int spin();

private:
  /// Until every node of ~nodes is up (or has only registered for ~grace s). False after ~timeout.
  bool waitForNodes(const ros::WallTime& start) const;
  /// Until every topic's publishers hold a connection to each subscriber, up to ~connect_timeout.
  void waitForConnections() const;
  /// Opens the gate (~open, latched) and stays until /clock moves (or ~timeout).
  void release();

  ros::NodeHandle& nh_;
  ros::NodeHandle pnh_;
  std::vector<std::string> nodes_;
  double timeout_ = 300.0, grace_ = 10.0, connect_timeout_ = 10.0;  ///< s, wall
};

}  // namespace node
}  // namespace avsp
