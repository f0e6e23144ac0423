// environment_node: the Sun, Moon, light and weather on /environment (README.md, "Environment
// node"). The node is avsp_ros' EnvironmentNode; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/environment_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::node::EnvironmentNode>(argc, argv, "environment_node");
}
