#include <cmath>
#include <limits>

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
