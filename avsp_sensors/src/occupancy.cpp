#include "avsp_sensors/occupancy.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <octomap/OcTree.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>

#include <avsp_terrain/output_file.hpp>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/noise.hpp"
#include "avsp_sensors/parallel.hpp"

namespace avsp
{
namespace sensors
{
void validateOccupancyConfig(const OccupancyConfig& c)
{
  const std::string ctx = "OccupancyConfig";
  check::positive(ctx, "resolution", c.resolution);
  check::positiveOrInfinite(ctx, "max_range", c.max_range);
  if (!(c.prob_hit > 0.5 && c.prob_hit < 1.0))
    check::fail(ctx, "prob_hit", "within (0.5, 1)", c.prob_hit);
  if (!(c.prob_miss > 0.0 && c.prob_miss < 0.5))
    check::fail(ctx, "prob_miss", "within (0, 0.5)", c.prob_miss);
  if (!(c.clamping_min > 0.0 && c.clamping_min < 1.0))
    check::fail(ctx, "clamping_min", "within (0, 1)", c.clamping_min);
  if (!(c.clamping_max > c.clamping_min && c.clamping_max < 1.0))
    check::fail(ctx, "clamping_max", "within (clamping_min, 1)", c.clamping_max);
  if (!(c.occupancy_threshold > 0.0 && c.occupancy_threshold < 1.0))
    check::fail(ctx, "occupancy_threshold", "within (0, 1)", c.occupancy_threshold);
}

std::int8_t OccupancyGrid2D::atPoint(double x, double y) const
{
  const double fi = std::floor((x - origin_x) / resolution), fj = std::floor((y - origin_y) / resolution);
  if (!(fi >= 0.0 && fj >= 0.0 && fi < static_cast<double>(width) && fj < static_cast<double>(height)))
    return kUnknown;
  return at(static_cast<std::size_t>(fi), static_cast<std::size_t>(fj));
}

namespace
{
/// spread3 of every byte: its bit b moved to bit 3b.
struct SpreadTable
{
  std::uint32_t v[256];
  SpreadTable()
  {
    for (std::uint32_t x = 0; x < 256; ++x)
    {
      std::uint32_t r = 0;
      for (int b = 0; b < 8; ++b)
        r |= ((x >> b) & 1u) << (3 * b);
      v[x] = r;
    }
  }
};
const SpreadTable kSpread;

inline std::uint64_t spread3(std::uint32_t k)
{
  return static_cast<std::uint64_t>(kSpread.v[k & 0xffu]) |
         (static_cast<std::uint64_t>(kSpread.v[(k >> 8) & 0xffu]) << 24);
}

/// Morton code of an octree key: bit b of k[0], k[1], k[2] at bits 3b, 3b + 1, 3b + 2, so the
/// 3-bit group of level bit b is the octree child index there (x = 1, y = 2, z = 4, as
/// octomap::computeChildIdx) and ascending codes are the tree's depth-first order.
inline std::uint64_t mortonCode(const octomap::OcTreeKey& k)
{
  return spread3(k[0]) | (spread3(k[1]) << 1) | (spread3(k[2]) << 2);
}

/// Open-addressing set of 48-bit Morton codes (linear probing, grows at half load).
class CodeSet
{
public:
  /// @param expected codes expected: the table starts at twice that (a power of two)
  explicit CodeSet(std::size_t expected = 2048)
  {
    std::size_t n = 4096;
    while (n < 2 * expected)
      n *= 2;
    slots_.assign(n, kEmpty);
    shift_ = 64 - log2(n);
  }

  void insert(std::uint64_t code)
  {
    const std::size_t mask = slots_.size() - 1;
    std::size_t i = slot(code);
    while (slots_[i] != kEmpty)
    {
      if (slots_[i] == code)
        return;
      i = (i + 1) & mask;
    }
    slots_[i] = code;
    if (2 * ++count_ > slots_.size())
      grow();
  }

