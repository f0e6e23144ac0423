// v2v_radio_node: the simulated V2V radio between the vehicles (README.md, "V2V radio node").
// The node is avsp_ros' V2vRadioNode; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/v2v_radio_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::node::V2vRadioNode>(argc, argv, "v2v_radio_node");
}
