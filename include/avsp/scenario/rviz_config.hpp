#pragma once
/**
 * @file rviz_config.hpp
 * @brief The RViz configuration of a scenario's run (issue 22, item 5): one display per topic
 *        the run's nodes publish that RViz can draw, grouped per vehicle, and a view that
 *        follows the lead vehicle. Written by scenario_launch beside the generated launch
 *        file. No ROS.
 */
#include <string>
#include <vector>

#include "avsp/scenario/scenario.hpp"

namespace avsp
{
namespace scenario
{
/// What one vehicle publishes that RViz can draw (besides its odometry and robot model), as
/// sensors_node will configure it (the caller reads that through the node's own parser).
struct VehicleDisplays
{
  std::string name;        ///< the vehicle (its topic namespace)
  bool lidar = false;      ///< <v>/avt_341/points
  bool radar = false;      ///< <v>/radar/points, <v>/radar/markers
  bool occupancy = false;  ///< <v>/octomap/occupied_cells, <v>/occupancy/grid
  /// Camera names with an RGB output (<v>/<camera>/image_raw); a stereo pair is two cameras,
  /// "<pair>/left" and "<pair>/right".
  std::vector<std::string> rgb_cameras;
};

/// The vehicle the view follows: the formation's first, else the first vehicle that follows
/// waypoints, else the first vehicle.
const VehicleSpec& leadVehicle(const Scenario& scenario);

/**
 * @brief RViz's YAML configuration for the run of `scenario`.
 *
 * Fixed frame `map`; the terrain mesh, ruts and objects; the agents' markers when the scenario
 * has agents; the V2V radio's links; per vehicle (a group named after it): robot model,
 * odometry, the controller's path and target (not for external control), lidar points, radar
 * points and targets, OctoMap cells and occupancy grid (off: they cost the sensors node work
 * only while someone subscribes), one image per RGB camera (the first of each vehicle on).
 * The view is a third-person follower of `<lead>/base_link` (leadVehicle()), behind the lead,
 * looking over the column.
 *
 * @param displays one entry per vehicle of the scenario, in any order
 * @throw std::invalid_argument when a vehicle has no entry or an entry names no vehicle
 */
std::string generateRvizConfig(const Scenario& scenario, const std::vector<VehicleDisplays>& displays);

/// Every topic a configuration from generateRvizConfig() subscribes (absolute names, sorted).
std::vector<std::string> rvizConfigTopics(const std::string& config_yaml);

}  // namespace scenario
}  // namespace avsp
