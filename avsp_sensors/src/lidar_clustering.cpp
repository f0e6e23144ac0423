#include "avsp_sensors/lidar_clustering.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include "avsp_sensors/noise.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kPi = 3.14159265358979323846;
}  // namespace

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
  // beta < 90 deg for every pair (lidar_clustering.hpp): 90 deg turns the ring links off.
  if (!(c.ring_link_angle > 0.0 && c.ring_link_angle <= 0.5 * kPi))
    check::fail(ctx, "ring_link_angle", "in (0, pi/2] rad", c.ring_link_angle);
  check::nonNegative(ctx, "ring_link_gap", c.ring_link_gap);  // 0: no links
}

namespace
{
/// Union-find over the groups PCL found, for the ring links.
struct Groups
{
  std::vector<int> parent;
  explicit Groups(std::size_t n) : parent(n)
  {
    for (std::size_t g = 0; g < n; ++g)
      parent[g] = static_cast<int>(g);
  }
  int find(int g)
  {
    while (parent[static_cast<std::size_t>(g)] != g)
    {
      parent[static_cast<std::size_t>(g)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(g)])];
      g = parent[static_cast<std::size_t>(g)];
    }
    return g;
  }
  /// The lower root survives, so that the groups keep PCL's order. False: already one group.
  bool join(int a, int b)
  {
    a = find(a);
    b = find(b);
    if (a == b)
      return false;
    parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
    return true;
  }
};

/// Horizontal bearing of v, rad.
double bearing(const Eigen::Vector3d& v)
{
  return std::atan2(v.y(), v.x());
}
}  // namespace

LidarClusterer::LidarClusterer(LidarClusterConfig config) : config_(config)
{
  validateLidarClusterConfig(config_);
}

LidarClustering LidarClusterer::cluster(const LidarCloud& points, const Eigen::Vector3d& origin,
                                        const TerrainHeightFn& terrain) const
{
  return clusterFrom(
      points, origin, [&origin](float) { return origin; }, terrain);
}

namespace
{
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/// The points above the ground, flattened onto z = 0 unless use_height, into `objects`, with
/// where each came from (`source`); counts the invalid and ground points in out.
void objectPoints(const LidarCloud& points, const TerrainHeightFn& terrain, const LidarClusterConfig& config,
                  LidarClustering& out, Cloud& objects, std::vector<int>& source)
{
  objects.reserve(points.size());
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
    if (terrain && terrain(p.x, p.y, ground) && static_cast<double>(p.z) - ground < config.ground_clearance)
    {
      ++out.ground_points;
      continue;
    }
    objects.push_back(pcl::PointXYZ(p.x, p.y, config.use_height ? p.z : 0.0f));
    source.push_back(static_cast<int>(k));
  }
}

/// What the kd-tree holds: the points, or (cell_size > 0) the centroid of each cell's points,
/// cells numbered in the order of their first point, with the cell of every point in node_of
/// (left empty for the identity). (Not pcl::VoxelGrid: its leaf layout, needed to map points to
/// centroids, is a dense array over the cloud's whole box, 800 MB for a sweep's 100 x 100 x 20 m
/// at 0.1 m in 3-D.)
Cloud::Ptr clusterNodes(const Cloud::Ptr& objects, double cell_size, std::vector<int>& node_of)
{
  node_of.clear();
  if (!(cell_size > 0.0))
    return objects;
  // Cell coordinates in 21 bits each (+-1e6 cells: +-100 km at 0.1 m); farther points leave the
  // clustering exact.
  const double inv = 1.0 / cell_size;
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
  if (!fits)
  {
    node_of.clear();
    return objects;
  }
  Cloud::Ptr nodes(new Cloud);
  nodes->reserve(sums.size());
  for (std::size_t n = 0; n < sums.size(); ++n)
  {
    const Eigen::Vector3d c = sums[n] / static_cast<double>(counts[n]);
    nodes->push_back(pcl::PointXYZ(static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())));
  }
  return nodes;
}

/// Euclidean cluster extraction: flood fill over radius queries of a kd-tree (unsorted results:
/// the extraction does not need them ordered). Sizes are checked on the points later, not on
/// the nodes PCL counts.
std::vector<pcl::PointIndices> euclideanGroups(const Cloud::Ptr& nodes, double tolerance)
{
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>(false));
  tree->setInputCloud(nodes);
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
  extraction.setClusterTolerance(tolerance);
  extraction.setMinClusterSize(1);
  extraction.setMaxClusterSize(std::numeric_limits<int>::max());
  extraction.setSearchMethod(tree);
  extraction.setInputCloud(nodes);
  std::vector<pcl::PointIndices> found;
  extraction.extract(found);
  return found;
}

