#pragma once
/**
 * @file height_field.hpp
 * @brief The terrain as the sensors see it: a copy of the deformed grid-point heights with a
 *        maximum mip-map over the cells, and an exact ray intersection with the bilinear
 *        surface of each cell (the same surface as ElevationGrid::height() and the soil
 *        contact), found by hierarchical traversal instead of sampled marching.
 */
#include <cstddef>
#include <cstdint>
#include <new>
#include <vector>

#include <Eigen/Core>

namespace avsp
{
namespace terrain
{
class ElevationGrid;
class DeformableTerrain;
struct PointRange;
}  // namespace terrain

namespace sensors
{
/// Where a ray met the terrain.
struct TerrainHit
{
  double t = 0.0;            ///< m along the (unit) ray direction from its origin
  Eigen::Vector3d point;     ///< m, map
  Eigen::Vector3d normal;    ///< unit upward normal of the bilinear surface at the hit
  std::size_t i = 0, j = 0;  ///< the cell hit (its south-west grid point)
};

/**
 * @brief Grid-point heights on the lattice of an ElevationGrid (origin, dx, dy, columns, rows)
 *        with a maximum mip-map, for exact and fast ray casting.
 *
 * Surface: inside cell (i, j) the terrain is the bilinear patch of its four corner heights,
 * z = h00 (1-u)(1-v) + h10 u (1-v) + h01 (1-u) v + h11 u v, exactly what the physics uses
 * (ElevationGrid::height, DeformableTerrain::height). Along a ray the patch height is a
 * quadratic in the ray parameter, so the first crossing is the smallest root of a quadratic:
 * exact up to floating-point rounding, never a sampled step.
 *
 * Mip-map: level 0 is the cells themselves (their maximum is computed from the corners on the
 * fly, which the exact test loads anyway); level L >= 1 stores, per block of 2^L x 2^L cells,
 * the largest corner height in it (stored in cache-line tiles of 4 x 4 blocks). A ray skips
 * a whole block when it stays above the block's maximum for the whole of its passage through it. Memory: 4 B per grid point for the heights
 * plus about 4/3 B per grid point for the mip levels.
 *
 * Rays whose origin is below the surface hit at t = 0 (they start inside the ground): no ray
 * passes through the terrain from below.
 *
 * Thread safety: intersect() and the accessors are const and may run concurrently; the
 * setters must not run while rays are cast.
 */
class HeightField
{
public:
  /**
   * @param origin_x, origin_y map position of grid point (0, 0), m
   * @param dx, dy grid spacing, m, > 0
   * @param columns, rows grid points along x and y, >= 2
   * @param heights row-major (index j * columns + i), m, finite
   * @throw std::invalid_argument naming the argument that is inconsistent
   */
  HeightField(double origin_x, double origin_y, double dx, double dy, std::size_t columns, std::size_t rows,
              std::vector<float> heights);

  /// The undeformed grid.
  static HeightField fromGrid(const terrain::ElevationGrid& grid);
  /// The deformed heights (ruts included) of a terrain.
  static HeightField fromTerrain(const terrain::DeformableTerrain& terrain);

  /**
   * @brief Replaces the heights of the grid points [i0, i0 + width) x [j0, j0 + height) and
   *        refreshes only the mip entries above them (ruts arriving).
   * @param heights row-major patch, index r * width + c for point (i0 + c, j0 + r), m, finite
   * @throw std::invalid_argument when the rectangle leaves the grid, is empty, the patch has
   *        the wrong size or a height is not finite
   */
  void setHeights(std::size_t i0, std::size_t j0, std::size_t width, std::size_t height,
                  const std::vector<float>& heights);

  /**
   * @brief Copies the deformed heights of points `range` (inclusive) from `terrain` (same
   *        lattice) and refreshes the mip entries above them.
   * @throw std::invalid_argument when the terrain's lattice differs or the range leaves the grid
   */
  void refreshFrom(const terrain::DeformableTerrain& terrain, const terrain::PointRange& range);

  /**
   * @brief First crossing of the ray origin + t * direction, t in [0, t_max], with the surface.
   * @param direction unit vector (the caller guarantees it; t is then metres)
   * @return false when the ray misses the grid's surface within t_max
   */
  bool intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max, TerrainHit& hit) const;

  /**
   * @brief intersect() for a ray the caller knows does not meet the surface before t_clear (m):
   *        the traversal starts there instead of at the origin. The result is intersect()'s,
   *        bit for bit (each cell is solved over its whole stretch of the ray, wherever the
   *        traversal entered it), as long as the promise holds; a t_clear past the true first
   *        crossing loses that crossing. Used for coherent rays (Scene::cast on a batch: a
   *        lidar column's channels share a vertical plane, so a channel above another one
   *        cannot meet the ground before the one below it did).
   */
  bool intersectFrom(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_clear, double t_max,
                     TerrainHit& hit) const;

