// Test helper for the package's rostests: runs a command (a node binary with its arguments) to
// completion with its output captured, as the bad-parameter tests need.
#pragma once

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
namespace test
{
/// Runs `command` through the shell and waits for it: {exit code (-1 if it did not exit
/// normally), its stdout and stderr}.
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
}  // namespace test
}  // namespace avsp
