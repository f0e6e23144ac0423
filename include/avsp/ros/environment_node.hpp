#pragma once
/**
 * @file environment_node.hpp
 * @brief environment_node as a class (README.md, "Environment node"): the simulated world's
 *        clock, Sun, Moon, light and weather on /environment at ~rate on sim time, changed at
 *        run time through ~set_environment.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
class EnvironmentNode
{
public:
  /**
   * @brief Reads the parameters (start time, place, weather timeline), advertises.
   * @throw avsp::node::StartupError naming the parameter
   */
  EnvironmentNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~EnvironmentNode();
  EnvironmentNode(const EnvironmentNode&) = delete;
  EnvironmentNode& operator=(const EnvironmentNode&) = delete;

  /// Until shutdown (ros::spin()). @return 0
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace avsp
