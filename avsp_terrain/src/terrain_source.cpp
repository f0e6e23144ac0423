#include "avsp_terrain/terrain_source.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

#include "avsp_terrain/terrain_file.hpp"

namespace avsp
{
namespace terrain
{
namespace
{
std::string number(double v)
{
  return std::to_string(v);
}

/// Refuses a grid of `columns` x `rows` points beyond the budget, before it is allocated.
void checkBudget(const std::string& field, double columns, double rows, std::uint64_t max_cells)
{
  const double points = columns * rows;
  if (!(points <= static_cast<double>(max_cells)))
    throw std::invalid_argument(field + ": " + number(columns) + " x " + number(rows) + " = " + number(points) +
                                " grid points exceed the budget max_cells = " + std::to_string(max_cells));
}

HeightRaster readDem(const TerrainSource& source)
{
  const std::string& path = source.dem_file;
  const std::string ext = fileExtension(path);
  const DemLimits limits{ source.max_cells };
  if (ext == ".asc")
    return readAsciiGrid(path, limits);
  if (ext == ".tif" || ext == ".tiff")
    return readGeoTiff(path, limits);
  if (ext == ".png")
  {
    if (!(source.png.cell_size > 0.0) || !(source.png.z_scale > 0.0))
      throw std::invalid_argument("dem_file " + path + " is a PNG: png.cell_size and png.z_scale must be > 0");
    return readPng16(path, source.png, limits);
  }
  throw std::invalid_argument("dem_file " + path + ": unknown extension '" + ext + "' (use .asc, .tif, .tiff or .png)");
}
}  // namespace

std::string fileExtension(const std::string& path)
{
  const auto dot = path.find_last_of('.');
  const auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

LoadedSource loadTerrainSource(const TerrainSource& source, const SoilLibrary& soils)
{
  const int given = !source.terrain_file.empty() + !source.dem_file.empty() + !source.flat_soil.empty();
  if (given > 1)
    throw std::invalid_argument("terrain_file, dem_file and flat_soil: give at most one (got " + std::to_string(given) +
                                ")");
  // Checked whichever source is used: a misspelt soil is a mistake even where it is unused.
  if (!soils.contains(source.soil))
    throw std::invalid_argument("soil: no soil '" + source.soil + "' in the soil library");
  const DeformableTerrain::Options options{ source.transport };
  LoadedSource out;
  if (!source.terrain_file.empty())
  {
    LoadedTerrain loaded = loadTerrain(source.terrain_file, soils, source.max_cells);
    out.terrain = std::make_unique<DeformableTerrain>(std::move(loaded.terrain));
    out.objects = std::move(loaded.objects);
    out.description = source.terrain_file;
    return out;
  }
  if (!source.flat_soil.empty())
  {
    if (!soils.contains(source.flat_soil))
      throw std::invalid_argument("flat_soil: no soil '" + source.flat_soil + "' in the soil library");
    if (!(std::isfinite(source.flat_size) && source.flat_size >= 1.0 && source.flat_size <= 1e4))
      throw std::invalid_argument("flat_size = " + number(source.flat_size) + " must be in [1, 10000] m");
    if (!(std::isfinite(source.flat_cell_size) && source.flat_cell_size >= 0.005 &&
          source.flat_cell_size <= 0.1 * source.flat_size))
      throw std::invalid_argument("flat_cell_size = " + number(source.flat_cell_size) +
                                  " must be in [0.005 m, flat_size / 10]");
    const auto n = static_cast<std::size_t>(std::llround(source.flat_size / source.flat_cell_size)) + 1;
    checkBudget("flat_cell_size", static_cast<double>(n), static_cast<double>(n), source.max_cells);
    ElevationGrid grid(-0.5 * source.flat_size, -0.5 * source.flat_size, source.flat_cell_size, source.flat_cell_size,
                       n, n, std::vector<float>(n * n, 0.0f));
    out.terrain = std::make_unique<DeformableTerrain>(std::move(grid), soils.get(source.flat_soil), options);
    out.description = "flat " + source.flat_soil + " " + number(source.flat_size) + " m";
    return out;
  }
  if (!source.dem_file.empty())
  {
    HeightRaster raster = readDem(source);
    out.filled_no_data = fillNoData(raster, source.dem_file);
    ElevationGrid grid(raster.origin_x, raster.origin_y, raster.cell_size, raster.cell_size, raster.columns,
                       raster.rows, std::move(raster.heights));
    out.terrain = std::make_unique<DeformableTerrain>(std::move(grid), soils.get(source.soil), options);
    out.description = source.dem_file;
    return out;
  }
  checkBudget("course_cell_size", std::floor(source.course.length_x / source.course.cell_size) + 1.0,
              std::floor(source.course.length_y / source.course.cell_size) + 1.0, source.max_cells);
  Course course = [&source] {
    try
    {
      return makeDefaultCourse(source.course);
    }
    catch (const std::invalid_argument& e)
    {
      throw std::invalid_argument(std::string("course_*: ") + e.what());
    }
  }();
  out.objects = std::move(course.objects);
  // The course's own soil map (road asphalt, trail gravel, pond mud, ...).
  out.terrain = std::make_unique<DeformableTerrain>(
      std::move(course.heights), paletteFromNames(course.soil_names, soils), std::move(course.soil_map), options);
  out.description = "the default course (seed " + std::to_string(source.course.seed) + ")";
  return out;
}

}  // namespace terrain
}  // namespace avsp
