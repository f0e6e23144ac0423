#include "avsp_sensors/lidar_clustering.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include "avsp_sensors/noise.hpp"

namespace avsp
{
namespace sensors
{
void validateLidarClusterConfig(const LidarClusterConfig& c)
{
  const std::string ctx = "LidarClusterConfig";
  check::positive(ctx, "cluster_tolerance", c.cluster_tolerance);
  if (c.min_points < 1)
    check::fail(ctx, "min_points", ">= 1", static_cast<double>(c.min_points));
  if (c.max_points < c.min_points)
    check::fail(ctx, "max_points", ">= min_points (" + std::to_string(c.min_points) + ")",
                static_cast<double>(c.max_points));
  // PCL counts cluster sizes in int.
  if (c.max_points > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    check::fail(ctx, "max_points", "<= 2^31 - 1", static_cast<double>(c.max_points));
  check::nonNegative(ctx, "ground_clearance", c.ground_clearance);
  check::nonNegative(ctx, "cell_size", c.cell_size);
  if (!(c.cell_size < c.cluster_tolerance))
    check::fail(ctx, "cell_size", "< cluster_tolerance (" + std::to_string(c.cluster_tolerance) + " m)", c.cell_size);
}

LidarClusterer::LidarClusterer(LidarClusterConfig config) : config_(config)
{
  validateLidarClusterConfig(config_);
}

LidarClustering LidarClusterer::cluster(const LidarCloud& points, const Eigen::Vector3d& origin,
                                        const TerrainHeightFn& terrain) const
{
  LidarClustering out;
  // The points above the ground, flattened onto z = 0 unless use_height, and where they came from.
  pcl::PointCloud<pcl::PointXYZ>::Ptr objects(new pcl::PointCloud<pcl::PointXYZ>);
  objects->reserve(points.size());
  std::vector<int> source;
  source.reserve(points.size());
  for (std::size_t k = 0; k < points.size(); ++k)
  {
    const LidarPoint& p = points[k];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
    {
      ++out.invalid_points;
      continue;
    }
    double ground = 0.0;
    if (terrain && terrain(p.x, p.y, ground) && static_cast<double>(p.z) - ground < config_.ground_clearance)
    {
      ++out.ground_points;
      continue;
    }
    objects->push_back(pcl::PointXYZ(p.x, p.y, config_.use_height ? p.z : 0.0f));
    source.push_back(static_cast<int>(k));
  }
  out.object_points = objects->size();
  if (objects->empty())
    return out;

  // What the kd-tree holds: the points, or (cell_size > 0) the centroid of each cell's points,
  // cells numbered in the order of their first point, with the cell of every point. (Not
  // pcl::VoxelGrid: its leaf layout, needed to map points to centroids, is a dense array over
  // the cloud's whole box, 800 MB for a sweep's 100 x 100 x 20 m at 0.1 m in 3-D.)
  pcl::PointCloud<pcl::PointXYZ>::Ptr nodes = objects;
  std::vector<int> node_of;  // object point -> node; empty: the identity
  if (config_.cell_size > 0.0)
  {
    // Cell coordinates in 21 bits each (+-1e6 cells: +-100 km at 0.1 m); farther points leave
    // the clustering exact.
    const double inv = 1.0 / config_.cell_size;
    const double limit = static_cast<double>(1 << 20);
    std::unordered_map<std::uint64_t, int> cell_index;
    cell_index.reserve(objects->size());
    std::vector<Eigen::Vector3d> sums;
    std::vector<int> counts;
    node_of.resize(objects->size());
    bool fits = true;
    for (std::size_t k = 0; k < objects->size() && fits; ++k)
    {
      const pcl::PointXYZ& p = (*objects)[k];
      std::uint64_t key = 0;
      for (const float v : { p.x, p.y, p.z })
      {
        const double c = std::floor(static_cast<double>(v) * inv);
        fits = fits && std::abs(c) < limit;
        key = (key << 21) | (static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + (1 << 20)) & 0x1fffffu);
      }
      const auto [it, added] = cell_index.emplace(key, static_cast<int>(sums.size()));
      if (added)
      {
        sums.emplace_back(Eigen::Vector3d::Zero());
        counts.push_back(0);
      }
      sums[static_cast<std::size_t>(it->second)] += Eigen::Vector3d(p.x, p.y, p.z);
      ++counts[static_cast<std::size_t>(it->second)];
      node_of[k] = it->second;
    }
    if (fits)
    {
      nodes.reset(new pcl::PointCloud<pcl::PointXYZ>);
      nodes->reserve(sums.size());
      for (std::size_t n = 0; n < sums.size(); ++n)
      {
        const Eigen::Vector3d c = sums[n] / static_cast<double>(counts[n]);
        nodes->push_back(pcl::PointXYZ(static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())));
      }
    }
    else
      node_of.clear();
  }

