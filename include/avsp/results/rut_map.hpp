#pragma once
/**
 * @file rut_map.hpp
 * @brief Rut depths over a run (no ROS): the deformed heights that /terrain/ruts patches
 *        carry, against the undeformed terrain. Depth = base height - deformed height (m,
 *        + = sunk; berms of displaced soil are negative). The latest patch covering a grid
 *        point gives its height (a patch carries current heights, changed or not).
 */
#include <cstddef>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

#include <avsp_terrain/elevation_grid.hpp>
#include <avsp_terrain/height_patch.hpp>

namespace avsp
{
namespace results
{
/// A regular grid of values (row-major, index row * width + col, rows along map y).
struct Grid
{
  double origin_x = 0.0;      ///< m, map x of the centre of cell (0, 0)
  double origin_y = 0.0;      ///< m, map y of the centre of cell (0, 0)
  double resolution = 0.0;    ///< m, cell size (square)
  std::size_t width = 0;      ///< cells along map x
  std::size_t height = 0;     ///< cells along map y
  std::vector<float> values;  ///< NaN = no data
};

/**
 * @brief Heights of `base` sampled on a grid covering [x0, x1] x [y0, y1] (m, map), at the
 *        base's spacing or coarser so that neither side has more than `max_cells` cells
 *        (bilinear, NaN off the terrain).
 * @throw std::invalid_argument if the box is empty or not finite, or max_cells < 2
 */
Grid sampleHeights(const terrain::ElevationGrid& base, double x0, double y0, double x1, double y1,
                   std::size_t max_cells);

class RutMap
{
public:
  /// `base`: the undeformed terrain, kept by reference (it must outlive the map).
  explicit RutMap(const terrain::ElevationGrid& base);

  /**
   * @brief Records a patch's heights; points outside the grid are ignored.
   * @throw terrain::PatchError naming the field: resolution not the grid's spacing (to 1e-9
   *        relative; the grid must be square), origin not on a grid point (to 1e-6 of a
   *        cell), width * height not the number of heights, a non-finite origin or height
   */
  void apply(const terrain::HeightPatch& patch);

  /// m, depth at grid point (i, j); nullopt if no patch covered it.
  std::optional<double> depth(std::size_t i, std::size_t j) const;
  /// Grid points covered by a patch so far.
  std::size_t pointCount() const { return count_; }
  /// m, the deepest point (0 if none is below its base height).
  double maxDepth() const;
  /// m^2, area of the grid points deeper than `d` (m), one cell each.
  double areaDeeperThan(double d) const;

  /**
   * @brief The depths around the points deeper than `min_depth` (m), widened by `margin` (m)
   *        on every side, each output cell the deepest of a block of f x f grid points with f
   *        the smallest factor giving at most `max_cells` cells per side (a rut narrower than
   *        a cell stays visible). NaN where no patch covered any point of the block.
   * @return nullopt when no point is deeper than min_depth
   */
  std::optional<Grid> depthGrid(double min_depth, double margin, std::size_t max_cells) const;

private:
  static constexpr std::size_t kTile = 64;  ///< grid points per tile side
  const std::vector<float>* tile(std::size_t ti, std::size_t tj) const;

  const terrain::ElevationGrid& base_;
  std::size_t tiles_x_;
  /// Deformed heights per tile (kTile x kTile, NaN = never patched), keyed tj * tiles_x_ + ti.
  std::unordered_map<std::uint64_t, std::vector<float>> tiles_;
  std::size_t count_ = 0;
};

}  // namespace results
}  // namespace avsp
