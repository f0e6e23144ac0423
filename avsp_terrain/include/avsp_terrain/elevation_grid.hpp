#pragma once
/**
 * @file elevation_grid.hpp
 * @brief Cartesian elevation grid (MODELS.md section 1, T1): grid points on a regular
 *        lattice in the map frame, O(1) cell lookup, bilinear height and normal queries.
 */
#include <cstddef>
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
  std::optional<double> height(double x, double y) const;

  /// Unit upward normal of the bilinear surface at (x, y); nullopt outside.
  std::optional<Eigen::Vector3d> normal(double x, double y) const;

  /// Bilinear blend of a cell's corner values (h_ij at corner (i, j)) at (u, v) in [0, 1].
  static double bilinear(double h00, double h10, double h01, double h11, double u, double v)
  {
    return (1 - u) * (1 - v) * h00 + u * (1 - v) * h10 + (1 - u) * v * h01 + u * v * h11;
  }

  /// Height of grid point (i, j), m. @throw std::out_of_range outside the grid.
  double pointHeight(std::size_t i, std::size_t j) const;

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

  /// Cell and the fractional position (u, v) in [0, 1] inside it.
  bool locate(double x, double y, CellIndex& cell, double& u, double& v) const;
  /// The patch under (x, y); false outside the grid.
  bool patchAt(double x, double y, Patch& p) const;

  double origin_x_;
  double origin_y_;
  double dx_;
  double dy_;
  std::size_t columns_;
  std::size_t rows_;
  std::vector<float> heights_;
};

}  // namespace terrain
}  // namespace avsp
