#include "avsp_terrain/height_patch.hpp"

#include <cmath>
#include <set>
#include <string>
#include <utility>

namespace avsp
{
namespace terrain
{
namespace
{
constexpr std::size_t kTile = DeformableTerrain::kTileSize;
}  // namespace

HeightPatch extractPatch(const DeformableTerrain& terrain, const PointRange& range)
{
  const ElevationGrid& grid = terrain.base();
  if (range.i1 < range.i0 || range.j1 < range.j0)
    throw PatchError("extractPatch: empty point range");
  if (range.i1 >= grid.columns() || range.j1 >= grid.rows())
    throw PatchError("extractPatch: point range [" + std::to_string(range.i0) + ", " + std::to_string(range.i1) +
                     "] x [" + std::to_string(range.j0) + ", " + std::to_string(range.j1) + "] leaves the " +
                     std::to_string(grid.columns()) + " x " + std::to_string(grid.rows()) + " grid");
  HeightPatch patch;
  patch.origin_x = grid.originX() + range.i0 * grid.dx();
  patch.origin_y = grid.originY() + range.j0 * grid.dy();
  patch.resolution = grid.dx();
  patch.width = range.i1 - range.i0 + 1;
  patch.height = range.j1 - range.j0 + 1;
  patch.heights.reserve(patch.width * patch.height);
  for (std::size_t j = range.j0; j <= range.j1; ++j)
    for (std::size_t i = range.i0; i <= range.i1; ++i)
      patch.heights.push_back(static_cast<float>(terrain.pointHeight(i, j)));
  return patch;
}

std::vector<HeightPatch> deformedPatches(const DeformableTerrain& terrain)
{
  // Allocated tiles, ordered by (tile row, tile column) so runs along a row are adjacent.
  std::set<std::pair<std::size_t, std::size_t>> tiles;
  for (const auto& [i, j] : terrain.statefulPoints())
    tiles.emplace(j / kTile, i / kTile);
  const std::size_t columns = terrain.base().columns(), rows = terrain.base().rows();
  std::vector<HeightPatch> patches;
  for (auto it = tiles.begin(); it != tiles.end();)
  {
    const std::size_t row = it->first, first = it->second;
    std::size_t last = first;
    ++it;
    while (it != tiles.end() && it->first == row && it->second == last + 1)
      last = (it++)->second;
    PointRange range;
    range.i0 = first * kTile;
    range.j0 = row * kTile;
    range.i1 = std::min(columns - 1, (last + 1) * kTile - 1);
    range.j1 = std::min(rows - 1, (row + 1) * kTile - 1);
    patches.push_back(extractPatch(terrain, range));
  }
  return patches;
}

std::optional<PointRange> applyPatch(DeformableTerrain& terrain, const HeightPatch& patch)
{
  const ElevationGrid& grid = terrain.base();
  if (!std::isfinite(patch.resolution) || patch.resolution <= 0.0)
    throw PatchError("TerrainPatch: resolution " + std::to_string(patch.resolution) + " m is not a positive number");
  if (std::abs(grid.dx() - grid.dy()) > 1e-9 * grid.dx())
    throw PatchError("TerrainPatch: the terrain grid is not square (dx " + std::to_string(grid.dx()) + " m, dy " +
                     std::to_string(grid.dy()) + " m); patches need square cells");
  if (std::abs(patch.resolution - grid.dx()) > 1e-9 * grid.dx())
    throw PatchError("TerrainPatch: resolution " + std::to_string(patch.resolution) +
                     " m differs from the terrain grid spacing " + std::to_string(grid.dx()) + " m");
  if (patch.width == 0 || patch.height == 0 || patch.heights.size() / patch.width != patch.height ||
      patch.heights.size() % patch.width != 0)
    throw PatchError("TerrainPatch: width " + std::to_string(patch.width) + " x height " +
                     std::to_string(patch.height) + " does not match " + std::to_string(patch.heights.size()) +
                     " heights");
  if (!std::isfinite(patch.origin_x) || !std::isfinite(patch.origin_y))
    throw PatchError("TerrainPatch: origin is not finite");
  const double fi = (patch.origin_x - grid.originX()) / grid.dx();
  const double fj = (patch.origin_y - grid.originY()) / grid.dy();
  const double ri = std::round(fi), rj = std::round(fj);
  if (std::abs(fi - ri) > 1e-6 || std::abs(fj - rj) > 1e-6)
    throw PatchError("TerrainPatch: origin (" + std::to_string(patch.origin_x) + ", " + std::to_string(patch.origin_y) +
                     ") is not on a grid point of the terrain");
  for (float h : patch.heights)
    if (!std::isfinite(h))
      throw PatchError("TerrainPatch: heights contain a non-finite value");

  // A patch wholly off the grid changes nothing; ruling it out here, in doubles, also keeps the
  // integer arithmetic below in range (an origin of 1e300 m rounds to no representable long).
  if (ri >= static_cast<double>(grid.columns()) || ri + static_cast<double>(patch.width) <= 0.0 ||
      rj >= static_cast<double>(grid.rows()) || rj + static_cast<double>(patch.height) <= 0.0)
    return std::nullopt;
  // Patch column c sits on grid column ri + c; keep the columns and rows inside the grid.
  const long i_first = std::max(0L, -static_cast<long>(ri));
  const long j_first = std::max(0L, -static_cast<long>(rj));
  const long i_end =
      std::min(static_cast<long>(patch.width), static_cast<long>(grid.columns()) - static_cast<long>(ri));
  const long j_end = std::min(static_cast<long>(patch.height), static_cast<long>(grid.rows()) - static_cast<long>(rj));
  if (i_first >= i_end || j_first >= j_end)
    return std::nullopt;
  for (long r = j_first; r < j_end; ++r)
    for (long c = i_first; c < i_end; ++c)
    {
      const std::size_t i = static_cast<std::size_t>(ri + c), j = static_cast<std::size_t>(rj + r);
      const double target = patch.heights[static_cast<std::size_t>(r) * patch.width + static_cast<std::size_t>(c)];
      const double current = terrain.pointHeight(i, j);
      if (current == target)
        continue;
      PointDeformation d = terrain.deformation(i, j);
      d.displaced = static_cast<float>(grid.pointHeight(i, j) - d.plastic - target);
      terrain.setDeformation(i, j, d);
    }
  PointRange range;
  range.i0 = static_cast<std::size_t>(ri + i_first);
  range.j0 = static_cast<std::size_t>(rj + j_first);
  range.i1 = static_cast<std::size_t>(ri + i_end - 1);
  range.j1 = static_cast<std::size_t>(rj + j_end - 1);
  return range;
}

}  // namespace terrain
}  // namespace avsp
