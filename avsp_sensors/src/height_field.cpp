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

/// Grid units: a ray that ends farther than this inside the grid's edge is not clipped by it
/// (far above the rounding of the end point and of the clipping divisions).
constexpr double kInsideMargin = 1e-6;

/// 2^L for the levels the walk visits (cells per block side at level L).
struct BlockSizes
{
  double v[64];
  constexpr BlockSizes() : v()
  {
    double s = 1.0;
    for (double& x : v)
    {
      x = s;
      s *= 2.0;
    }
  }
  constexpr double operator[](int level) const { return v[level]; }
};
constexpr BlockSizes kBlockSize;

[[noreturn]] void bad(const std::string& what)
{
  throw std::invalid_argument("HeightField: " + what);
}
}  // namespace

HeightField::HeightField(double origin_x, double origin_y, double dx, double dy, std::size_t columns, std::size_t rows,
                         std::vector<float> heights)
  : origin_x_(origin_x),
    origin_y_(origin_y),
    dx_(dx),
    dy_(dy),
    columns_(columns),
    rows_(rows),
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
    bad("heights has " + std::to_string(heights_.size()) +
        " values, expected columns * rows = " + std::to_string(columns * rows));
  for (std::size_t k = 0; k < heights_.size(); ++k)
    if (!std::isfinite(heights_[k]))
      bad("heights[" + std::to_string(k) + "] is not finite");
  cells_x_ = columns - 1;
  cells_y_ = rows - 1;
  cells_xd_ = static_cast<double>(cells_x_);
  cells_yd_ = static_cast<double>(cells_y_);
  cell_diagonal_ = std::sqrt(dx * dx + dy * dy);
  inv_dx_ = 1.0 / dx;
  inv_dy_ = 1.0 / dy;
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
  if (level > mipLevels())
    throw std::out_of_range("HeightField: mip level " + std::to_string(level) + " of " + std::to_string(mipLevels()));
  return levels_[level].nx;
}

std::size_t HeightField::mipRows(std::size_t level) const
{
  if (level > mipLevels())
    throw std::out_of_range("HeightField: mip level " + std::to_string(level) + " of " + std::to_string(mipLevels()));
  return levels_[level].ny;
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
  return mip_max_[levels_[level].index(bi, bj)];
}

std::size_t HeightField::bytes() const
{
  std::size_t b = heights_.size() * sizeof(float);
  return b + mip_max_.size() * sizeof(float);
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
  levels_.clear();
  Level cells;
  cells.nx = cells_x_;
  cells.ny = cells_y_;
  levels_.push_back(cells);
  std::size_t nx = cells_x_, ny = cells_y_, offset = 0;
  // At least one stored level, then halve until one block covers the grid; then the +inf block.
  do
  {
    nx = (nx + 1) / 2;
    ny = (ny + 1) / 2;
    Level l;
    l.nx = nx;
    l.ny = ny;
    l.tiles_x = (nx + Level::kTile - 1) / Level::kTile;
    l.offset = offset;
    offset += l.tiles() * Level::kTile * Level::kTile;
    levels_.push_back(l);
  } while (nx > 1 || ny > 1);
  Level cap;
  cap.nx = cap.ny = cap.tiles_x = 1;
  cap.offset = offset;
  levels_.push_back(cap);
  if (levels_.size() > static_cast<std::size_t>(kMaxLevels))
    bad("the grid needs more than " + std::to_string(kMaxLevels - 2) + " mip levels");
  // Padding entries of partial tiles are never read; -inf keeps them harmless anyway.
  mip_max_.assign(offset + Level::kTile * Level::kTile, -std::numeric_limits<float>::infinity());
  std::fill(mip_max_.begin() + static_cast<std::ptrdiff_t>(offset), mip_max_.end(),
            std::numeric_limits<float>::infinity());
  refreshMips(0, 0, cells_x_ - 1, cells_y_ - 1);
}

