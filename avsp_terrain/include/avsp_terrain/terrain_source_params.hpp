#pragma once
/**
 * @file terrain_source_params.hpp
 * @brief The ROS side of terrain_source.hpp (this header, unlike the core's, includes ROS):
 *        the private parameters every node that holds the terrain reads, with the same names
 *        and defaults everywhere (avsp_terrain/README.md, "Terrain source parameters").
 */
#include <cstdint>
#include <stdexcept>
#include <string>

#include <ros/node_handle.h>

#include <avsp_msgs/node_params.hpp>

#include "avsp_terrain/terrain_source.hpp"

namespace avsp
{
namespace terrain
{
/// Reads ~terrain_file, ~dem_file, ~png_*, ~soil, ~flat_*, ~course_*, ~transport, ~max_cells.
/// @throw avsp::msgs::StartupError naming the parameter
inline TerrainSource terrainSourceFromParams(const ros::NodeHandle& pnh)
{
  using avsp::msgs::boolParam;
  using avsp::msgs::boundedParam;
  using avsp::msgs::numberParam;
  using avsp::msgs::StartupError;
  using avsp::msgs::stringParam;
  // Typed readers: a value of the wrong type is refused naming the parameter, never replaced
  // by the default (pnh.param<> would).
  TerrainSource s;
  s.terrain_file = stringParam(pnh, "terrain_file", "");
  s.dem_file = stringParam(pnh, "dem_file", "");
  s.soil = stringParam(pnh, "soil", "sandy_loam");
  s.flat_soil = stringParam(pnh, "flat_soil", "");
  s.transport = boolParam(pnh, "transport", true);
  if (!s.dem_file.empty() && fileExtension(s.dem_file) == ".png")
  {
    s.png.origin_x = numberParam(pnh, "png_origin_x", 0.0);
    s.png.origin_y = numberParam(pnh, "png_origin_y", 0.0);
    s.png.z_offset = numberParam(pnh, "png_z_offset", 0.0);
    if (!pnh.hasParam("png_cell_size") || !pnh.hasParam("png_z_scale"))
      throw StartupError("~dem_file " + s.dem_file +
                         " is a PNG: parameters ~png_cell_size and ~png_z_scale are required");
    s.png.cell_size = numberParam(pnh, "png_cell_size", 0.0);
    s.png.z_scale = numberParam(pnh, "png_z_scale", 0.0);
  }
  s.flat_size = boundedParam(pnh, "flat_size", 100.0, 1.0, 1e4);
  s.flat_cell_size = boundedParam(pnh, "flat_cell_size", 0.1, 0.005, 10.0);
  s.course.seed = static_cast<std::uint64_t>(avsp::msgs::boundedIntParam(pnh, "course_seed", 1, 0, 2147483647));
  s.course.cell_size = boundedParam(pnh, "course_cell_size", 0.1, 1e-3, 100.0);
  s.course.length_x = boundedParam(pnh, "course_length_x", 600.0, 1.0, 1e5);
  s.course.length_y = boundedParam(pnh, "course_length_y", 400.0, 1.0, 1e5);
  // XML-RPC integers are 32-bit: the budget is given in grid points up to 2^31 - 1.
  s.max_cells = static_cast<std::uint64_t>(avsp::msgs::boundedIntParam(
      pnh, "max_cells", static_cast<int>(kDefaultMaxPoints), 1, 2147483647));
  return s;
}

/// terrainSourceFromParams() then loadTerrainSource(). @throw avsp::msgs::StartupError naming
/// the parameter or the file
inline LoadedSource loadTerrainFromParams(const ros::NodeHandle& pnh, const SoilLibrary& soils)
{
  const TerrainSource source = terrainSourceFromParams(pnh);
  try
  {
    return loadTerrainSource(source, soils);
  }
  catch (const std::invalid_argument& e)
  {
    throw avsp::msgs::StartupError(std::string("parameter ~") + e.what());
  }
  catch (const std::exception& e)
  {
    throw avsp::msgs::StartupError(std::string("terrain: ") + e.what());
  }
}

}  // namespace terrain
}  // namespace avsp
