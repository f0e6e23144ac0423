// OctoMap occupancy: a wall ahead becomes occupied and the space before it free, the 2-D grid
// marks it (height above terrain), max range clips rays, a lidar sweep over a scene does the
// same, .bt save/load round-trips the occupied cells, bad configuration names the field.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/occupancy.hpp"
#include "avsp_sensors/scene.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;
using Eigen::Vector3f;

namespace
{
/// A wall's face at x = wall_x (y in [-3, 3], z in [0.1, 2.9], 5 cm spacing) and the ground
/// z = 0 in front of it (x in [1, wall_x), |y| <= 3, 10 cm spacing), as a sensor sees them.
std::vector<Vector3f> wallAndGround(double wall_x)
{
  std::vector<Vector3f> pts;
  for (double y = -3.0; y <= 3.0 + 1e-9; y += 0.05)
    for (double z = 0.1; z <= 2.9 + 1e-9; z += 0.05)
      pts.emplace_back(static_cast<float>(wall_x), static_cast<float>(y), static_cast<float>(z));
  for (double x = 1.0; x < wall_x - 0.2; x += 0.1)
    for (double y = -3.0; y <= 3.0 + 1e-9; y += 0.1)
      pts.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
  return pts;
}

const TerrainHeightFn kFlat = [](double, double, double& z) {
  z = 0.0;
  return true;
};

GridProjection window()
{
  GridProjection g;
  g.origin_x = -2.0;
  g.origin_y = -5.0;
  g.width = 90;   // to x = 16 m
  g.height = 50;  // to y = 5 m
  return g;
}

std::vector<std::tuple<double, double, double, double>> sortedCells(const OccupancyMap& map)
{
  std::vector<std::tuple<double, double, double, double>> v;
  for (const OccupiedCell& c : map.occupiedCells())
    v.emplace_back(c.centre.x(), c.centre.y(), c.centre.z(), c.size);
  std::sort(v.begin(), v.end());
  return v;
}

std::string thrownMessage(const OccupancyConfig& c)
{
  try
  {
    OccupancyMap m(c);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Occupancy, WallAheadIsOccupiedAndTheSpaceBeforeItFree)
{
  OccupancyMap map;  // 0.2 m voxels
  map.insert(wallAndGround(10.05), Vector3d(0.0, 0.0, 1.0));
  // The wall's voxels: x in [10.0, 10.2).
  for (double y = -2.9; y <= 2.9; y += 0.2)
    for (double z = 0.3; z <= 2.7; z += 0.2)
      EXPECT_EQ(map.state(Vector3d(10.1, y, z)), CellState::kOccupied) << y << " " << z;
  // Before it, along the rays: free, up to the voxel right in front of the wall.
  for (double x = 0.5; x < 10.0; x += 0.2)
    EXPECT_EQ(map.state(Vector3d(x, 0.0, 1.0)), CellState::kFree) << x;
  EXPECT_EQ(map.state(Vector3d(9.9, 1.5, 2.0)), CellState::kFree);
  // Behind it and above the rays: never observed.
  EXPECT_EQ(map.state(Vector3d(11.1, 0.0, 1.0)), CellState::kUnknown);
  EXPECT_EQ(map.state(Vector3d(5.0, 0.0, 5.0)), CellState::kUnknown);
  // Every occupied cell is the wall's slab or the ground's layer.
  const auto cells = map.occupiedCells();
  ASSERT_FALSE(cells.empty());
  for (const OccupiedCell& c : cells)
  {
    EXPECT_DOUBLE_EQ(c.size, 0.2);
    EXPECT_TRUE(std::abs(c.centre.x() - 10.1) < 1e-4 || std::abs(std::abs(c.centre.z()) - 0.1) < 1e-4)
        << c.centre.transpose();
    EXPECT_GT(c.probability, 0.5);
  }
}

TEST(Occupancy, GridMarksTheWallByHeightAboveTerrain)
{
  OccupancyMap map;
  map.insert(wallAndGround(10.05), Vector3d(0.0, 0.0, 1.0));
  const OccupancyGrid2D grid = map.projectGrid(window(), kFlat);
  ASSERT_EQ(grid.width, 90u);
  ASSERT_EQ(grid.height, 50u);
  EXPECT_DOUBLE_EQ(grid.resolution, 0.2);
  ASSERT_EQ(grid.data.size(), 90u * 50u);
  // The wall: every cell of x in [10.0, 10.2), |y| < 3.
  for (double y = -2.9; y < 3.0; y += 0.2)
    EXPECT_EQ(grid.atPoint(10.1, y), OccupancyGrid2D::kOccupied) << y;
  // In front of it the ground was seen (its voxels sit +-0.1 m from the terrain, below the
  // 0.3 m obstacle height): free.
  for (double x = 1.1; x < 9.9; x += 0.2)
    for (double y = -2.5; y < 2.6; y += 0.5)
      EXPECT_EQ(grid.atPoint(x, y), OccupancyGrid2D::kFree) << x << " " << y;
  // Behind the wall and beyond its sides: unknown.
  for (double x = 10.5; x < 15.9; x += 0.4)
    EXPECT_EQ(grid.atPoint(x, 0.0), OccupancyGrid2D::kUnknown) << x;
  EXPECT_EQ(grid.atPoint(5.0, 4.5), OccupancyGrid2D::kUnknown);
  EXPECT_EQ(grid.atPoint(100.0, 0.0), OccupancyGrid2D::kUnknown);  // outside the grid
  // Cell (i, j) is data[j * width + i] and covers [origin + i res, origin + (i + 1) res).
  EXPECT_EQ(grid.at(static_cast<std::size_t>((10.1 + 2.0) / 0.2), static_cast<std::size_t>((0.1 + 5.0) / 0.2)),
            OccupancyGrid2D::kOccupied);

  // Raise the terrain under the wall to 2.7 m: its highest voxel (centre 2.9 m) now stands 0.2 m
  // above it, not above the 0.3 m obstacle height (a bank, not a wall).
  const TerrainHeightFn bank = [](double x, double, double& z) {
    z = (x >= 10.0 && x < 10.2) ? 2.7 : 0.0;
    return true;
  };
  EXPECT_EQ(map.projectGrid(window(), bank).atPoint(10.1, 0.1), OccupancyGrid2D::kFree);
  // Unknown terrain leaves the cell unknown.
  const TerrainHeightFn none = [](double, double, double&) { return false; };
  EXPECT_EQ(map.projectGrid(window(), none).atPoint(10.1, 0.1), OccupancyGrid2D::kUnknown);
  // An overhang: with max_height 1.0 m only wall voxels up to 1 m count; they still block.
  GridProjection low = window();
  low.max_height = 1.0;
  EXPECT_EQ(map.projectGrid(low, kFlat).atPoint(10.1, 0.1), OccupancyGrid2D::kOccupied);
  // Coarser grid: 0.4 m cells covering the wall's 0.2 m column still see it.
  GridProjection coarse = window();
  coarse.resolution = 0.4;
  coarse.width = 45;
  coarse.height = 25;
  EXPECT_EQ(map.projectGrid(coarse, kFlat).atPoint(10.1, 0.1), OccupancyGrid2D::kOccupied);
}

TEST(Occupancy, MaxRangeClipsRays)
{
  OccupancyConfig c;
  c.max_range = 30.0;
  OccupancyMap map(c);
  std::vector<Vector3f> pts;
  for (double y = -1.0; y <= 1.0; y += 0.05)
    pts.emplace_back(40.05f, static_cast<float>(y), 1.0f);  // a wall at 40 m
  map.insert(pts, Vector3d(0.0, 0.0, 1.0));
  EXPECT_EQ(map.state(Vector3d(25.1, 0.0, 1.1)), CellState::kFree);
  EXPECT_EQ(map.state(Vector3d(29.7, 0.0, 1.1)), CellState::kFree);
  EXPECT_EQ(map.state(Vector3d(32.1, 0.0, 1.1)), CellState::kUnknown);
  EXPECT_EQ(map.state(Vector3d(40.1, 0.0, 1.1)), CellState::kUnknown);
  EXPECT_TRUE(map.occupiedCells().empty());
}

TEST(Occupancy, LidarSweepOverAWallMarksIt)
{
  // VLP-16 2 m above flat ground, a 0.4 m thick wall whose face is 12.1 m ahead, in the middle
  // of the voxel column [12.0, 12.2) (1 cm range noise: every wall point stays in it).
  const auto n = static_cast<std::size_t>(2 * 60 / 1.0) + 1;
  Scene scene(HeightField(-60, -60, 1.0, 1.0, n, n, std::vector<float>(n * n, 0.f)));
  Primitive wall;
  wall.shape = Shape::kBox;
  wall.half_extents = Vector3d(0.2, 4.0, 1.5);
  wall.centre = Vector3d(12.3, 0.0, 1.5);
  scene.setStaticPrimitives({ wall });
  LidarConfig vlp16 = lidarPreset("VLP-16");
  vlp16.range_noise = 0.01;
  const Lidar lidar(vlp16, 1);
  for (const bool registered : { true, false })
  {
    LidarScanRequest req;
    req.motion.pose.translation() = Vector3d(0.0, 0.0, 2.0);
    req.motion.linear_velocity = Vector3d(2.0, 0.0, 0.0);  // 0.2 m during the sweep
    req.registered = registered;
    const LidarScan scan = lidar.scan(scene, req);
    OccupancyMap map;
    map.insert(scan, req.motion, 4);
    const OccupancyGrid2D grid = map.projectGrid(window(), kFlat);
    int wall_cells = 0;
    for (double y = -2.9; y < 3.0; y += 0.2)
      wall_cells += grid.atPoint(12.1, y) == OccupancyGrid2D::kOccupied;
    EXPECT_GE(wall_cells, 28) << "registered " << registered;  // of 30
    // The ground between the lowest ring's footprint (7.5 m) and the wall was seen: free; so is
    // the sensor's surroundings, seen by rays passing over them below 1 m.
    for (double x = 4.1; x < 11.9; x += 0.4)
      EXPECT_EQ(grid.atPoint(x, 0.1), OccupancyGrid2D::kFree) << x << " registered " << registered;
    EXPECT_EQ(grid.atPoint(13.5, 0.1), OccupancyGrid2D::kUnknown);  // in the wall's shadow
    // Nothing else stands above the ground.
    int occupied = 0;
    for (std::int8_t v : grid.data)
      occupied += v == OccupancyGrid2D::kOccupied;
    EXPECT_LE(occupied, 42) << "registered " << registered;  // the wall's column: 40 cells
  }
}

TEST(Occupancy, RainClutterClearsTheSpaceInsteadOfStandingInIt)
{
  // A parked VLP-16 in heavy rain by a wall, 30 sweeps. Particle echoes come from within 10 m of
  // the sensor, many from its upward rings, where no later return passes: inserted as returns
  // they would stay occupied for good (the map, and a soak's memory, grow with the rain); as
  // what they are, rays through free space, they leave nothing standing above the wall.
  const auto n = static_cast<std::size_t>(2 * 60 / 1.0) + 1;
  Scene scene(HeightField(-60, -60, 1.0, 1.0, n, n, std::vector<float>(n * n, 0.f)));
  Primitive wall;
  wall.shape = Shape::kBox;
  wall.half_extents = Vector3d(0.2, 4.0, 1.5);
  wall.centre = Vector3d(12.3, 0.0, 1.5);
  scene.setStaticPrimitives({ wall });
  const Lidar lidar(lidarPreset("VLP-16"), 5);
  std::vector<LidarScan> scans;
  LidarScanRequest req;
  req.motion.pose.translation() = Vector3d(0.0, 0.0, 2.0);
  req.weather.rain_rate = 20.0;
  std::size_t echoes = 0;
  for (std::uint64_t k = 0; k < 30; ++k)
  {
    req.sweep = k;
    scans.push_back(lidar.scan(scene, req));
    echoes += scans.back().clutter;
  }
  ASSERT_GT(echoes, 300u);
  auto occupiedAbove = [](const OccupancyMap& map, double z) {
    int count = 0;
    for (const OccupiedCell& c : map.occupiedCells())
      count += c.centre.z() - 0.5 * c.size > z;
    return count;
  };
  OccupancyMap map, naive;
  for (const LidarScan& scan : scans)
  {
    map.insert(scan, req.motion, 1);
    LidarScan as_returns = scan;
    as_returns.particle_echo.clear();  // no point known as an echo
    naive.insert(as_returns, req.motion, 1);
  }
  EXPECT_EQ(occupiedAbove(map, 3.2), 0);  // the wall's top is at 3.0 m
  EXPECT_GT(occupiedAbove(naive, 3.2), 100);
  // The wall is mapped as before.
  const OccupancyGrid2D grid = map.projectGrid(window(), kFlat);
  int wall_cells = 0;
  for (double y = -2.9; y < 3.0; y += 0.2)
    wall_cells += grid.atPoint(12.1, y) == OccupancyGrid2D::kOccupied;
  EXPECT_GE(wall_cells, 28);
  // A scan whose flags do not match its points is refused, naming the field.
  LidarScan bad = scans.front();
  bad.particle_echo.pop_back();
  try
  {
    map.insert(bad, req.motion, 1);
    FAIL() << "accepted " << bad.particle_echo.size() << " flags for " << bad.points.size() << " points";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("particle_echo"), std::string::npos) << e.what();
  }
}

TEST(Occupancy, ClearRaysFreeTheirPathButNeverOccupyTheirEnd)
{
  OccupancyMap map;
  const Vector3d origin(0.0, 0.0, 1.0);
  // A return 5 m ahead, and a clear ray (nothing met) 5 m to the left.
  map.insert({ Vector3f(5.05f, 0.05f, 1.05f) }, { Vector3f(0.05f, 5.05f, 1.05f) }, origin);
  EXPECT_EQ(map.state(Vector3d(5.1, 0.1, 1.1)), CellState::kOccupied);
  EXPECT_EQ(map.state(Vector3d(0.1, 5.1, 1.1)), CellState::kUnknown);  // its end: not observed
  for (double y = 0.5; y < 4.9; y += 0.2)
    EXPECT_EQ(map.state(Vector3d(0.1, y, 1.1)), CellState::kFree) << y;
  // A voxel a return made occupied is freed by clear rays through it, as by any ray: log-odds
  // ln(0.7 / 0.3) = 0.847 after the hit, -ln(0.6 / 0.4) = -0.405 per pass, so the third frees it.
  for (int pass = 1; pass <= 3; ++pass)
  {
    map.insert({}, { Vector3f(9.05f, 0.05f, 1.05f) }, origin);
    EXPECT_EQ(map.state(Vector3d(5.1, 0.1, 1.1)), pass < 3 ? CellState::kOccupied : CellState::kFree) << pass;
  }
  EXPECT_THROW(map.insert({}, { Vector3f(std::nanf(""), 0.f, 0.f) }, origin), std::invalid_argument);
}

namespace
{
/// Every leaf of both trees, in the same depth-first order: same key, depth and log-odds.
void expectSameTree(const octomap::OcTree& a, const octomap::OcTree& b, const std::string& what)
{
  ASSERT_EQ(a.size(), b.size()) << what;
  auto ia = a.begin_leafs(), ib = b.begin_leafs();
  std::size_t n = 0;
  for (; ia != a.end_leafs() && ib != b.end_leafs(); ++ia, ++ib, ++n)
  {
    ASSERT_EQ(ia.getKey(), ib.getKey()) << what << " leaf " << n;
    ASSERT_EQ(ia.getDepth(), ib.getDepth()) << what << " leaf " << n;
    ASSERT_EQ(ia->getLogOdds(), ib->getLogOdds()) << what << " leaf " << n;
  }
  EXPECT_TRUE(ia == a.end_leafs() && ib == b.end_leafs()) << what;
  EXPECT_GT(n, 1000u) << what;
}
}  // namespace

TEST(Occupancy, BatchedInsertionGivesOctomapsOwnTree)
{
  // Successive scans from moving origins: voxels saturate, pruned blocks get expanded again,
  // hits turn free and back. Every variant must match insertPointCloud leaf by leaf.
  std::vector<std::pair<std::vector<Vector3f>, Vector3d>> scans;
  for (int k = 0; k < 8; ++k)
  {
    std::vector<Vector3f> pts = wallAndGround(10.05 - 0.3 * (k % 4));
    // A few far returns beyond 30 m and some scatter.
    for (int m = 0; m < 400; ++m)
    {
      const double a = 0.0157 * m;
      pts.emplace_back(static_cast<float>(35.0 * std::cos(a)), static_cast<float>(35.0 * std::sin(a)),
                       static_cast<float>(0.5 + 0.01 * (m % 50)));
    }
    scans.emplace_back(pts, Vector3d(0.1 * k, 0.05 * k, 1.0 + 0.02 * k));
  }
  const double inf = std::numeric_limits<double>::infinity();
  const std::tuple<bool, double, unsigned> variants[] = {
    { false, 30.0, 1u }, { false, 30.0, 2u }, { false, inf, 1u }, { true, 30.0, 3u }, { true, inf, 2u }
  };
  for (const auto& [discretize, max_range, threads] : variants)
  {
    OccupancyConfig c;
    c.discretize = discretize;
    c.max_range = max_range;
    c.threads = threads;
    OccupancyMap ours(c), reference(c);
    for (const auto& scan : scans)
    {
      ours.insert(scan.first, scan.second);
      reference.insertWithOctomap(scan.first, scan.second);
    }
    expectSameTree(ours.tree(), reference.tree(),
                   "discretize " + std::to_string(discretize) + " max_range " + std::to_string(max_range) +
                       " threads " + std::to_string(threads));
  }
}

TEST(Occupancy, SaveLoadRoundTripKeepsTheOccupiedCells)
{
  OccupancyMap map;
  map.insert(wallAndGround(10.05), Vector3d(0.0, 0.0, 1.0));
  map.insert(wallAndGround(7.45), Vector3d(0.0, 0.5, 1.2));
  const std::string path = ::testing::TempDir() + "avsp_test_occupancy.bt";
  map.save(path);
  OccupancyConfig other;
  other.resolution = 0.5;  // replaced by the file's
  const OccupancyMap back = OccupancyMap::load(path, other);
  std::remove(path.c_str());
  EXPECT_DOUBLE_EQ(back.resolution(), 0.2);
  EXPECT_EQ(sortedCells(back), sortedCells(map));
  EXPECT_GT(sortedCells(map).size(), 1000u);
  for (double x = -1.0; x < 12.0; x += 0.3)
    for (double z = -0.5; z < 3.5; z += 0.3)
      EXPECT_EQ(back.state(Vector3d(x, 0.3, z)), map.state(Vector3d(x, 0.3, z))) << x << " " << z;
  EXPECT_EQ(back.projectGrid(window(), kFlat).data, map.projectGrid(window(), kFlat).data);
  EXPECT_THROW(OccupancyMap::load(::testing::TempDir() + "avsp_no_such_map.bt"), std::runtime_error);
  EXPECT_THROW(map.save("/nonexistent_dir/avsp.bt"), std::runtime_error);
  // A full disk is a failure, not a success with a truncated file (OctoMap's writer said true).
  EXPECT_THROW(map.save("/dev/full"), std::runtime_error);
}

TEST(Occupancy, BadConfigAndInputNameTheField)
{
  OccupancyConfig c;
  c.resolution = 0.0;
  EXPECT_NE(thrownMessage(c).find("resolution"), std::string::npos);
  c = OccupancyConfig();
  c.max_range = std::nan("");
  EXPECT_NE(thrownMessage(c).find("max_range"), std::string::npos);
  c = OccupancyConfig();
  c.prob_hit = 0.4;
  EXPECT_NE(thrownMessage(c).find("prob_hit"), std::string::npos);
  c = OccupancyConfig();
  c.prob_miss = 0.6;
  EXPECT_NE(thrownMessage(c).find("prob_miss"), std::string::npos);
  c = OccupancyConfig();
  c.clamping_max = 0.1;
  EXPECT_NE(thrownMessage(c).find("clamping_max"), std::string::npos);
  c = OccupancyConfig();
  c.occupancy_threshold = 1.0;
  EXPECT_NE(thrownMessage(c).find("occupancy_threshold"), std::string::npos);

  OccupancyMap map;
  GridProjection g = window();
  g.width = 0;
  try
  {
    map.projectGrid(g, kFlat);
    ADD_FAILURE() << "no throw";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("width"), std::string::npos);
  }
  g = window();
  g.max_height = 0.2;  // below obstacle_height
  try
  {
    map.projectGrid(g, kFlat);
    ADD_FAILURE() << "no throw";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("max_height"), std::string::npos);
  }
  EXPECT_THROW(map.insert({ Vector3f(1, 2, std::nanf("")) }, Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(map.insert({ Vector3f(1, 2, 3) }, Vector3d(0, std::nan(""), 0)), std::invalid_argument);
}

TEST(Occupancy, VoxelGridCentroidsAreTheMeansOfEachLeaf)
{
  // Points in three 0.2 m cubes (one of them straddling zero): one centroid per cube, each the
  // mean of its points, computed here by hand.
  const std::vector<Vector3f> pts{ { 0.05f, 0.05f, 0.05f }, { 0.15f, 0.05f, 0.15f }, { 0.11f, 0.19f, 0.01f },
                                   { 1.01f, 0.01f, 0.01f }, { 1.19f, 0.19f, 0.19f }, { -0.05f, -0.1f, 0.1f } };
  const std::vector<Vector3f> got = voxelGridCentroids(pts, 0.2);
  ASSERT_EQ(got.size(), 3u);
  const std::vector<Vector3f> want{ (pts[0] + pts[1] + pts[2]) / 3.0f, (pts[3] + pts[4]) / 2.0f, pts[5] };
  for (const Vector3f& w : want)
    EXPECT_TRUE(std::any_of(got.begin(), got.end(), [&](const Vector3f& g) { return (g - w).norm() < 1e-6f; }))
        << w.transpose();
  EXPECT_TRUE(voxelGridCentroids({}, 0.2).empty());
}

TEST(Occupancy, VoxelFilterKeepsTheOccupiedVoxelsAndCutsTheRays)
{
  // A wall face (5 cm grid) and the ground before it (10 cm grid), no point on a voxel face
  // (there PCL's float and OctoMap's double arithmetic may pick neighbouring voxels). With
  // discretize the filter gives the same tree leaf by leaf (rays end at the voxel centres
  // either way); without it, one ray per voxel ends at the points' centroid, in the same voxel,
  // so the occupied voxels are those of the exact insertion.
  std::vector<Vector3f> pts;
  for (int j = 0; j < 120; ++j)
    for (int k = 0; k < 56; ++k)
      pts.emplace_back(10.05f, -2.975f + 0.05f * static_cast<float>(j), 0.125f + 0.05f * static_cast<float>(k));
  for (int i = 0; i < 88; ++i)
    for (int j = 0; j < 60; ++j)
      pts.emplace_back(1.05f + 0.1f * static_cast<float>(i), -2.95f + 0.1f * static_cast<float>(j), 0.05f);
  const Vector3d origin(0.0, 0.0, 1.0);
  for (const bool discretize : { true, false })
  {
    OccupancyConfig plain, filtered;
    plain.discretize = filtered.discretize = discretize;
    filtered.voxel_filter = true;
    OccupancyMap a(plain), b(filtered);
    a.insert(pts, origin);
    b.insert(pts, origin);
    EXPECT_EQ(sortedCells(a), sortedCells(b)) << "discretize " << discretize;
    if (discretize)
      expectSameTree(a.tree(), b.tree(), "discretize with and without the voxel filter");
    EXPECT_EQ(b.state(Vector3d(10.1, 0.1, 1.5)), CellState::kOccupied);
    EXPECT_EQ(b.state(Vector3d(5.1, 0.1, 1.0)), CellState::kFree);
  }
  // The filter merges the 5 cm wall grid 4 x 4 into each 0.2 m voxel: far fewer rays.
  EXPECT_LT(voxelGridCentroids(pts, 0.2).size(), pts.size() / 4);
}
