// Height patches (what /terrain/ruts carries) and the chunked RViz mesh, without ROS.
#include <cmath>
#include <limits>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "avsp_terrain/height_patch.hpp"
#include "avsp_terrain/terrain_mesh.hpp"

namespace at = avsp::terrain;

namespace
{
/// A tilted plane z = 0.1 x - 0.05 y + 2 on 41 x 31 points at 0.25 m, origin (-3, 4).
at::DeformableTerrain plane()
{
  const std::size_t nx = 41, ny = 31;
  std::vector<float> h(nx * ny);
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx; ++i)
      h[j * nx + i] = static_cast<float>(0.1 * (-3 + 0.25 * i) - 0.05 * (4 + 0.25 * j) + 2.0);
  static const at::SoilLibrary soils = at::SoilLibrary::load(AVSP_CONFIG_DIR "/soils.yaml");
  return at::DeformableTerrain(at::ElevationGrid(-3.0, 4.0, 0.25, 0.25, nx, ny, std::move(h)), soils.get("sandy_loam"),
                               at::DeformableTerrain::Options{});
}

at::PointColour grey()
{
  return [](std::size_t, std::size_t) { return std::array<float, 3>{ 0.5f, 0.5f, 0.5f }; };
}
}  // namespace

TEST(HeightPatch, ExtractThenApplyElsewhereMovesTheHeights)
{
  at::DeformableTerrain source = plane(), target = plane();
  // Lower a 5 x 4 block of the source by applying a patch, then copy it to the target.
  at::HeightPatch rut = at::extractPatch(source, { 10, 7, 14, 10 });
  EXPECT_EQ(rut.width, 5u);
  EXPECT_EQ(rut.height, 4u);
  EXPECT_DOUBLE_EQ(rut.origin_x, -3.0 + 10 * 0.25);
  EXPECT_DOUBLE_EQ(rut.origin_y, 4.0 + 7 * 0.25);
  for (std::size_t k = 0; k < rut.heights.size(); ++k)
    rut.heights[k] -= 0.05f * static_cast<float>(k % 3 + 1);
  const auto range = at::applyPatch(source, rut);
  ASSERT_TRUE(range);
  EXPECT_EQ(range->i0, 10u);
  EXPECT_EQ(range->j1, 10u);

  for (const at::HeightPatch& p : at::deformedPatches(source))
    ASSERT_TRUE(at::applyPatch(target, p));
  for (std::size_t j = 0; j < 31; ++j)
    for (std::size_t i = 0; i < 41; ++i)
    {
      ASSERT_NEAR(target.pointHeight(i, j), source.pointHeight(i, j), 1e-6) << i << ", " << j;
      const bool inside = i >= 10 && i <= 14 && j >= 7 && j <= 10;
      if (inside)
        ASSERT_NEAR(source.pointHeight(i, j), rut.heights[(j - 7) * 5 + (i - 10)], 1e-6);
      else
        ASSERT_EQ(source.pointHeight(i, j), source.base().pointHeight(i, j));
    }
  // Plastic sinkage and stress history are kept; the change is booked as displaced soil.
  EXPECT_EQ(source.deformation(11, 8).plastic, 0.f);
  EXPECT_GT(source.deformation(11, 8).displaced, 0.f);
}

TEST(HeightPatch, ClipsToTheGridAndIgnoresPatchesOutsideIt)
{
  at::DeformableTerrain t = plane();
  at::HeightPatch p;
  p.origin_x = -3.0 - 2 * 0.25;  // two columns west of the grid
  p.origin_y = 4.0 + 29 * 0.25;  // the last two rows and two beyond
  p.resolution = 0.25;
  p.width = 4;
  p.height = 4;
  p.heights.assign(16, -1.0f);
  const auto range = at::applyPatch(t, p);
  ASSERT_TRUE(range);
  EXPECT_EQ(range->i0, 0u);
  EXPECT_EQ(range->i1, 1u);
  EXPECT_EQ(range->j0, 29u);
  EXPECT_EQ(range->j1, 30u);
  EXPECT_NEAR(t.pointHeight(0, 30), -1.0, 1e-6);
  EXPECT_NEAR(t.pointHeight(1, 29), -1.0, 1e-6);
  EXPECT_EQ(t.pointHeight(2, 29), t.base().pointHeight(2, 29));

  p.origin_x = 100.0;
  EXPECT_FALSE(at::applyPatch(t, p));
}

