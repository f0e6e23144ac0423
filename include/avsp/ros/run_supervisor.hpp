#pragma once
/**
 * @file run_supervisor.hpp
 * @brief run_recorder's watch over the run (the ROS side of avsp_results): polls every roslaunch
 *        server of the master (`/roslaunch/uris`) for dead processes and their exit codes,
 *        checks that each watched node is registered and its XML-RPC port accepts connections
 *        (catches nodes on other machines, and SIGKILL, which leaves a node registered), and
 *        keeps each node's last ERROR/FATAL from /rosout. RunWatch decides.
 */
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>

#include "avsp/results/run_watch.hpp"

namespace avsp
{
namespace node
{
class RunSupervisor
{
public:
  /// @param watched resolved names of the nodes that must live for the whole run
  RunSupervisor(ros::NodeHandle& nh, std::vector<std::string> watched);

  /// Polls roslaunch and the watched nodes; call from the recorder's loop (cheap, a few ms).
  void poll(double sim_time);
  /// The first failure seen, if any.
  std::optional<results::Abort> abort() const { return watch_.abort(); }
  /// Fails the run for a reason of the recorder's own (e.g. an interrupt).
  void fail(const std::string& node, const std::string& reason, double sim_time)
  {
    watch_.fail(node, reason, sim_time);
  }
  const results::RunWatch& watch() const { return watch_; }

private:
  void onLog(const rosgraph_msgs::Log::ConstPtr& m);
  void pollLaunchServers(double sim_time);
  void pingWatched(double sim_time);

  results::RunWatch watch_;
  ros::Subscriber log_sub_;
  std::set<std::string> dead_seen_;          // "<server uri> <process>" already reported
  std::map<std::string, std::string> uris_;  // watched node -> XML-RPC URI, once registered
};

}  // namespace node
}  // namespace avsp
