#pragma once
/**
 * @file scene.hpp
 * @brief Everything a ray can hit: the deformed terrain (HeightField), the standing and
 *        toppled terrain objects (a static BVH), and moving bodies (other vehicles, agents; a
 *        small BVH rebuilt whenever they move). Exact hits; batches cast on several threads.
 */
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "avsp_sensors/height_field.hpp"
#include "avsp_sensors/primitives.hpp"

namespace avsp
{
namespace terrain
{
class ObjectSet;
}

namespace sensors
{
/// What a ray hit.
enum class HitKind : std::uint8_t
{
  kNone,     ///< nothing within the ray's range
  kTerrain,  ///< the ground
  kObject,   ///< a terrain object (tree, rock, building, ...); id = its ObjectSet id
  kBody,     ///< a moving body (vehicle, agent); id = Body::primitive.id
};

/// A ray to cast. direction must be a unit vector; ranges are metres along it.
struct Ray
{
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();      ///< m, map
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  ///< unit, map
  double max_range = 100.0;                              ///< m, finite, >= 0
  std::uint32_t ignore_body = PrimitiveBvh::kNoId;       ///< body id not to hit (the sensor's own vehicle)
};

/// The first thing a ray met.
struct RayHit
{
  double range = std::numeric_limits<double>::infinity();  ///< m; +inf when kind == kNone
  Eigen::Vector3d point = Eigen::Vector3d::Zero();         ///< m, map
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();       ///< unit outward surface normal, map
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      ///< m/s, map velocity of the surface point hit
  HitKind kind = HitKind::kNone;
  std::uint32_t id = 0;      ///< object or body id (kObject, kBody)
  float reflectivity = 0.f;  ///< diffuse reflectivity of the surface hit, [0, 1]

  bool hit() const { return kind != HitKind::kNone; }
};

/**
 * @brief Diffuse reflectivity of each material at the lidar's near-infrared wavelength
 *        (850-905 nm). Defaults are representative round values (README, "Materials"), not
 *        measurements of the course.
 */
struct Reflectivities
{
  float terrain = 0.25f;  ///< bare soil and gravel
  /// Per terrain::ObjectType, in enum order: tree, shrub, grass, rock, pole, fence, barrier, building.
  std::array<float, 8> objects{ { 0.35f, 0.45f, 0.45f, 0.30f, 0.35f, 0.30f, 0.35f, 0.35f } };
};

/// A moving solid: its shape and pose now, and its rigid-body velocity (for radar Doppler).
struct Body
{
  Primitive primitive;                                         ///< pose now; id = the body's id
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();          ///< m/s, map, of primitive.centre
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, map
};

/**
 * @brief Primitives for the terrain objects, as RViz draws them (avsp_terrain's terrain_node):
 *        rocks are ellipsoids, trees, shrubs and poles elliptic cylinders, fences, barriers and
 *        buildings boxes, each length x width x height standing on the ground at its centre.
 *        A toppled object lies along its fall direction with its thinner footprint side
 *        vertical. Grass patches are left out (they do not block; README). Objects outside the
 *        height field stand on z = 0.
 */
std::vector<Primitive> objectPrimitives(const terrain::ObjectSet& objects, const HeightField& ground,
                                        const Reflectivities& reflectivities);

/**
 * @brief The scene the sensors ray-cast: terrain + static objects + moving bodies.
 *
 * A cast tests the terrain first, then only primitives nearer than the terrain hit, so a ray
 * that meets the ground early prunes most of the BVH. Ties between the terrain and a solid go
 * to the solid.
 */
class Scene
{
public:
  explicit Scene(HeightField terrain, Reflectivities reflectivities = Reflectivities());

  /// The terrain, for updates (setHeights / refreshFrom when ruts arrive).
  HeightField& terrain() { return terrain_; }
  const HeightField& terrain() const { return terrain_; }
  const Reflectivities& reflectivities() const { return reflectivities_; }

  /// Rebuilds the static set from the objects (e.g. after some toppled). See objectPrimitives().
  void setObjects(const terrain::ObjectSet& objects);
  /// Replaces the static set. @throw std::invalid_argument for a bad primitive
  void setStaticPrimitives(std::vector<Primitive> primitives);
  /// Replaces the moving bodies. @throw std::invalid_argument for a bad primitive or velocity
  void setBodies(std::vector<Body> bodies);

  const std::vector<Primitive>& staticPrimitives() const { return objects_.primitives(); }
  const std::vector<Body>& bodies() const { return bodies_; }

