#pragma once
/**
 * @file scenario.hpp
 * @brief The scenario file (README.md, "Scenario files"): terrain, geodetic reference, world
 *        time, weather, vehicles with their sensors and controllers, waypoint paths, formation,
 *        V2V radio, dynamic agents, seed and duration. No ROS: loadScenario() reads and
 *        validates a file; launch_generator.hpp turns the result into the component nodes'
 *        parameters.
 *
 * Every error is a ScenarioError whose message starts with the file's path and names the key
 * path, e.g. `reference_traverse.yaml: vehicles[2].controller.type: unknown 'foo' (waypoints,
 * leader_follower, external)`.
 */
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "avsp/v2v/radio.hpp"

#include <avsp/control/leader_follower.hpp>
#include <avsp_terrain/dem_io.hpp>
#include <avsp_terrain/terrain_objects.hpp>
#include <avsp_terrain/terrain_source.hpp>

namespace avsp
{
namespace terrain
{
class DeformableTerrain;  // avsp_terrain/deformable_terrain.hpp: held, not used, here
}  // namespace terrain

namespace scenario
{
/// A bad scenario: "<file>: <key path>: <reason>".
struct ScenarioError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/// One private parameter of a node as roslaunch writes it: `type` is str, double, int or bool;
/// numbers are printed so that they read back bit for bit.
struct NodeParam
{
  std::string name, value, type;
};

/// Where the ground comes from: exactly one of the default course, a file, a flat square.
struct TerrainSpec
{
  enum class Kind
  {
    kDefaultCourse,
    kFile,
    kFlat
  };
  Kind kind = Kind::kDefaultCourse;
  // default course
  std::uint64_t course_seed = 1;
  double course_cell_size = 0.1;                            ///< m
  double course_length_x = 600.0, course_length_y = 400.0;  ///< m
  // file: a saved .avspterrain or a DEM (.asc, .tif/.tiff, .png)
  std::string file;                 ///< absolute (relative paths are resolved against the scenario's folder)
  std::string soil = "sandy_loam";  ///< DEM soil everywhere
  bool has_png = false;             ///< a .png DEM's georeference given
  double png_cell_size = 0.0, png_z_scale = 0.0, png_origin_x = 0.0, png_origin_y = 0.0, png_z_offset = 0.0;
  // flat
  std::string flat_soil;
  double flat_size = 100.0, flat_cell_size = 0.1;        ///< m
  bool transport = true;                                 ///< T5 soil transport
  std::uint64_t max_cells = terrain::kDefaultMaxPoints;  ///< grid-point budget of every node holding the terrain
  std::string soils_file;                                ///< absolute; empty = LoadOptions::soils_file

