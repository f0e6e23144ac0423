// scenario_node: what launch/reference_traverse.launch runs. Validates the scenario, writes
// its launch file (scenario_launch's options) and runs it with a child `roslaunch` on the same
// master; SIGINT/SIGTERM are forwarded to the child, and the node exits with its status, so a
// required="true" scenario_node ends the outer launch when the run (run_recorder) ends.
// roslaunch exits 0 whatever its nodes did, so the verdict comes from run_recorder's
// summary.json: exit 5 when the run was aborted or wrote no results, 128 + signal when it was
// interrupted (README, "Scenarios").
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstring>
#include <ctime>
#include <iostream>

#include <yaml-cpp/yaml.h>

#include "scenario_cli.hpp"

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

int main(int argc, char** argv)
{
  avsp::scenario::Generated g;
  const int rc = avsp::scenario::generateFromCommandLine("scenario_node", std::vector<std::string>(argv + 1, argv + argc),
                                                         g, false);
  if (rc != 0)
    return rc;
  if (g.launch_file == "-")
  {
    std::cerr << "scenario_node: --out - is for scenario_launch; give a file\n";
    return 2;
  }
  std::cout << "scenario_node: " << g.scenario.file << " -> " << g.launch_file << " (results in " << g.output_dir
            << ")" << std::endl;
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
  if (!WIFEXITED(status))
    return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  if (WEXITSTATUS(status) != 0)
    return WEXITSTATUS(status);
  return verdict(g.output_dir, started, 0);
}
