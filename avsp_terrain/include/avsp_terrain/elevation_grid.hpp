#pragma once
/**
 * @file elevation_grid.hpp
 * @brief Cartesian elevation grid (docs/MODELS.md section 1, T1): grid points on a regular
 *        lattice in the map frame, O(1) cell lookup, bilinear height and normal queries.
 */
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace avsp
{
namespace terrain
{
/// Thrown when a grid is constructed from inconsistent dimensions or values.
class GridError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Index of a cell: the cell spans grid points (i, j) .. (i + 1, j + 1).
struct CellIndex
{
  std::size_t i;  ///< column, along map x
  std::size_t j;  ///< row, along map y
};

/**
 * @brief Heights on a regular lattice of grid points.
 *
 * Grid point (i, j) sits at map position (origin_x + i * dx, origin_y + j * dy); there are
 * `columns` points along x and `rows` along y, so columns - 1 by rows - 1 cells. Heights
 * are metres in map z. Points outside the grid have no height (std::nullopt), never a
 * silent default.
 */
class ElevationGrid
{
public:
  /**
   * @param origin_x map x of grid point (0, 0), m
   * @param origin_y map y of grid point (0, 0), m
   * @param dx spacing along x, m, > 0
   * @param dy spacing along y, m, > 0
   * @param columns grid points along x, >= 2
   * @param rows grid points along y, >= 2
   * @param heights row-major heights (index = j * columns + i), m, all finite
   * @throw GridError naming the argument that is inconsistent
   */
  ElevationGrid(double origin_x, double origin_y, double dx, double dy, std::size_t columns, std::size_t rows,
                std::vector<float> heights);

  /// Cell containing map point (x, y) by T1, or nullopt outside the grid.
  std::optional<CellIndex> cellAt(double x, double y) const;

  /// Bilinear height of the cell's four corner points at (x, y), m; nullopt outside.
  std::optional<double> height(double x, double y) const
  {
    double h = 0.0;
    if (!heightAt(x, y, h))
      return std::nullopt;
    return h;
  }

  /**
   * @brief Fast path of height() for inner loops (wheel contact, ray marching): the same
   *        bilinear height, bit for bit, without the std::optional and inlined.
   * @param[out] h bilinear height at (x, y), m; left unchanged when the point is outside
   * @return false outside the grid (or for NaN coordinates)
   */
  bool heightAt(double x, double y, double& h) const
  {
    std::size_t k = 0;
    double u = 0.0, v = 0.0;
    if (!locateFlat(x, y, k, u, v))
      return false;
    h = blendAt(k, u, v);
    return true;
  }

  /**
   * @brief Batch of height queries: out[k] = height at (xy[2k], xy[2k+1]), m, or NaN where
   *        that point is outside the grid.
   *
   * Same values as heightAt(), bit for bit. It locates a block of points first and
   * prefetches their cells before blending, so the cache misses of scattered queries
   * overlap instead of queueing one after another: use it for many unrelated points (a
   * lidar scan, a whole vehicle's contact points). NaN marks "outside" because a batch has
   * no per-point optional; the count tells whether any point was outside.
   * @param xy n interleaved (x, y) pairs, map m
   * @param out n heights, m
   * @return number of points inside the grid (n when none is NaN in @p out)
   */
  std::size_t heights(const double* xy, double* out, std::size_t n) const;

  /// Unit upward normal of the bilinear surface at (x, y); nullopt outside.
  std::optional<Eigen::Vector3d> normal(double x, double y) const;

  /// Bilinear blend of a cell's corner values (h_ij at corner (i, j)) at (u, v) in [0, 1].
  static double bilinear(double h00, double h10, double h01, double h11, double u, double v)
  {
    return (1 - u) * (1 - v) * h00 + u * (1 - v) * h10 + (1 - u) * v * h01 + u * v * h11;
  }

  /// Height of grid point (i, j), m. @throw std::out_of_range outside the grid.
  double pointHeight(std::size_t i, std::size_t j) const;

  /**
   * @brief Fast path of cellAt() for inner loops: cell (i, j) under (x, y) and the fractional
   *        position (u, v) in [0, 1] inside it, exactly as height() locates it; inlined, no
   *        std::optional. Outputs are left unchanged when it returns false (outside, or NaN).
   */
  bool cellOf(double x, double y, std::size_t& i, std::size_t& j, double& u, double& v) const
  {
    return locate(x, y, i, j, u, v);
  }

  /// Heights of all grid points, m, row-major (index j * columns + i): for writing the grid
  /// out without copying it point by point.
  const std::vector<float>& pointHeights() const { return heights_; }

  double originX() const { return origin_x_; }
  double originY() const { return origin_y_; }
  double dx() const { return dx_; }
  double dy() const { return dy_; }
  std::size_t columns() const { return columns_; }
  std::size_t rows() const { return rows_; }

private:
  /// A cell's corner heights (h_ij at grid point (i, j) of the cell) and (u, v) in [0, 1].
  struct Patch
  {
    double h00, h10, h01, h11, u, v;
  };

  /**
   * T1: cell (i, j) under (x, y) and the fractional position (u, v) in [0, 1] inside it.
   * Inline and branch-light: it is the whole cost of a query whose cell is in cache.
   */
  bool locate(double x, double y, std::size_t& i, std::size_t& j, double& u, double& v) const
  {
    // Division, not a stored reciprocal: x * (1 / dx) can differ from x / dx in the last
    // bit, which moves points on a cell edge into the neighbouring cell. Its throughput
    // cost is a few cycles, small next to the cache miss of a scattered query.
    const double fx = (x - origin_x_) / dx_;
    const double fy = (y - origin_y_) / dy_;
    // One range check for both bounds; NaN fails every comparison, so it is rejected too.
    if (!(fx >= 0.0 && fy >= 0.0 && fx <= max_fx_ && fy <= max_fy_))
      return false;
    // floor of a non-negative value is its truncation, and fx <= columns - 1 fits int64 (one
    // cvttsd2si, no libm call); the far edge belongs to the last cell so that it has a height.
    const std::int64_t ci = std::min(static_cast<std::int64_t>(fx), last_cell_i_);
    const std::int64_t cj = std::min(static_cast<std::int64_t>(fy), last_cell_j_);
    u = fx - static_cast<double>(ci);
    v = fy - static_cast<double>(cj);
    i = static_cast<std::size_t>(ci);
    j = static_cast<std::size_t>(cj);
    return true;
  }

  /// As locate(), with the cell as the flat index k = j * columns + i of its south-west point.
  bool locateFlat(double x, double y, std::size_t& k, double& u, double& v) const
  {
    std::size_t i = 0, j = 0;
    if (!locate(x, y, i, j, u, v))
      return false;
    k = j * columns_ + i;
    return true;
  }

  /// Bilinear blend of the cell whose south-west point has flat index k.
  double blendAt(std::size_t k, double u, double v) const
  {
    const float* south = heights_.data() + k;
    const float* north = south + columns_;
    return bilinear(south[0], south[1], north[0], north[1], u, v);
  }

  /// The patch under (x, y); false outside the grid.
  bool patchAt(double x, double y, Patch& p) const;

  double origin_x_;
  double origin_y_;
  double dx_;
  double dy_;
  std::size_t columns_;
  std::size_t rows_;
  double max_fx_;             ///< columns - 1: largest (x - origin_x) / dx inside the grid
  double max_fy_;             ///< rows - 1
  std::int64_t last_cell_i_;  ///< columns - 2: index of the last cell along x
  std::int64_t last_cell_j_;  ///< rows - 2
  std::vector<float> heights_;
};

}  // namespace terrain
}  // namespace avsp