  /// The terrain-source parameters of the component nodes (avsp_terrain README, "Terrain
  /// source parameters") and soils_file, in a fixed order.
  std::vector<struct NodeParam> nodeParams() const;
};

/// A waypoint of a path: position (map, m) and the speed (m/s) held from it to the next.
struct Waypoint
{
  double x = 0.0, y = 0.0, speed = 0.0;
};

enum class ControllerType
{
  kWaypoints,
  kLeaderFollower,
  kExternal
};
const char* toString(ControllerType type);

struct ControllerSpec
{
  ControllerType type = ControllerType::kExternal;
  std::string path;                 ///< waypoints: name of the path in Scenario::paths
  std::string leader;               ///< leader_follower: vehicle followed
  double gap = 15.0, offset = 0.0;  ///< leader_follower: m, m (+ left)
  bool from_formation = false;      ///< leader/gap/offset come from the formation
  YAML::Node params;                ///< further controller_node parameters (a map; may be null)
};

struct VehicleSpec
{
  std::string name, model;
  double x = 0.0, y = 0.0, yaw = 0.0;  ///< start pose in map: m, m, rad
  YAML::Node sensors;                  ///< sections replacing Scenario::sensors' (may be null)
  ControllerSpec controller;
  /// terramechanics: false = soil (the terrain's own model, simple or Bekker per soil), true =
  /// dem (its wheels on the DEM moving patch over the scenario's `dem:` segment)
  bool dem = false;
  // From the model's files (for run_recorder's anomaly counts):
  double max_speed = 0.0;     ///< m/s, governed
  double rest_height = 0.0;   ///< m, base_link above flat ground at rest (lowest wheel centre + radius)
  double wheel_radius = 0.0;  ///< m, of that lowest wheel
};

struct FormationSpec
{
  bool present = false;
  std::string type_name;  ///< column | line | diamond
  control::FormationType type = control::FormationType::kColumn;
  double spacing = 15.0, width = 5.0;  ///< m
  std::vector<std::string> vehicles;   ///< in slot order; the first leads
};

/// The radio's options (v2v_radio_node's; its seed is the scenario's).
using V2VSpec = v2v::RadioOptions;

/// A dynamics partition: one dynamics_node process with these vehicles (issue 7).
struct PartitionSpec
{
  std::string name;                   ///< dynamics_node ~partition
  std::vector<std::string> vehicles;  ///< in scenario order
  std::string machine;                ///< roslaunch <machine> it runs on ("" = the launching host)
};

/// A roslaunch <machine> a partition can run on.
struct MachineSpec
{
  std::string name, address, env_loader, user;  ///< user "" = the launching user
};

/**
 * @brief Splits vehicles over `count` partitions p1..pN, balancing their cost: the most
 *        expensive first, each to the partition with the least cost so far (ties: the lower
 *        number). A vehicle's cost is 1 + its wheels + its road wheels (the ODE bodies with
 *        soil contacts, what a step costs). Vehicles keep the scenario's order within a
 *        partition. Deterministic.
 * @param costs per vehicle, in scenario order
 */
std::vector<PartitionSpec> balancedPartitions(const std::vector<std::string>& names, const std::vector<double>& costs,
                                              std::size_t count);

struct Scenario
{
  std::string file;  ///< as given to loadScenario()
  std::string name;  ///< the file's name without folder and extension
  TerrainSpec terrain;
  double latitude = 0.0, longitude = 0.0, altitude = 0.0;  ///< deg, deg, m
  std::string start_utc;                                   ///< ISO 8601 ending in Z
  double time_acceleration = 1.0;                          ///< world s per sim s
  YAML::Node weather;  ///< environment_node's ~weather list (validated); may be null
  YAML::Node sensors;  ///< sensors_node's ~sensors sections for every vehicle; may be null
  std::vector<VehicleSpec> vehicles;
  std::map<std::string, std::vector<Waypoint>> paths;
  FormationSpec formation;
  V2VSpec v2v;
  YAML::Node agents;  ///< agents_node's ~agents list (validated); may be null
  /// dynamics_node's ~dem: the `dem:` section as flow YAML, read back by the node's own reader
  /// (parseDemSoilSpec) at load; empty without one
  std::string dem;
  /// Dynamics partitions (`partitions:` N or an explicit list); empty = one dynamics_node
  /// that is its own clock. Each vehicle is in exactly one.
  std::vector<PartitionSpec> partitions;
  std::vector<MachineSpec> machines;  ///< `machines:` (only those partitions name)
  std::uint64_t seed = 0;
  double duration = 0.0;  ///< s of sim time

  /// Index of the vehicle called `name`, or -1.
  int vehicleIndex(const std::string& name) const;
};

/// What the start-pose check needs of the terrain: its extent and objects.
struct TerrainFootprint
{
  double min_x = 0.0, min_y = 0.0, max_x = 0.0, max_y = 0.0;  ///< m, map: the grid's extent
  terrain::ObjectSet objects;
  /// The terrain itself, for the agents' paths (each spline's height profile, as the nodes
  /// build it); null = not loaded (a test's footprint): the agents are not checked against it.
  std::shared_ptr<const terrain::DeformableTerrain> ground;
};

/// Loads the terrain a spec describes (throws std::exception with the reason on failure).
using TerrainLoader = std::function<std::shared_ptr<const TerrainFootprint>(const TerrainSpec&)>;

/// The footprint through avsp_terrain's loadTerrainSource() with the spec's soils file (the
/// scenario's own reading of the spec; `scenario_launch --check` loads it instead as the nodes
/// read the generated parameters, node_checks.hpp).
std::shared_ptr<const TerrainFootprint> loadTerrainFootprint(const TerrainSpec& spec);

/// The footprint of a loaded terrain source.
std::shared_ptr<const TerrainFootprint> footprintOf(terrain::LoadedSource loaded);

struct LoadOptions
{
  std::string vehicles_dir;  ///< folder of <model>.yaml (required)
  std::string soils_file;    ///< soil library when the scenario names none (required)
  /// Used for the start-pose check; empty = loadTerrainFootprint. Tests give a cheap one.
  TerrainLoader terrain_loader;
  bool check_terrain = true;  ///< false: skip loading the terrain (no start-pose check)
  /// Clearance (m) a vehicle's start point must keep from every object but grass.
  double start_clearance = 1.0;
};

/**
 * @brief Reads and validates a scenario file.
 * @throw ScenarioError "<path>: <key path>: <reason>" for any problem: unreadable file, YAML
 *        syntax (with line and column), missing or unknown key, wrong type, value out of range,
 *        unknown model, empty path, negative speed, unknown or cyclic leader, duplicate name,
 *        a vehicle starting off the terrain or within start_clearance of an object
 */
Scenario loadScenario(const std::string& path, const LoadOptions& options);

/// As loadScenario() from text; `path` names the file in messages and anchors relative paths.
Scenario parseScenario(const std::string& text, const std::string& path, const LoadOptions& options);

}  // namespace scenario
}  // namespace avsp
