#pragma once
/**
 * @file height_patch.hpp
 * @brief A rectangle of deformed grid-point heights: what one process sends so that every
 *        other process holding the same terrain sees the same ruts (the ROS-free half of
 *        avsp_msgs/TerrainPatch on /terrain/ruts).
 */
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <vector>

#include "avsp_terrain/deformable_terrain.hpp"

namespace avsp
{
namespace terrain
{
/// A patch that cannot be applied to a terrain; what() names the field and the reason.
class PatchError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Heights of a rectangle of grid points (index row * width + col, rows along map y).
struct HeightPatch
{
  double origin_x = 0.0;       ///< m, map x of the patch's point (0, 0)
  double origin_y = 0.0;       ///< m, map y of the patch's point (0, 0)
  double resolution = 0.0;     ///< m, spacing of the points (square cells)
  std::size_t width = 0;       ///< points along map x
  std::size_t height = 0;      ///< points along map y
  std::vector<float> heights;  ///< m, map z
};

/// Inclusive range of grid points [i0, i1] x [j0, j1].
struct PointRange
{
  std::size_t i0 = 0, j0 = 0, i1 = 0, j1 = 0;
};

/**
 * @brief The current deformed heights of points [i0, i1] x [j0, j1] of `terrain`.
 * @throw PatchError when the range is empty or leaves the grid
 */
HeightPatch extractPatch(const DeformableTerrain& terrain, const PointRange& range);

/**
 * @brief Patches that together cover every allocated deformation tile of `terrain`, one per
 *        run of adjacent tiles in a tile row: what a node publishes so late joiners see
 *        ruts loaded from a saved terrain.
 */
std::vector<HeightPatch> deformedPatches(const DeformableTerrain& terrain);

/**
 * @brief Sets the deformed height of every patch point inside the grid to the patch's
 *        height, keeping each point's plastic sinkage and stress history and putting the
 *        difference into its displaced soil (the change arrived from another process, so
 *        this process books it as soil moved, not compacted).
 *
 * Points of the patch outside the grid are ignored (a patch from a larger map).
 * @return the grid points the patch covers, clipped to the grid; nullopt when it covers none
 * @throw PatchError naming the field: resolution not equal to the grid spacing (to 1e-9
 *        relative) or grid not square, origin not on a grid point (to 1e-6 of a cell),
 *        width * height not equal to the number of heights, a non-finite height or origin
 */
std::optional<PointRange> applyPatch(DeformableTerrain& terrain, const HeightPatch& patch);

}  // namespace terrain
}  // namespace avsp