void HeightField::refreshMips(std::size_t ci0, std::size_t cj0, std::size_t ci1, std::size_t cj1)
{
  std::size_t bi0 = ci0 / 2, bj0 = cj0 / 2, bi1 = ci1 / 2, bj1 = cj1 / 2;
  const Level& first = levels_[1];
  for (std::size_t bj = bj0; bj <= bj1; ++bj)
    for (std::size_t bi = bi0; bi <= bi1; ++bi)
      mip_max_[first.index(bi, bj)] = blockMaxFromHeights(bi, bj);
  for (std::size_t L = 2; L <= mipLevels(); ++L)
  {
    const Level& child = levels_[L - 1];
    const Level& parent = levels_[L];
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
            m = std::max(m, mip_max_[child.index(ci, cj)]);
        mip_max_[parent.index(bi, bj)] = m;
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
    bad("setHeights: the rectangle is empty (width " + std::to_string(width) + ", height " + std::to_string(height) +
        ")");
  if (i0 >= columns_ || width > columns_ - i0 || j0 >= rows_ || height > rows_ - j0)
    bad("setHeights: points [" + std::to_string(i0) + ", " + std::to_string(i0 + width) + ") x [" + std::to_string(j0) +
        ", " + std::to_string(j0 + height) + ") leave the " + std::to_string(columns_) + " x " + std::to_string(rows_) +
        " grid");
  if (heights.size() != width * height)
    bad("setHeights: heights has " + std::to_string(heights.size()) +
        " values, expected width * height = " + std::to_string(width * height));
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
        // Numerically stable pair of roots: C / q, the one nearer 0, and q / A. C > 0 so q != 0
        // unless B = disc = 0 (then A C = 0). The first crossing is the near root when that
        // is not before the cell (when both are within the tolerance of 0, either is the start
        // of the stretch), else the far one: the far one's division only then.
        const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
        const double r_near = q != 0.0 ? C / q : -kInf;
        if (r_near >= -kRootTolerance)
          s_hit = r_near;
        else
        {
          const double r_far = q / A;
          if (r_far >= -kRootTolerance)
            s_hit = r_far;
        }
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
  // One division instead of five (two slopes, three normalised components): divisions are a
  // good part of a ray's cost.
  const double gx = -(a + k * v) * inv_dx_, gy = -(b + k * u) * inv_dy_;
  const double inv_norm = 1.0 / std::sqrt(gx * gx + gy * gy + 1.0);
  hit.normal = Eigen::Vector3d(gx * inv_norm, gy * inv_norm, inv_norm);
  hit.i = ci;
  hit.j = cj;
  return true;
}

bool HeightField::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, TerrainHit& hit) const
{
  return intersectFrom(o, d, 0.0, t_max, hit);
}

