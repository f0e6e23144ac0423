#include "avsp_sensors/height_field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "avsp_terrain/deformable_terrain.hpp"
#include "avsp_terrain/elevation_grid.hpp"
#include "avsp_terrain/height_patch.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Roots closer than this (m along the ray) outside a cell's interval still count for it: a
/// crossing exactly on a cell edge must not be lost to rounding in both neighbouring cells.
constexpr double kRootTolerance = 1e-9;

/// A block is skipped only when the ray clears its maximum by more than this (m), so that a
/// ray touching a block's highest point is not skipped on a rounding error; it costs at most
/// an exact cell test, never a wrong miss.
constexpr double kSkipMargin = 1e-7;

[[noreturn]] void bad(const std::string& what)
{
  throw std::invalid_argument("HeightField: " + what);
}
}  // namespace

HeightField::HeightField(double origin_x, double origin_y, double dx, double dy, std::size_t columns,
                         std::size_t rows, std::vector<float> heights)
  : origin_x_(origin_x), origin_y_(origin_y), dx_(dx), dy_(dy), columns_(columns), rows_(rows),
    heights_(std::move(heights))
{
  if (!std::isfinite(origin_x) || !std::isfinite(origin_y))
    bad("origin_x/origin_y must be finite");
  if (!(dx > 0.0) || !std::isfinite(dx))
    bad("dx must be finite and > 0, got " + std::to_string(dx));
  if (!(dy > 0.0) || !std::isfinite(dy))
    bad("dy must be finite and > 0, got " + std::to_string(dy));
  if (columns < 2)
    bad("columns must be >= 2, got " + std::to_string(columns));
  if (rows < 2)
    bad("rows must be >= 2, got " + std::to_string(rows));
  if (heights_.size() != columns * rows)
    bad("heights has " + std::to_string(heights_.size()) + " values, expected columns * rows = " +
        std::to_string(columns * rows));
  for (std::size_t k = 0; k < heights_.size(); ++k)
    if (!std::isfinite(heights_[k]))
      bad("heights[" + std::to_string(k) + "] is not finite");
  cells_x_ = columns - 1;
  cells_y_ = rows - 1;
  buildMips();
}

HeightField HeightField::fromGrid(const terrain::ElevationGrid& grid)
{
  return HeightField(grid.originX(), grid.originY(), grid.dx(), grid.dy(), grid.columns(), grid.rows(),
                     grid.pointHeights());
}

HeightField HeightField::fromTerrain(const terrain::DeformableTerrain& terrain)
{
  const terrain::ElevationGrid& g = terrain.base();
  std::vector<float> h(g.pointHeights());
  // Only deformed tiles differ from the base: copy those points instead of asking every point.
  for (const auto& p : terrain.statefulPoints())
    h[p.second * g.columns() + p.first] = static_cast<float>(terrain.pointHeight(p.first, p.second));
  return HeightField(g.originX(), g.originY(), g.dx(), g.dy(), g.columns(), g.rows(), std::move(h));
}

std::size_t HeightField::mipColumns(std::size_t level) const
{
  if (level == 0)
    return cells_x_;
  if (level > mips_.size())
    throw std::out_of_range("HeightField: mip level " + std::to_string(level) + " of " + std::to_string(mips_.size()));
  return mips_[level - 1].nx;
}

std::size_t HeightField::mipRows(std::size_t level) const
{
  if (level == 0)
    return cells_y_;
  if (level > mips_.size())
    throw std::out_of_range("HeightField: mip level " + std::to_string(level) + " of " + std::to_string(mips_.size()));
  return mips_[level - 1].ny;
}

