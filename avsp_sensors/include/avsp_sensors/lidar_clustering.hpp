#pragma once
/**
 * @file lidar_clustering.hpp
 * @brief Objects in a lidar sweep: the points higher than `ground_clearance` above the scene's
 *        own terrain are kept (the height test the OctoMap's 2-D grid uses), then grouped by
 *        PCL's Euclidean cluster extraction (pcl::EuclideanClusterExtraction on a kd-tree); each
 *        group is reported with its centroid, axis-aligned box and point count.
 *
 * Why the terrain and not a ground-fitting filter: the simulator knows its terrain exactly, and
 * lidar points of the ground lie on it to the range noise (docs/design/avsp_sensors.md, "The
 * terrain surface"). A plane fit (RANSAC) fails on the course's hills, and PCL's progressive
 * morphological filter needs a window and slope tuned per terrain, costs several times the
 * clustering on a VLP-16 sweep, and still cuts the feet off objects on slopes. The height test
 * is exact on any slope and costs one bilinear lookup per point.
 *
 * Why x, y only by default (`use_height` false, as Autoware's euclidean_cluster): a VLP-16's
 * rings are 2 deg apart, 0.52 m at 15 m and 1.05 m at 30 m, so a 3-D tolerance that keeps a
 * tree's rings together at 30 m would also join a deer to the vehicle beside it. On the ground
 * plane the points of one object are as dense as the azimuth step (0.2 deg: 0.1 m at 30 m).
 * Overhangs join what stands under them, which the course does not have.
 *
 * Why cells: PCL's kd-tree answers a radius query in microseconds, and a VLP-16 sweep in the
 * woods keeps ~7000 points above the ground; merging them per 0.1 m cell first (`cell_size`)
 * leaves a fraction of the queries for the same objects.
 *
 * No ROS types; the result is in the map frame, whatever frame the sweep was asked in.
 */
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/occupancy.hpp"
#include "avsp_sensors/point_types.hpp"

namespace avsp
{
namespace sensors
{
/// Clustering parameters (the node's `lidar/clustering/...`).
struct LidarClusterConfig
{
  /// m, > 0: two points closer than this (on the ground plane unless use_height) are in one
  /// cluster. 0.5 m: wider than the azimuth step at 100 m (0.35 m), narrower than the gap between
  /// objects the course keeps apart (trees are spaced > 1 m).
  double cluster_tolerance = 0.5;
  /// >= 1: smaller groups are dropped (a single return is a mixed pixel or a snowflake).
  std::size_t min_points = 5;
  /// >= min_points: larger groups are dropped, as PCL does (a building face, not an object).
  std::size_t max_points = 50000;
  /// m, >= 0: points lower than this above the terrain are ground. 0.3 m: the 2-D grid's
  /// obstacle_height (GridProjection), a small UGV's ground clearance.
  double ground_clearance = 0.3;
  /// true: 3-D distances; false: x and y only (see the file comment).
  bool use_height = false;
  /// m, [0, cluster_tolerance): points are first merged per cell of this size (in plan unless
  /// use_height) and the cells' centroids clustered, each point joining its cell's cluster. A
  /// lidar's rings stack a trunk's returns on a few plan cells, so this cuts the kd-tree queries
  /// several fold (figures: docs/benchmarks.md, "2026-12-03: PCL"). Gaps are then judged to
  /// within the cell's diagonal twice (0.28 m at 0.1 m); 0: every point queried, exact.
  double cell_size = 0.1;
};

/// @throw std::invalid_argument naming the field ("LidarClusterConfig: cluster_tolerance must
///        be finite and > 0 m (got 0)")
void validateLidarClusterConfig(const LidarClusterConfig& config);

/// One cluster. Coordinates in the map frame.
struct LidarCluster
{
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< m, mean of the points
  Eigen::Vector3d min = Eigen::Vector3d::Zero();       ///< m, lowest x, y, z of the points
  Eigen::Vector3d max = Eigen::Vector3d::Zero();       ///< m, highest x, y, z
  double range = 0.0;  ///< m, horizontal distance from the sensor (the `origin` given) to the centroid
  std::vector<int> indices;  ///< the points' indices in the input cloud, ascending

  std::size_t size() const { return indices.size(); }
  /// m, max - min
  Eigen::Vector3d extent() const { return max - min; }
};

/// What cluster() found.
struct LidarClustering
{
  /// Largest first; equal sizes by their lowest point index (deterministic whatever PCL's sort).
  std::vector<LidarCluster> clusters;
  std::size_t ground_points = 0;   ///< lower than ground_clearance above the terrain
  std::size_t invalid_points = 0;  ///< a NaN or infinite coordinate: skipped
  std::size_t object_points = 0;   ///< above the ground: the points clustered
};

/**
 * @brief Ground removal and Euclidean clustering with a fixed configuration. Reusable: holds
 *        no per-sweep state, safe to call from several threads on different sweeps.
 */
class LidarClusterer
{
public:
  /// @throw std::invalid_argument (validateLidarClusterConfig)
  explicit LidarClusterer(LidarClusterConfig config);

  const LidarClusterConfig& config() const { return config_; }

  /**
   * @brief Clusters points given in the map frame.
   * @param points any cloud; points with a NaN or infinite coordinate are skipped (counted)
   * @param origin m, map: the sensor, for LidarCluster::range
   * @param terrain height of the terrain at (x, y); where it answers false (off the terrain) a
   *        point counts as above the ground
   * @return no clusters for an empty cloud or one with nothing above the ground
   */
  LidarClustering cluster(const LidarCloud& points, const Eigen::Vector3d& origin,
                          const TerrainHeightFn& terrain) const;

  /**
   * @brief Clusters a sweep: its points as they are when registered, else each carried into the
   *        map by its firing pose (motion.at(time)); range from the pose at the sweep start.
   *        Cluster indices are those of scan.points.
   * @throw std::invalid_argument for a bad motion (validateMotion)
   */
  LidarClustering cluster(const LidarScan& scan, const SensorMotion& motion, const TerrainHeightFn& terrain) const;

private:
  LidarClusterConfig config_;
};

}  // namespace sensors
}  // namespace avsp
