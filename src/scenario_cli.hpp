#pragma once
// Shared by scenario_launch and scenario_node: command line -> validated scenario -> launch file.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <ros/package.h>

#include <avsp/scenario/launch_generator.hpp>
#include <avsp/scenario/ros/node_checks.hpp>
#include <avsp/scenario/scenario.hpp>

namespace avsp
{
namespace scenario
{
/// What generateFromCommandLine() produced.
struct Generated
{
  std::string launch_file;  ///< written file ("-" when printed)
  std::string output_dir;
  Scenario scenario;
};

/**
 * Parses the arguments, loads and validates the scenario, writes the launch file.
 * @return 0 on success, 2 for a bad command line, 1 for a bad scenario (message on stderr
 *         naming the file and key), 3 when the launch file cannot be written
 */
inline int generateFromCommandLine(const std::string& program, const std::vector<std::string>& args, Generated& out,
                                   bool default_to_stdout)
{
  namespace fs = std::filesystem;
  LaunchCommand cmd;
  try
  {
    cmd = parseLaunchCommand(args);
  }
  catch (const std::exception& e)
  {
    std::cerr << program << ": " << e.what() << "\n" << launchCommandUsage(program);
    return 2;
  }
  if (cmd.help)
  {
    std::cout << launchCommandUsage(program);
    std::exit(0);
  }
  std::string config = cmd.config_dir;
  if (config.empty())
  {
    const std::string share = ros::package::getPath("avsp");
    if (share.empty())
    {
      std::cerr << program << ": cannot find the avsp package (source a setup.sh, or give --config-dir)\n";
      return 2;
    }
    config = share + "/config";
  }
  LoadOptions load;
  load.vehicles_dir = fs::absolute(config + "/vehicles").lexically_normal().string();
  load.soils_file = fs::absolute(config + "/soils.yaml").lexically_normal().string();
  try
  {
    out.scenario = loadScenario(cmd.scenario, load);
    // The sections the nodes parse themselves, through their own parsers (--check and runs alike).
    checkSensorsAsTheNodeWill(out.scenario, load.vehicles_dir);
  }
  catch (const std::exception& e)
  {
    std::cerr << e.what() << "\n";
    return 1;
  }
  if (cmd.check_only)
  {
    std::cout << cmd.scenario << ": OK (" << out.scenario.vehicles.size() << " vehicles, " << out.scenario.duration
              << " s)\n";
    std::exit(0);
  }
  // Results under the caller's working directory: roslaunch runs nodes in ROS_HOME but
  // keeps the shell's PWD in the environment.
  std::string dir = cmd.options.output_dir;
  if (dir.empty())
  {
    const char* pwd = std::getenv("PWD");
    dir = (pwd && *pwd ? fs::path(pwd) : fs::current_path()).string() + "/results/" + out.scenario.name;
  }
  else if (fs::path(dir).is_relative())
  {
    const char* pwd = std::getenv("PWD");
    dir = ((pwd && *pwd ? fs::path(pwd) : fs::current_path()) / dir).string();
  }
  dir = fs::path(dir).lexically_normal().string();
  cmd.options.output_dir = dir;
  cmd.options.vehicles_dir = load.vehicles_dir;
  std::string text;
  try
  {
    text = generateLaunch(out.scenario, cmd.options);
  }
  catch (const std::exception& e)
  {
    std::cerr << program << ": " << e.what() << "\n";
    return 2;
  }
  out.output_dir = dir;
  std::string file = cmd.out;
  if (file.empty())
    file = default_to_stdout ? "-" : dir + "/" + out.scenario.name + ".launch";
  if (file == "-")
  {
    std::cout << text;
    out.launch_file = "-";
    return 0;
  }
  std::error_code ec;
  fs::create_directories(fs::absolute(file).parent_path(), ec);
  std::ofstream f(file);
  f << text;
  f.close();
  if (!f)
  {
    std::cerr << program << ": cannot write " << file << "\n";
    return 3;
  }
  out.launch_file = fs::absolute(file).string();
  return 0;
}

}  // namespace scenario
}  // namespace avsp
