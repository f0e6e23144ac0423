#pragma once
/**
 * @file terrain_file.hpp
 * @brief Saves a deformed terrain (base heights, soil map and palette, per-point deformation,
 *        flow accounting, objects with their toppled state) to one binary file and loads it
 *        back bit-exactly, so a run can resume on yesterday's ruts.
 *
 * Format version 2 (little-endian): "AVSPTRN1", version, grid (origin, spacing, size),
 * palette (count, soil names), transport flag, flow volumes, base heights, soil map (a kind
 * byte: 0 = palette entry 0 everywhere, 1 = one index byte per grid point follows), stateful
 * points, objects, then an FNV-1a 64-bit checksum of everything before it. Version 1 (one
 * soil name, no soil map) is still read.
 */
#include <cstdint>
#include <stdexcept>
#include <string>

#include "avsp_terrain/deformable_terrain.hpp"
#include "avsp_terrain/dem_io.hpp"
#include "avsp_terrain/terrain_objects.hpp"

namespace avsp
{
namespace terrain
{
/// A terrain file that cannot be written or read; what() names the file and the reason.
class TerrainFileError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// @throw TerrainFileError naming the file when it cannot be written completely
void saveTerrain(const std::string& path, const DeformableTerrain& terrain, const ObjectSet& objects);

/// A terrain and its objects as loaded.
struct LoadedTerrain
{
  DeformableTerrain terrain;
  ObjectSet objects;
};

/// Largest terrain file read for a budget of `max_points` grid points: 25 bytes a point (height,
/// soil index, deformation state) + 64 MiB (palette, objects).
std::uint64_t maxTerrainFileBytes(std::uint64_t max_points);

/**
 * @brief Loads a file written by saveTerrain(); the palette's soils are looked up by their
 *        saved names (a soil changed with DeformableTerrain::setSoil() comes back as the
 *        library has it). Only a regular file of at most maxTerrainFileBytes(max_points) is
 *        read, and a grid of more than `max_points` points is refused before it is allocated.
 * @throw TerrainFileError naming the file: missing, not a regular file, too big, not a terrain
 *        file, other version, truncated, checksum mismatch, inconsistent sizes, more points than
 *        max_points, a soil not in `soils`, a soil index outside the palette
 */
LoadedTerrain loadTerrain(const std::string& path, const SoilLibrary& soils,
                          std::uint64_t max_points = kDefaultMaxPoints);

}  // namespace terrain
}  // namespace avsp
