#include "avsp_terrain/elevation_grid.hpp"

#include <cmath>
#include <sstream>

namespace avsp
{
namespace terrain
{
ElevationGrid::ElevationGrid(double origin_x, double origin_y, double dx, double dy, std::size_t columns,
                             std::size_t rows, std::vector<float> heights)
  : origin_x_(origin_x)
  , origin_y_(origin_y)
  , dx_(dx)
  , dy_(dy)
  , columns_(columns)
  , rows_(rows)
  , heights_(std::move(heights))
{
  std::ostringstream why;
  if (!std::isfinite(origin_x) || !std::isfinite(origin_y))
    why << "origin must be finite";
  else if (!(dx > 0.0) || !(dy > 0.0) || !std::isfinite(dx) || !std::isfinite(dy))
    why << "cell size (dx=" << dx << ", dy=" << dy << ") must be finite and > 0";
  else if (columns < 2 || rows < 2)
    why << "grid needs at least 2x2 points (got " << columns << "x" << rows << ")";
  else if (heights_.size() != columns * rows)
    why << "heights has " << heights_.size() << " values, expected columns*rows = " << columns * rows;
  else
  {
    for (std::size_t k = 0; k < heights_.size(); ++k)
    {
      if (!std::isfinite(heights_[k]))
      {
        why << "height at point (" << k % columns << ", " << k / columns << ") is not finite";
        break;
      }
    }
  }
  if (why.tellp() > 0)
    throw GridError("ElevationGrid: " + why.str());
}

bool ElevationGrid::locate(double x, double y, CellIndex& cell, double& u, double& v) const
{
  const double fx = (x - origin_x_) / dx_;
  const double fy = (y - origin_y_) / dy_;
  const double max_i = static_cast<double>(columns_ - 1);
  const double max_j = static_cast<double>(rows_ - 1);
  // NaN fails every comparison, so it is rejected here too.
  if (!(fx >= 0.0 && fy >= 0.0 && fx <= max_i && fy <= max_j))
    return false;
  // T1; the far edge belongs to the last cell so that it has a height.
  const double ci = std::min(std::floor(fx), max_i - 1.0);
  const double cj = std::min(std::floor(fy), max_j - 1.0);
  cell = CellIndex{ static_cast<std::size_t>(ci), static_cast<std::size_t>(cj) };
  u = fx - ci;
  v = fy - cj;
  return true;
}

bool ElevationGrid::patchAt(double x, double y, Patch& p) const
{
  CellIndex c{};
  if (!locate(x, y, c, p.u, p.v))
    return false;
  p.h00 = heights_[c.j * columns_ + c.i];
  p.h10 = heights_[c.j * columns_ + c.i + 1];
  p.h01 = heights_[(c.j + 1) * columns_ + c.i];
  p.h11 = heights_[(c.j + 1) * columns_ + c.i + 1];
  return true;
}

std::optional<CellIndex> ElevationGrid::cellAt(double x, double y) const
{
  CellIndex cell{};
  double u = 0.0, v = 0.0;
  if (!locate(x, y, cell, u, v))
    return std::nullopt;
  return cell;
}

double ElevationGrid::pointHeight(std::size_t i, std::size_t j) const
{
  if (i >= columns_ || j >= rows_)
    throw std::out_of_range("ElevationGrid::pointHeight: point outside the grid");
  return heights_[j * columns_ + i];
}

std::optional<double> ElevationGrid::height(double x, double y) const
{
  Patch p{};
  if (!patchAt(x, y, p))
    return std::nullopt;
  return bilinear(p.h00, p.h10, p.h01, p.h11, p.u, p.v);
}

std::optional<Eigen::Vector3d> ElevationGrid::normal(double x, double y) const
{
  Patch p{};
  if (!patchAt(x, y, p))
    return std::nullopt;
  // Partial derivatives of the bilinear patch, per metre.
  const double dhdx = ((1 - p.v) * (p.h10 - p.h00) + p.v * (p.h11 - p.h01)) / dx_;
  const double dhdy = ((1 - p.u) * (p.h01 - p.h00) + p.u * (p.h11 - p.h10)) / dy_;
  return Eigen::Vector3d(-dhdx, -dhdy, 1.0).normalized();
}

}  // namespace terrain
}  // namespace avsp
