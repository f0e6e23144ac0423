#pragma once
/**
 * @file agent_params.hpp
 * @brief The ROS side of agents.hpp: the private `~agents` list that agents_node, sensors_node
 *        and dynamics_node all read, so the three evaluate the same agents
 *        (avsp_terrain/README.md, "Dynamic agents").
 *
 * ```yaml
 * agents:
 *   - {name: deer1, type: deer, path: [[30, -10], [30, 10]], speed: 3.0, start_time: 2.0}
 *   - {name: walker, type: pedestrian, path: [[5, 5], [10, 5], [10, 10]], speed: 1.4, loop: true}
 *   - {name: bystander, type: pedestrian, path: [[0, 8]], yaw: 1.57}
 * ```
 */
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include "avsp_terrain/agents.hpp"
#include "avsp_terrain/ros/node_params.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
/**
 * @brief Parses a list of agents (`~agents`): each a struct with `name` (string), `type` (deer |
 *        pedestrian | truck), `path` (list of [x, y] in m, map), and optional `speed` (m/s, 0),
 *        `start_time` (s, 0), `loop` (bool, false), `yaw` (rad, 0; a single-point agent's heading).
 *        Then validateAgentSpecs().
 * @param key the parameter's name in errors, e.g. "~agents"
 * @throw avsp::node::StartupError "parameter <key>[k].<field>: <reason>": not a list, an entry
 *        not a struct, an unknown or missing key, a wrong type, an unknown agent type, and every
 *        validateAgentSpec() reason
 */
std::vector<AgentSpec> parseAgents(XmlRpc::XmlRpcValue& list, const std::string& key = "~agents");

/// `~agents` of a node (none when unset). @throw avsp::node::StartupError as parseAgents()
std::vector<AgentSpec> agentSpecsFromParams(const ros::NodeHandle& pnh);

/// agentSpecsFromParams() then makeAgents() on `ground` (the terrain's base grid).
/// @throw avsp::node::StartupError naming the key
std::vector<Agent> agentsFromParams(const ros::NodeHandle& pnh, const ElevationGrid& ground);

}  // namespace node
}  // namespace terrain
}  // namespace avsp