float HeightField::mipMax(std::size_t level, std::size_t bi, std::size_t bj) const
{
  if (bi >= mipColumns(level) || bj >= mipRows(level))
    throw std::out_of_range("HeightField: mip block (" + std::to_string(bi) + ", " + std::to_string(bj) +
                            ") outside level " + std::to_string(level));
  if (level == 0)
  {
    const float* s = heights_.data() + bj * columns_ + bi;
    return std::max(std::max(s[0], s[1]), std::max(s[columns_], s[columns_ + 1]));
  }
  const Level& l = mips_[level - 1];
  return l.max[bj * l.nx + bi];
}

std::size_t HeightField::bytes() const
{
  std::size_t b = heights_.size() * sizeof(float);
  for (const Level& l : mips_)
    b += l.max.size() * sizeof(float);
  return b;
}

double HeightField::pointHeight(std::size_t i, std::size_t j) const
{
  if (i >= columns_ || j >= rows_)
    throw std::out_of_range("HeightField: point (" + std::to_string(i) + ", " + std::to_string(j) +
                            ") outside the grid");
  return heights_[j * columns_ + i];
}

bool HeightField::heightAt(double x, double y, double& h) const
{
  const double fx = (x - origin_x_) / dx_;
  const double fy = (y - origin_y_) / dy_;
  if (!(fx >= 0.0 && fy >= 0.0 && fx <= static_cast<double>(cells_x_) && fy <= static_cast<double>(cells_y_)))
    return false;
  const std::size_t i = std::min(static_cast<std::size_t>(fx), cells_x_ - 1);
  const std::size_t j = std::min(static_cast<std::size_t>(fy), cells_y_ - 1);
  const double u = fx - static_cast<double>(i), v = fy - static_cast<double>(j);
  const float* s = heights_.data() + j * columns_ + i;
  const float* n = s + columns_;
  h = (1 - u) * (1 - v) * s[0] + u * (1 - v) * s[1] + (1 - u) * v * n[0] + u * v * n[1];
  return true;
}

float HeightField::blockMaxFromHeights(std::size_t bi, std::size_t bj) const
{
  // Block (bi, bj) of level 1 covers cells 2bi..2bi+1, i.e. grid points 2bi..2bi+2 (clamped).
  const std::size_t i0 = 2 * bi, j0 = 2 * bj;
  const std::size_t i1 = std::min(i0 + 2, columns_ - 1), j1 = std::min(j0 + 2, rows_ - 1);
  float m = -std::numeric_limits<float>::infinity();
  for (std::size_t j = j0; j <= j1; ++j)
  {
    const float* row = heights_.data() + j * columns_;
    for (std::size_t i = i0; i <= i1; ++i)
      m = std::max(m, row[i]);
  }
  return m;
}

void HeightField::buildMips()
{
  mips_.clear();
  std::size_t nx = cells_x_, ny = cells_y_;
  // At least one stored level, then halve until one block covers the grid.
  do
  {
    nx = (nx + 1) / 2;
    ny = (ny + 1) / 2;
    Level l;
    l.nx = nx;
    l.ny = ny;
    l.max.assign(nx * ny, 0.f);
    mips_.push_back(std::move(l));
  } while (nx > 1 || ny > 1);
  refreshMips(0, 0, cells_x_ - 1, cells_y_ - 1);
}

