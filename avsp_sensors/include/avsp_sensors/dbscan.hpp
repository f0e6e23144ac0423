#pragma once
/**
 * @file dbscan.hpp
 * @brief DBSCAN clustering exactly as docs/MODELS.md section 4 states it, on a fixed-radius
 *        neighbour search (a uniform grid of eps cells by default; nanoflann's kd-tree, PCL's
 *        KdTreeFLANN or PCL's octree for comparison), with a deterministic rule for border points
 *        that two clusters could claim. Takes points as Eigen vectors or as any PCL cloud.
 *
 * Definitions (eps > 0, min_points >= 1, distances Euclidean):
 * - N(p) = { q : |p - q| <= eps }, p itself included (as in Ester et al. 1996).
 * - p is a core point when |N(p)| >= min_points.
 * - Clusters are the connected components of the core points, two cores being connected
 *   when they are within eps of each other.
 * - A point that is not core but has a core point within eps is a border point. It joins the
 *   cluster of its nearest core point; equally near cores are ranked by index, lowest first.
 *   (Classic DBSCAN gives it to whichever cluster reaches it first, which depends on the
 *   visiting order; this rule does not.)
 * - All other points are noise (label -1).
 * - Clusters are numbered 0, 1, ... in the order of their lowest-indexed member.
 */
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <pcl/point_cloud.h>

namespace avsp
{
namespace sensors
{
/// Role of a point in the clustering.
enum class PointClass : std::uint8_t
{
  kNoise,
  kBorder,
  kCore,
};

/// Result of dbscan().
struct DbscanResult
{
  std::vector<int> labels;          ///< per point: cluster index, or -1 for noise
  std::vector<PointClass> classes;  ///< per point
  std::size_t clusters = 0;
};

/// Label of noise points.
constexpr int kNoiseLabel = -1;

/// How dbscan() finds the pairs of points within eps. Both give identical results.
enum class NeighbourSearch : std::uint8_t
{
  /// Cells of side eps, points sorted by cell, pairs tested between each cell and its 26
  /// neighbours (each cell pair once). The fast default (README: measured figures). Points
  /// spread over more than ~2 million eps along an axis fall back to the kd-tree.
  kGrid,
  /// nanoflann kd-tree (leaves of 16 points), one radius query per point.
  kKdTree,
  /// PCL's pcl::KdTreeFLANN (FLANN in float), one radiusSearch per point; each candidate is
  /// re-tested in double, so the result is the grid's. For the benchmark (README: figures).
  kPclKdTree,
  /// PCL's pcl::octree::OctreePointCloudSearch (leaves of eps), one radiusSearch per point,
  /// candidates re-tested in double. For the benchmark.
  kPclOctree,
};

/// Name of a search for messages and benchmarks: "grid", "kd-tree", "pcl-kdtree", "pcl-octree".
const char* toString(NeighbourSearch search);

/**
 * @brief Clusters `points`.
 *
 * Two sweeps over the pairs within eps (count neighbours; then link cores and attach the
 * others); no neighbour lists are stored, so memory stays O(n) even when every point is within
 * eps of every other (time is then O(n^2), as for any DBSCAN).
 * @throw std::invalid_argument naming the argument: eps not finite and > 0, min_points == 0,
 *        a point with a non-finite coordinate
 */
DbscanResult dbscan(const std::vector<Eigen::Vector3d>& points, double eps, std::size_t min_points,
                    NeighbourSearch search = NeighbourSearch::kGrid);

/**
 * @brief dbscan() with its working memory kept between calls: a sensor clustering every scan
 *        reuses it instead of allocating (and page-faulting) megabytes each time. Not safe to
 *        share between threads.
 */
class Dbscan
{
public:
  Dbscan();
  ~Dbscan();
  Dbscan(Dbscan&&) noexcept;
  Dbscan& operator=(Dbscan&&) noexcept;

  /// As dbscan(); the result stays valid until the next run(). @throw as dbscan()
  const DbscanResult& run(const std::vector<Eigen::Vector3d>& points, double eps, std::size_t min_points,
                          NeighbourSearch search = NeighbourSearch::kGrid);

  /**
   * @brief The same clustering of a PCL cloud of any point type with float x, y, z (labels by
   *        point index). Coordinates are widened to double exactly, so the labels are those of
   *        run() on the same coordinates as Eigen vectors.
   * @throw as dbscan(); a NaN point is named as points[i]
   */
  template <typename PointT>
  const DbscanResult& run(const pcl::PointCloud<PointT>& cloud, double eps, std::size_t min_points,
                          NeighbourSearch search = NeighbourSearch::kGrid)
  {
    widened_.resize(cloud.size());
    for (std::size_t k = 0; k < cloud.size(); ++k)
      widened_[k] = Eigen::Vector3d(cloud[k].x, cloud[k].y, cloud[k].z);
    return run(widened_, eps, min_points, search);
  }

private:
  struct Workspace;
  std::unique_ptr<Workspace> ws_;
  std::vector<Eigen::Vector3d> widened_;  ///< a PCL cloud's points in double, reused
};

/// dbscan() of a PCL cloud (Dbscan::run's PCL overload). @throw as dbscan()
template <typename PointT>
DbscanResult dbscan(const pcl::PointCloud<PointT>& cloud, double eps, std::size_t min_points,
                    NeighbourSearch search = NeighbourSearch::kGrid)
{
  Dbscan d;
  return d.run(cloud, eps, min_points, search);
}

}  // namespace sensors
}  // namespace avsp