TEST(HeightPatch, FarAwayOriginsChangeNothing)
{
  // Issue 21: an origin of -1e300 m aborted terrain_node (a huge rounded origin cast to long)
  // and +1e300 m wrote into column 0. Every origin off the grid, however far, is a no-op.
  at::DeformableTerrain t = plane();
  at::HeightPatch p;
  p.resolution = 0.25;
  p.width = 2;
  p.height = 2;
  p.heights.assign(4, -1.0f);
  for (const double far : { -1e300, 1e300, -1e19, 1e19, -9.3e18, 9.3e18, -1e6, 1e6 })
  {
    for (const bool along_x : { true, false })
    {
      p.origin_x = along_x ? far : -3.0;
      p.origin_y = along_x ? 4.0 : far;
      EXPECT_FALSE(at::applyPatch(t, p)) << far << (along_x ? " in x" : " in y");
    }
  }
  for (std::size_t j = 0; j < 31; ++j)
    for (std::size_t i = 0; i < 41; ++i)
      ASSERT_EQ(t.pointHeight(i, j), t.base().pointHeight(i, j)) << i << ", " << j;
  // The patch just off each edge is outside too; one point over the edge is applied.
  p.origin_x = -3.0 - 2 * 0.25;
  p.origin_y = 4.0;
  EXPECT_FALSE(at::applyPatch(t, p));
  p.origin_x = -3.0 + 41 * 0.25;
  EXPECT_FALSE(at::applyPatch(t, p));
  p.origin_x = -3.0 - 1 * 0.25;
  EXPECT_TRUE(at::applyPatch(t, p));
}