  // Euclidean cluster extraction: flood fill over radius queries of a kd-tree (unsorted
  // results: the extraction does not need them ordered). Sizes are checked on the points below,
  // not on the nodes PCL counts.
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>(false));
  tree->setInputCloud(nodes);
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
  extraction.setClusterTolerance(config_.cluster_tolerance);
  extraction.setMinClusterSize(1);
  extraction.setMaxClusterSize(std::numeric_limits<int>::max());
  extraction.setSearchMethod(tree);
  extraction.setInputCloud(nodes);
  std::vector<pcl::PointIndices> found;
  extraction.extract(found);

  // The points of each group.
  std::vector<int> group_of_node(nodes->size(), -1);
  for (std::size_t g = 0; g < found.size(); ++g)
    for (const auto n : found[g].indices)
      group_of_node[static_cast<std::size_t>(n)] = static_cast<int>(g);
  std::vector<std::vector<int>> members(found.size());
  for (std::size_t k = 0; k < objects->size(); ++k)
  {
    const int g = group_of_node[static_cast<std::size_t>(node_of.empty() ? static_cast<int>(k) : node_of[k])];
    members[static_cast<std::size_t>(g)].push_back(source[k]);
  }

  out.clusters.reserve(found.size());
  for (std::vector<int>& group : members)
  {
    if (group.size() < config_.min_points || group.size() > config_.max_points)
      continue;
    LidarCluster c;
    c.indices = std::move(group);  // ascending: the points were visited in index order
    c.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    c.max = -c.min;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const int i : c.indices)
    {
      const LidarPoint& p = points[static_cast<std::size_t>(i)];
      const Eigen::Vector3d q(p.x, p.y, p.z);
      sum += q;
      c.min = c.min.cwiseMin(q);
      c.max = c.max.cwiseMax(q);
    }
    c.centroid = sum / static_cast<double>(c.indices.size());
    c.range = std::hypot(c.centroid.x() - origin.x(), c.centroid.y() - origin.y());
    out.clusters.push_back(std::move(c));
  }
  // PCL sorts by size only; clusters are disjoint, so the lowest index breaks every tie.
  std::sort(out.clusters.begin(), out.clusters.end(), [](const LidarCluster& a, const LidarCluster& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.indices.front() < b.indices.front();
  });
  return out;
}

LidarClustering LidarClusterer::cluster(const LidarScan& scan, const SensorMotion& motion,
                                        const TerrainHeightFn& terrain) const
{
  validateMotion(motion, "LidarClusterer::cluster");
  const Eigen::Vector3d origin = motion.pose.translation();
  if (scan.registered)
    return cluster(scan.points, origin, terrain);
  // Sensor-frame points: each into the map through its own firing pose (as OccupancyMap does),
  // so that the height test and the clusters are in the terrain's frame.
  LidarCloud registered = scan.points;
  for (LidarPoint& p : registered)
  {
    const Eigen::Vector3d q = motion.at(p.time) * Eigen::Vector3d(p.x, p.y, p.z);
    p.x = static_cast<float>(q.x());
    p.y = static_cast<float>(q.y());
    p.z = static_cast<float>(q.z());
  }
  return cluster(registered, origin, terrain);
}

}  // namespace sensors
}  // namespace avsp
