#include "avsp_terrain/ros/terrain_source_params.hpp"

#include <cstdint>
#include <stdexcept>
#include <string>

#include "avsp_terrain/ros/node_params.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
TerrainSource terrainSourceFromParams(const avsp::node::ParamSource& pnh)
{
  using avsp::node::boolParam;
  using avsp::node::boundedIntParam;
  using avsp::node::boundedParam;
  using avsp::node::numberParam;
  using avsp::node::StartupError;
  using avsp::node::stringParam;
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
    if (!pnh.has("png_cell_size") || !pnh.has("png_z_scale"))
      throw StartupError("~dem_file " + s.dem_file +
                         " is a PNG: parameters ~png_cell_size and ~png_z_scale are required");
    s.png.cell_size = numberParam(pnh, "png_cell_size", 0.0);
    s.png.z_scale = numberParam(pnh, "png_z_scale", 0.0);
  }
  // The cell sizes' upper bounds are relative (a tenth of the square or of the course's
  // sides): loadTerrainSource applies them, the rule the scenario check loads with too.
  s.flat_size = boundedParam(pnh, "flat_size", 100.0, 1.0, 1e4);
  s.flat_cell_size = boundedParam(pnh, "flat_cell_size", 0.1, 0.005, 1e3);
  s.course.seed = static_cast<std::uint64_t>(boundedIntParam(pnh, "course_seed", 1, 0, 2147483647));
  s.course.cell_size = boundedParam(pnh, "course_cell_size", 0.1, 1e-3, 1e4);
  s.course.length_x = boundedParam(pnh, "course_length_x", 600.0, 1.0, 1e5);
  s.course.length_y = boundedParam(pnh, "course_length_y", 400.0, 1.0, 1e5);
  // XML-RPC integers are 32-bit: the budget is given in grid points up to 2^31 - 1.
  s.max_cells =
      static_cast<std::uint64_t>(boundedIntParam(pnh, "max_cells", static_cast<int>(kDefaultMaxPoints), 1, 2147483647));
  return s;
}

LoadedSource loadTerrainFromParams(const avsp::node::ParamSource& pnh, const SoilLibrary& soils)
{
  const TerrainSource source = terrainSourceFromParams(pnh);
  try
  {
    return loadTerrainSource(source, soils);
  }
  catch (const std::invalid_argument& e)
  {
    throw avsp::node::StartupError(std::string("parameter ~") + e.what());
  }
  catch (const std::exception& e)
  {
    throw avsp::node::StartupError(std::string("terrain: ") + e.what());
  }
}

}  // namespace node
}  // namespace terrain
}  // namespace avsp
