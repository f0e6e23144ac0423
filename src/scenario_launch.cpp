// scenario_launch: validates a scenario file and writes the roslaunch file of its run
// (README.md, "Scenarios"). Exit 0 and the file's path on stdout, or 1 and the file + key
// of the first problem on stderr (2: bad command line, 3: cannot write).
#include <iostream>
#include <string>
#include <vector>

#include "avsp/ros/scenario_command.hpp"

int main(int argc, char** argv)
{
  avsp::node::Generated g;
  const int rc =
      avsp::node::generateFromCommandLine("scenario_launch", std::vector<std::string>(argv + 1, argv + argc), g, false);
  if (rc == 0 && g.launch_file != "-")
    std::cout << g.launch_file << "\n";
  return rc;
}
