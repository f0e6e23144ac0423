#include "avsp_terrain/elevation_grid.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>

namespace avsp
{
namespace terrain
{
ElevationGrid::ElevationGrid(double origin_x, double origin_y, double dx, double dy, std::size_t columns,
                             std::size_t rows, std::vector<float> heights)
  : origin_x_(origin_x),
    origin_y_(origin_y),
    dx_(dx),
    dy_(dy),
    columns_(columns),
    rows_(rows),
    max_fx_(static_cast<double>(columns) - 1.0),
    max_fy_(static_cast<double>(rows) - 1.0),
    last_cell_i_(static_cast<std::int64_t>(columns) - 2),
    last_cell_j_(static_cast<std::int64_t>(rows) - 2),
    heights_(std::move(heights))
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

bool ElevationGrid::patchAt(double x, double y, Patch& p) const
{
  std::size_t k = 0;
  if (!locateFlat(x, y, k, p.u, p.v))
    return false;
  p.h00 = heights_[k];
  p.h10 = heights_[k + 1];
  p.h01 = heights_[k + columns_];
  p.h11 = heights_[k + columns_ + 1];
  return true;
}

std::optional<CellIndex> ElevationGrid::cellAt(double x, double y) const
{
  CellIndex cell{};
  double u = 0.0, v = 0.0;
  if (!locate(x, y, cell.i, cell.j, u, v))
    return std::nullopt;
  return cell;
}

double ElevationGrid::pointHeight(std::size_t i, std::size_t j) const
{
  if (i >= columns_ || j >= rows_)
    throw std::out_of_range("ElevationGrid::pointHeight: point outside the grid");
  return heights_[j * columns_ + i];
}

std::size_t ElevationGrid::heights(const double* xy, double* out, std::size_t n) const
{
  // Points per block: enough cells in flight to hide a cache miss behind the others (a core
  // tracks a few dozen outstanding lines), few enough that the block stays in registers/L1.
  constexpr std::size_t kBlock = 16;
  constexpr std::size_t kOutside = SIZE_MAX;
  std::size_t cell[kBlock];
  double u[kBlock], v[kBlock];
  std::size_t inside = 0;
  for (std::size_t start = 0; start < n; start += kBlock)
  {
    const std::size_t m = std::min(kBlock, n - start);
    const double* p = xy + 2 * start;
    // Pass 1: locate every point and ask for both rows of its cell.
    for (std::size_t b = 0; b < m; ++b)
    {
      if (locateFlat(p[2 * b], p[2 * b + 1], cell[b], u[b], v[b]))
      {
        __builtin_prefetch(heights_.data() + cell[b]);
        __builtin_prefetch(heights_.data() + cell[b] + columns_);
      }
      else
        cell[b] = kOutside;
    }
    // Pass 2: the loads now mostly hit cache.
    for (std::size_t b = 0; b < m; ++b)
    {
      if (cell[b] == kOutside)
        out[start + b] = std::numeric_limits<double>::quiet_NaN();
      else
      {
        out[start + b] = blendAt(cell[b], u[b], v[b]);
        ++inside;
      }
    }
  }
  return inside;
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
