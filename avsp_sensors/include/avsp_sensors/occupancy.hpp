#pragma once
/**
 * @file occupancy.hpp
 * @brief A vehicle's 3-D occupancy map (OctoMap): each scan inserted with free-space ray
 *        casting at a configurable resolution and maximum range; occupied cells exported for a
 *        MarkerArray; a 2-D occupancy grid of obstacles by height above the local terrain, laid
 *        out like nav_msgs/OccupancyGrid; saving to and loading from OctoMap's .bt format.
 *        No ROS types; the octomap types stay out of this header.
 */
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace octomap
{
class OcTree;
}

namespace avsp
{
namespace sensors
{
struct LidarScan;
struct SensorMotion;

/**
 * @brief Occupancy map parameters. The probabilities are OctoMap's sensor model (log-odds
 *        updates per hit and miss, clamping); their defaults are the library's own.
 */
struct OccupancyConfig
{
  double resolution = 0.2;  ///< m, voxel edge, > 0
  /// m, rays are inserted this far: a return beyond it marks only the free space up to it; > 0
  /// (+inf: no limit).
  double max_range = 30.0;
  double prob_hit = 0.7;             ///< P(occupied | hit), (0.5, 1)
  double prob_miss = 0.4;            ///< P(occupied | ray passed), (0, 0.5)
  double clamping_min = 0.1192;      ///< lower probability clamp, (0, 1)
  double clamping_max = 0.971;       ///< upper probability clamp, (clamping_min, 1)
  double occupancy_threshold = 0.5;  ///< a voxel is occupied above this probability, (0, 1)
  /// Merge returns in the same voxel before casting, each ray then ending at its voxel's centre
  /// (OctoMap's computeDiscreteUpdate): the same occupied voxels, free voxels traced to the
  /// centres instead of the exact returns, half the cost of a lidar sweep whose near-range
  /// returns crowd into few voxels (README.md, "OctoMap occupancy"). false: every return cast.
  bool discretize = true;
  /// Replace the returns in each voxel by their centroid (pcl::VoxelGrid, leaf = resolution,
  /// its cells on the map's voxel grid) before casting. With `discretize` the map is the same
  /// (rays end at the voxel centres either way; a return exactly on a voxel face may fall in
  /// the neighbouring voxel, PCL computing in float and OctoMap in double) at the filter's extra
  /// cost; without it, one ray per voxel ending at the centroid instead of one per return. Off:
  /// not better than `discretize` (figures: docs/benchmarks.md, "PCL").
  bool voxel_filter = false;
  /// Threads that trace the rays of a scan (0 = all cores); the map does not depend on it.
  unsigned threads = 1;
};

/// @throw std::invalid_argument naming the field ("OccupancyConfig: resolution must be ...")
void validateOccupancyConfig(const OccupancyConfig& config);

/**
 * @brief The centroid of the points in each cube [i leaf, (i + 1) leaf) x ... (pcl::VoxelGrid),
 *        one per occupied cube, in PCL's cube order (deterministic). Points must be finite.
 *        (PCL leaves the cloud unfiltered, with a warning on stderr, when the cubes of the
 *        cloud's bounding box number more than 2^31 - 1, e.g. 1300 leaves along each axis.)
 * @param leaf m, > 0
 */
std::vector<Eigen::Vector3f> voxelGridCentroids(const std::vector<Eigen::Vector3f>& points, double leaf);

/// One occupied leaf of the octree: a cube.
struct OccupiedCell
{
  Eigen::Vector3d centre;  ///< m, map
  double size;             ///< m, edge (resolution x 2^k for pruned nodes)
  double probability;      ///< occupancy probability
};

/// State of the map at a point.
enum class CellState : std::int8_t
{
  kUnknown = -1,
  kFree = 0,
  kOccupied = 1,
};

/**
 * @brief A 2-D occupancy grid like nav_msgs/OccupancyGrid: cell (i, j) covers
 *        [origin_x + i res, origin_x + (i + 1) res) x [origin_y + j res, ...), data row-major
 *        (data[j * width + i]), values -1 unknown, 0 free, 100 occupied.
 */
struct OccupancyGrid2D
{
  static constexpr std::int8_t kUnknown = -1;
  static constexpr std::int8_t kFree = 0;
  static constexpr std::int8_t kOccupied = 100;

  std::size_t width = 0, height = 0;      ///< cells along x and y
  double resolution = 0.0;                ///< m per cell
  double origin_x = 0.0, origin_y = 0.0;  ///< m, map position of cell (0, 0)'s corner
  std::vector<std::int8_t> data;

