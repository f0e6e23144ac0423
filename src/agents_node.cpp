// agents_node: the dynamic agents on TF, /agents/markers and /agents/states (README.md, "Agents
// node"). The node is avsp_ros' AgentsNode; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/agents_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::node::AgentsNode>(argc, argv, "agents_node");
}
