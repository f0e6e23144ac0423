#pragma once
/**
 * @file agents_node.hpp
 * @brief agents_node as a class (README.md, "Agents node"): the dynamic agents (deer,
 *        pedestrians, trucks) of ~agents for everybody who is not a sensor or the physics: TF
 *        <frame> -> agents/<name>, /agents/markers and /agents/states at ~rate on sim time.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
class AgentsNode
{
public:
  /**
   * @brief Reads the parameters and the terrain (the agents' heights), advertises.
   * @throw avsp::node::StartupError naming the parameter
   */
  AgentsNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~AgentsNode();
  AgentsNode(const AgentsNode&) = delete;
  AgentsNode& operator=(const AgentsNode&) = delete;

  /// Publishes the agents' states if sim time has reached the next ~rate instant.
  void update();

  /// Until shutdown: callbacks, then update(), polling the clock every 2 ms (wall). @return 0
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace avsp