  /**
   * @brief Per-grid-point terrain reflectivity: soil_map[j * columns + i] indexes `palette`.
   *        An empty map returns to the single Reflectivities::terrain value.
   * @throw std::invalid_argument when the map size differs from the grid, an index is not in
   *        the palette, or a palette value is outside [0, 1]
   */
  void setTerrainReflectivity(std::vector<std::uint8_t> soil_map, std::vector<float> palette);

  /**
   * @brief The first hit of one ray.
   * @throw std::invalid_argument naming the field: origin or direction not finite, direction
   *        not of unit length (to 1e-6), max_range not finite or negative
   */
  RayHit cast(const Ray& ray) const;

  /**
   * @brief Whether the ray meets anything within its max_range: cast(ray).hit() without the
   *        search for the nearest hit and its details (shadow rays). The terrain is tested
   *        first, then the solids; the first one found ends the search.
   * @throw std::invalid_argument as cast()
   */
  bool occluded(const Ray& ray) const;

  /**
   * @brief hits[k] = cast(rays[k]) on `threads` threads (0 = all cores). Results do not depend
   *        on the thread count. Consecutive rays sharing an origin and a vertical half-plane
   *        (lidar columns) are cast faster: each starts its terrain traversal where a lower
   *        one met the ground (same hits).
   * @throw std::invalid_argument naming the first bad ray (before any casting)
   */
  void cast(const std::vector<Ray>& rays, std::vector<RayHit>& hits, unsigned threads) const;

  /// Checks a ray as cast() does. @throw std::invalid_argument naming `context` and the field
  static void validateRay(const Ray& ray, const char* context);

private:
  RayHit castUnchecked(const Ray& ray) const;
  /// With the terrain traversal starting at t_clear (HeightField::intersectFrom); sets
  /// terrain_reach to the terrain hit's range, or max_range when the terrain is not hit.
  RayHit castUnchecked(const Ray& ray, double t_clear, double& terrain_reach) const;
  /// Reflectivity of the soil map at terrain hit p in cell (i, j); only with a soil map (the
  /// uniform value is read by the caller, without a call).
  float terrainReflectivity(std::size_t i, std::size_t j, const Eigen::Vector3d& p) const;

  /// A static primitive that a fan's rays may enter: where the fan's ground line crosses its
  /// (slightly widened) footprint and its height range.
  struct FanCandidate
  {
    std::uint32_t index;  ///< into staticPrimitives()
    double s0, s1;        ///< m, horizontal distance from the origin: the line within the footprint
    double z_lo, z_hi;    ///< m, the primitive's height range, widened
  };
  /// Fills `out` with the static primitives the rays of the fan rays[begin, end) may enter;
  /// hz[k - begin] is the horizontal length of rays[k].direction.
  void fanCandidates(const std::vector<Ray>& rays, const double* hz, std::size_t begin, std::size_t end,
                     std::vector<std::uint32_t>& scratch, std::vector<FanCandidate>& out) const;
  /// out = castUnchecked(ray, t_clear, terrain_reach) with the static primitives searched among
  /// `candidates` (a fan's, ascending index) instead of the BVH: the same hit, bit for bit.
  /// h: horizontal length of ray.direction (> 0).
  void castFanRay(const Ray& ray, double h, double t_clear, double& terrain_reach,
                  const std::vector<FanCandidate>& candidates, RayHit& out) const;
  /// The terrain part of a cast: `out` (a fresh RayHit) given the terrain hit, if any, from a
  /// traversal starting at t_clear; terrain_reach and the returned range are that hit's, or max_range.
  double castTerrain(const Ray& ray, double t_clear, double& terrain_reach, RayHit& out) const;
  /// The object and body part of a cast, after the terrain hit (or none) left in `out` with
  /// range `best`: static primitives from the BVH, or from a fan's `candidates` (then h is the
  /// horizontal length of ray.direction), then the bodies.
  void castSolids(const Ray& ray, double h, double best, RayHit& out,
                  const std::vector<FanCandidate>* candidates) const;

  HeightField terrain_;
  Reflectivities reflectivities_;
  PrimitiveBvh objects_;
  PrimitiveBvh body_bvh_;  ///< primitive k is bodies_[k]'s
  std::vector<Body> bodies_;
  std::vector<std::uint8_t> soil_map_;
  std::vector<float> soil_reflectivity_;
};

}  // namespace sensors
}  // namespace avsp
