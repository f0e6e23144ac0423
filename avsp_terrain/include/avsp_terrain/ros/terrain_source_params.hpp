#pragma once
/**
 * @file terrain_source_params.hpp
 * @brief The ROS side of terrain_source.hpp: the private parameters every node that holds the
 *        terrain reads, with the same names and defaults everywhere (avsp_terrain/README.md,
 *        "Terrain source parameters").
 */
#include <ros/node_handle.h>

#include "avsp_terrain/ros/node_params.hpp"
#include "avsp_terrain/terrain_source.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
/// Reads ~terrain_file, ~dem_file, ~png_*, ~soil, ~flat_*, ~course_*, ~transport, ~max_cells,
/// from the master or from the tree a launch file would set (`scenario_launch --check` reads the
/// generated terrain parameters with it). @throw avsp::node::StartupError naming the parameter
TerrainSource terrainSourceFromParams(const avsp::node::ParamSource& pnh);

/// terrainSourceFromParams() then loadTerrainSource(). @throw avsp::node::StartupError naming
/// the parameter or the file
LoadedSource loadTerrainFromParams(const avsp::node::ParamSource& pnh, const SoilLibrary& soils);

}  // namespace node
}  // namespace terrain
}  // namespace avsp