TEST(HeightPatch, RefusesInconsistentPatchesByField)
{
  at::DeformableTerrain t = plane();
  at::HeightPatch good = at::extractPatch(t, { 0, 0, 3, 2 });
  auto expectError = [&](at::HeightPatch p, const std::string& words) {
    try
    {
      at::applyPatch(t, p);
      ADD_FAILURE() << "accepted a patch that should fail with '" << words << "'";
    }
    catch (const at::PatchError& e)
    {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  at::HeightPatch p = good;
  p.resolution = 0.5;
  expectError(p, "resolution");
  p = good;
  p.resolution = std::nan("");
  expectError(p, "resolution");
  p = good;
  p.origin_x += 0.1;
  expectError(p, "not on a grid point");
  p = good;
  p.heights.pop_back();
  expectError(p, "does not match");
  p = good;
  p.width = 0;
  expectError(p, "does not match");
  p = good;
  p.heights[3] = std::nanf("");
  expectError(p, "non-finite");
  p = good;
  p.origin_y = INFINITY;
  expectError(p, "origin");
  // Nothing was applied by the refused patches.
  for (std::size_t j = 0; j < 3; ++j)
    for (std::size_t i = 0; i < 4; ++i)
      EXPECT_EQ(t.pointHeight(i, j), t.base().pointHeight(i, j));
  EXPECT_THROW(at::extractPatch(t, { 0, 0, 41, 2 }), at::PatchError);
}

/// Issue 21: 3000 seeded patches mutated from good ones (origins off-grid, huge or not finite;
/// wrong or non-finite resolutions; sizes that do not match, or whose product overflows;
/// non-finite heights). None may crash; a refused or off-grid patch changes no point; an
/// applied one changes exactly the points of its returned range, to the patch's heights.
TEST(HeightPatch, SeededFuzzRefusalsChangeNothing)
{
  at::DeformableTerrain t = plane();
  const std::size_t nx = 41, ny = 31;
  std::vector<double> before(nx * ny);
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> choice(0, 9);
  std::uniform_int_distribution<int> index(-8, 48);
  std::uniform_int_distribution<std::size_t> size(1, 6);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double inf = std::numeric_limits<double>::infinity(), nan = std::nan("");
  const std::vector<double> wild = { 1e300, -1e300, 9.3e18, -9.3e18, inf, -inf, nan, 1e-300, 0.0 };
  int refused = 0, off_grid = 0, applied = 0;
  for (int k = 0; k < 3000; ++k)
  {
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i)
        before[j * nx + i] = t.pointHeight(i, j);
    at::HeightPatch p;
    p.resolution = 0.25;
    p.width = size(rng);
    p.height = size(rng);
    p.origin_x = -3.0 + 0.25 * index(rng);
    p.origin_y = 4.0 + 0.25 * index(rng);
    p.heights.resize(p.width * p.height);
    for (float& h : p.heights)
      h = static_cast<float>(2.0 + unit(rng));
    std::uniform_int_distribution<std::size_t> pick_wild(0, wild.size() - 1);
    switch (choice(rng))
    {
      case 0:
        p.origin_x = wild[pick_wild(rng)];
        break;
      case 1:
        p.origin_y += 0.25 * unit(rng);
        break;
      case 2:
        p.resolution = choice(rng) < 5 ? wild[pick_wild(rng)] : 0.25 * (1.0 + 1e-6 * unit(rng));
        break;
      case 3:
        p.heights.resize(p.heights.size() + (choice(rng) < 5 ? 1 : -1));
        break;
      case 4:
        p.heights[p.heights.size() / 2] = static_cast<float>(wild[pick_wild(rng)]);
        break;
      case 5:  // width x height overflows to the number of heights
        p.width = std::size_t{ 1 } << 33;
        p.height = std::size_t{ 1 } << 31;
        p.heights.clear();
        break;
      case 6:
        p.width = 0;
        break;
      default:
        break;  // a good patch, somewhere on or near the grid
    }
    std::optional<at::PointRange> range;
    bool threw = false;
    try
    {
      range = at::applyPatch(t, p);
    }
    catch (const at::PatchError& e)
    {
      threw = true;
      ASSERT_EQ(std::string(e.what()).rfind("TerrainPatch: ", 0), 0u) << e.what();
    }
    refused += threw;
    off_grid += !threw && !range;
    applied += range.has_value();
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i)
      {
        const bool changed = range && i >= range->i0 && i <= range->i1 && j >= range->j0 && j <= range->j1;
        if (!changed)
        {
          ASSERT_EQ(t.pointHeight(i, j), before[j * nx + i]) << "case " << k << " point " << i << ", " << j;
          continue;
        }
        const long c = static_cast<long>(std::lround((-3.0 + 0.25 * i - p.origin_x) / 0.25));
        const long r = static_cast<long>(std::lround((4.0 + 0.25 * j - p.origin_y) / 0.25));
        ASSERT_TRUE(c >= 0 && r >= 0 && c < static_cast<long>(p.width) && r < static_cast<long>(p.height));
        ASSERT_NEAR(t.pointHeight(i, j), p.heights[static_cast<std::size_t>(r) * p.width + c], 1e-6);
      }
  }
  // Each outcome occurred often: the generator reaches all three branches.
  EXPECT_GT(refused, 1000);
  EXPECT_GT(off_grid, 100);
  EXPECT_GT(applied, 300);
}

