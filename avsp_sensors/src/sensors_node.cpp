// sensors_node: the vehicles' sensors over the shared terrain (README.md, "sensors_node"). The
// node is avsp_sensors_ros' SensorsNode; this main only constructs it and spins.
#include <avsp_terrain/ros/node_main.hpp>

#include "avsp_sensors/ros/sensors_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::sensors::node::SensorsNode>(argc, argv, "sensors_node");
}
