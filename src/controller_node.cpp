// controller_node: one vehicle's waypoint or leader-follower controller (README.md, "Controller
// node"). The node is avsp_ros' ControllerNode; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/controller_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::node::ControllerNode>(argc, argv, "controller_node");
}
