#pragma once
/**
 * @file terrain_objects.hpp
 * @brief Vegetation and structures standing on the terrain (docs/MODELS.md section 3): their
 *        footprints, strength and toppled state, queryable by region for the dynamics
 *        (collisions, grass resistance) and the sensors (ray casting).
 */
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace avsp
{
namespace terrain
{
enum class ObjectType : std::uint8_t
{
  kTree,
  kShrub,
  kGrass,  ///< a patch: adds rolling resistance, never blocks
  kRock,
  kPole,
  kFence,    ///< one fence segment
  kBarrier,  ///< concrete barrier
  kBuilding
};

/// Name used in files and messages ("tree", "shrub", ...).
const char* toString(ObjectType type);
/// @throw std::invalid_argument for an unknown name
ObjectType objectTypeFromString(const std::string& name);

/// One object. Its footprint is the rectangle length x width centred at (x, y), rotated by yaw.
struct TerrainObject
{
  std::uint32_t id = 0;
  ObjectType type = ObjectType::kRock;
  double x = 0.0, y = 0.0;  ///< m, map position of the footprint centre
  double yaw = 0.0;         ///< rad, direction of the length axis from map x
  double length = 0.0;      ///< m, along yaw
  double width = 0.0;       ///< m
  double height = 0.0;      ///< m, above the ground
  /// N: horizontal push that topples it; +inf = rigid (rocks, large trees, barriers, buildings).
  double strength = std::numeric_limits<double>::infinity();
  double rolling_resistance = 0.0;  ///< f added to wheels inside a grass patch
  bool toppled = false;
  double fall_direction = 0.0;  ///< rad, map direction it fell towards (valid when toppled)
};

/**
 * @brief All objects of a terrain, bucketed on a coarse grid so that a region query costs
 *        the objects near it, not all of them.
 */
class ObjectSet
{
public:
  /// @param bucket_size m, side of the square buckets of the spatial index (> 0)
  explicit ObjectSet(double bucket_size = 10.0);

  /**
   * @brief Adds an object and returns its id (ids count from 0 in insertion order).
   * @throw std::invalid_argument naming the object (the id it would have had, its kind and
   *        position) and the field: non-finite position or yaw, length or width not finite and
   *        > 0, height not finite and >= 0, negative (or NaN) strength or rolling resistance
   */
  std::uint32_t add(TerrainObject object);

  /// Ids of the objects whose footprint overlaps the axis-aligned box, in id order.
  std::vector<std::uint32_t> query(double min_x, double min_y, double max_x, double max_y) const;

  /// Ids of the objects whose footprint contains (x, y), in id order.
  std::vector<std::uint32_t> at(double x, double y) const;

  /**
   * @brief Pushes an object with a horizontal force (N) towards `direction` (rad): if it is
   *        toppleable and the force reaches its strength, it falls and stays fallen.
   * @return true if this push toppled it
   * @throw std::out_of_range for an unknown id
   */
  bool push(std::uint32_t id, double force, double direction);

  /**
   * @brief Applies a topple another process reported (avsp_msgs/ObjectToppled): the object
   *        falls towards `fall_direction` as if pushed with its strength.
   * @return false, with `why` naming the id and the reason, for an unknown id, a rigid object
   *         or a non-finite direction (nothing changes); true otherwise, also when it already lay
   */
  bool applyToppled(std::uint32_t id, double fall_direction, std::string& why);

  const TerrainObject& get(std::uint32_t id) const;
  std::size_t size() const { return objects_.size(); }
  const std::vector<TerrainObject>& all() const { return objects_; }

private:
  void insertIntoBuckets(const TerrainObject& o);
  long bucketKeyX(double x) const;
  long bucketKeyY(double y) const;

  double bucket_size_;
  std::vector<TerrainObject> objects_;
  /// (bucket x, bucket y) -> ids, kept sorted by key for deterministic iteration.
  std::vector<std::pair<std::pair<long, long>, std::vector<std::uint32_t>>> buckets_;
};

/// Half extents (m) of an object's footprint's axis-aligned bounding box.
void footprintHalfExtents(const TerrainObject& o, double& half_x, double& half_y);

}  // namespace terrain
}  // namespace avsp