/// Ring links between object points of adjacent rings (lidar_clustering.hpp): each object
/// point and the object point of the ring below it fired nearest in time (the same column of
/// the range image; among equal times the nearest in bearing), joined when they lie within the
/// tolerance across the beam, at most ring_link_gap apart in plan, and the segment between
/// them makes at least ring_link_angle with the farther beam. Returns the links made.
class RingLinker
{
public:
  RingLinker(const LidarCloud& points, const std::vector<int>& source, const std::vector<int>& group_of,
             const std::function<Eigen::Vector3d(float)>& firing_origin, const LidarClusterConfig& config)
    : points_(points),
      source_(source),
      group_of_(group_of),
      config_(config),
      tan_min_(std::tan(config.ring_link_angle)),
      ray_(source.size()),
      keys_(source.size())
  {
    // Each object point seen from the sensor where it fired, its (firing time, bearing) there,
    // and per ring the points in that order.
    for (std::size_t k = 0; k < source.size(); ++k)
    {
      const LidarPoint& p = points[static_cast<std::size_t>(source[k])];
      ray_[k] = Eigen::Vector3d(p.x, p.y, p.z) - firing_origin(p.time);
      keys_[k] = Key(p.time, bearing(ray_[k]));
      by_ring_[p.ring].push_back(static_cast<int>(k));
    }
    for (auto& [ring, list] : by_ring_)
      std::sort(list.begin(), list.end(), [&](int a, int b) { return key(a) < key(b); });
  }

  std::size_t link(Groups& groups) const
  {
    std::size_t links = 0;
    for (const auto& [ring, list] : by_ring_)
    {
      if (ring == 0)
        continue;
      const auto below = by_ring_.find(static_cast<std::uint16_t>(ring - 1));
      if (below == by_ring_.end())
        continue;
      for (const int q : list)
      {
        const int p = nearestBelow(below->second, key(q));
        if (p < 0 || group_of_[static_cast<std::size_t>(p)] == group_of_[static_cast<std::size_t>(q)])
          continue;
        if (linked(p, q) && groups.join(group_of_[static_cast<std::size_t>(p)], group_of_[static_cast<std::size_t>(q)]))
          ++links;
      }
    }
    return links;
  }

private:
  using Key = std::pair<float, double>;
  const Key& key(int k) const { return keys_[static_cast<std::size_t>(k)]; }

  /// The neighbour of (time, bearing) kq in the lower ring: the nearer in time, then in bearing.
  int nearestBelow(const std::vector<int>& lower, const Key& kq) const
  {
    const auto it = std::lower_bound(lower.begin(), lower.end(), kq, [&](int a, const Key& k) { return key(a) < k; });
    int p = -1;
    double best_dt = std::numeric_limits<double>::infinity(), best_da = best_dt;
    for (const auto c : { it, it == lower.begin() ? lower.end() : std::prev(it) })
    {
      if (c == lower.end())
        continue;
      const double dt = std::abs(static_cast<double>(key(*c).first) - static_cast<double>(kq.first));
      const double da = std::abs(std::remainder(key(*c).second - kq.second, 2.0 * kPi));
      if (dt < best_dt || (dt == best_dt && da < best_da))
      {
        p = *c;
        best_dt = dt;
        best_da = da;
      }
    }
    return p;
  }

  /// Whether object points p and q pass the link's three tests.
  bool linked(int p, int q) const
  {
    // Near (n) and far (f) return from where each fired; across the beam: f's distance in plan
    // from the vertical plane of n's beam; beta: the angle at f between its beam (back to the
    // sensor) and the segment to n, tan(beta) = |n| sin(psi) / (|f| - |n| cos(psi)).
    const Eigen::Vector3d& a = ray_[static_cast<std::size_t>(p)];
    const Eigen::Vector3d& b = ray_[static_cast<std::size_t>(q)];
    const bool p_near = a.norm() <= b.norm();
    const Eigen::Vector3d& n = p_near ? a : b;
    const Eigen::Vector3d& f = p_near ? b : a;
    const double n_plan = std::hypot(n.x(), n.y());
    if (!(n_plan > 0.0) || n.x() * f.x() + n.y() * f.y() <= 0.0 ||
        std::abs(n.x() * f.y() - n.y() * f.x()) / n_plan > config_.cluster_tolerance)
      return false;
    const LidarPoint& pp = points_[static_cast<std::size_t>(source_[static_cast<std::size_t>(p)])];
    const LidarPoint& pq = points_[static_cast<std::size_t>(source_[static_cast<std::size_t>(q)])];
    if (std::hypot(static_cast<double>(pp.x) - pq.x, static_cast<double>(pp.y) - pq.y) > config_.ring_link_gap)
      return false;
    const double dn = n.norm(), df = f.norm();
    const double psi = std::atan2(n.cross(f).norm(), n.dot(f));
    const double along = df - dn * std::cos(psi);  // > 0 unless |f| = |n| and psi = 0
    return dn * std::sin(psi) >= tan_min_ * along;
  }

