#include "avsp_sensors/occupancy.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <octomap/OcTree.h>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/noise.hpp"

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
std::unique_ptr<octomap::OcTree> makeTree(const OccupancyConfig& c)
{
  auto tree = std::make_unique<octomap::OcTree>(c.resolution);
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

OccupancyMap::OccupancyMap(const OccupancyConfig& config) : config_(validated(config)), tree_(makeTree(config_)) {}
OccupancyMap::~OccupancyMap() = default;
OccupancyMap::OccupancyMap(OccupancyMap&&) noexcept = default;
OccupancyMap& OccupancyMap::operator=(OccupancyMap&&) noexcept = default;

void OccupancyMap::insert(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin)
{
  if (!origin.allFinite())
    throw std::invalid_argument("OccupancyMap::insert: origin is not finite");
  octomap::Pointcloud cloud;
  cloud.reserve(points.size());
  for (std::size_t k = 0; k < points.size(); ++k)
  {
    const Eigen::Vector3f& p = points[k];
    if (!p.allFinite())
      throw std::invalid_argument("OccupancyMap::insert: points[" + std::to_string(k) + "] is not finite");
    cloud.push_back(p.x(), p.y(), p.z());
  }
  const double max_range = std::isfinite(config_.max_range) ? config_.max_range : -1.0;
  tree_->insertPointCloud(cloud, octomap::point3d(static_cast<float>(origin.x()), static_cast<float>(origin.y()),
                                                  static_cast<float>(origin.z())),
                          max_range, /*lazy_eval=*/false, config_.discretize);
}

void OccupancyMap::insert(const LidarScan& scan, const SensorMotion& motion, std::size_t slices)
{
  if (slices == 0)
    throw std::invalid_argument("OccupancyMap::insert: slices must be >= 1");
  validateMotion(motion, "OccupancyMap::insert");
  const double duration = scan.duration > 0.0 ? scan.duration : 1.0;
  std::vector<std::vector<Eigen::Vector3f>> parts(slices);
  for (const LidarPoint& p : scan.points)
  {
    const double s = std::floor(static_cast<double>(p.time) / duration * static_cast<double>(slices));
    const std::size_t k = static_cast<std::size_t>(std::clamp(s, 0.0, static_cast<double>(slices - 1)));
    Eigen::Vector3f q(p.x, p.y, p.z);
    if (!scan.registered)
      q = (motion.at(p.time) * q.cast<double>()).cast<float>();
    parts[k].push_back(q);
  }
  for (std::size_t k = 0; k < slices; ++k)
    if (!parts[k].empty())
    {
      const double t_mid = (static_cast<double>(k) + 0.5) * duration / static_cast<double>(slices);
      insert(parts[k], motion.at(t_mid).translation());
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
      if (terrain(g.origin_x + (static_cast<double>(i) + 0.5) * r, g.origin_y + (static_cast<double>(j) + 0.5) * r, z) &&
          std::isfinite(z))
        ground[j * g.width + i] = z;
    }
  std::vector<std::uint8_t> obstacle(grid.data.size(), 0), observed(grid.data.size(), 0);

  if (tree_->getRoot() != nullptr)
  {
    double zmin = 0.0, ymin = 0.0, xmin = 0.0, zmax = 0.0, ymax = 0.0, xmax = 0.0;
    tree_->getMetricMin(xmin, ymin, zmin);
    tree_->getMetricMax(xmax, ymax, zmax);
    const double x1 = g.origin_x + static_cast<double>(g.width) * r, y1 = g.origin_y + static_cast<double>(g.height) * r;
    const octomap::point3d bmin(static_cast<float>(std::max(xmin, g.origin_x)), static_cast<float>(std::max(ymin, g.origin_y)),
                                static_cast<float>(zmin));
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
    grid.data[k] = obstacle[k] ? OccupancyGrid2D::kOccupied : (observed[k] ? OccupancyGrid2D::kFree : OccupancyGrid2D::kUnknown);
  return grid;
}

void OccupancyMap::save(const std::string& path) const
{
  if (!tree_->writeBinaryConst(path))
    throw std::runtime_error("OccupancyMap::save: cannot write '" + path + "'");
}

OccupancyMap OccupancyMap::load(const std::string& path, OccupancyConfig config)
{
  auto tree = std::make_unique<octomap::OcTree>(config.resolution > 0.0 ? config.resolution : 0.1);
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
