#pragma once
/**
 * @file terrain_source.hpp
 * @brief Where a node's terrain comes from: the embedded default course, a DEM raster, a
 *        saved .avspterrain file or a flat square of one soil. terrain_node, dynamics_node and
 *        the sensor nodes all build their terrain through loadTerrainSource(), so given the
 *        same parameters they hold the same ground (heights, soils, objects) bit for bit.
 */
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "avsp_terrain/default_course.hpp"
#include "avsp_terrain/deformable_terrain.hpp"
#include "avsp_terrain/dem_io.hpp"
#include "avsp_terrain/soil.hpp"
#include "avsp_terrain/terrain_objects.hpp"

namespace avsp
{
namespace terrain
{
/// What to load. Exactly one of terrain_file, dem_file and flat_soil may be set; none = course.
struct TerrainSource
{
  std::string terrain_file;         ///< a saved .avspterrain (heights, soils, ruts, objects)
  std::string dem_file;             ///< .asc, .tif/.tiff or .png (16-bit, georeferenced by `png`)
  Png16Georef png;                  ///< for a .png DEM: cell_size and z_scale must be set (> 0)
  std::string soil = "sandy_loam";  ///< the soil everywhere on a DEM (checked whatever the source)
  std::string flat_soil;            ///< non-empty: a level square of this soil centred on the origin
  double flat_size = 100.0;         ///< m, side of the flat square
  double flat_cell_size = 0.1;      ///< m, its grid spacing
  CourseOptions course;             ///< the default course's seed, cell size and extent
  bool transport = true;            ///< DeformableTerrain::Options::transport (T5 flow to neighbours)
  /// Grid points the terrain may have, whatever its source (a DEM's header is checked before
  /// any allocation; a flat square's and the course's size from their parameters).
  std::uint64_t max_cells = kDefaultMaxPoints;
};

/// The loaded ground.
struct LoadedSource
{
  std::unique_ptr<DeformableTerrain> terrain;
  ObjectSet objects;               ///< the course's or the saved file's objects; none for DEMs and flats
  std::string description;         ///< e.g. "the default course (seed 1)", the file's path
  std::size_t filled_no_data = 0;  ///< DEM points without data, filled from their neighbours
};

/// Lower-case extension of a path with its dot ("" if none), e.g. ".tif".
std::string fileExtension(const std::string& path);

/**
 * @brief Builds the terrain `source` describes.
 * @throw std::invalid_argument naming the field (e.g. "dem_file", "flat_size", "soil") and
 *        the reason; std::runtime_error from the file readers naming the file
 */
LoadedSource loadTerrainSource(const TerrainSource& source, const SoilLibrary& soils);

}  // namespace terrain
}  // namespace avsp
