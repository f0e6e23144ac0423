// v2v_broadcaster: a vehicle's V2V transmitter (README.md, "V2V broadcaster"). The node is
// avsp_ros' V2vBroadcaster; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp/ros/v2v_broadcaster.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::node::V2vBroadcaster>(argc, argv, "v2v_broadcaster");
}
