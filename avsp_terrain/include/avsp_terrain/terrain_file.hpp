#pragma once
/**
 * @file terrain_file.hpp
 * @brief Saves a deformed terrain (base heights, per-point deformation, flow accounting,
 *        objects with their toppled state) to one binary file and loads it back bit-exactly,
 *        so a run can resume on yesterday's ruts.
 *
 * Format (little-endian): "AVSPTRN1", grid (origin, spacing, size), soil name, transport
 * flag, flow volumes, base heights, stateful points, objects, then an FNV-1a 64-bit checksum
 * of everything before it.
 */
#include <stdexcept>
#include <string>

#include "avsp_terrain/deformable_terrain.hpp"
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

/**
 * @brief Loads a file written by saveTerrain(); the soil is looked up by its saved name.
 * @throw TerrainFileError naming the file: missing, not a terrain file, other version,
 *        truncated, checksum mismatch, inconsistent sizes, or a soil not in `soils`
 */
LoadedTerrain loadTerrain(const std::string& path, const SoilLibrary& soils);

}  // namespace terrain
}  // namespace avsp