  std::int8_t at(std::size_t i, std::size_t j) const { return data.at(j * width + i); }
  /// Value of the cell holding map point (x, y); kUnknown outside the grid.
  std::int8_t atPoint(double x, double y) const;
};

/// Terrain height at map (x, y), m: false where unknown (HeightField::heightAt fits).
using TerrainHeightFn = std::function<bool(double x, double y, double& z)>;

/**
 * @brief Window and thresholds of the 2-D projection. Heights are of voxel centres above the
 *        terrain height at the 2-D cell's centre.
 *
 * A cell is occupied (100) when an occupied voxel above it stands higher than obstacle_height
 * and not higher than max_height (overhangs above it, e.g. a canopy, do not block); else free (0)
 * when a known voxel (free, or occupied ground) lies within [min_height, free_max_height], i.e.
 * the ground or the space just above it was observed; else unknown (-1).
 */
struct GridProjection
{
  double origin_x = 0.0, origin_y = 0.0;  ///< m, corner of cell (0, 0)
  std::size_t width = 0, height = 0;      ///< cells, >= 1
  double resolution = 0.0;                ///< m per cell; 0: the map's resolution
  double obstacle_height = 0.3;           ///< m above terrain, > min_height
  double max_height = 3.0;                ///< m above terrain, > obstacle_height
  double min_height = -0.5;               ///< m above terrain (below: ignored)
  double free_max_height = 1.0;           ///< m above terrain, >= min_height
};

/**
 * @brief One vehicle's OctoMap.
 *
 * insert() gives exactly the tree octomap::OcTree::insertPointCloud gives (tested leaf by leaf):
 * every voxel a ray passes (OcTree::computeRayKeys) is updated once as free, every endpoint voxel
 * once as occupied (occupied wins), rays clipped at max_range, log-odds clamped, nodes pruned.
 * It gets there faster: rays traced on several threads into open-addressing sets instead of one
 * std::unordered_set, the unique voxels radix-sorted in Morton (octree child) order and applied
 * in one depth-first pass that creates, expands, updates and prunes each node once per scan
 * instead of once per voxel (README.md, "OctoMap occupancy").
 */
class OccupancyMap
{
public:
  /// @throw std::invalid_argument (validateOccupancyConfig)
  explicit OccupancyMap(const OccupancyConfig& config = OccupancyConfig());
  ~OccupancyMap();
  OccupancyMap(OccupancyMap&&) noexcept;
  OccupancyMap& operator=(OccupancyMap&&) noexcept;

  const OccupancyConfig& config() const { return config_; }
  double resolution() const { return config_.resolution; }

  /**
   * @brief Inserts one scan: points (m, map) seen from `origin` (m, map).
   * @throw std::invalid_argument when the origin or a point is not finite (nothing inserted)
   */
  void insert(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin);

  /**
   * @brief insert(points, origin), and rays that met nothing: every voxel from `origin` to each
   *        of `clear_ends` (clipped at max_range) is updated once as free, none as occupied
   *        (occupied wins over free within the scan, as for returns).
   * @throw std::invalid_argument when the origin, a point or a clear end is not finite (nothing inserted)
   */
  void insert(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& clear_ends,
              const Eigen::Vector3d& origin);

  /**
   * @brief Inserts a lidar sweep split into `slices` time slices, each cast from the sensor's
   *        position at the slice's middle (motion.at(t)); unregistered sweeps are registered
   *        with each point's firing pose first. Its particle echoes (weather clutter) only
   *        clear the space up to them: the map is of the solid world.
   * @throw std::invalid_argument for slices == 0, a bad motion, a non-finite point or a
   *        particle_echo not of the points' size (empty: none is an echo)
   */
  void insert(const LidarScan& scan, const SensorMotion& motion, std::size_t slices = 1);

  /// The same insertion through octomap::OcTree::insertPointCloud itself (the reference the
  /// tests compare insert() with; slower). No input checks.
  void insertWithOctomap(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin);

  /// State at a map point (kUnknown outside anything observed).
  CellState state(const Eigen::Vector3d& p) const;

  /// Occupied leaves (pruned nodes keep their size).
  std::vector<OccupiedCell> occupiedCells() const;
  /// Leaves in the tree (known voxels or pruned blocks).
  std::size_t leafCount() const;
  /// Bytes the octree uses.
  std::size_t memoryUsage() const;

  /**
   * @brief The 2-D grid (GridProjection's rules) over its window.
   * @throw std::invalid_argument naming the field for a bad window or thresholds
   */
  OccupancyGrid2D projectGrid(const GridProjection& projection, const TerrainHeightFn& terrain) const;

  /// The map as the bytes of an OctoMap binary file (.bt: maximum-likelihood occupancy, pruned).
  std::string binary() const;
  /// Writes binary() to `path`, every write, the sync and the close checked.
  /// @throw std::runtime_error naming the path and the failing call when the file cannot be written
  void save(const std::string& path) const;
  /**
   * @brief Reads a .bt file; the resolution comes from the file, the rest of `config` is kept.
   * @throw std::runtime_error when the file cannot be read or is not an OcTree
   */
  static OccupancyMap load(const std::string& path, OccupancyConfig config = OccupancyConfig());

  /// The underlying octree (for code that speaks OctoMap).
  const octomap::OcTree& tree() const { return *tree_; }

private:
  OccupancyConfig config_;
  std::unique_ptr<octomap::OcTree> tree_;
};

}  // namespace sensors
}  // namespace avsp