  /// Height of grid point (i, j), m. @throw std::out_of_range outside the grid
  double pointHeight(std::size_t i, std::size_t j) const;
  /// Bilinear height at map (x, y), m; false outside the grid (h unchanged).
  bool heightAt(double x, double y, double& h) const;

  /// Number of mip levels stored (levels 1 .. mipLevels()), plus the implicit level 0.
  std::size_t mipLevels() const { return levels_.size() - 2; }
  /// Blocks along x and y at mip level L (L = 0: cells).
  std::size_t mipColumns(std::size_t level) const;
  std::size_t mipRows(std::size_t level) const;
  /// Stored maximum of block (bi, bj) at level L >= 1 (level 0: maximum of the cell's corners).
  float mipMax(std::size_t level, std::size_t bi, std::size_t bj) const;

  double originX() const { return origin_x_; }
  double originY() const { return origin_y_; }
  double dx() const { return dx_; }
  double dy() const { return dy_; }
  std::size_t columns() const { return columns_; }
  std::size_t rows() const { return rows_; }
  /// Bytes held by heights and mip levels.
  std::size_t bytes() const;

private:
  /// A ray in grid units: X = (x - origin_x) / dx, so that cell boundaries are integers.
  struct GridRay
  {
    double X0, Y0, DX, DY;
  };
  /// More levels than any grid of 2^31 points per side needs.
  static constexpr int kMaxLevels = 40;

  /// Storage aligned to a 64-byte cache line, so that each mip tile is exactly one line.
  template <class T>
  struct CacheLineAllocator
  {
    using value_type = T;
    CacheLineAllocator() = default;
    template <class U>
    CacheLineAllocator(const CacheLineAllocator<U>&)
    {
    }
    T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(64))); }
    void deallocate(T* p, std::size_t) { ::operator delete(p, std::align_val_t(64)); }
    bool operator==(const CacheLineAllocator&) const { return true; }
    bool operator!=(const CacheLineAllocator&) const { return false; }
  };

  /// Where a level's block maxima are in mip_max_: in tiles of kTile x kTile blocks (one 64-byte
  /// cache line each), row-major within a tile and tiles row-major: a ray's next block, across x
  /// or y, is then mostly in the line it already loaded, where a row-major level (thousands of
  /// blocks wide at level 1) costs a cache miss per step across y.
  struct Level
  {
    static constexpr std::size_t kTile = 4;
    std::size_t nx = 0, ny = 0;  ///< blocks along x and y (level 0: the cells)
    std::size_t tiles_x = 0;     ///< tiles per row
    std::size_t offset = 0;      ///< index of the level's first entry in mip_max_ (a tile start)
    std::size_t tiles() const { return tiles_x * ((ny + kTile - 1) / kTile); }
    std::size_t index(std::size_t bi, std::size_t bj) const
    {
      return offset + ((bj / kTile) * tiles_x + bi / kTile) * (kTile * kTile) + (bj % kTile) * kTile + bi % kTile;
    }
  };

  void buildMips();
  /// Recomputes the mip entries above cells [ci0, ci1] x [cj0, cj1] (inclusive, level 0).
  void refreshMips(std::size_t ci0, std::size_t cj0, std::size_t ci1, std::size_t cj1);
  /// Level-1 block (bi, bj) from the heights.
  float blockMaxFromHeights(std::size_t bi, std::size_t bj) const;
  /// Exact crossing inside level-0 cell (ci, cj) for t in [ta, tb]; false if none.
  bool cellHit(std::size_t ci, std::size_t cj, const Eigen::Vector3d& o, const Eigen::Vector3d& d, const GridRay& g,
               double ta, double tb, TerrainHit& hit) const;
  /// The hierarchical walk of intersectFrom() from t (clipped ray [t_first, t1]), for a ray
  /// moving along x and y with signs SX, SY (-1, 0, +1), upward or level (RISING) or downward.
  template <int SX, int SY, bool RISING>
  class Walker;
  template <int SX, int SY, bool RISING>
  bool walk(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const GridRay& g, double t_first, double t, double t1,
            TerrainHit& hit) const;

  double origin_x_, origin_y_, dx_, dy_;
  std::size_t columns_, rows_;
  std::size_t cells_x_, cells_y_;
  double cells_xd_, cells_yd_;  ///< cells_x_, cells_y_ as doubles (the walk clips to them)
  double cell_diagonal_;        ///< m, sqrt(dx^2 + dy^2)
  double inv_dx_, inv_dy_;      ///< 1/m: 1 / dx, 1 / dy
  std::vector<float> heights_;
  /// levels_[0] describes the cells (nothing stored), levels_[L] for 1 <= L <= mipLevels() the
  /// mip levels, and one more a single block of +inf above the top, so that the walk's climbs
  /// stop there without a test of the level.
  std::vector<Level> levels_;
  std::vector<float, CacheLineAllocator<float>> mip_max_;  ///< the levels' tiles, one after another
  float min_height_ = 0.f;                                 ///< a lower bound of all heights (exact after construction)
};

}  // namespace sensors
}  // namespace avsp