  const LidarCloud& points_;
  const std::vector<int>& source_;
  const std::vector<int>& group_of_;
  const LidarClusterConfig& config_;
  const double tan_min_;  ///< tan(ring_link_angle)
  std::vector<Eigen::Vector3d> ray_;
  std::vector<Key> keys_;
  std::unordered_map<std::uint16_t, std::vector<int>> by_ring_;
};

/// The clusters of the groups' points (each group's point indices ascending) within the size
/// limits, largest first.
std::vector<LidarCluster> clustersOf(std::vector<std::vector<int>>& members, const LidarCloud& points,
                                     const Eigen::Vector3d& origin, const LidarClusterConfig& config)
{
  std::vector<LidarCluster> clusters;
  clusters.reserve(members.size());
  for (std::vector<int>& group : members)
  {
    std::sort(group.begin(), group.end());  // object points are in index order, but joined groups interleave
    if (group.empty() || group.size() < config.min_points || group.size() > config.max_points)
      continue;
    LidarCluster c;
    c.indices = std::move(group);  // ascending
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
    clusters.push_back(std::move(c));
  }
  // PCL sorts by size only; clusters are disjoint, so the lowest index breaks every tie.
  std::sort(clusters.begin(), clusters.end(), [](const LidarCluster& a, const LidarCluster& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.indices.front() < b.indices.front();
  });
  return clusters;
}
}  // namespace

LidarClustering LidarClusterer::clusterFrom(const LidarCloud& points, const Eigen::Vector3d& origin,
                                            const std::function<Eigen::Vector3d(float)>& firing_origin,
                                            const TerrainHeightFn& terrain) const
{
  LidarClustering out;
  Cloud::Ptr objects(new Cloud);
  std::vector<int> source;
  objectPoints(points, terrain, config_, out, *objects, source);
  out.object_points = objects->size();
  if (objects->empty())
    return out;
  std::vector<int> node_of;  // object point -> node; empty: the identity
  const Cloud::Ptr nodes = clusterNodes(objects, config_.cell_size, node_of);
  const std::vector<pcl::PointIndices> found = euclideanGroups(nodes, config_.cluster_tolerance);
  // The group of each object point.
  std::vector<int> group_of_node(nodes->size(), -1);
  for (std::size_t g = 0; g < found.size(); ++g)
    for (const auto n : found[g].indices)
      group_of_node[static_cast<std::size_t>(n)] = static_cast<int>(g);
  std::vector<int> group_of(objects->size());
  for (std::size_t k = 0; k < objects->size(); ++k)
    group_of[k] = group_of_node[static_cast<std::size_t>(node_of.empty() ? static_cast<int>(k) : node_of[k])];
  Groups groups(found.size());
  if (config_.ring_link_angle < 0.5 * kPi && config_.ring_link_gap > 0.0)
    out.ring_links = RingLinker(points, source, group_of, firing_origin, config_).link(groups);
  // The points of each group (joined groups under their lowest group's number).
  std::vector<std::vector<int>> members(found.size());
  for (std::size_t k = 0; k < objects->size(); ++k)
    members[static_cast<std::size_t>(groups.find(group_of[k]))].push_back(source[k]);
  out.clusters = clustersOf(members, points, origin, config_);
  return out;
}

LidarClustering LidarClusterer::cluster(const LidarScan& scan, const SensorMotion& motion,
                                        const TerrainHeightFn& terrain) const
{
  validateMotion(motion, "LidarClusterer::cluster");
  const Eigen::Vector3d origin = motion.pose.translation();
  // The ring links see each point from where the sensor was when it fired.
  const auto firing_origin = [&motion](float t) -> Eigen::Vector3d { return motion.at(t).translation(); };
  if (scan.registered)
    return clusterFrom(scan.points, origin, firing_origin, terrain);
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
  return clusterFrom(registered, origin, firing_origin, terrain);
}

}  // namespace sensors
}  // namespace avsp