void HeightField::refreshMips(std::size_t ci0, std::size_t cj0, std::size_t ci1, std::size_t cj1)
{
  std::size_t bi0 = ci0 / 2, bj0 = cj0 / 2, bi1 = ci1 / 2, bj1 = cj1 / 2;
  Level& first = mips_[0];
  for (std::size_t bj = bj0; bj <= bj1; ++bj)
    for (std::size_t bi = bi0; bi <= bi1; ++bi)
      first.max[bj * first.nx + bi] = blockMaxFromHeights(bi, bj);
  for (std::size_t L = 1; L < mips_.size(); ++L)
  {
    const Level& child = mips_[L - 1];
    Level& parent = mips_[L];
    bi0 /= 2;
    bj0 /= 2;
    bi1 /= 2;
    bj1 /= 2;
    for (std::size_t bj = bj0; bj <= bj1; ++bj)
      for (std::size_t bi = bi0; bi <= bi1; ++bi)
      {
        float m = -std::numeric_limits<float>::infinity();
        for (std::size_t cj = 2 * bj; cj <= std::min(2 * bj + 1, child.ny - 1); ++cj)
          for (std::size_t ci = 2 * bi; ci <= std::min(2 * bi + 1, child.nx - 1); ++ci)
            m = std::max(m, child.max[cj * child.nx + ci]);
        parent.max[bj * parent.nx + bi] = m;
      }
  }
  // The lowest height bounds rays from below (see intersect()); it only needs to be a lower
  // bound, so a patch can lower it but never has to raise it.
  float lo = std::numeric_limits<float>::infinity();
  if (ci0 == 0 && cj0 == 0 && ci1 + 1 == cells_x_ && cj1 + 1 == cells_y_)
  {
    for (float h : heights_)
      lo = std::min(lo, h);
    min_height_ = lo;
  }
  else
  {
    for (std::size_t j = cj0; j <= std::min(cj1 + 1, rows_ - 1); ++j)
      for (std::size_t i = ci0; i <= std::min(ci1 + 1, columns_ - 1); ++i)
        lo = std::min(lo, heights_[j * columns_ + i]);
    min_height_ = std::min(min_height_, lo);
  }
}

void HeightField::setHeights(std::size_t i0, std::size_t j0, std::size_t width, std::size_t height,
                             const std::vector<float>& heights)
{
  if (width == 0 || height == 0)
    bad("setHeights: the rectangle is empty (width " + std::to_string(width) + ", height " + std::to_string(height) + ")");
  if (i0 >= columns_ || width > columns_ - i0 || j0 >= rows_ || height > rows_ - j0)
    bad("setHeights: points [" + std::to_string(i0) + ", " + std::to_string(i0 + width) + ") x [" +
        std::to_string(j0) + ", " + std::to_string(j0 + height) + ") leave the " + std::to_string(columns_) + " x " +
        std::to_string(rows_) + " grid");
  if (heights.size() != width * height)
    bad("setHeights: heights has " + std::to_string(heights.size()) + " values, expected width * height = " +
        std::to_string(width * height));
  for (std::size_t k = 0; k < heights.size(); ++k)
    if (!std::isfinite(heights[k]))
      bad("setHeights: heights[" + std::to_string(k) + "] is not finite");
  for (std::size_t r = 0; r < height; ++r)
    std::copy(heights.begin() + r * width, heights.begin() + (r + 1) * width,
              heights_.begin() + (j0 + r) * columns_ + i0);
  // A point touches the cells to its south-west, south-east, north-west and north-east.
  const std::size_t ci0 = i0 == 0 ? 0 : i0 - 1, cj0 = j0 == 0 ? 0 : j0 - 1;
  const std::size_t ci1 = std::min(i0 + width - 1, cells_x_ - 1), cj1 = std::min(j0 + height - 1, cells_y_ - 1);
  refreshMips(ci0, cj0, ci1, cj1);
}

void HeightField::refreshFrom(const terrain::DeformableTerrain& terrain, const terrain::PointRange& range)
{
  const terrain::ElevationGrid& g = terrain.base();
  if (g.columns() != columns_ || g.rows() != rows_ || g.dx() != dx_ || g.dy() != dy_ || g.originX() != origin_x_ ||
      g.originY() != origin_y_)
    bad("refreshFrom: the terrain's lattice differs from this height field's");
  if (range.i1 < range.i0 || range.j1 < range.j0)
    bad("refreshFrom: empty range");
  if (range.i1 >= columns_ || range.j1 >= rows_)
    bad("refreshFrom: range leaves the grid");
  const std::size_t w = range.i1 - range.i0 + 1, h = range.j1 - range.j0 + 1;
  std::vector<float> patch(w * h);
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c)
      patch[r * w + c] = static_cast<float>(terrain.pointHeight(range.i0 + c, range.j0 + r));
  setHeights(range.i0, range.j0, w, h, patch);
}

