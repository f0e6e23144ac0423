#include "avsp_terrain/ros/conversions.hpp"

#include <cstdint>
#include <utility>

namespace avsp
{
namespace terrain
{
namespace node
{
HeightPatch heightPatchFromMessage(const avsp_msgs::TerrainPatch& msg)
{
  HeightPatch p;
  p.origin_x = msg.origin.x;
  p.origin_y = msg.origin.y;
  p.resolution = msg.resolution;
  p.width = msg.width;
  p.height = msg.height;
  p.heights = msg.heights;
  return p;
}

avsp_msgs::TerrainPatch toTerrainPatch(HeightPatch patch, const std_msgs::Header& header)
{
  avsp_msgs::TerrainPatch msg;
  msg.header = header;
  msg.origin.x = patch.origin_x;
  msg.origin.y = patch.origin_y;
  msg.resolution = patch.resolution;
  msg.width = static_cast<std::uint32_t>(patch.width);
  msg.height = static_cast<std::uint32_t>(patch.height);
  msg.heights = std::move(patch.heights);
  return msg;
}

avsp_msgs::TerrainPatch endOfInstantMarker(const std_msgs::Header& header, double resolution)
{
  avsp_msgs::TerrainPatch marker;
  marker.header = header;
  marker.resolution = resolution;
  return marker;
}

bool isEndOfInstantMarker(const avsp_msgs::TerrainPatch& msg)
{
  return msg.width == 0 && msg.height == 0 && msg.heights.empty();
}

}  // namespace node
}  // namespace terrain
}  // namespace avsp
