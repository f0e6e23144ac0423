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

#include <avsp_terrain/ros/node_params.hpp>

#include "avsp/scenario/rviz_config.hpp"
#include "avsp/scenario/scenario.hpp"

namespace avsp
{
namespace node
{
// toXmlRpc() (YAML as rosparam types it): avsp_terrain/ros/node_params.hpp, which every node reads with.

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
