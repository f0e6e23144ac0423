#pragma once
/**
 * @file course_export.hpp
 * @brief The `export_course` tool as a library: command-line parsing and writing the
 *        default course (makeDefaultCourse) to DEM files, so both can be tested without
 *        running the executable.
 *
 * Files written (the format follows the extension of --out, case-insensitive):
 * - `.asc`: ESRI ASCII grid, heights exact (writeAsciiGrid).
 * - `.tif`/`.tiff`: Float32 GeoTIFF, heights exact, georeferenced (writeGeoTiff).
 * - `.png`: 16-bit greyscale heightmap spanning exactly the course's height range, plus
 *   the sidecar `<out>.yaml` (writePng16Georef) needed to read it back with readPng16.
 * - `--soil-map PATH` (`.png` or `.tif`/`.tiff`): one 8-bit pixel per grid point holding
 *   the soil index, and the legend `<PATH>.yaml`: the raster's georeference and
 *   `soils: {index: name}` with names from config/soils.yaml.
 */
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "avsp_terrain/default_course.hpp"

namespace avsp
{
namespace terrain
{
/// A bad command line; what() names the flag or path and the reason.
class UsageError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// What export_course was asked to do.
struct ExportOptions
{
  CourseOptions course;  ///< --seed, --cell-size, --length-x, --length-y (defaults as CourseOptions)
  std::string out;       ///< --out: heights file, .asc, .png, .tif or .tiff (required)
  std::string soil_map;  ///< --soil-map: soil index raster, .png, .tif or .tiff; empty = none
  bool help = false;     ///< --help / -h: print usage and write nothing
};

/// The usage text of export_course (flags, defaults, formats, one example).
std::string exportUsage();

/**
 * @brief Parses the arguments after the program name: `--flag value` or `--flag=value`.
 *
 * Numbers must be complete ("1.5x" is rejected), finite and > 0; --seed is a whole number
 * in [0, 2^64). The range rules that depend on each other (minimum extents, cell size at
 * most a tenth of an extent) are makeDefaultCourse's; exportCourse() reports them.
 * @throw UsageError naming the flag (unknown flag, missing value, bad number, given twice,
 *        --out missing) or the path (unknown extension, --soil-map equal to --out)
 */
ExportOptions parseExportArguments(const std::vector<std::string>& args);

/**
 * @brief Builds the course and writes the requested files.
 * @return the paths written, heights file first
 * @throw UsageError naming the flag when makeDefaultCourse refuses the sizes (extent
 *        below its minimum, cell size above a tenth of an extent, too many points)
 * @throw DemError naming the file that could not be written and why
 */
std::vector<std::string> exportCourse(const ExportOptions& options);

}  // namespace terrain
}  // namespace avsp
