#include "avsp_terrain/ros/agent_params.hpp"

#include <optional>
#include <stdexcept>
#include <utility>

#include "avsp_terrain/ros/node_params.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
namespace
{
bool xmlNumber(const XmlRpc::XmlRpcValue& v, double& out)
{
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    out = static_cast<double>(const_cast<XmlRpc::XmlRpcValue&>(v));
  else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
    out = static_cast<int>(const_cast<XmlRpc::XmlRpcValue&>(v));
  else
    return false;
  return true;
}
}  // namespace

std::vector<AgentSpec> parseAgents(XmlRpc::XmlRpcValue& list, const std::string& key)
{
  using avsp::node::StartupError;
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
      if (path[p].getType() != XmlRpcValue::TypeArray || path[p].size() != 2 || !xmlNumber(path[p][0], x) ||
          !xmlNumber(path[p][1], y))
        throw StartupError(where + ".path[" + std::to_string(p) + "]: must be a pair of numbers [x, y] (m)");
      s.path.emplace_back(x, y);
    }
    for (const auto& [field, target] : { std::pair<const char*, double*>{ "speed", &s.speed },
                                         std::pair<const char*, double*>{ "start_time", &s.start_time },
                                         std::pair<const char*, double*>{ "yaw", &s.yaw } })
      if (e.hasMember(field) && !xmlNumber(e[field], *target))
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

std::vector<AgentSpec> agentSpecsFromParams(const ros::NodeHandle& pnh)
{
  XmlRpc::XmlRpcValue list;
  if (!avsp::node::structuredParam(pnh, "agents", list))
    return {};
  return parseAgents(list, "~agents");
}

std::vector<Agent> agentsFromParams(const ros::NodeHandle& pnh, const ElevationGrid& ground)
{
  const std::vector<AgentSpec> specs = agentSpecsFromParams(pnh);
  try
  {
    return makeAgents(specs, ground, "~agents");
  }
  catch (const std::invalid_argument& e)
  {
    throw avsp::node::StartupError(std::string("parameter ") + e.what());
  }
}

}  // namespace node
}  // namespace terrain
}  // namespace avsp