  /// Appends the codes (in no particular order).
  void appendTo(std::vector<std::uint64_t>& out) const
  {
    for (const std::uint64_t c : slots_)
      if (c != kEmpty)
        out.push_back(c);
  }

  std::size_t size() const { return count_; }

private:
  static constexpr std::uint64_t kEmpty = ~0ull;  // not a 48-bit code

  static int log2(std::size_t n)
  {
    int l = 0;
    while ((std::size_t(1) << l) < n)
      ++l;
    return l;
  }

  /// Fibonacci hashing: the top bits of code * 2^64 / phi.
  std::size_t slot(std::uint64_t code) const
  {
    return static_cast<std::size_t>((code * 0x9e3779b97f4a7c15ull) >> shift_);
  }

  void grow()
  {
    std::vector<std::uint64_t> old;
    old.swap(slots_);
    slots_.assign(old.size() * 2, kEmpty);
    shift_ = 64 - log2(slots_.size());
    count_ = 0;
    for (const std::uint64_t c : old)
      if (c != kEmpty)
        insert(c);
  }

  std::vector<std::uint64_t> slots_;
  std::size_t count_ = 0;
  int shift_ = 52;
};

/// LSD radix sort of 48-bit codes, four passes of 12 bits.
void radixSort48(std::vector<std::uint64_t>& v)
{
  std::vector<std::uint64_t> tmp(v.size());
  std::vector<std::size_t> count(4096);
  for (int pass = 0; pass < 4; ++pass)
  {
    const int shift = 12 * pass;
    std::fill(count.begin(), count.end(), 0);
    for (const std::uint64_t c : v)
      ++count[(c >> shift) & 4095];
    std::size_t sum = 0;
    for (std::size_t& n : count)
    {
      const std::size_t here = n;
      n = sum;
      sum += here;
    }
    for (const std::uint64_t c : v)
      tmp[count[(c >> shift) & 4095]++] = c;
    v.swap(tmp);
  }
}

/// One voxel's update: its Morton code and the log-odds to add.
struct VoxelUpdate
{
  std::uint64_t code;
  float log_odds;
};

/**
 * An OcTree that applies a sorted batch of unique voxel updates in one depth-first pass. Per
 * voxel it does what OccupancyOcTreeBase::updateNode(key, log_odds, lazy_eval = false) does
 * (skip when the deepest existing node is a leaf already clamped in the update's direction;
 * create or expand children on the way down; update and clamp the leaf; prune or refresh every
 * node on the way up), each node once per batch instead of once per voxel. The resulting tree
 * is the one the sequential updates give (test_occupancy compares them leaf by leaf).
 */
class BatchOcTree : public octomap::OcTree
{
public:
  using octomap::OcTree::OcTree;

  void applyBatch(const std::vector<VoxelUpdate>& updates)
  {
    if (updates.empty())
      return;
    bool created_root = false;
    if (this->root == nullptr)
    {
      this->root = new octomap::OcTreeNode();
      ++this->tree_size;
      created_root = true;
    }
    update(this->root, created_root, 0, updates.data(), updates.data() + updates.size());
  }

private:
  bool saturated(const octomap::OcTreeNode* node, float u) const
  {
    return (u >= 0.f && node->getLogOdds() >= this->clamping_thres_max) ||
           (u <= 0.f && node->getLogOdds() <= this->clamping_thres_min);
  }

  /// Applies updates [b, e) below `node` (at `depth`); false when every one was skipped.
  bool update(octomap::OcTreeNode* node, bool just_created, unsigned depth, const VoxelUpdate* b, const VoxelUpdate* e)
  {
    if (depth == this->tree_depth)
    {
      // A voxel: exactly one update (the batch holds unique codes).
      this->updateNodeLogOdds(node, b->log_odds);
      return true;
    }
    // A pruned leaf above voxel level: the voxels whose update it already saturates are left
    // alone (updateNode's early exit); the others need it expanded.
    if (!just_created && !this->nodeHasChildren(node))
    {
      std::vector<VoxelUpdate> kept;
      for (const VoxelUpdate* u = b; u != e; ++u)
        if (!saturated(node, u->log_odds))
          kept.push_back(*u);
      if (kept.empty())
        return false;
      if (kept.size() != static_cast<std::size_t>(e - b))
        return descend(node, false, depth, kept.data(), kept.data() + kept.size());
    }
    return descend(node, just_created, depth, b, e);
  }

