// start_gate: holds a scenario's physics until every node of the run is up and connected
// (README.md, "Scenarios"). The node is avsp_ros' StartGate; this main only constructs it and
// spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/start_gate.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::node::StartGate>(argc, argv, "start_gate");
}
