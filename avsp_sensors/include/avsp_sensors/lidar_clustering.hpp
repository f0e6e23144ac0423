#pragma once
/**
 * @file lidar_clustering.hpp
 * @brief Objects in a lidar sweep: the points higher than `ground_clearance` above the scene's
 *        own terrain are kept (the height test the OctoMap's 2-D grid uses), then grouped by
 *        PCL's Euclidean cluster extraction (pcl::EuclideanClusterExtraction on a kd-tree), and
 *        groups joined where adjacent rings see one surface past an edge (ring links); each
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
 * Why ring links: on the ground plane, one object's points can lie farther apart along the
 * beam than any tolerance that keeps objects apart. A ring that hits a vehicle's rear face just
 * under its top edge and the ring 2 deg above it, clearing the edge by c, lands on the roof c /
 * tan(depression) behind the face: at 12.4 m, 6 cm over the edge and 5 deg down put the roof's
 * returns 0.64-0.8 m behind the face's, and the vehicle fell into two clusters (sensors_node's
 * rostest, the other vehicle's first sweep). A plan tolerance wide enough for that, fixed or
 * scaled with range and the rings' spacing, would join neighbours in every direction. What
 * tells a surface seen past an edge from a second object behind is the range image: the
 * criterion of Bogoslavskyi and Stachniss ("Fast range image-based segmentation of sparse 3D
 * laser scans for online operation", IROS 2016), made for 16-beam lidars. For two returns of
 * adjacent rings in one column (angle psi apart, ranges d_near <= d_far), beta =
 * atan2(d_near sin psi, d_far - d_near cos psi) is the angle at the far return between its beam
 * and the segment to the near one: a depth jump along the beam makes beta small, a surface makes
 * it large. Two such returns join one cluster when beta >= `ring_link_angle` (10 deg, the
 * paper's value) and they are at most `ring_link_gap` (1 m) apart on the ground plane, on top of
 * the plan tolerance; the face and the roof make beta ~30 deg. The gap cap: beta alone does not
 * grow stricter with range (it admits gaps up to d sin(psi) / tan(10 deg), 0.2 d for 2 deg
 * rings), and over 100 VLP-16 sweeps across the default course it joined 134 groups, leaving
 * 102 clusters that held two or more of the course's objects (trees and shrubs 3-9 m behind one
 * another at 10-60 m) against 13 without links (touching barrier and fence segments); capped at
 * 1 m it joins 2 and adds none. The price, that of any range-image segmentation: an object
 * standing within that reach behind a lower one, in the strip the lower one's top hides from the
 * next ring, joins it; the lidar sees no ground between them there. And a roof the upper ring
 * reaches more than 1 m behind the face stays a cluster of its own. The column is found from the
 * points' own `ring` and `time` (the lidar's; the ring below's return fired nearest in time,
 * among equal times the nearest in bearing), and both returns must lie within the tolerance
 * across the beam.
 *
 * No ROS types; the result is in the map frame, whatever frame the sweep was asked in.
 */
#include <cstdint>
#include <functional>
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
  /// rad, (0, pi/2]: two returns of adjacent rings in one column (`ring` and `time` as the lidar
  /// sets them) within the tolerance across the beam and at most ring_link_gap apart join one
  /// cluster when the segment between them makes at least this angle with the farther beam
  /// (beta, the file comment): a surface an edge hides from the ring below, not a second object
  /// behind. 10 deg (Bogoslavskyi and Stachniss 2016); larger joins less; pi/2: no links (beta <
  /// 90 deg always), the plan tolerance alone.
  double ring_link_angle = 10.0 * 3.14159265358979323846 / 180.0;
  /// m, >= 0: the farthest apart on the ground plane two returns are linked (0: no links). 1 m:
  /// the objects the course keeps apart stand farther apart (trees > 1 m), and beta alone, which
  /// does not grow stricter with range, joined trees and shrubs several metres behind one another
  /// at 20-60 m (the file comment).
  double ring_link_gap = 1.0;
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
  double range = 0.0;        ///< m, horizontal distance from the sensor (the `origin` given) to the centroid
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
  std::size_t ring_links = 0;      ///< groups the plan tolerance left apart that ring links joined
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
   * @param origin m, map: the sensor, for LidarCluster::range and the ring links (the sensor
   *        as every point fired: for a moving sensor use the sweep overload)
   * @param terrain height of the terrain at (x, y); where it answers false (off the terrain) a
   *        point counts as above the ground
   * @return no clusters for an empty cloud or one with nothing above the ground
   */
  LidarClustering cluster(const LidarCloud& points, const Eigen::Vector3d& origin,
                          const TerrainHeightFn& terrain) const;

  /**
   * @brief Clusters a sweep: its points as they are when registered, else each carried into the
   *        map by its firing pose (motion.at(time)); range from the pose at the sweep start,
   *        ring links from each point's firing position.
   *        Cluster indices are those of scan.points.
   * @throw std::invalid_argument for a bad motion (validateMotion)
   */
  LidarClustering cluster(const LidarScan& scan, const SensorMotion& motion, const TerrainHeightFn& terrain) const;

private:
  /// cluster() with the sensor's position at each point's firing time (for the ring links).
  LidarClustering clusterFrom(const LidarCloud& points, const Eigen::Vector3d& origin,
                              const std::function<Eigen::Vector3d(float)>& firing_origin,
                              const TerrainHeightFn& terrain) const;

  LidarClusterConfig config_;
};

}  // namespace sensors
}  // namespace avsp