bool HeightField::intersectFrom(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_clear, double t_max,
                                TerrainHit& hit) const
{
  if (!(t_max >= 0.0))
    return false;
  // Ray in grid units: X = (x - origin_x) / dx, so cell boundaries are the integers.
  GridRay g;
  g.X0 = (o.x() - origin_x_) * inv_dx_;
  g.Y0 = (o.y() - origin_y_) * inv_dy_;
  g.DX = d.x() * inv_dx_;
  g.DY = d.y() * inv_dy_;
  const double X0 = g.X0, Y0 = g.Y0, DX = g.DX, DY = g.DY;
  const double nx = cells_xd_, ny = cells_yd_;
  double t0 = 0.0, t1 = t_max;
  // Clip to the grid's footprint ...
  auto slab = [&](double p0, double dp, double hi) {
    if (dp == 0.0)
      return p0 >= 0.0 && p0 <= hi;
    // A ray that starts and ends well inside (most of them) cannot be clipped: the divisions
    // below would give t0 <= 0 and t1 >= t_max, so they are skipped.
    const double p1 = p0 + t_max * dp;
    if (p0 >= 0.0 && p0 <= hi && p1 > kInsideMargin && p1 < hi - kInsideMargin)
      return true;
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
  const Level* const levels = levels_.data();
  const float* const mips = mip_max_.data();
  const int top_level = static_cast<int>(levels_.size()) - 2;
  const double top = mips[levels[top_level].offset];
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

  // Where the ray may first meet the surface, as far as the caller knows (t_clear), and where
  // the exact cell tests start from: t0, the same with or without t_clear.
  const double t_first = t0;
  double t = std::max(t0, t_clear);
  if (t > t1)
    return false;
  // The walk, compiled once per direction of travel along x and y (-1, 0, +1) and for rays
  // going up or down: the signs then fold into the code instead of being selected at every step.
  using Walk = bool (HeightField::*)(const Eigen::Vector3d&, const Eigen::Vector3d&, const GridRay&, double, double,
                                     double, TerrainHit&) const;
  static constexpr Walk kWalks[2][9] = {
    { &HeightField::walk<-1, -1, false>, &HeightField::walk<-1, 0, false>, &HeightField::walk<-1, 1, false>,
      &HeightField::walk<0, -1, false>, &HeightField::walk<0, 0, false>, &HeightField::walk<0, 1, false>,
      &HeightField::walk<1, -1, false>, &HeightField::walk<1, 0, false>, &HeightField::walk<1, 1, false> },
    { &HeightField::walk<-1, -1, true>, &HeightField::walk<-1, 0, true>, &HeightField::walk<-1, 1, true>,
      &HeightField::walk<0, -1, true>, &HeightField::walk<0, 0, true>, &HeightField::walk<0, 1, true>,
      &HeightField::walk<1, -1, true>, &HeightField::walk<1, 0, true>, &HeightField::walk<1, 1, true> }
  };
  const int sx = (DX > 0.0) - (DX < 0.0), sy = (DY > 0.0) - (DY < 0.0);
  return (this->*kWalks[d.z() >= 0.0 ? 1 : 0][3 * sx + sy + 4])(o, d, g, t_first, t, t1, hit);
}

/// The hierarchical walk of one ray (HeightField::walk), its state kept as it moves from block
/// to block. Every method is inlined into walk(): one loop, its state in registers, as when it
/// was written as one function; the pieces only name its steps.
template <int SX, int SY, bool RISING>
class HeightField::Walker
{
public:
  Walker(const HeightField& field, const Eigen::Vector3d& o, const Eigen::Vector3d& d, const GridRay& g, double t_first,
         double t, double t1)
    : field_(field),
      o_(o),
      d_(d),
      g_(g),
      X0(g.X0),
      Y0(g.Y0),
      DX(g.DX),
      DY(g.DY),
      nx(field.cells_xd_),
      ny(field.cells_yd_),
      iX(move_x ? 1.0 / DX : 1.0),
      iY(move_y ? 1.0 / DY : 1.0),
      ncx(static_cast<std::int64_t>(field.cells_x_)),
      ncy(static_cast<std::int64_t>(field.cells_y_)),
      oz(o.z()),
      dz(d.z()),
      t_first_(t_first),
      t1_(t1),
      levels(field.levels_.data()),
      mips(field.mip_max_.data()),
      heights(field.heights_.data()),
      columns(field.columns_),
      row(static_cast<std::ptrdiff_t>(field.columns_)),
      t_(t)
  {
    // How far the ray can drop while crossing a block of level L: at most its diagonal times
    // the ray's slope (0 for rays going up). Used only to choose levels, never to skip.
    if (!RISING)
    {
      const double horizontal = std::sqrt(d.x() * d.x() + d.y() * d.y());
      drop_per_cell = horizontal > 0.0 ? field.cell_diagonal_ * (-d.z()) / horizontal : kInf;
    }
    // Start at the coarsest block around the start that the ray is likely to clear: a coarser
    // one reaches the ray (or the ray drops to it while crossing), so testing it would only
    // lead to descending through it.
    bi = cellOf(X0 + t_ * DX, 0, ncx);
    bj = cellOf(Y0 + t_ * DY, 0, ncy);
    const double z_start = oz + t_ * dz;
    while (clears(level + 1, bi >> 1, bj >> 1, z_start))
    {
      ++level;
      bi >>= 1;
      bj >>= 1;
    }
    enterLevel();
  }

  [[gnu::always_inline]] bool run(TerrainHit& hit)
  {
    for (;;)
    {
      // The ray's exit from block (bi, bj) of the current level. A face beyond the grid's edge
      // (the last block of a level may be partial) is never reached: t1 ends the ray there.
      const double tx = (fx - X0) * iX;
      const double ty = (fy - Y0) * iY;
      const double t_exit = std::min(tx, ty);
      // Rounding can leave the current position on the block's exit face: step across it.
      if (t_exit <= t_)
      {
        if (!stepOffFace(tx, ty))
          return false;
        continue;
      }
      const double t_out = std::min(t_exit, t1_);
      const double z_low = oz + (RISING ? t_ : t_out) * dz;
      if (level > 0)
      {
        if (dipsInto(z_low))
        {
          descend();
          continue;
        }
      }
      else if (hitsCell(z_low, t_out, hit))
        return true;
      // Past this block (skipped, or tested without a hit): into the neighbour it exits to.
      if (t_out >= t1_ || !advance(tx, ty, t_out))
        return false;
      climb();
    }
  }

private:
  static constexpr bool px = SX > 0, py = SY > 0;
  static constexpr bool move_x = SX != 0, move_y = SY != 0;
  // The traversal works in blocks of the current level: block b of level L spans cells
  // [b 2^L, (b + 1) 2^L); the ray leaves it through face (b + exit) 2^L and steps to b + step.
  static constexpr std::int64_t exit_x = px ? 1 : 0, exit_y = py ? 1 : 0;
  static constexpr std::int64_t step_x = px ? 1 : -1, step_y = py ? 1 : -1;
  static constexpr std::ptrdiff_t kLineFloats = 64 / sizeof(float);
  static constexpr auto kTileFloats = static_cast<std::ptrdiff_t>(Level::kTile * Level::kTile);

  /// Level-0 cell holding the ray at p, kept inside [lo, hi) so that rounding of the position
  /// cannot put it in a block the traversal has not reached (or has left).
  [[gnu::always_inline]] static std::int64_t cellOf(double p, std::int64_t lo, std::int64_t hi)
  {
    if (!(p > static_cast<double>(lo)))
      return lo;
    return std::min(static_cast<std::int64_t>(p), hi - 1);
  }
  /// The walk is bound by the latency of loading the points of cells it has not met yet (about
  /// a third of its time went to those loads): it asks for them a few steps early. A prefetch
  /// never faults, so an address beyond the grid's edge costs nothing; the arithmetic is done
  /// on integers, not on pointers past the array.
  [[gnu::always_inline]] static void prefetch(const float* s, std::ptrdiff_t floats)
  {
    __builtin_prefetch(reinterpret_cast<const void*>(reinterpret_cast<std::uintptr_t>(s) +
                                                     static_cast<std::uintptr_t>(floats) * sizeof(float)));
  }
  /// Stored maximum of block (bi, bj) of level L >= 1 (+inf above the top level).
  [[gnu::always_inline]] double mip(int L, std::int64_t i, std::int64_t j) const
  {
    return mips[levels[L].index(static_cast<std::size_t>(i), static_cast<std::size_t>(j))];
  }
  /// Whether block (i, j) of level L >= 1 lies wholly below the ray, which is at height z now.
  [[gnu::always_inline]] bool clears(int L, std::int64_t i, std::int64_t j, double z) const
  {
    return mip(L, i, j) + kSkipMargin + (RISING ? 0.0 : drop_per_cell * kBlockSize[L]) < z;
  }
  /// The current block's exit faces (fx, fy, grid units), steps to the next block's (sx, sy) and
  /// block counts, refreshed when the walk changes level: the faces are integers times 2^level,
  /// exact in doubles, so each is the value (b + exit) 2^level would give.
  [[gnu::always_inline]] void enterLevel()
  {
    const double size = kBlockSize[level];
    fx = move_x ? static_cast<double>(bi + exit_x) * size : kInf;
    fy = move_y ? static_cast<double>(bj + exit_y) * size : kInf;
    sx = px ? size : -size;
    sy = py ? size : -size;
    nbx = levels[level].nx;
    nby = levels[level].ny;
  }
  [[gnu::always_inline]] bool inGrid() const
  {
    return static_cast<std::uint64_t>(bi) < nbx && static_cast<std::uint64_t>(bj) < nby;
  }
  /// Across the face(s) the ray is on already. False: off the grid.
  [[gnu::always_inline]] bool stepOffFace(double tx, double ty)
  {
    if (tx <= t_)
    {
      bi += step_x;
      fx += sx;
    }
    if (ty <= t_)
    {
      bj += step_y;
      fy += sy;
    }
    return inGrid();
  }
  /// Whether the ray, at z_low at its lowest over the block, may dip into block (bi, bj) of
  /// level >= 1; prefetches what the walk reads next either way.
  [[gnu::always_inline]] bool dipsInto(double z_low) const
  {
    const Level& lv = levels[level];
    const float* m = mips + lv.index(static_cast<std::size_t>(bi), static_cast<std::size_t>(bj));
    // The same place in the neighbouring tiles along x and y: the blocks the walk meets next at
    // this level, when they are not in this tile.
    if (move_x)
      prefetch(m, px ? kTileFloats : -kTileFloats);
    if (move_y)
      prefetch(m, (py ? kTileFloats : -kTileFloats) * static_cast<std::ptrdiff_t>(lv.tiles_x));
    // What a descent would read first: the children's tile one level down (all four children
    // of a block share a tile), or at level 1 the block's three rows of points.
    if (level > 1)
      prefetch(mips + levels[level - 1].index(static_cast<std::size_t>(2 * bi), static_cast<std::size_t>(2 * bj)), 0);
    else
    {
      const float* s = heights + static_cast<std::size_t>(2 * bj) * columns + static_cast<std::size_t>(2 * bi);
      prefetch(s, 0);
      prefetch(s, row);
      prefetch(s, 2 * row);
    }
    return z_low <= *m + kSkipMargin;
  }
  /// Into the children of the current block, starting with the one the ray is in now (the
  /// lower one when the upper would lie beyond the grid).
  [[gnu::always_inline]] void descend()
  {
    --level;
    const double half = kBlockSize[level];
    const double mid_x = static_cast<double>(2 * bi + 1) * half, mid_y = static_cast<double>(2 * bj + 1) * half;
    bi = 2 * bi + (mid_x < nx && X0 + t_ * DX >= mid_x ? 1 : 0);
    bj = 2 * bj + (mid_y < ny && Y0 + t_ * DY >= mid_y ? 1 : 0);
    enterLevel();
  }
  /// The exact test of level-0 cell (bi, bj) where the ray, at z_low at its lowest over it, may
  /// reach its highest corner.
  [[gnu::always_inline]] bool hitsCell(double z_low, double t_out, TerrainHit& hit) const
  {
    const float* s = heights + static_cast<std::size_t>(bj) * columns + static_cast<std::size_t>(bi);
    // The points the next cells need: two rows ahead along y, a cache line ahead along x.
    if (move_y)
    {
      prefetch(s, py ? 2 * row : -row);
      prefetch(s, py ? 3 * row : -2 * row);
    }
    if (move_x)
    {
      prefetch(s, px ? kLineFloats : -kLineFloats);
      prefetch(s, row + (px ? kLineFloats : -kLineFloats));
    }
    const float cell_max = std::max(std::max(s[0], s[1]), std::max(s[columns], s[columns + 1]));
    if (!(z_low <= cell_max + kSkipMargin))
      return false;
    // The exact test runs over the cell's whole stretch of the ray, from where the ray enters it
    // (or starts), not from where the traversal came in: the hit then depends on the ray and the
    // cell alone, whatever path (coarse levels, a t_clear start) led here.
    double t_in = t_first_;
    if (move_x)
      t_in = std::max(t_in, (static_cast<double>(bi + 1 - exit_x) - X0) * iX);
    if (move_y)
      t_in = std::max(t_in, (static_cast<double>(bj + 1 - exit_y) - Y0) * iY);
    return field_.cellHit(static_cast<std::size_t>(bi), static_cast<std::size_t>(bj), o_, d_, g_, std::min(t_in, t_out),
                          t_out, hit);
  }
  /// Into the neighbour the ray exits to at t_out: across x, y or both (at a corner). False: off
  /// the grid. (Done by arithmetic instead, this costs ~30 more instructions per ray and saved
  /// no time: the hardware predicts it better than callgrind.)
  [[gnu::always_inline]] bool advance(double tx, double ty, double t_out)
  {
    t_ = t_out;
    if (tx <= ty)
    {
      bi += step_x;
      fx += sx;
    }
    if (ty <= tx)
    {
      bj += step_y;
      fy += sy;
    }
    return inGrid();
  }
  /// Up while the parent block lies wholly below the ray here (above the top level sits a block
  /// of +inf). A parent the step did not leave was tested before and dipped to the ray, so it
  /// mostly fails again; testing it anyway is cheaper than the unpredictable branch on whether
  /// the step left it.
  [[gnu::always_inline]] void climb()
  {
    const double z_now = oz + t_ * dz;
    if (!clears(level + 1, bi >> 1, bj >> 1, z_now))
      return;
    do
    {
      ++level;
      bi >>= 1;
      bj >>= 1;
    } while (clears(level + 1, bi >> 1, bj >> 1, z_now));
    enterLevel();
  }

  const HeightField& field_;
  const Eigen::Vector3d& o_;
  const Eigen::Vector3d& d_;
  const GridRay& g_;
  const double X0, Y0, DX, DY;
  const double nx, ny;
  /// Reciprocals: one multiply per face instead of a division in the inner loop. An axis the
  /// ray does not move along gets an infinite exit face and a factor of 1, so its exit time is
  /// +inf.
  const double iX, iY;
  const std::int64_t ncx, ncy;
  const double oz, dz;
  const double t_first_, t1_;
  const Level* const levels;
  const float* const mips;
  const float* const heights;
  const std::size_t columns;
  const std::ptrdiff_t row;
  double drop_per_cell = 0.0;
  double t_;  ///< where the walk is along the ray
  int level = 0;
  std::int64_t bi = 0, bj = 0;  ///< the current block of the current level
  double fx = 0.0, fy = 0.0, sx = 0.0, sy = 0.0;
  std::uint64_t nbx = 0, nby = 0;
};

template <int SX, int SY, bool RISING>
bool HeightField::walk(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const GridRay& g, double t_first, double t,
                       double t1, TerrainHit& hit) const
{
  Walker<SX, SY, RISING> walker(*this, o, d, g, t_first, t, t1);
  return walker.run(hit);
}

}  // namespace sensors
}  // namespace avsp
