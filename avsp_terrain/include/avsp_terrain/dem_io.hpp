#pragma once
/**
 * @file dem_io.hpp
 * @brief Loaders and writers for digital elevation model (DEM) rasters: ESRI ASCII grid
 *        (.asc), 16-bit greyscale PNG heightmaps and GeoTIFF (via GDAL), plus no-data filling.
 *
 * Every reader either returns a complete, consistent HeightRaster or throws DemError naming
 * the file and the reason; a missing or unusable value is never replaced by a default.
 * Number parsing and printing (.asc) assume the C numeric locale (the default unless the
 * program calls setlocale).
 */
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace avsp
{
namespace terrain
{
/// Thrown for an unusable DEM file (or a raster that cannot be written); what() names the
/// file and the reason.
class DemError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/**
 * @brief A DEM as read from a file.
 *
 * Grid point (i, j) sits at map position (origin_x + i * cell_size, origin_y + j * cell_size).
 * Row 0 is the SOUTHERNMOST row (y = origin_y): files stored north-up (all three formats)
 * are flipped on read and on write. The grid points are the centres of the file's pixels.
 */
struct HeightRaster
{
  double origin_x = 0;         ///< map x of grid point (0, 0) (the south-west point), m
  double origin_y = 0;         ///< map y of grid point (0, 0), m
  double cell_size = 0;        ///< spacing of the grid points along x and y, m, > 0
  std::size_t columns = 0;     ///< grid points along x
  std::size_t rows = 0;        ///< grid points along y
  std::vector<float> heights;  ///< m, row-major, index j * columns + i; NaN = no data

  /// Number of no-data (NaN) heights.
  std::size_t noDataCount() const;
};

/**
 * @brief Georeference of a 16-bit greyscale PNG heightmap, which carries none itself.
 *
 * Pixel value v (0..65535) is the height z = z_offset + z_scale * v / 65535, so the PNG
 * spans heights [z_offset, z_offset + z_scale] in steps of z_scale / 65535.
 */
struct Png16Georef
{
  double origin_x = 0;   ///< map x of the centre of the south-west pixel, m
  double origin_y = 0;   ///< map y of the centre of the south-west pixel, m
  double cell_size = 0;  ///< pixel size, m, > 0
  double z_offset = 0;   ///< height of pixel value 0, m
  double z_scale = 0;    ///< height of pixel value 65535 minus z_offset, m, > 0
};

/**
 * @brief A raster of small class numbers per grid point (a soil map: soil indices), laid out
 *        like HeightRaster: row 0 is the southernmost row, grid points are pixel centres.
 */
struct ClassRaster
{
  double origin_x = 0;               ///< map x of grid point (0, 0) (the south-west point), m
  double origin_y = 0;               ///< map y of grid point (0, 0), m
  double cell_size = 0;              ///< spacing of the grid points along x and y, m, > 0
  std::size_t columns = 0;           ///< grid points along x
  std::size_t rows = 0;              ///< grid points along y
  std::vector<std::uint8_t> values;  ///< row-major, index j * columns + i
};

/// Default budget of grid points of a raster read from a file (a node's ~max_cells): 250 M
/// points, 1 GB of float heights per process (the site-scale bench's 218 M fit).
constexpr std::uint64_t kDefaultMaxPoints = 250000000;

/// What a DEM read from a file may be. The readers check the header against it before they
/// allocate anything.
struct DemLimits
{
  std::uint64_t max_points = kDefaultMaxPoints;  ///< columns x rows at most
};

/// Plausible geometry of a DEM read from a file: cell size 1 mm .. 10 km; origin within
/// +-1e8 m (any projected CRS); heights from 12 km below sea level (deeper than the Mariana
/// Trench, 11 km) to 10 km above it (higher than Everest, 8.85 km).
constexpr double kMinPlausibleCellSize = 1e-3;
constexpr double kMaxPlausibleCellSize = 1e4;
constexpr double kMaxPlausibleCoordinate = 1e8;
constexpr float kMinPlausibleHeight = -12000.0f;
constexpr float kMaxPlausibleHeight = 10000.0f;

/**
 * @brief Reads an ESRI ASCII grid (.asc).
 *
 * Header keys (case-insensitive): ncols, nrows, xllcorner or xllcenter, yllcorner or
 * yllcenter, cellsize (all required), NODATA_value (optional). xll/yllcorner is the outer
 * corner of the south-west cell, so the origin is half a cell further in; xll/yllcenter is
 * the south-west grid point itself. Values equal to NODATA_value become NaN; exactly
 * ncols * nrows finite values must follow (text "nan"/"inf" is rejected).
 * @throw DemError naming @p path and the reason; also for a file that is not regular, more than
 *        `limits.max_points` grid points (from the header, before allocating) and geometry or
 *        heights outside the plausible ranges above
 */
HeightRaster readAsciiGrid(const std::string& path, const DemLimits& limits = DemLimits());

/**
 * @brief Writes an ESRI ASCII grid with xllcenter/yllcenter and NODATA_value -9999.
 *
 * Heights are printed with 9 significant digits and the header with 17, so readAsciiGrid
 * returns bit-identical floats and doubles.
 * @throw DemError if the raster is inconsistent, holds infinite heights or a height equal
 *        to -9999 (it would read back as no-data), or the file cannot be written
 */
void writeAsciiGrid(const HeightRaster& raster, const std::string& path);

/**
 * @brief Reads a 16-bit greyscale PNG heightmap (libpng); pixel row 0 is the north edge.
 *
 * 8-bit, grey+alpha, RGB(A) and palette images are rejected. The result has no no-data.
 * @throw DemError naming @p path and the reason (also for an invalid @p georef); also for a
 *        file that is not regular, more than `limits.max_points` grid points (from the header,
 *        before allocating) and geometry or heights outside the plausible ranges above
 */
HeightRaster readPng16(const std::string& path, const Png16Georef& georef, const DemLimits& limits = DemLimits());

/**
 * @brief Writes a 16-bit greyscale PNG, quantising heights to round((z - z_offset) / z_scale * 65535).
 *
 * @p georef must describe the raster (same origin and cell size) so that readPng16 with the
 * same georef places it where it was.
 * @throw DemError if the raster holds no-data (PNG cannot store it), a height lies outside
 *        [z_offset, z_offset + z_scale], the georef does not match, or the write fails
 */
void writePng16(const HeightRaster& raster, const std::string& path, const Png16Georef& georef);

/**
 * @brief Writes a PNG's georeference as a small YAML sidecar file, since the PNG has none.
 *
 * Keys origin_x, origin_y, cell_size, z_offset, z_scale (m), printed with 17 significant
 * digits so that readPng16Georef() returns the same doubles, plus comments saying how a
 * pixel value becomes a height. @p image_name is only named in a comment.
 * @throw DemError naming @p path if the georef is invalid or the file cannot be written
 */
void writePng16Georef(const Png16Georef& georef, const std::string& path, const std::string& image_name);

/**
 * @brief Reads a sidecar written by writePng16Georef(): all five keys required, finite,
 *        cell_size and z_scale > 0; other keys are rejected (a typo must not become a default).
 * @throw DemError naming @p path and the key with the reason
 */
Png16Georef readPng16Georef(const std::string& path);

/**
 * @brief Writes an 8-bit greyscale PNG of a class raster, pixel row 0 = the north edge, pixel
 *        value = class number. Carries no georeference: write it beside (e.g. a YAML sidecar).
 * @throw DemError if the raster is inconsistent or the write fails
 */
void writeClassPng8(const ClassRaster& raster, const std::string& path);

/**
 * @brief Writes a Byte GeoTIFF of a class raster with the same north-up geotransform as
 *        writeGeoTiff() and no nodata (every point has a class).
 * @throw DemError if the raster is inconsistent or the write fails
 */
void writeClassGeoTiff(const ClassRaster& raster, const std::string& path);

/**
 * @brief Reads band 1 of a GeoTIFF (GDAL).
 *
 * Requires a north-up geotransform (no rotation, pixel height < 0) with square pixels, a
 * Float32, Float64, Int16 or UInt16 band, metre units if a CRS or band unit is given
 * (geographic CRSs are rejected), and applies the band's scale and offset if present. The
 * band's nodata value and NaN become NaN.
 *
 * Memory: the heights once (4 B per point) plus one row. Rows are read straight into the
 * result and GDAL's block cache is released after each row of blocks, so a site-size
 * raster is not held a second time in that cache.
 * @throw DemError naming @p path and the reason; also for a file that is not regular, more than
 *        `limits.max_points` grid points (from the header, before allocating) and geometry or
 *        heights outside the plausible ranges above
 */
HeightRaster readGeoTiff(const std::string& path, const DemLimits& limits = DemLimits());

/**
 * @brief Writes a Float32 GeoTIFF with a north-up geotransform, no CRS (map frame), band
 *        unit "metre" and nodata NaN.
 * @throw DemError if the raster is inconsistent, holds infinite heights, or the write fails
 */
void writeGeoTiff(const HeightRaster& raster, const std::string& path);

/**
 * @brief Fills no-data points with the height of the nearest valid point.
 *
 * "Nearest" is by steps through the 4-neighbourhood (breadth-first from all valid points at
 * once); ties go to whichever valid point reaches the point first in that search, which is
 * deterministic (valid points are seeded in index order, neighbours visited -x, +x, -y, +y).
 * Memory: one bit per point plus 4 B per no-data point and per valid point next to one
 * (only those can reach a void, so only those are seeded).
 * @param source name used in error messages (usually the file the raster came from)
 * @return number of points filled
 * @throw DemError naming @p source if every point is no-data or the raster is inconsistent
 */
std::size_t fillNoData(HeightRaster& raster, const std::string& source);

}  // namespace terrain
}  // namespace avsp
