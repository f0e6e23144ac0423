// scenario_node: what launch/reference_traverse.launch runs. Validates the scenario, writes
// its launch file (scenario_launch's options) and runs it with a child `roslaunch` on the same
// master; SIGINT/SIGTERM are forwarded to the child, and the node exits with its status, so a
// required="true" scenario_node ends the outer launch when the run (run_recorder) ends.
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstring>
#include <iostream>

#include "scenario_cli.hpp"

namespace
{
volatile sig_atomic_t g_child = 0;

void forward(int sig)
{
  if (g_child > 0)
    kill(g_child, sig);
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
  if (WIFEXITED(status))
    return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}
