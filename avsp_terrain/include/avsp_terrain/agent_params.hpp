#pragma once
/**
 * @file agent_params.hpp
 * @brief The ROS side of agents.hpp (this header, unlike the core's, includes ROS): the private
 *        `~agents` list that agents_node, sensors_node and dynamics_node all read, so the three
 *        evaluate the same agents (avsp_terrain/README.md, "Dynamic agents").
 *
 * ```yaml
 * agents:
 *   - {name: deer1, type: deer, path: [[30, -10], [30, 10]], speed: 3.0, start_time: 2.0}
 *   - {name: walker, type: pedestrian, path: [[5, 5], [10, 5], [10, 10]], speed: 1.4, loop: true}
 *   - {name: bystander, type: pedestrian, path: [[0, 8]], yaw: 1.57}
 * ```
 */
#include <optional>
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <avsp_msgs/node_params.hpp>

#include "avsp_terrain/agents.hpp"

namespace avsp
{
namespace terrain
{
namespace detail
{
inline bool xmlNumber(const XmlRpc::XmlRpcValue& v, double& out)
{
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    out = static_cast<double>(const_cast<XmlRpc::XmlRpcValue&>(v));
  else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
    out = static_cast<int>(const_cast<XmlRpc::XmlRpcValue&>(v));
  else
    return false;
  return true;
}
}  // namespace detail

/**
 * @brief Parses a list of agents (`~agents`): each a struct with `name` (string), `type` (deer |
 *        pedestrian | truck), `path` (list of [x, y] in m, map), and optional `speed` (m/s, 0),
 *        `start_time` (s, 0), `loop` (bool, false), `yaw` (rad, 0; a single-point agent's heading).
 *        Then validateAgentSpecs().
 * @param key the parameter's name in errors, e.g. "~agents"
 * @throw avsp::msgs::StartupError "parameter <key>[k].<field>: <reason>": not a list, an entry
 *        not a struct, an unknown or missing key, a wrong type, an unknown agent type, and every
 *        validateAgentSpec() reason
 */
inline std::vector<AgentSpec> parseAgents(XmlRpc::XmlRpcValue& list, const std::string& key = "~agents")
{
  using avsp::msgs::StartupError;
  using XmlRpc::XmlRpcValue;
  if (list.getType() != XmlRpcValue::TypeArray)
    throw StartupError("parameter " + key + " must be a list of {name, type, path, speed, start_time, loop, yaw}");
  std::vector<AgentSpec> specs;
  for (int k = 0; k < list.size(); ++k)
  {
    const std::string where = "parameter " + key + "[" + std::to_string(k) + "]";
    XmlRpcValue& e = list[k];
    if (e.getType() != XmlRpcValue::TypeStruct)
      throw StartupError(where + " must be a map {name, type, path, ...}");
    for (auto it = e.begin(); it != e.end(); ++it)
    {
      static const char* const known[] = { "name", "type", "path", "speed", "start_time", "loop", "yaw" };
      bool ok = false;
      for (const char* name : known)
        ok = ok || it->first == name;
      if (!ok)
        throw StartupError(where + "." + it->first +
                           ": unknown key (known: name, type, path, speed, start_time, loop, yaw)");
    }
    AgentSpec s;
    for (const char* required : { "name", "type", "path" })
      if (!e.hasMember(required))
        throw StartupError(where + "." + required + ": missing (required)");
    if (e["name"].getType() != XmlRpcValue::TypeString)
      throw StartupError(where + ".name: must be a string");
    s.name = static_cast<std::string>(e["name"]);
    if (e["type"].getType() != XmlRpcValue::TypeString)
      throw StartupError(where + ".type: must be a string (deer, pedestrian or truck)");
    const std::string type = static_cast<std::string>(e["type"]);
    const std::optional<AgentType> t = agentTypeFromString(type);
    if (!t)
      throw StartupError(where + ".type: unknown agent type '" + type + "' (deer, pedestrian or truck)");
    s.type = *t;
    XmlRpcValue& path = e["path"];
    if (path.getType() != XmlRpcValue::TypeArray)
      throw StartupError(where + ".path: must be a list of [x, y] points (m)");
    for (int p = 0; p < path.size(); ++p)
    {
      double x = 0.0, y = 0.0;
      if (path[p].getType() != XmlRpcValue::TypeArray || path[p].size() != 2 || !detail::xmlNumber(path[p][0], x) ||
          !detail::xmlNumber(path[p][1], y))
        throw StartupError(where + ".path[" + std::to_string(p) + "]: must be a pair of numbers [x, y] (m)");
      s.path.emplace_back(x, y);
    }
    for (const auto& [field, target] : { std::pair<const char*, double*>{ "speed", &s.speed },
                                         std::pair<const char*, double*>{ "start_time", &s.start_time },
                                         std::pair<const char*, double*>{ "yaw", &s.yaw } })
      if (e.hasMember(field) && !detail::xmlNumber(e[field], *target))
        throw StartupError(where + "." + field + ": must be a number");
    if (e.hasMember("loop"))
    {
      if (e["loop"].getType() != XmlRpcValue::TypeBoolean)
        throw StartupError(where + ".loop: must be true or false");
      s.loop = static_cast<bool>(e["loop"]);
    }
    specs.push_back(std::move(s));
  }
  try
  {
    validateAgentSpecs(specs, key);
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError(std::string("parameter ") + e.what());
  }
  return specs;
}

/// `~agents` of a node (none when unset). @throw avsp::msgs::StartupError as parseAgents()
inline std::vector<AgentSpec> agentSpecsFromParams(const ros::NodeHandle& pnh)
{
  XmlRpc::XmlRpcValue list;
  if (!pnh.getParam("agents", list))
    return {};
  return parseAgents(list, "~agents");
}

/// agentSpecsFromParams() then makeAgents() on `ground` (the terrain's base grid).
/// @throw avsp::msgs::StartupError naming the key
inline std::vector<Agent> agentsFromParams(const ros::NodeHandle& pnh, const ElevationGrid& ground)
{
  const std::vector<AgentSpec> specs = agentSpecsFromParams(pnh);
  try
  {
    return makeAgents(specs, ground, "~agents");
  }
  catch (const std::invalid_argument& e)
  {
    throw avsp::msgs::StartupError(std::string("parameter ") + e.what());
  }
}

}  // namespace terrain
}  // namespace avsp
