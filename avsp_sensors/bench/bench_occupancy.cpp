// Prints the cost of inserting one VLP-16 sweep into a vehicle's OctoMap at 0.2 m on the default
// course (600 m x 400 m at 0.1 m, ~1090 objects), target <= 20 ms per sweep: into an empty map
// and into a map that already holds the previous sweeps of a vehicle driving at 5 m/s; with the
// default 30 m insertion range and with the lidar's full 100 m; with and without OctoMap's
// discretisation; with and without the PCL VoxelGrid pre-filter (OccupancyConfig::voxel_filter).
// Also the 2-D projection of a 60 m x 60 m window.
//
// Usage: bench_occupancy [x y] (map position, default the middle of the course)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/occupancy.hpp"
#include "avsp_sensors/scene.hpp"
#include "avsp_terrain/default_course.hpp"

using namespace avsp::sensors;
using Clock = std::chrono::steady_clock;

namespace
{
double seconds(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// octomap's own insertPointCloud on the same sweep, for comparison (best of 5).
void benchOctomapReference(const LidarScan& scan, const SensorMotion& motion)
{
  std::vector<Eigen::Vector3f> pts;
  for (const LidarPoint& p : scan.points)
    pts.emplace_back(p.x, p.y, p.z);
  const Eigen::Vector3d origin = motion.at(0.5 * scan.duration).translation();
  for (const bool discretize : { false, true })
  {
    OccupancyConfig config;
    config.discretize = discretize;
    double best = 1e300;
    for (int rep = 0; rep < 5; ++rep)
    {
      OccupancyMap map(config);
      const auto t0 = Clock::now();
      map.insertWithOctomap(pts, origin);
      best = std::min(best, seconds(t0));
    }
    std::printf("reference octomap::OcTree::insertPointCloud, max_range 30 m, discretize %-3s: first sweep %6.1f ms\n",
                discretize ? "yes" : "no", 1e3 * best);
  }
}

/// Projects the map's cells within 30 m onto a 300 x 300 grid at 0.2 m round (x, y): best of 5.
void benchGridProjection(const OccupancyMap& map, const Scene& scene, double x, double y)
{
  GridProjection g;
  g.width = g.height = 300;
  g.origin_x = x - 30.0;
  g.origin_y = y - 30.0;
  const TerrainHeightFn ground = [&](double gx, double gy, double& gz) { return scene.terrain().heightAt(gx, gy, gz); };
  double best = 1e300;
  OccupancyGrid2D grid;
  for (int rep = 0; rep < 5; ++rep)
  {
    const auto t0 = Clock::now();
    grid = map.projectGrid(g, ground);
    best = std::min(best, seconds(t0));
  }
  std::size_t occupied = 0, free_cells = 0;
  for (const std::int8_t v : grid.data)
  {
    occupied += v == OccupancyGrid2D::kOccupied;
    free_cells += v == OccupancyGrid2D::kFree;
  }
  std::printf("2-D grid 300 x 300 cells (60 m x 60 m at 0.2 m): %6.1f ms; %zu occupied, %zu free, %zu unknown\n",
              1e3 * best, occupied, free_cells, grid.data.size() - occupied - free_cells);
}

}  // namespace

int main(int argc, char** argv)
{
  const double x = argc > 2 ? std::atof(argv[1]) : 300.0, y = argc > 2 ? std::atof(argv[2]) : 200.0;
  const avsp::terrain::Course course = avsp::terrain::makeDefaultCourse(avsp::terrain::CourseOptions());
  Scene scene(HeightField::fromGrid(course.heights));
  scene.setObjects(course.objects);
  const Lidar lidar(lidarPreset("VLP-16"), 1);
  const double speed = 5.0;
  const int sweeps = 10;
  std::vector<LidarScan> scans;
  std::vector<SensorMotion> motions;
  for (int k = 0; k < sweeps; ++k)
  {
    const double px = x + speed * 0.1 * k;
    double z = 0.0;
    scene.terrain().heightAt(px, y, z);
    LidarScanRequest req;
    req.motion.pose.translation() = Eigen::Vector3d(px, y, z + 2.0);
    req.motion.linear_velocity = Eigen::Vector3d(speed, 0.0, 0.0);
    req.sweep = static_cast<std::uint64_t>(k);
    req.threads = 0;
    scans.push_back(lidar.scan(scene, req));
    motions.push_back(req.motion);
  }
  std::printf("VLP-16 at (%.0f, %.0f), 2 m above the ground, %.0f m/s: %zu points per sweep (of %zu pulses)\n", x, y,
              speed, scans[0].points.size(), scans[0].pulses);

  const struct
  {
    double max_range;
    bool discretize;
    unsigned threads;
    bool voxel_filter;
  } variants[] = { { 30.0, false, 1, false }, { 30.0, false, 2, false }, { 30.0, true, 1, false },
                   { 30.0, false, 1, true },  { 30.0, true, 1, true },   { 100.0, false, 1, false },
                   { 100.0, true, 1, false }, { 100.0, false, 1, true } };
  benchOctomapReference(scans[0], motions[0]);
  for (const auto& v : variants)
  {
    const double max_range = v.max_range;
    const bool discretize = v.discretize;
    OccupancyConfig config;
    config.max_range = max_range;
    config.discretize = discretize;
    config.threads = v.threads;
    config.voxel_filter = v.voxel_filter;
    // One sweep into an empty map, best of 5 (the machine is shared).
    double first = 1e300;
    for (int rep = 0; rep < 5; ++rep)
    {
      OccupancyMap map(config);
      const auto t0 = Clock::now();
      map.insert(scans[0], motions[0], 1);
      first = std::min(first, seconds(t0));
    }
    // Sweeps 1..9 into a map holding the sweeps before them: the steady state while driving.
    OccupancyMap map(config);
    map.insert(scans[0], motions[0], 1);
    double total = 0.0, worst = 0.0;
    for (int k = 1; k < sweeps; ++k)
    {
      const auto t0 = Clock::now();
      map.insert(scans[k], motions[k], 1);
      const double s = seconds(t0);
      total += s;
      worst = std::max(worst, s);
    }
    std::size_t occupied = 0;
    for (const OccupiedCell& c : map.occupiedCells())
      occupied += c.size <= config.resolution * 1.5;
    std::printf(
        "insert at 0.2 m, max_range %5.0f m, discretize %-3s, voxel filter %-3s, %u thread%s: first sweep "
        "%6.1f ms; next %d sweeps mean %6.1f ms, worst %6.1f ms; %zu leaves, %zu occupied voxels, %.1f MB\n",
        max_range, discretize ? "yes" : "no", v.voxel_filter ? "yes" : "no", v.threads, v.threads > 1 ? "s" : " ",
        1e3 * first, sweeps - 1, 1e3 * total / (sweeps - 1), 1e3 * worst, map.leafCount(), occupied,
        map.memoryUsage() / 1e6);
    if (max_range == 30.0 && !discretize && v.threads == 1 && !v.voxel_filter)
      benchGridProjection(map, scene, x, y);
  }
  return 0;
}