bool HeightField::cellHit(std::size_t ci, std::size_t cj, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                          const GridRay& g, double ta, double tb, TerrainHit& hit) const
{
  const float* s = heights_.data() + cj * columns_ + ci;
  const double h00 = s[0], h10 = s[1], h01 = s[columns_], h11 = s[columns_ + 1];
  const double a = h10 - h00, b = h01 - h00, k = h00 - h10 - h01 + h11;
  // Local coordinates (u, v) in [0, 1] at the interval start; s = t - ta from there, so the
  // coefficients stay small and the roots well conditioned inside the cell.
  const double du = g.DX, dv = g.DY;
  const double ua = g.X0 + ta * du - static_cast<double>(ci);
  const double va = g.Y0 + ta * dv - static_cast<double>(cj);
  const double za = o.z() + ta * d.z();
  // f(s) = ray z - surface z = C + B s + A s^2 along the ray.
  const double C = za - (h00 + a * ua + b * va + k * ua * va);
  const double B = d.z() - (a + k * va) * du - (b + k * ua) * dv;
  const double A = -k * du * dv;
  const double len = tb - ta;
  double s_hit = -1.0;
  if (C <= 0.0)
    s_hit = 0.0;  // at or below the surface already: the ray starts in the ground, or the
                  // crossing was exactly on the edge it entered through
  else
  {
    const double f_end = C + len * (B + A * len);
    const double scale = std::abs(B) * len + C;
    if (std::abs(A) * len * len <= 1e-12 * scale)
    {
      // Linear along this ray (a planar cell, or the ray runs along a cell axis).
      if (B < 0.0)
        s_hit = -C / B;
    }
    else
    {
      const double disc = B * B - 4.0 * A * C;
      if (disc >= 0.0)
      {
        // Numerically stable pair of roots; C > 0 so q != 0 unless B = disc = 0 (then A C = 0).
        const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
        double r1 = q / A, r2 = q != 0.0 ? C / q : kInf;
        if (r1 > r2)
          std::swap(r1, r2);
        if (r1 >= -kRootTolerance)
          s_hit = r1;
        else if (r2 >= -kRootTolerance)
          s_hit = r2;
      }
    }
    if (s_hit > len + kRootTolerance || s_hit < -kRootTolerance)
      s_hit = -1.0;
    // Below the surface at the far end yet no root found: only rounding can do that, and the
    // crossing is then at the far edge.
    if (s_hit < 0.0 && f_end <= 0.0)
      s_hit = len;
  }
  if (s_hit < 0.0)
    return false;
  s_hit = std::min(std::max(s_hit, 0.0), len);
  const double t = ta + s_hit;
  const double u = std::min(std::max(ua + s_hit * du, 0.0), 1.0);
  const double v = std::min(std::max(va + s_hit * dv, 0.0), 1.0);
  hit.t = t;
  hit.point = o + t * d;
  hit.normal = Eigen::Vector3d(-(a + k * v) / dx_, -(b + k * u) / dy_, 1.0).normalized();
  hit.i = ci;
  hit.j = cj;
  return true;
}

