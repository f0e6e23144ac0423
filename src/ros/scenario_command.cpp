// The scenario tools' command lines (scenario_command.hpp): scenario_launch writes a scenario's
// launch file; scenario_node (what launch/reference_traverse.launch runs) also runs it with a
// child `roslaunch` on the same master, forwards SIGINT/SIGTERM to it and exits with its status,
// so a required="true" scenario_node ends the outer launch when the run (run_recorder) ends.
// roslaunch exits 0 whatever its nodes did, so the verdict comes from run_recorder's
// summary.json: exit 5 when the run was aborted or wrote no results, 128 + signal when it was
// interrupted (README, "Scenarios").
#include "avsp/ros/scenario_command.hpp"

#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <iostream>

#include <avsp_terrain/output_file.hpp>
#include <ros/package.h>
#include <yaml-cpp/yaml.h>

#include "avsp/ros/node_checks.hpp"
#include "avsp/scenario/launch_generator.hpp"
#include "avsp/scenario/rviz_config.hpp"

namespace avsp
{
namespace node
{
using scenario::generateLaunch;
using scenario::generateRvizConfig;
using scenario::LaunchCommand;
using scenario::launchCommandUsage;
using scenario::LoadOptions;
using scenario::loadScenario;
using scenario::parseLaunchCommand;
using scenario::VehicleDisplays;

namespace
{
volatile sig_atomic_t g_child = 0;
volatile sig_atomic_t g_signal = 0;

void forward(int sig)
{
  g_signal = sig;
  if (g_child > 0)
    kill(g_child, sig);
}

/// The run's exit code from what run_recorder wrote into `dir` since `started`.
int verdict(const std::string& dir, std::time_t started, int status)
{
  const int interrupted = g_signal != 0 ? 128 + static_cast<int>(g_signal) : 0;
  const std::string path = dir + "/summary.json";
  struct stat st;
  if (stat(path.c_str(), &st) != 0 || st.st_mtime + 1 < started)
  {
    std::cerr << "scenario_node: the run wrote no results (" << path << " is missing or older than the run)\n";
    return interrupted ? interrupted : 5;
  }
  YAML::Node aborted;
  try
  {
    aborted = YAML::LoadFile(path)["aborted"];
  }
  catch (const std::exception& e)
  {
    std::cerr << "scenario_node: " << path << " cannot be read: " << e.what() << "\n";
    return interrupted ? interrupted : 5;
  }
  if (aborted.IsMap())
  {
    std::cerr << "scenario_node: the run was aborted at sim time " << aborted["sim_time"].as<std::string>("?")
              << " s: " << aborted["node"].as<std::string>("?") << ": " << aborted["reason"].as<std::string>("?")
              << "; the results so far are in " << dir << "\n";
    return interrupted ? interrupted : 5;
  }
  return interrupted ? interrupted : status;
}
}  // namespace

int generateFromCommandLine(const std::string& program, const std::vector<std::string>& args, Generated& out,
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
  std::vector<VehicleDisplays> displays;
  load.vehicles_dir = fs::absolute(config + "/vehicles").lexically_normal().string();
  load.soils_file = fs::absolute(config + "/soils.yaml").lexically_normal().string();
  load.terrain_loader = loadTerrainAsTheNodesWill;  // the nodes' reader on the generated parameters
  try
  {
    out.scenario = loadScenario(cmd.scenario, load);
    // The sections the nodes parse themselves, through their own parsers (--check and runs alike).
    displays = checkSensorsAsTheNodeWill(out.scenario, load.vehicles_dir);
    checkControllersAsTheNodeWill(out.scenario, load.vehicles_dir);
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
  std::string file = cmd.out;
  if (file.empty())
    file = default_to_stdout ? "-" : dir + "/" + out.scenario.name + ".launch";
  // The run's RViz configuration beside its launch file (in the results folder when the launch
  // file is printed), written whether or not --rviz asks for RViz: a user may open it later.
  const fs::path rviz_file = fs::absolute(file == "-" ? fs::path(dir) / (out.scenario.name + ".rviz")
                                                      : fs::path(file).replace_extension(".rviz"));
  cmd.options.rviz_config = rviz_file.string();
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
  out.end_launch = cmd.end_launch;
  // Both files through avsp_terrain's checked write (every write, the fsync and the close).
  auto write = [&](const fs::path& path, const std::string& bytes) {
    std::error_code ec;
    fs::create_directories(fs::absolute(path).parent_path(), ec);
    try
    {
      avsp::terrain::writeBytes(path.string(), bytes);
      return true;
    }
    catch (const std::exception& e)
    {
      std::cerr << program << ": cannot write " << path.string() << ": " << e.what() << "\n";
      return false;
    }
  };
  if (!write(rviz_file, generateRvizConfig(out.scenario, displays)))
    return 3;
  out.rviz_file = rviz_file.string();
  if (file == "-")
  {
    std::cout << text;
    out.launch_file = "-";
    return 0;
  }
  if (!write(file, text))
    return 3;
  out.launch_file = fs::absolute(file).string();
  return 0;
}

int runScenario(const std::vector<std::string>& args)
{
  Generated g;
  const int rc = generateFromCommandLine("scenario_node", args, g, false);
  if (rc != 0)
    return rc;
  if (g.launch_file == "-")
  {
    std::cerr << "scenario_node: --out - is for scenario_launch; give a file\n";
    return 2;
  }
  std::cout << "scenario_node: " << g.scenario.file << " -> " << g.launch_file << " (results in " << g.output_dir << ")"
            << std::endl;
  const std::time_t started = std::time(nullptr);
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = forward;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  const pid_t child = fork();
  if (child < 0)
  {
    std::perror("scenario_node: fork");
    return 4;
  }
  if (child == 0)
  {
    // Own process group: a terminal's Ctrl-C reaches the child once, through us.
    setpgid(0, 0);
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    execlp("roslaunch", "roslaunch", g.launch_file.c_str(), static_cast<char*>(nullptr));
    std::perror("scenario_node: cannot run roslaunch");
    _exit(127);
  }
  g_child = child;
  int status = 0;
  while (waitpid(child, &status, 0) < 0)
    if (errno != EINTR)
    {
      std::perror("scenario_node: waitpid");
      return 4;
    }
  g_child = 0;  // reaped: its pid may be reused
  int verdict_rc = 0;
  if (!WIFEXITED(status))
    verdict_rc = 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  else if (WEXITSTATUS(status) != 0)
    verdict_rc = WEXITSTATUS(status);
  else
    verdict_rc = verdict(g.output_dir, started, 0);
  if (g.end_launch && g_signal == 0)
  {
    // --end-launch (reference_traverse.launch): end the roslaunch that started us as a Ctrl-C
    // would, and exit when its SIGINT comes back (20 s at most), so that it does not print
    // "REQUIRED process [scenario] has died" for a run that ended. (Debian's roslaunch exits 0
    // whatever we return: ros/ros_comm#919; scenario_node's own exit code is the verdict.)
    const pid_t launcher = getppid();
    if (launcher > 1 && kill(launcher, SIGINT) == 0)
      for (int k = 0; k < 400 && g_signal == 0; ++k)
        usleep(50000);
  }
  return verdict_rc;
}

}  // namespace node
}  // namespace avsp
