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

/**
 * @brief Runs controller_node's parser (readControllerParams) on every controlled vehicle's
 *        parameters as the generated launch file sets them (controllerNodeParams), with the
 *        models in `vehicles_dir`; then refuses a key of the vehicle's `controller.params` the
 *        parser never read (in the controller's mode).
 * @throw scenario::ScenarioError "<file>: vehicles[i].controller (as controller_node reads it
 *        for '<v>'): <its message>" or "<file>: vehicles[i].controller.params.<key>: unknown key
 *        ..."
 */
void checkControllersAsTheNodeWill(const scenario::Scenario& s, const std::string& vehicles_dir);

/**
 * @brief The scenario's terrain loaded as every node that holds it will load it: the node's
 *        reader (terrainSourceFromParams) on the parameters the generated launch file gives
 *        them (TerrainSpec::nodeParams), then loadTerrainSource with the ~soils_file given. For
 *        LoadOptions::terrain_loader.
 * @throw std::exception with the node's message (a value it refuses, a file it cannot load);
 *        std::logic_error for a generated parameter no node reads
 */
std::shared_ptr<const scenario::TerrainFootprint> loadTerrainAsTheNodesWill(const scenario::TerrainSpec& spec);

/**
 * @brief A node's private parameters as a tree (what ParamSource reads), from the launch
 *        file's `<param>` (str, double, int, bool) and `<rosparam>` ("yaml") entries.
 * @throw std::invalid_argument for a value its type cannot hold
 */
XmlRpc::XmlRpcValue paramTree(const std::vector<scenario::NodeParam>& params);

}  // namespace node
}  // namespace avsp