  bool descend(octomap::OcTreeNode* node, bool just_created, unsigned depth, const VoxelUpdate* b, const VoxelUpdate* e)
  {
    const int shift = 3 * static_cast<int>(this->tree_depth - 1 - depth);
    bool changed = false;
    for (const VoxelUpdate* g = b; g != e;)
    {
      const unsigned pos = static_cast<unsigned>((g->code >> shift) & 7u);
      const VoxelUpdate* g_end = g + 1;
      while (g_end != e && ((g_end->code >> shift) & 7u) == pos)
        ++g_end;
      bool created = false;
      if (!this->nodeChildExists(node, pos))
      {
        if (!this->nodeHasChildren(node) && !just_created)
          this->expandNode(node);  // a pruned node: its 8 children take its value
        else
        {
          this->createNodeChild(node, pos);
          created = true;
        }
        changed = true;
      }
      octomap::OcTreeNode* child = this->getNodeChild(node, pos);
      // A voxel whose leaf exists and is saturated is skipped, as updateNode does.
      if (!(depth + 1 == this->tree_depth && !created && saturated(child, g->log_odds)))
        changed = update(child, created, depth + 1, g, g_end) || changed;
      g = g_end;
    }
    // As updateNodeRecurs on the way up: prune if possible, else take the children's maximum.
    if (changed && !this->pruneNode(node))
      node->updateOccupancyChildren();
    return changed;
  }
};

std::unique_ptr<octomap::OcTree> makeTree(const OccupancyConfig& c)
{
  auto tree = std::make_unique<BatchOcTree>(c.resolution);
  tree->setProbHit(c.prob_hit);
  tree->setProbMiss(c.prob_miss);
  tree->setClampingThresMin(c.clamping_min);
  tree->setClampingThresMax(c.clamping_max);
  tree->setOccupancyThres(c.occupancy_threshold);
  return tree;
}

const OccupancyConfig& validated(const OccupancyConfig& c)
{
  validateOccupancyConfig(c);
  return c;
}
}  // namespace

OccupancyMap::OccupancyMap(const OccupancyConfig& config) : config_(validated(config)), tree_(makeTree(config_))
{
}
std::vector<Eigen::Vector3f> voxelGridCentroids(const std::vector<Eigen::Vector3f>& points, double leaf)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(points.size());
  for (const Eigen::Vector3f& p : points)
    cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(cloud);
  const float l = static_cast<float>(leaf);
  grid.setLeafSize(l, l, l);
  pcl::PointCloud<pcl::PointXYZ> out;
  grid.filter(out);
  std::vector<Eigen::Vector3f> centroids;
  centroids.reserve(out.size());
  for (const pcl::PointXYZ& p : out)
    centroids.emplace_back(p.x, p.y, p.z);
  return centroids;
}

OccupancyMap::~OccupancyMap() = default;
OccupancyMap::OccupancyMap(OccupancyMap&&) noexcept = default;
OccupancyMap& OccupancyMap::operator=(OccupancyMap&&) noexcept = default;

void OccupancyMap::insert(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin)
{
  insert(points, {}, origin);
}

void OccupancyMap::insert(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& clear_ends,
                          const Eigen::Vector3d& origin)
{
  if (!origin.allFinite())
    throw std::invalid_argument("OccupancyMap::insert: origin is not finite");
  for (std::size_t k = 0; k < points.size(); ++k)
    if (!points[k].allFinite())
      throw std::invalid_argument("OccupancyMap::insert: points[" + std::to_string(k) + "] is not finite");
  for (std::size_t k = 0; k < clear_ends.size(); ++k)
    if (!clear_ends[k].allFinite())
      throw std::invalid_argument("OccupancyMap::insert: clear_ends[" + std::to_string(k) + "] is not finite");
  if (points.empty() && clear_ends.empty())
    return;
  const octomap::point3d o(static_cast<float>(origin.x()), static_cast<float>(origin.y()),
                           static_cast<float>(origin.z()));
  const octomap::OcTree& tree = *tree_;

  // Optional PCL pre-filter of the returns: the centroid of the returns in each voxel
  // (OccupancyConfig::voxel_filter); rays that met nothing only clear and are kept as they are.
  std::vector<Eigen::Vector3f> filtered;
  if (config_.voxel_filter)
    filtered = voxelGridCentroids(points, config_.resolution);
  const std::vector<Eigen::Vector3f>& returns_in = config_.voxel_filter ? filtered : points;

  // The endpoints: as given, or (discretize) the centres of the distinct voxels they fall in;
  // the returns' first, then the clear ones (`returns` of them end in a hit).
  std::vector<octomap::point3d> ends;
  ends.reserve(returns_in.size() + clear_ends.size());
  auto addEnds = [&](const std::vector<Eigen::Vector3f>& from) {
    if (config_.discretize)
    {
      CodeSet seen;
      for (const Eigen::Vector3f& p : from)
      {
        const octomap::OcTreeKey k = tree.coordToKey(octomap::point3d(p.x(), p.y(), p.z()));
        const std::size_t before = seen.size();
        seen.insert(mortonCode(k));
        if (seen.size() != before)
          ends.push_back(tree.keyToCoord(k));
      }
    }
    else
      for (const Eigen::Vector3f& p : from)
        ends.emplace_back(p.x(), p.y(), p.z());
  };
  addEnds(returns_in);
  const std::size_t returns = ends.size();
  addEnds(clear_ends);

  // Trace the rays in chunks, one per thread, each into its own sets (computeUpdate's rules).
  const bool clip = std::isfinite(config_.max_range);
  const double max_range = config_.max_range;
  const std::size_t chunks = std::min<std::size_t>(resolveThreads(config_.threads), ends.size());
  // A sweep's rays share most voxels: ~8 unique voxels per ray at 0.2 m on the default course.
  std::vector<CodeSet> free_sets(chunks, CodeSet(8 * ends.size() / chunks));
  std::vector<CodeSet> occupied_sets(chunks, CodeSet(ends.size() / chunks));
  parallelFor(chunks, config_.threads, [&](std::size_t c0, std::size_t c1) {
    octomap::KeyRay ray;
    for (std::size_t c = c0; c < c1; ++c)
      for (std::size_t i = c * ends.size() / chunks; i < (c + 1) * ends.size() / chunks; ++i)
      {
        const octomap::point3d& p = ends[i];
        if (!clip || (p - o).norm() <= max_range)
        {
          if (tree.computeRayKeys(o, p, ray))
            for (const octomap::OcTreeKey& k : ray)
              free_sets[c].insert(mortonCode(k));
          octomap::OcTreeKey key;
          if (i < returns && tree.coordToKeyChecked(p, key))
            occupied_sets[c].insert(mortonCode(key));
        }
        else
        {
          const octomap::point3d end = o + (p - o).normalized() * static_cast<float>(max_range);
          if (tree.computeRayKeys(o, end, ray))
            for (const octomap::OcTreeKey& k : ray)
              free_sets[c].insert(mortonCode(k));
        }
      }
  });

  // Unique voxels in Morton order; occupied wins over free.
  std::vector<std::uint64_t> occupied, free_codes;
  for (const CodeSet& set : occupied_sets)
    set.appendTo(occupied);
  for (const CodeSet& set : free_sets)
    set.appendTo(free_codes);
  radixSort48(occupied);
  occupied.erase(std::unique(occupied.begin(), occupied.end()), occupied.end());
  radixSort48(free_codes);
  free_codes.erase(std::unique(free_codes.begin(), free_codes.end()), free_codes.end());
  const float hit = tree.getProbHitLog(), miss = tree.getProbMissLog();
  std::vector<VoxelUpdate> updates;
  updates.reserve(occupied.size() + free_codes.size());
  std::size_t a = 0, f = 0;
  while (a < occupied.size() || f < free_codes.size())
  {
    if (f == free_codes.size() || (a < occupied.size() && occupied[a] <= free_codes[f]))
    {
      if (f < free_codes.size() && free_codes[f] == occupied[a])
        ++f;
      updates.push_back({ occupied[a++], hit });
    }
    else
      updates.push_back({ free_codes[f++], miss });
  }
  static_cast<BatchOcTree&>(*tree_).applyBatch(updates);
}

void OccupancyMap::insertWithOctomap(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin)
{
  octomap::Pointcloud cloud;
  cloud.reserve(points.size());
  for (const Eigen::Vector3f& p : points)
    cloud.push_back(p.x(), p.y(), p.z());
  tree_->insertPointCloud(
      cloud,
      octomap::point3d(static_cast<float>(origin.x()), static_cast<float>(origin.y()), static_cast<float>(origin.z())),
      std::isfinite(config_.max_range) ? config_.max_range : -1.0, false, config_.discretize);
}

void OccupancyMap::insert(const LidarScan& scan, const SensorMotion& motion, std::size_t slices)
{
  if (slices == 0)
    throw std::invalid_argument("OccupancyMap::insert: slices must be >= 1");
  validateMotion(motion, "OccupancyMap::insert");
  const double duration = scan.duration > 0.0 ? scan.duration : 1.0;
  std::vector<std::vector<Eigen::Vector3f>> parts(slices), clears(slices);
  auto sort = [&](const std::vector<LidarPoint>& from, std::vector<std::vector<Eigen::Vector3f>>& into) {
    for (const LidarPoint& p : from)
    {
      const double s = std::floor(static_cast<double>(p.time) / duration * static_cast<double>(slices));
      const std::size_t k = static_cast<std::size_t>(std::clamp(s, 0.0, static_cast<double>(slices - 1)));
      Eigen::Vector3f q(p.x, p.y, p.z);
      if (!scan.registered)
        q = (motion.at(p.time) * q.cast<double>()).cast<float>();
      into[k].push_back(q);
    }
  };
  if (!scan.particle_echo.empty() && scan.particle_echo.size() != scan.points.size())
    throw std::invalid_argument("OccupancyMap::insert: scan.particle_echo has " +
                                std::to_string(scan.particle_echo.size()) + " flags for " +
                                std::to_string(scan.points.size()) + " points");
  // A falling particle's echo says the space up to it is free, not that the world is solid
  // there: it clears like a ray that met nothing (clutter above the sensor would otherwise stay
  // occupied for good, as no later return passes through it).
  std::vector<LidarPoint> solid, particles;
  for (std::size_t k = 0; k < scan.points.size(); ++k)
    (!scan.particle_echo.empty() && scan.particle_echo[k] ? particles : solid).push_back(scan.points[k]);
  sort(solid, parts);
  sort(particles, clears);
  for (std::size_t k = 0; k < slices; ++k)
    if (!parts[k].empty() || !clears[k].empty())
    {
      const double t_mid = (static_cast<double>(k) + 0.5) * duration / static_cast<double>(slices);
      insert(parts[k], clears[k], motion.at(t_mid).translation());
    }
}

CellState OccupancyMap::state(const Eigen::Vector3d& p) const
{
  const octomap::OcTreeNode* node =
      tree_->search(static_cast<double>(p.x()), static_cast<double>(p.y()), static_cast<double>(p.z()));
  if (node == nullptr)
    return CellState::kUnknown;
  return tree_->isNodeOccupied(node) ? CellState::kOccupied : CellState::kFree;
}

std::vector<OccupiedCell> OccupancyMap::occupiedCells() const
{
  std::vector<OccupiedCell> cells;
  for (auto it = tree_->begin_leafs(), end = tree_->end_leafs(); it != end; ++it)
    if (tree_->isNodeOccupied(*it))
    {
      const octomap::point3d c = it.getCoordinate();
      cells.push_back({ Eigen::Vector3d(c.x(), c.y(), c.z()), it.getSize(), it->getOccupancy() });
    }
  return cells;
}

std::size_t OccupancyMap::leafCount() const
{
  return tree_->getNumLeafNodes();
}

std::size_t OccupancyMap::memoryUsage() const
{
  return tree_->memoryUsage();
}

OccupancyGrid2D OccupancyMap::projectGrid(const GridProjection& g, const TerrainHeightFn& terrain) const
{
  const std::string ctx = "GridProjection";
  if (g.width < 1 || g.height < 1)
    check::fail(ctx, g.width < 1 ? "width" : "height", ">= 1 cell", 0.0);
  if (static_cast<double>(g.width) * static_cast<double>(g.height) > 1e9)
    check::fail(ctx, "width", "such that width x height <= 1e9 cells",
                static_cast<double>(g.width) * static_cast<double>(g.height));
  check::finite(ctx, "origin_x", g.origin_x);
  check::finite(ctx, "origin_y", g.origin_y);
  if (g.resolution != 0.0)
    check::positive(ctx, "resolution", g.resolution);
  check::finite(ctx, "min_height", g.min_height);
  check::finite(ctx, "obstacle_height", g.obstacle_height);
  check::finite(ctx, "max_height", g.max_height);
  check::finite(ctx, "free_max_height", g.free_max_height);
  if (!(g.obstacle_height > g.min_height))
    check::fail(ctx, "obstacle_height", "> min_height", g.obstacle_height);
  if (!(g.max_height > g.obstacle_height))
    check::fail(ctx, "max_height", "> obstacle_height", g.max_height);
  if (!(g.free_max_height >= g.min_height))
    check::fail(ctx, "free_max_height", ">= min_height", g.free_max_height);
  if (!terrain)
    throw std::invalid_argument(ctx + ": terrain height function is empty");

  OccupancyGrid2D grid;
  grid.width = g.width;
  grid.height = g.height;
  grid.resolution = g.resolution > 0.0 ? g.resolution : config_.resolution;
  grid.origin_x = g.origin_x;
  grid.origin_y = g.origin_y;
  grid.data.assign(g.width * g.height, OccupancyGrid2D::kUnknown);

  const double r = grid.resolution;
  // Terrain height at each cell centre (NaN where unknown), computed once.
  std::vector<double> ground(grid.data.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t j = 0; j < g.height; ++j)
    for (std::size_t i = 0; i < g.width; ++i)
    {
      double z = 0.0;
      const double cx = g.origin_x + (static_cast<double>(i) + 0.5) * r;
      const double cy = g.origin_y + (static_cast<double>(j) + 0.5) * r;
      if (terrain(cx, cy, z) && std::isfinite(z))
        ground[j * g.width + i] = z;
    }
  std::vector<std::uint8_t> obstacle(grid.data.size(), 0), observed(grid.data.size(), 0);

  if (tree_->getRoot() != nullptr)
  {
    double zmin = 0.0, ymin = 0.0, xmin = 0.0, zmax = 0.0, ymax = 0.0, xmax = 0.0;
    tree_->getMetricMin(xmin, ymin, zmin);
    tree_->getMetricMax(xmax, ymax, zmax);
    const double x1 = g.origin_x + static_cast<double>(g.width) * r;
    const double y1 = g.origin_y + static_cast<double>(g.height) * r;
    const octomap::point3d bmin(static_cast<float>(std::max(xmin, g.origin_x)),
                                static_cast<float>(std::max(ymin, g.origin_y)), static_cast<float>(zmin));
    const octomap::point3d bmax(static_cast<float>(std::min(xmax, x1)), static_cast<float>(std::min(ymax, y1)),
                                static_cast<float>(zmax));
    const double half_voxel = 0.5 * config_.resolution;
    const auto cellRange = [&](double lo, double hi, double origin, std::size_t n, long& c0, long& c1) {
      // Cells whose centres lie in [lo, hi); a node smaller than a cell gives the cell holding its centre.
      c0 = static_cast<long>(std::ceil((lo - origin) / r - 0.5));
      c1 = static_cast<long>(std::ceil((hi - origin) / r - 0.5)) - 1;
      if (c1 < c0)
        c0 = c1 = static_cast<long>(std::floor((0.5 * (lo + hi) - origin) / r));
      c0 = std::max(c0, 0L);
      c1 = std::min(c1, static_cast<long>(n) - 1);
    };
    if (bmin.x() <= bmax.x() && bmin.y() <= bmax.y())
      for (auto it = tree_->begin_leafs_bbx(bmin, bmax), end = tree_->end_leafs_bbx(); it != end; ++it)
      {
        const double s = it.getSize();
        const octomap::point3d c = it.getCoordinate();
        const bool occupied = tree_->isNodeOccupied(*it);
        long i0, i1, j0, j1;
        cellRange(c.x() - 0.5 * s, c.x() + 0.5 * s, g.origin_x, g.width, i0, i1);
        cellRange(c.y() - 0.5 * s, c.y() + 0.5 * s, g.origin_y, g.height, j0, j1);
        // Heights of the lowest and highest voxel centres in the node.
        const double z_lo = c.z() - 0.5 * s + half_voxel, z_hi = c.z() + 0.5 * s - half_voxel;
        for (long j = j0; j <= j1; ++j)
          for (long i = i0; i <= i1; ++i)
          {
            const std::size_t k = static_cast<std::size_t>(j) * g.width + static_cast<std::size_t>(i);
            const double h0 = ground[k];
            if (std::isnan(h0))
              continue;
            const double lo = z_lo - h0, hi = z_hi - h0;
            if (occupied && hi > g.obstacle_height && lo <= g.max_height)
              obstacle[k] = 1;
            if (hi >= g.min_height && lo <= g.free_max_height)
              observed[k] = 1;
          }
      }
  }
  for (std::size_t k = 0; k < grid.data.size(); ++k)
    grid.data[k] =
        obstacle[k] ? OccupancyGrid2D::kOccupied : (observed[k] ? OccupancyGrid2D::kFree : OccupancyGrid2D::kUnknown);
  return grid;
}

std::string OccupancyMap::binary() const
{
  std::ostringstream out(std::ios::binary);
  if (!tree_->writeBinaryConst(out))
    throw std::runtime_error("OccupancyMap::binary: OctoMap could not serialise the tree");
  return out.str();
}

void OccupancyMap::save(const std::string& path) const
{
  // OctoMap's own file writer does not check the close, so a full disk looked like success.
  avsp::terrain::writeBytes(path, binary());
}

OccupancyMap OccupancyMap::load(const std::string& path, OccupancyConfig config)
{
  auto tree = std::make_unique<BatchOcTree>(config.resolution > 0.0 ? config.resolution : 0.1);
  if (!tree->readBinary(path))
    throw std::runtime_error("OccupancyMap::load: cannot read an OcTree from '" + path + "'");
  config.resolution = tree->getResolution();
  OccupancyMap map(config);
  tree->setProbHit(config.prob_hit);
  tree->setProbMiss(config.prob_miss);
  tree->setClampingThresMin(config.clamping_min);
  tree->setClampingThresMax(config.clamping_max);
  tree->setOccupancyThres(config.occupancy_threshold);
  map.tree_ = std::move(tree);
  return map;
}

}  // namespace sensors
}  // namespace avsp
