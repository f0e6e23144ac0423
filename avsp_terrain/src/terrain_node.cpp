// terrain_node: the terrain for RViz and the other nodes (README.md, "terrain_node"). The node is
// avsp_terrain_ros' TerrainNode; this main only constructs it and spins.
#include "avsp_terrain/ros/node_main.hpp"
#include "avsp_terrain/ros/terrain_node.hpp"

int main(int argc, char** argv)
{
  return avsp::node::runNode<avsp::terrain::node::TerrainNode>(argc, argv, "terrain_node");
}
