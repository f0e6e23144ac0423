#pragma once
/**
 * @file node_main.hpp
 * @brief The body of every AVSP node's main(): the node class does the work, main() only
 *        constructs it and spins (octomap_server's shape), so the class can run in any process,
 *        a test's included.
 */
#include <cstdint>
#include <exception>
#include <memory>

#include <ros/console.h>
#include <ros/init.h>
#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
/**
 * @brief Constructs `Node` from the global and the private NodeHandle, then returns its spin().
 *
 * A start-up failure (the constructor throws, e.g. a StartupError naming a parameter) is logged
 * as "<name>: <what>" and gives exit code 1: a node never runs on a silent default.
 * @tparam Node has Node(ros::NodeHandle& nh, ros::NodeHandle& pnh) and int spin() (the exit code)
 * @pre ros::init() was called
 */
template <typename Node>
int constructAndSpin(const char* name)
{
  ros::NodeHandle nh, pnh("~");
  std::unique_ptr<Node> node;
  try
  {
    node = std::make_unique<Node>(nh, pnh);
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("%s: %s", name, e.what());
    return 1;
  }
  return node->spin();
}

/// ros::init(argc, argv, name, init_options), then constructAndSpin<Node>(name).
template <typename Node>
int runNode(int argc, char** argv, const char* name, std::uint32_t init_options = 0)
{
  ros::init(argc, argv, name, init_options);
  return constructAndSpin<Node>(name);
}

}  // namespace node
}  // namespace avsp