TEST(TerrainMesher, ChunksCoverTheGridOnceAtTheStride)
{
  at::DeformableTerrain t = plane();
  // 40 x 30 cells, stride 3, chunks of 12 cells: 4 x 3 chunks; the last column (40) and row
  // (30) are not on the stride but must be vertices.
  const at::TerrainMesher mesher(41, 31, 3, 12);
  ASSERT_EQ(mesher.chunksX(), 4u);
  ASSERT_EQ(mesher.chunksY(), 3u);
  double area = 0.0;
  std::set<std::pair<float, float>> xs_on_edge;
  for (std::size_t id = 0; id < mesher.chunkCount(); ++id)
  {
    const at::MeshChunk c = mesher.build(id, t, grey());
    ASSERT_EQ(c.vertices.size() % 3, 0u);
    ASSERT_EQ(c.colours.size(), c.vertices.size());
    for (std::size_t k = 0; k < c.vertices.size(); k += 3)
    {
      const auto &a = c.vertices[k], &b = c.vertices[k + 1], &d = c.vertices[k + 2];
      const double cross = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
      ASSERT_GT(cross, 0.0);
      area += 0.5 * cross;
    }
    for (const auto& v : c.vertices)
    {
      // On the plane (vertices sit on grid points; float heights).
      ASSERT_NEAR(v[2], 0.1 * v[0] - 0.05 * v[1] + 2.0, 1e-5);
      if (std::abs(v[0] - 7.0f) < 1e-5f)  // x of column 40
        xs_on_edge.emplace(v[0], v[1]);
    }
  }
  EXPECT_NEAR(area, 10.0 * 7.5, 1e-4);
  EXPECT_FALSE(xs_on_edge.empty());

  // A changed point on a chunk border belongs to both chunks; an interior one to one.
  EXPECT_EQ(mesher.chunksTouching({ 12, 5, 12, 5 }), (std::vector<std::size_t>{ 0, 1 }));
  EXPECT_EQ(mesher.chunksTouching({ 13, 13, 13, 13 }), (std::vector<std::size_t>{ 5 }));
  EXPECT_EQ(mesher.chunksTouching({ 40, 30, 40, 30 }), (std::vector<std::size_t>{ 11 }));
  EXPECT_TRUE(mesher.chunksTouching({ 50, 50, 60, 60 }).empty());

  EXPECT_THROW(at::TerrainMesher(41, 31, 3, 10), std::invalid_argument);
  EXPECT_THROW(at::TerrainMesher(41, 31, 0, 12), std::invalid_argument);
  EXPECT_THROW(at::TerrainMesher(1, 31, 1, 12), std::invalid_argument);
  EXPECT_THROW(mesher.chunkPoints(12), std::out_of_range);
}

TEST(TerrainMesher, DeformedDetailOnlyWhereTheTerrainDeformed)
{
  at::DeformableTerrain t = plane();
  const at::TerrainMesher mesher(41, 31, 4, 16);
  for (std::size_t id = 0; id < mesher.chunkCount(); ++id)
    EXPECT_TRUE(mesher.buildDeformed(id, t, grey(), 0.01f).vertices.empty());

  at::HeightPatch dip = at::extractPatch(t, { 20, 20, 20, 20 });
  dip.heights[0] -= 0.2f;
  ASSERT_TRUE(at::applyPatch(t, dip));
  const std::vector<std::size_t> ids = mesher.chunksTouching({ 20, 20, 20, 20 });
  ASSERT_EQ(ids, (std::vector<std::size_t>{ 4 }));
  const at::MeshChunk detail = mesher.buildDeformed(4, t, grey(), 0.01f);
  ASSERT_FALSE(detail.vertices.empty());
  bool found = false;
  for (const auto& v : detail.vertices)
  {
    const double plane_z = 0.1 * v[0] - 0.05 * v[1] + 2.0 + 0.01;
    const bool at_dip = std::abs(v[0] - 2.0f) < 1e-5f && std::abs(v[1] - 9.0f) < 1e-5f;  // point (20, 20)
    ASSERT_NEAR(v[2], at_dip ? plane_z - 0.2 : plane_z, 1e-5);
    found |= at_dip;
  }
  EXPECT_TRUE(found);
  // Full resolution: every cell of the deformed 8 x 8 tile, clipped to the chunk.
  EXPECT_EQ(detail.vertices.size() % 6, 0u);
  EXPECT_GE(detail.vertices.size(), 6u * 8 * 8);
  for (std::size_t id = 0; id < mesher.chunkCount(); ++id)
    if (id != 4)
      EXPECT_TRUE(mesher.buildDeformed(id, t, grey(), 0.01f).vertices.empty()) << id;
}
