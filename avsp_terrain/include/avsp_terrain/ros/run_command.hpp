#pragma once
/**
 * @file run_command.hpp
 * @brief The rostests' way to run a node that must refuse to start: run a command to completion
 *        with its output captured. One definition for every package's rostests (with
 *        spin_until.hpp).
 */
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

namespace avsp
{
namespace node
{
/**
 * @brief Runs `command` through the shell and waits for it.
 * @return {exit code (-1 if it did not exit normally), its stdout and stderr}
 */
inline std::pair<int, std::string> runCommand(const std::string& command)
{
  static int run = 0;
  const std::string log = "/tmp/avsp_test_command_" + std::to_string(getpid()) + "_" + std::to_string(run++) + ".log";
  const int status = std::system((command + " > " + log + " 2>&1").c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  std::remove(log.c_str());
  return { WIFEXITED(status) ? WEXITSTATUS(status) : -1, text.str() };
}

}  // namespace node
}  // namespace avsp
