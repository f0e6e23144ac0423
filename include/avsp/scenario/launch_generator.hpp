#pragma once
/**
 * @file launch_generator.hpp
 * @brief Turns a validated Scenario into a roslaunch XML file: every component node with its
 *        own private parameters (the component packages cannot read a scenario file). No ROS.
 */
#include <string>
#include <vector>

#include "avsp/scenario/scenario.hpp"

namespace avsp
{
namespace scenario
{
struct LaunchOptions
{
  double duration = 0.0;          ///< s of sim time; <= 0: the scenario's
  double real_time_factor = 0.0;  ///< dynamics_node: 0 = as fast as possible (lockstep)
  bool rviz = false;              ///< add RViz (with rviz_config)
  /// RViz's configuration file (absolute; scenario_launch writes the run's own beside the
  /// launch file, rviz_config.hpp); empty: the package's rviz/avsp.rviz
  std::string rviz_config;
  std::string output_dir;        ///< run_recorder's results folder (absolute)
  std::string vehicles_dir;      ///< the folder the scenario's models were checked against
  double progress_period = 1.0;  ///< run_recorder: wall s between progress lines
  double clock_rate = 100.0;     ///< dynamics_node's /clock rate (Hz)
  bool start_gate = true;        ///< hold the physics until every node is up (start_gate node)
  /// Whether run_recorder / agents_node are built: a missing one is left out of the launch
  /// file (without the recorder the run has no end). Both exist in a complete build.
  bool have_run_recorder = true, have_agents_node = true;
};

/// The roslaunch XML of the scenario. @throw std::invalid_argument naming a bad option
std::string generateLaunch(const Scenario& scenario, const LaunchOptions& options);

/**
 * @brief The private parameters the generated launch file gives vehicle `v`'s controller_node
 *        (none for an external controller), in the order written: type "str", "double",
 *        "bool", or "yaml" (a `<rosparam>` flow YAML body). node_checks.hpp runs the node's own
 *        parser on them.
 */
std::vector<NodeParam> controllerNodeParams(const Scenario& s, const VehicleSpec& v, const std::string& vehicles_dir);

/**
 * @brief Emits a YAML node in flow style on one line, for a `<rosparam>` body: each scalar with
 *        rosparam's type for it (terrain::rosparamFlow), so that the node reads what the scenario
 *        check read.
 * @param force_double integers are written as floating point (`50` becomes `50.0`) so that
 *        nodes reading doubles from XML-RPC get doubles
 */
std::string flowYaml(const YAML::Node& node, bool force_double);

/// Shortest decimal text that reads back as exactly `v` in yaml-cpp and PyYAML, always with a
/// '.' (terrain::rosparamDouble; YAML's `.inf`, `-.inf`, `.nan` for the others).
std::string yamlDouble(double v);

/// The command line of scenario_launch / scenario_node (README.md, "scenario_launch").
struct LaunchCommand
{
  std::string scenario;  ///< the scenario file
  LaunchOptions options;
  std::string out;          ///< generated file; "-" = stdout; empty = <output_dir>/<name>.launch
  std::string config_dir;   ///< folder with vehicles/ and soils.yaml; empty = the package's config
  bool check_only = false;  ///< validate only, write nothing
  /// --end-launch (scenario_node): when the run ends, end the roslaunch that started this node
  /// with a SIGINT (a clean end, without roslaunch's "REQUIRED process has died" banner)
  bool end_launch = false;
  bool help = false;
};

/**
 * @brief Parses `scenario_file [--duration S] [--real-time-factor R] [--rviz [true|false]]
 *        [--output-dir DIR] [--out FILE] [--config-dir DIR] [--progress-period S] [--check]`.
 *        Arguments containing ":=" (roslaunch's __name:=, __log:=) are skipped.
 * @throw std::invalid_argument naming the option and the reason
 */
LaunchCommand parseLaunchCommand(const std::vector<std::string>& args);

/// Usage text of the command line above.
std::string launchCommandUsage(const std::string& program);

}  // namespace scenario
}  // namespace avsp
