// Prints the cost of clustering one VLP-16 sweep (LidarClusterer: ground removal against the
// terrain, then PCL's Euclidean cluster extraction and the ring links) on the default course, on
// one core (target <= 10 ms per sweep), with what it found, and without the ring links; and, for
// the choice of ground removal, the cost of PCL's progressive morphological filter on the same
// sweep and how many of the points it calls ground lie above the terrain by more than the
// clearance. Figures are printed, not asserted.
//
// Usage: bench_lidar_clustering [x y] (map position, default (150, 340): in the woods along the
// course's north edge, where a sweep holds the most objects; the course's middle is open ground)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <pcl/point_types.h>
#include <pcl/segmentation/progressive_morphological_filter.h>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/lidar_clustering.hpp"
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
}  // namespace

int main(int argc, char** argv)
{
  const double x = argc > 2 ? std::atof(argv[1]) : 150.0, y = argc > 2 ? std::atof(argv[2]) : 340.0;
  const avsp::terrain::Course course = avsp::terrain::makeDefaultCourse(avsp::terrain::CourseOptions());
  Scene scene(HeightField::fromGrid(course.heights));
  scene.setObjects(course.objects);
  double z = 0.0;
  scene.terrain().heightAt(x, y, z);
  const Lidar lidar(lidarPreset("VLP-16"), 1);
  LidarScanRequest req;
  req.motion.pose.translation() = Eigen::Vector3d(x, y, z + 2.0);
  req.motion.linear_velocity = Eigen::Vector3d(5.0, 0.0, 0.0);
  req.threads = 1;
  const LidarScan scan = lidar.scan(scene, req);
  const TerrainHeightFn terrain = [&scene](double px, double py, double& pz) {
    return scene.terrain().heightAt(px, py, pz);
  };

  const LidarClusterConfig config;
  const LidarClusterer clusterer(config);
  std::vector<double> times;
  LidarClustering r;
  for (int rep = 0; rep < 21; ++rep)
  {
    const auto t0 = Clock::now();
    r = clusterer.cluster(scan, req.motion, terrain);
    times.push_back(seconds(t0));
  }
  std::sort(times.begin(), times.end());
  std::printf("VLP-16 sweep at (%.0f, %.0f), 2 m up, 5 m/s: %zu points; %zu ground, %zu above %.2f m\n", x, y,
              scan.points.size(), r.ground_points, r.object_points, config.ground_clearance);
  std::printf(
      "lidar clustering (1 thread, tolerance %.2f m on x-y, min %zu points): best %.2f ms, median %.2f ms "
      "per sweep; %zu clusters (largest %zu points), %zu groups joined by ring links\n",
      config.cluster_tolerance, config.min_points, 1e3 * times.front(), 1e3 * times[times.size() / 2],
      r.clusters.size(), r.clusters.empty() ? std::size_t{ 0 } : r.clusters.front().size(), r.ring_links);
  {
    LidarClusterConfig plain = config;
    plain.ring_link_angle = 0.5 * 3.14159265358979323846;  // no ring links: the plan tolerance alone
    const LidarClusterer clusterer0(plain);
    std::vector<double> t0s;
    LidarClustering r0;
    for (int rep = 0; rep < 11; ++rep)
    {
      const auto t0 = Clock::now();
      r0 = clusterer0.cluster(scan, req.motion, terrain);
      t0s.push_back(seconds(t0));
    }
    std::sort(t0s.begin(), t0s.end());
    std::printf("  without ring links: best %.2f ms, median %.2f ms; %zu clusters\n", 1e3 * t0s.front(),
                1e3 * t0s[t0s.size() / 2], r0.clusters.size());
  }
  {
    LidarClusterConfig c3 = config;
    c3.use_height = true;
    const LidarClusterer clusterer3(c3);
    std::vector<double> t3;
    LidarClustering r3;
    for (int rep = 0; rep < 11; ++rep)
    {
      const auto t0 = Clock::now();
      r3 = clusterer3.cluster(scan, req.motion, terrain);
      t3.push_back(seconds(t0));
    }
    std::sort(t3.begin(), t3.end());
    std::printf("  with use_height (3-D distances): best %.2f ms, median %.2f ms; %zu clusters\n", 1e3 * t3.front(),
                1e3 * t3[t3.size() / 2], r3.clusters.size());
  }
  // Ground removal alone (a cluster tolerance nothing can join: every point its own group).
  {
    std::size_t ground = 0;
    const auto t0 = Clock::now();
    for (const LidarPoint& p : scan.points)
    {
      double g = 0.0;
      ground += terrain(p.x, p.y, g) && p.z - g < config.ground_clearance;
    }
    std::printf("  of which the terrain height test: %.2f ms (%zu ground)\n", 1e3 * seconds(t0), ground);
  }

  // PCL's progressive morphological filter (Zhang et al. 2003) on the same points, with the
  // parameters of PCL's tutorial (window up to 20 cells of 1 m, slope 1, 0.5-3 m).
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz(new pcl::PointCloud<pcl::PointXYZ>);
  for (const LidarPoint& p : scan.points)
    xyz->push_back(pcl::PointXYZ(p.x, p.y, p.z));
  pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> pmf;
  pmf.setInputCloud(xyz);
  pmf.setMaxWindowSize(20);
  pmf.setSlope(1.0f);
  pmf.setInitialDistance(0.5f);
  pmf.setMaxDistance(3.0f);
  pcl::Indices ground;
  const auto t0 = Clock::now();
  pmf.extract(ground);
  const double pmf_time = seconds(t0);
  std::size_t wrong = 0;
  for (const auto i : ground)
  {
    const LidarPoint& p = scan.points[static_cast<std::size_t>(i)];
    double g = 0.0;
    wrong += terrain(p.x, p.y, g) && p.z - g >= config.ground_clearance;
  }
  std::printf(
      "progressive morphological filter: %.1f ms, %zu ground points, %zu of them more than %.2f m above "
      "the terrain (object points lost)\n",
      1e3 * pmf_time, ground.size(), wrong, config.ground_clearance);
  return 0;
}
