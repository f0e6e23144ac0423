#pragma once
/**
 * @file terrain_node.hpp
 * @brief terrain_node as a class (avsp_terrain/README.md, "terrain_node"): holds the terrain
 *        (default course, a DEM raster or a saved terrain), shows it in RViz (/terrain/mesh,
 *        /terrain/rut_markers, /terrain/objects), applies the ruts other processes publish on
 *        /terrain/ruts and the objects they topple, tracks soil moisture and snow from
 *        /environment, and saves the terrain on request (~save_map).
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace terrain
{
namespace node
{
class TerrainNode
{
public:
  /**
   * @brief Reads the parameters, loads the terrain, advertises and publishes the mesh, the
   *        objects and the loaded ruts.
   * @throw avsp::node::StartupError naming the parameter or the file
   */
  TerrainNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~TerrainNode();
  TerrainNode(const TerrainNode&) = delete;
  TerrainNode& operator=(const TerrainNode&) = delete;

  /// Publishes the mesh chunks changed since the last call (a burst of patches becomes one
  /// publication).
  void publishDirtyChunks();

  /// Until shutdown: callbacks, then the chunks they changed, 20 times a second (wall). @return 0
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace terrain
}  // namespace avsp
