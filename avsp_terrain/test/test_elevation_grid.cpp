#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_terrain/elevation_grid.hpp"

using avsp::terrain::ElevationGrid;
using avsp::terrain::GridError;

namespace
{
// A plane z = a x + b y + c sampled on the grid: bilinear interpolation must reproduce it
// exactly, and its normal is (-a, -b, 1) normalised.
ElevationGrid planeGrid(double a, double b, double c, double ox, double oy, double d, std::size_t n)
{
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(a * (ox + i * d) + b * (oy + j * d) + c);
  return ElevationGrid(ox, oy, d, d, n, n, std::move(h));
}
}  // namespace

class PlaneSlope : public ::testing::TestWithParam<double>
{
};

TEST_P(PlaneSlope, BilinearHeightAndNormalMatchInclinedPlane)
{
  const double slope_deg = GetParam();
  const double a = std::tan(slope_deg * M_PI / 180.0);
  const double b = -0.25 * a;
  const ElevationGrid grid = planeGrid(a, b, 2.0, -5.0, -5.0, 0.5, 21);
  const Eigen::Vector3d expected_n = Eigen::Vector3d(-a, -b, 1.0).normalized();
  for (double x = -4.9; x < 4.9; x += 0.37)
  {
    for (double y = -4.9; y < 4.9; y += 0.41)
    {
      ASSERT_NEAR(*grid.height(x, y), a * x + b * y + 2.0, 2e-5) << x << "," << y;
      const Eigen::Vector3d n = *grid.normal(x, y);
      ASSERT_NEAR((n - expected_n).norm(), 0.0, 1e-6);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Slopes, PlaneSlope, ::testing::Values(0.0, 5.0, 15.0, 20.0, 35.0));

TEST(ElevationGrid, CellLookupIsFloorOfOffsetOverSize)
{
  const ElevationGrid grid = planeGrid(0, 0, 0, 10.0, 20.0, 0.1, 11);
  auto c = grid.cellAt(10.0, 20.0);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->i, 0u);
  EXPECT_EQ(c->j, 0u);
  c = grid.cellAt(10.35, 20.71);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->i, 3u);
  EXPECT_EQ(c->j, 7u);
  // The far edge belongs to the last cell.
  c = grid.cellAt(11.0, 21.0);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->i, 9u);
  EXPECT_EQ(c->j, 9u);
}

TEST(ElevationGrid, OutsideOrNaNHasNoHeight)
{
  const ElevationGrid grid = planeGrid(0, 0, 1, 0.0, 0.0, 1.0, 3);
  EXPECT_FALSE(grid.height(-0.01, 1.0));
  EXPECT_FALSE(grid.height(1.0, 2.01));
  EXPECT_FALSE(grid.height(std::nan(""), 1.0));
  EXPECT_FALSE(grid.normal(1.0, std::numeric_limits<double>::infinity()));
  EXPECT_FALSE(grid.cellAt(3.0, 0.0));
}

TEST(ElevationGrid, SaddleIsBilinearNotPlanar)
{
  // Corners 0, 0, 0, 1: bilinear gives u*v, which a triangulation would not.
  const ElevationGrid grid(0, 0, 1, 1, 2, 2, { 0.f, 0.f, 0.f, 1.f });
  EXPECT_NEAR(*grid.height(0.5, 0.5), 0.25, 1e-12);
  EXPECT_NEAR(*grid.height(0.2, 0.7), 0.14, 1e-12);
}

TEST(ElevationGrid, RejectsInconsistentConstruction)
{
  EXPECT_THROW(ElevationGrid(0, 0, 0.0, 1, 2, 2, { 0, 0, 0, 0 }), GridError);
  EXPECT_THROW(ElevationGrid(0, 0, 1, -1, 2, 2, { 0, 0, 0, 0 }), GridError);
  EXPECT_THROW(ElevationGrid(0, 0, 1, 1, 1, 2, { 0, 0 }), GridError);
  EXPECT_THROW(ElevationGrid(0, 0, 1, 1, 2, 2, { 0, 0, 0 }), GridError);
  EXPECT_THROW(ElevationGrid(0, 0, 1, 1, 2, 2, { 0, 0, std::numeric_limits<float>::quiet_NaN(), 0 }), GridError);
  try
  {
    ElevationGrid(0, 0, 1, 1, 2, 2, { 0, 0, 0 });
    FAIL() << "no throw";
  }
  catch (const GridError& e)
  {
    EXPECT_NE(std::string(e.what()).find("heights"), std::string::npos) << e.what();
  }
}