bool HeightField::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, TerrainHit& hit) const
{
  if (!(t_max >= 0.0))
    return false;
  // Ray in grid units: X = (x - origin_x) / dx, so cell boundaries are the integers.
  GridRay g;
  g.X0 = (o.x() - origin_x_) / dx_;
  g.Y0 = (o.y() - origin_y_) / dy_;
  g.DX = d.x() / dx_;
  g.DY = d.y() / dy_;
  const double X0 = g.X0, Y0 = g.Y0, DX = g.DX, DY = g.DY;
  const double nx = static_cast<double>(cells_x_), ny = static_cast<double>(cells_y_);
  double t0 = 0.0, t1 = t_max;
  // Clip to the grid's footprint ...
  auto slab = [&](double p0, double dp, double hi) {
    if (dp == 0.0)
      return p0 >= 0.0 && p0 <= hi;
    double ta = (0.0 - p0) / dp, tb = (hi - p0) / dp;
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    return t0 <= t1;
  };
  if (!slab(X0, DX, nx) || !slab(Y0, DY, ny))
    return false;
  // ... and to the heights' range: above the highest point going up, or below the lowest going
  // down, nothing can be hit. This also bounds vertical rays.
  const double top = mips_.back().max[0];
  if (d.z() > 0.0)
  {
    if (o.z() + t0 * d.z() > top + kSkipMargin)
      return false;
    t1 = std::min(t1, (top + 1e-3 - o.z()) / d.z());
  }
  else if (d.z() < 0.0)
  {
    // Below the lowest point the ray is inside the ground, so it must have crossed by then;
    // the margin keeps that crossing inside [t0, t1] despite rounding.
    t1 = std::min(t1, std::max(t0, (static_cast<double>(min_height_) - 1e-3 - o.z()) / d.z()));
  }
  else if (o.z() > top + kSkipMargin)
    return false;
  if (t0 > t1)
    return false;

  const int top_level = static_cast<int>(mips_.size());
  double t = t0;
  const bool px = DX > 0.0, py = DY > 0.0;
  // Reciprocals: one multiply per face instead of a division in the inner loop (+-inf for a
  // ray parallel to the faces, which then never exits through them).
  const double iX = 1.0 / DX, iY = 1.0 / DY;
  const auto ncx = static_cast<std::int64_t>(cells_x_), ncy = static_cast<std::int64_t>(cells_y_);
  // Level-0 cell holding the ray at t, kept inside [lo, hi) so that rounding of the position
  // cannot put it in a block the traversal has not reached (or has left).
  auto cellOf = [](double p, std::int64_t lo, std::int64_t hi) {
    if (!(p > static_cast<double>(lo)))
      return lo;
    return std::min(static_cast<std::int64_t>(p), hi - 1);
  };
  std::int64_t ci = cellOf(X0 + t * DX, 0, ncx);
  std::int64_t cj = cellOf(Y0 + t * DY, 0, ncy);
  // The mip levels as flat arrays (index L - 1), read once per ray instead of through the
  // vectors on every step.
  const float* level_max[kMaxLevels];
  std::size_t level_nx[kMaxLevels];
  for (int L = 0; L < top_level; ++L)
  {
    level_max[L] = mips_[L].max.data();
    level_nx[L] = mips_[L].nx;
  }
  // Largest block maximum around (ci, cj) at `level` (0: the cell's corners).
  auto blockMax = [&](int level, std::int64_t i, std::int64_t j) -> double {
    if (level == 0)
    {
      const float* s = heights_.data() + static_cast<std::size_t>(j) * columns_ + static_cast<std::size_t>(i);
      return std::max(std::max(s[0], s[1]), std::max(s[columns_], s[columns_ + 1]));
    }
    return level_max[level - 1][static_cast<std::size_t>(j >> level) * level_nx[level - 1] +
                                static_cast<std::size_t>(i >> level)];
  };
  // How far the ray can drop while crossing a block of level L: at most its diagonal times the
  // ray's slope (0 for rays going up). Used only to choose levels, never to skip.
  const double horizontal = std::sqrt(d.x() * d.x() + d.y() * d.y());
  const double drop_per_cell = d.z() >= 0.0      ? 0.0
                               : horizontal > 0.0 ? std::sqrt(dx_ * dx_ + dy_ * dy_) * (-d.z()) / horizontal
                                                  : kInf;
  auto clears = [&](int L, std::int64_t i, std::int64_t j, double z) {
    return blockMax(L, i, j) + kSkipMargin + drop_per_cell * static_cast<double>(std::int64_t{ 1 } << L) < z;
  };
  // Start at the coarsest block around the start that the ray is likely to clear: a coarser one
  // reaches the ray (or the ray drops to it while crossing), so testing it would only lead to
  // descending through it.
  int level = 0;
  {
    const double z_start = o.z() + t * d.z();
    while (level < top_level && clears(level + 1, ci, cj, z_start))
      ++level;
  }
  for (;;)
  {
    // Block of the current level that contains cell (ci, cj), and the ray's exit from it.
    const std::int64_t bi = ci >> level, bj = cj >> level;
    const std::int64_t x_lo = bi << level, x_hi = std::min((bi + 1) << level, ncx);
    const std::int64_t y_lo = bj << level, y_hi = std::min((bj + 1) << level, ncy);
    const double tx = DX != 0.0 ? (static_cast<double>(px ? x_hi : x_lo) - X0) * iX : kInf;
    const double ty = DY != 0.0 ? (static_cast<double>(py ? y_hi : y_lo) - Y0) * iY : kInf;
    // Rounding can leave the current position on the block's exit face: step across it.
    if (tx <= t || ty <= t)
    {
      if (tx <= t)
        ci = px ? x_hi : x_lo - 1;
      if (ty <= t)
        cj = py ? y_hi : y_lo - 1;
      if (ci < 0 || ci >= ncx || cj < 0 || cj >= ncy)
        return false;
      continue;
    }
    const double t_out = std::min(std::min(tx, ty), t1);
    const double z_low = d.z() >= 0.0 ? o.z() + t * d.z() : o.z() + t_out * d.z();
    if (level > 0)
    {
      if (z_low <= level_max[level - 1][static_cast<std::size_t>(bj) * level_nx[level - 1] +
                                        static_cast<std::size_t>(bi)] +
                       kSkipMargin)
      {
        // The ray may dip into this block: look at its children, starting with the one the
        // ray is in now.
        --level;
        ci = cellOf(X0 + t * DX, x_lo, x_hi);
        cj = cellOf(Y0 + t * DY, y_lo, y_hi);
        continue;
      }
    }
    else
    {
      const float* s = heights_.data() + static_cast<std::size_t>(cj) * columns_ + static_cast<std::size_t>(ci);
      const float cell_max = std::max(std::max(s[0], s[1]), std::max(s[columns_], s[columns_ + 1]));
      if (z_low <= cell_max + kSkipMargin &&
          cellHit(static_cast<std::size_t>(ci), static_cast<std::size_t>(cj), o, d, g, t, t_out, hit))
        return true;
    }
    // Past this block (skipped, or tested without a hit): into the neighbour it exits to.
    if (t_out >= t1)
      return false;
    t = t_out;
    const bool cross_x = tx <= ty, cross_y = ty <= tx;
    const std::int64_t ni = cross_x ? (px ? x_hi : x_lo - 1) : cellOf(X0 + t * DX, x_lo, x_hi);
    const std::int64_t nj = cross_y ? (py ? y_hi : y_lo - 1) : cellOf(Y0 + t * DY, y_lo, y_hi);
    if (ni < 0 || ni >= ncx || nj < 0 || nj >= ncy)
      return false;
    // Go up while the step also left the parent block and the new parent lies wholly below the
    // ray here: a parent the ray was already inside dips to the ray somewhere, and one that
    // reaches the ray's height cannot be skipped, so testing either would only send the
    // traversal straight back down.
    const double z_now = o.z() + t * d.z();
    while (level < top_level && (((ni ^ ci) >> (level + 1)) != 0 || ((nj ^ cj) >> (level + 1)) != 0) &&
           clears(level + 1, ni, nj, z_now))
      ++level;
    ci = ni;
    cj = nj;
  }
}

}  // namespace sensors
}  // namespace avsp
