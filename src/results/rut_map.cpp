#include "avsp/results/rut_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace results
{
namespace
{
constexpr float kNoData = std::numeric_limits<float>::quiet_NaN();
}

Grid sampleHeights(const terrain::ElevationGrid& base, double x0, double y0, double x1, double y1,
                   std::size_t max_cells)
{
  if (!(std::isfinite(x0) && std::isfinite(y0) && std::isfinite(x1) && std::isfinite(y1)) || !(x1 > x0) || !(y1 > y0))
    throw std::invalid_argument("sampleHeights: the box must be finite and non-empty");
  if (max_cells < 2)
    throw std::invalid_argument("sampleHeights: max_cells must be >= 2");
  Grid g;
  const double longest = std::max(x1 - x0, y1 - y0);
  g.resolution = std::max(std::min(base.dx(), base.dy()), longest / static_cast<double>(max_cells - 1));
  g.width = std::min(max_cells, static_cast<std::size_t>(std::floor((x1 - x0) / g.resolution + 1e-9)) + 1);
  g.height = std::min(max_cells, static_cast<std::size_t>(std::floor((y1 - y0) / g.resolution + 1e-9)) + 1);
  g.origin_x = x0;
  g.origin_y = y0;
  g.values.resize(g.width * g.height);
  for (std::size_t j = 0; j < g.height; ++j)
    for (std::size_t i = 0; i < g.width; ++i)
    {
      const double x = x0 + static_cast<double>(i) * g.resolution, y = y0 + static_cast<double>(j) * g.resolution;
      const auto z = base.height(x, y);
      g.values[j * g.width + i] = z ? static_cast<float>(*z) : kNoData;
    }
  return g;
}

RutMap::RutMap(const terrain::ElevationGrid& base) : base_(base), tiles_x_((base.columns() + kTile - 1) / kTile)
{
}

void RutMap::apply(const terrain::HeightPatch& p)
{
  using terrain::PatchError;
  const double dx = base_.dx();
  if (std::abs(base_.dy() - dx) > 1e-9 * dx)
    throw PatchError("the terrain's grid is not square (dx " + std::to_string(dx) + " m, dy " +
                     std::to_string(base_.dy()) + " m)");
  if (!std::isfinite(p.resolution) || std::abs(p.resolution - dx) > 1e-9 * dx)
    throw PatchError("resolution " + std::to_string(p.resolution) + " m is not the grid spacing " + std::to_string(dx) +
                     " m");
  if (!std::isfinite(p.origin_x) || !std::isfinite(p.origin_y))
    throw PatchError("origin is not finite");
  const double fi = (p.origin_x - base_.originX()) / dx, fj = (p.origin_y - base_.originY()) / dx;
  if (std::abs(fi - std::round(fi)) > 1e-6 || std::abs(fj - std::round(fj)) > 1e-6)
    throw PatchError("origin (" + std::to_string(p.origin_x) + ", " + std::to_string(p.origin_y) +
                     ") is not on a grid point");
  if (p.width * p.height != p.heights.size())
    throw PatchError("width x height = " + std::to_string(p.width * p.height) + " but " +
                     std::to_string(p.heights.size()) + " heights");
  for (float h : p.heights)
    if (!std::isfinite(h))
      throw PatchError("heights: a value is not finite");
  const long i0 = std::lround(fi), j0 = std::lround(fj);
  const long cols = static_cast<long>(base_.columns()), rows = static_cast<long>(base_.rows());
  for (std::size_t r = 0; r < p.height; ++r)
  {
    const long j = j0 + static_cast<long>(r);
    if (j < 0 || j >= rows)
      continue;
    for (std::size_t c = 0; c < p.width; ++c)
    {
      const long i = i0 + static_cast<long>(c);
      if (i < 0 || i >= cols)
        continue;
      const std::size_t ti = static_cast<std::size_t>(i) / kTile, tj = static_cast<std::size_t>(j) / kTile;
      std::vector<float>& t = tiles_[tj * tiles_x_ + ti];
      if (t.empty())
        t.assign(kTile * kTile, kNoData);
      float& cell = t[(static_cast<std::size_t>(j) % kTile) * kTile + static_cast<std::size_t>(i) % kTile];
      if (std::isnan(cell))
        ++count_;
      cell = p.heights[r * p.width + c];
    }
  }
}

const std::vector<float>* RutMap::tile(std::size_t ti, std::size_t tj) const
{
  const auto it = tiles_.find(tj * tiles_x_ + ti);
  return it == tiles_.end() ? nullptr : &it->second;
}

std::optional<double> RutMap::depth(std::size_t i, std::size_t j) const
{
  if (i >= base_.columns() || j >= base_.rows())
    return std::nullopt;
  const std::vector<float>* t = tile(i / kTile, j / kTile);
  if (!t)
    return std::nullopt;
  const float h = (*t)[(j % kTile) * kTile + i % kTile];
  if (std::isnan(h))
    return std::nullopt;
  return base_.pointHeight(i, j) - static_cast<double>(h);
}

namespace
{
/// Calls f(i, j, depth) for every patched grid point.
template <typename F>
void forEachPoint(const std::unordered_map<std::uint64_t, std::vector<float>>& tiles, std::size_t tiles_x,
                  std::size_t tile, const terrain::ElevationGrid& base, F f)
{
  for (const auto& [key, t] : tiles)
  {
    const std::size_t ti = key % tiles_x, tj = key / tiles_x;
    for (std::size_t b = 0; b < tile; ++b)
      for (std::size_t a = 0; a < tile; ++a)
      {
        const float h = t[b * tile + a];
        if (std::isnan(h))
          continue;
        const std::size_t i = ti * tile + a, j = tj * tile + b;
        f(i, j, base.pointHeight(i, j) - static_cast<double>(h));
      }
  }
}
}  // namespace

double RutMap::maxDepth() const
{
  double out = 0.0;
  forEachPoint(tiles_, tiles_x_, kTile, base_, [&](std::size_t, std::size_t, double d) { out = std::max(out, d); });
  return out;
}

double RutMap::areaDeeperThan(double d) const
{
  std::size_t n = 0;
  forEachPoint(tiles_, tiles_x_, kTile, base_, [&](std::size_t, std::size_t, double depth) { n += depth > d; });
  return static_cast<double>(n) * base_.dx() * base_.dy();
}

std::optional<Grid> RutMap::depthGrid(double min_depth, double margin, std::size_t max_cells) const
{
  if (max_cells < 1)
    throw std::invalid_argument("RutMap::depthGrid: max_cells must be >= 1");
  std::size_t i0 = std::numeric_limits<std::size_t>::max(), j0 = i0, i1 = 0, j1 = 0;
  forEachPoint(tiles_, tiles_x_, kTile, base_, [&](std::size_t i, std::size_t j, double d) {
    if (d < min_depth)
      return;
    i0 = std::min(i0, i);
    j0 = std::min(j0, j);
    i1 = std::max(i1, i);
    j1 = std::max(j1, j);
  });
  if (i1 < i0)
    return std::nullopt;
  const std::size_t m = static_cast<std::size_t>(std::ceil(std::max(0.0, margin) / base_.dx() - 1e-9));
  i0 = i0 > m ? i0 - m : 0;
  j0 = j0 > m ? j0 - m : 0;
  i1 = std::min(i1 + m, base_.columns() - 1);
  j1 = std::min(j1 + m, base_.rows() - 1);
  const std::size_t nx = i1 - i0 + 1, ny = j1 - j0 + 1;
  const std::size_t f = std::max<std::size_t>(1, (std::max(nx, ny) + max_cells - 1) / max_cells);
  Grid g;
  g.width = (nx + f - 1) / f;
  g.height = (ny + f - 1) / f;
  g.resolution = base_.dx() * static_cast<double>(f);
  g.origin_x = base_.originX() + (static_cast<double>(i0) + 0.5 * static_cast<double>(f - 1)) * base_.dx();
  g.origin_y = base_.originY() + (static_cast<double>(j0) + 0.5 * static_cast<double>(f - 1)) * base_.dy();
  g.values.assign(g.width * g.height, kNoData);
  for (std::size_t j = j0; j <= j1; ++j)
    for (std::size_t i = i0; i <= i1; ++i)
    {
      const auto d = depth(i, j);
      if (!d)
        continue;
      float& cell = g.values[((j - j0) / f) * g.width + (i - i0) / f];
      const float v = static_cast<float>(*d);
      if (std::isnan(cell) || v > cell)
        cell = v;
    }
  return g;
}

}  // namespace results
}  // namespace avsp