namespace
{
// T1 and the bilinear blend written out literally (floor, division, four corner reads), the
// reference the inline fast paths must reproduce bit for bit.
bool referenceHeight(const ElevationGrid& g, double x, double y, double& h)
{
  const double fx = (x - g.originX()) / g.dx();
  const double fy = (y - g.originY()) / g.dy();
  const double max_i = static_cast<double>(g.columns() - 1), max_j = static_cast<double>(g.rows() - 1);
  if (!(fx >= 0.0 && fy >= 0.0 && fx <= max_i && fy <= max_j))
    return false;
  const double ci = std::min(std::floor(fx), max_i - 1.0);
  const double cj = std::min(std::floor(fy), max_j - 1.0);
  const auto i = static_cast<std::size_t>(ci), j = static_cast<std::size_t>(cj);
  h = ElevationGrid::bilinear(g.pointHeight(i, j), g.pointHeight(i + 1, j), g.pointHeight(i, j + 1),
                              g.pointHeight(i + 1, j + 1), fx - ci, fy - cj);
  return true;
}

// A rough, non-planar grid with an awkward origin and spacing (0.1 is not a binary fraction),
// so that rounding differences in the lookup would show.
ElevationGrid roughGrid()
{
  const std::size_t cols = 57, rows = 43;
  std::vector<float> h(cols * rows);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> z(-3.f, 7.f);
  for (float& v : h)
    v = z(rng);
  return ElevationGrid(-12.3, 45.6, 0.1, 0.3, cols, rows, std::move(h));
}

// Query points: random ones inside and around the grid, every grid line and both far edges
// exactly, and NaN/inf.
std::vector<std::pair<double, double>> queryPoints(const ElevationGrid& g)
{
  std::vector<std::pair<double, double>> q;
  const double x0 = g.originX(), y0 = g.originY();
  const double x1 = x0 + (g.columns() - 1) * g.dx(), y1 = y0 + (g.rows() - 1) * g.dy();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> px(x0 - 0.5, x1 + 0.5), py(y0 - 0.5, y1 + 0.5);
  for (int k = 0; k < 20000; ++k)
    q.emplace_back(px(rng), py(rng));
  for (std::size_t i = 0; i < g.columns(); ++i)
    for (std::size_t j = 0; j < g.rows(); ++j)
      q.emplace_back(x0 + i * g.dx(), y0 + j * g.dy());
  q.emplace_back(x1, y1);
  q.emplace_back(x1, y0);
  q.emplace_back(std::nextafter(x1, 1e9), y0);
  q.emplace_back(x0, std::nextafter(y0, -1e9));
  q.emplace_back(std::nan(""), y0);
  q.emplace_back(x0, std::numeric_limits<double>::infinity());
  return q;
}
}  // namespace

TEST(ElevationGrid, FastPathsMatchTheLiteralFormulaBitForBit)
{
  const ElevationGrid grid = roughGrid();
  const auto points = queryPoints(grid);
  std::vector<double> xy;
  for (const auto& p : points)
  {
    xy.push_back(p.first);
    xy.push_back(p.second);
  }
  std::vector<double> batch(points.size(), 123.0);
  const std::size_t inside = grid.heights(xy.data(), batch.data(), points.size());

  std::size_t expected_inside = 0;
  for (std::size_t k = 0; k < points.size(); ++k)
  {
    const double x = points[k].first, y = points[k].second;
    double ref = 0.0;
    const bool in = referenceHeight(grid, x, y, ref);
    expected_inside += in ? 1 : 0;
    double fast = -999.0;
    ASSERT_EQ(grid.heightAt(x, y, fast), in) << x << ", " << y;
    const auto opt = grid.height(x, y);
    ASSERT_EQ(opt.has_value(), in) << x << ", " << y;
    if (in)
    {
      // EXPECT_EQ on doubles is exact: any change of lookup or blend arithmetic fails here.
      ASSERT_EQ(fast, ref) << x << ", " << y;
      ASSERT_EQ(*opt, ref) << x << ", " << y;
      ASSERT_EQ(batch[k], ref) << "batch point " << k << " at " << x << ", " << y;
    }
    else
    {
      EXPECT_EQ(fast, -999.0) << "heightAt must leave h alone outside";
      ASSERT_TRUE(std::isnan(batch[k])) << "batch point " << k << " at " << x << ", " << y;
    }
  }
  EXPECT_EQ(inside, expected_inside);
  EXPECT_GT(inside, points.size() / 2);
  EXPECT_LT(inside, points.size());
}

TEST(ElevationGrid, BatchHandlesEmptyAndPartialBlocks)
{
  const ElevationGrid grid = roughGrid();
  EXPECT_EQ(grid.heights(nullptr, nullptr, 0), 0u);
  // 1, 15, 16, 17 and 33 points: below, at and past the batch's block size.
  for (std::size_t n : { 1u, 15u, 16u, 17u, 33u })
  {
    std::vector<double> xy, out(n + 1, 7.0);
    for (std::size_t k = 0; k < n; ++k)
    {
      xy.push_back(-12.0 + 0.13 * k);
      xy.push_back(46.0 + 0.29 * k);
    }
    EXPECT_EQ(grid.heights(xy.data(), out.data(), n), n);
    for (std::size_t k = 0; k < n; ++k)
      EXPECT_EQ(out[k], *grid.height(xy[2 * k], xy[2 * k + 1]));
    EXPECT_EQ(out[n], 7.0) << "wrote past the end";
  }
}
