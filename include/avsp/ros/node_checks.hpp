#pragma once
/**
 * @file node_checks.hpp
 * @brief What `scenario_launch --check` (and scenario_node before it runs anything) checks with
 *        the nodes' own parameter parsers: a scenario's sections become the XML-RPC values the
 *        generated launch file gives the nodes (rosparam's typing of YAML), and each node's
 *        parser reads them. So a key a node would refuse at start-up is refused here, naming the
 *        scenario file and the section, before any process starts.
 */
#include <string>
#include <vector>

#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include "avsp/scenario/rviz_config.hpp"
#include "avsp/scenario/scenario.hpp"

namespace avsp
{
namespace node
{
/**
 * @brief A YAML node as rosparam loads it: plain scalars typed as YAML 1.1 does (true/false/yes/
 *        no/on/off, integers, floats, .inf/.nan), quoted ones strings, sequences arrays, maps
 *        structs.
 * @throw std::invalid_argument for a null or a non-string map key (rosparam cannot set those)
 */
XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node);

/**
 * @brief Runs sensors_node's parser on every vehicle's sensors (the scenario's `sensors` and the
 *        vehicle's own), as the generated launch file passes them, and mounts them on the
 *        vehicle's URDF links from `vehicles_dir` as the node does (a link the URDF lacks).
 * @return per vehicle, in the scenario's order, what sensors_node will publish of it that RViz
 *         can draw (the run's RViz configuration is made from it)
 * @throw scenario::ScenarioError "<file>: vehicles[i].sensors (as sensors_node reads it for '<v>'): <its message>"
 */
std::vector<scenario::VehicleDisplays> checkSensorsAsTheNodeWill(const scenario::Scenario& s,
                                                                 const std::string& vehicles_dir);

}  // namespace node
}  // namespace avsp
