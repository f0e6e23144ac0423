// dynamics_node: vehicles on the deformable soil, the clock or a partition of a run
// (README.md, "dynamics_node"). The node is avsp_dynamics_ros' DynamicsNode; this main only
// constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp_dynamics/ros/dynamics_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::dynamics::node::DynamicsNode>(argc, argv, "dynamics_node");
}
