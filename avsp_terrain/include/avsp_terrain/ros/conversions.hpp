#pragma once
/**
 * @file conversions.hpp
 * @brief avsp_terrain's conversions between ROS messages and the core's types, as plain
 *        functions: the one TerrainPatch <-> HeightPatch conversion that terrain_node,
 *        dynamics_node, sensors_node and run_recorder all use.
 */
#include <avsp_msgs/TerrainPatch.h>
#include <std_msgs/Header.h>

#include "avsp_terrain/height_patch.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
/// The HeightPatch of a TerrainPatch message, field for field; not checked here (applyPatch()
/// and avsp_sensors' applyHeightPatch() refuse a bad one naming the field).
HeightPatch heightPatchFromMessage(const avsp_msgs::TerrainPatch& msg);

/// The TerrainPatch message of `patch` (its heights moved into the message) under `header`.
avsp_msgs::TerrainPatch toTerrainPatch(HeightPatch patch, const std_msgs::Header& header);

/// The end-of-instant marker (TerrainPatch.msg: width = height = 0, no heights) under `header`:
/// every patch of its stamp from that publisher has gone out before it.
avsp_msgs::TerrainPatch endOfInstantMarker(const std_msgs::Header& header, double resolution);
/// Whether `msg` is an end-of-instant marker (no heights to apply).
bool isEndOfInstantMarker(const avsp_msgs::TerrainPatch& msg);

}  // namespace node
}  // namespace terrain
}  // namespace avsp
