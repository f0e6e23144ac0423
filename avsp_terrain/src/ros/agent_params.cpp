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
std::vector<AgentSpec> parseAgents(XmlRpc::XmlRpcValue& list, const std::string& key)
{
  try
  {
    return parseAgentSpecs(avsp::node::toYaml(list), key);  // the one parser, the scenario's too
  }
  catch (const std::invalid_argument& e)
  {
    throw avsp::node::StartupError(std::string("parameter ") + e.what());
  }
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
