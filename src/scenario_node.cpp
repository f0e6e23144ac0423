// scenario_node: what launch/reference_traverse.launch runs (README.md, "Scenarios"): validates
// the scenario, writes its launch file and runs it with a child roslaunch; the exit code is the
// run's verdict. The work is avsp_ros' runScenario().
#include <string>
#include <vector>

#include "avsp/ros/scenario_command.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runScenario(std::vector<std::string>(argv + 1, argv + argc));
}
