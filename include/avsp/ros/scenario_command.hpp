#pragma once
/**
 * @file scenario_command.hpp
 * @brief The scenario tools' command lines (README.md, "Scenarios"): scenario_launch (command line
 *        -> validated scenario -> launch file) and scenario_node (that, then a child `roslaunch`
 *        of it on the same master, whose verdict becomes the exit code).
 */
#include <string>
#include <vector>

#include "avsp/scenario/scenario.hpp"

namespace avsp
{
namespace node
{
/// What generateFromCommandLine() produced.
struct Generated
{
  std::string launch_file;  ///< written file ("-" when printed)
  std::string output_dir;
  std::string rviz_file;  ///< the run's RViz configuration (written beside the launch file)
  scenario::Scenario scenario;
  bool end_launch = false;  ///< --end-launch
};

/**
 * @brief Parses the arguments, loads and validates the scenario (with the nodes' own parsers:
 *        node_checks.hpp), writes the launch file. `--help` and `--check` print and exit 0.
 * @param program the tool's name in messages
 * @param default_to_stdout without --out, print the launch file instead of writing it
 * @return 0 on success, 2 for a bad command line, 1 for a bad scenario (message on stderr
 *         naming the file and key), 3 when the launch file cannot be written
 */
int generateFromCommandLine(const std::string& program, const std::vector<std::string>& args, Generated& out,
                            bool default_to_stdout);

/**
 * @brief scenario_node: generateFromCommandLine(), then `roslaunch <file>` as a child on the same
 *        master; SIGINT/SIGTERM are forwarded to it. roslaunch exits 0 whatever its nodes did,
 *        so the verdict comes from run_recorder's summary.json.
 * @return the child's non-zero exit code; 5 when the run was aborted or wrote no results;
 *         128 + signal when it was interrupted; 4 when the child cannot be started; the codes of
 *         generateFromCommandLine()
 */
int runScenario(const std::vector<std::string>& args);

}  // namespace node
}  // namespace avsp
