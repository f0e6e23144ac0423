#pragma once
/**
 * @file primitives.hpp
 * @brief Convex solids the sensors ray-cast against (boxes, elliptic cylinders, ellipsoids
 *        at any orientation) and a bounding-volume hierarchy over them. Intersections are
 *        exact: each ray is moved into the solid's own frame and solved in closed form.
 */
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace avsp
{
namespace sensors
{
/// Shape of a Primitive, in its own frame (centre at the origin, axes x, y, z).
enum class Shape : std::uint8_t
{
  kBox,        ///< |x| <= a, |y| <= b, |z| <= c
  kCylinder,   ///< (x/a)^2 + (y/b)^2 <= 1, |z| <= c (axis along its own z, capped)
  kEllipsoid,  ///< (x/a)^2 + (y/b)^2 + (z/c)^2 <= 1 (a sphere when a = b = c)
};

/**
 * @brief One solid: shape, half extents (a, b, c) in its own frame, pose in the map, and what a
 *        sensor needs to know about what it hit.
 *
 * Surfaces are one-sided: a ray that starts inside a solid does not hit that solid (a sensor
 * mounted inside its own vehicle's box sees out of it).
 */
struct Primitive
{
  Shape shape = Shape::kBox;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Ones();  ///< m, a, b, c > 0
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();        ///< m, map
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< own frame -> map (orthonormal)
  std::uint32_t id = 0;                                    ///< the object's or body's id, reported with hits
  float reflectivity = 0.5f;                               ///< diffuse reflectivity at the lidar's wavelength, [0, 1]
};

/// A ray hit on a primitive.
struct PrimitiveHit
{
  double t = 0.0;           ///< m along the ray
  Eigen::Vector3d normal;   ///< unit outward normal at the hit, map
  std::uint32_t index = 0;  ///< index of the primitive in the set it was found in
};

/**
 * @brief Exact first entry of a ray into one primitive within (t_min, t_max].
 * @param direction unit vector
 * @return false when the ray misses, starts inside, or enters outside the interval
 */
bool intersectPrimitive(const Primitive& p, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        double t_min, double t_max, PrimitiveHit& hit);

/// Axis-aligned bounding box of a primitive in the map frame (exact for its shape).
void primitiveBounds(const Primitive& p, Eigen::Vector3d& lo, Eigen::Vector3d& hi);

/**
 * @brief Checks a primitive's fields.
 * @throw std::invalid_argument naming the field: non-finite centre or rotation, half extents
 *        not finite and > 0, rotation not orthonormal (to 1e-6), reflectivity outside [0, 1]
 */
void validatePrimitive(const Primitive& p, const char* context);

/**
 * @brief Binary BVH (binned surface-area heuristic, up to 4 primitives per leaf) over a fixed
 *        set of primitives; rebuilt whole when the set changes (1000 primitives: well under a
 *        millisecond).
 */
class PrimitiveBvh
{
public:
  PrimitiveBvh() = default;
  /// @throw std::invalid_argument (validatePrimitive) for a bad primitive
  explicit PrimitiveBvh(std::vector<Primitive> primitives);

  /// Id that matches no primitive (skip nothing).
  static constexpr std::uint32_t kNoId = 0xffffffffu;

  /**
   * @brief Nearest entry with t in (t_min, t_max]; false if none. Ties go to the lower index.
   * @param skip_id primitives with this id are ignored (a sensor's own vehicle)
   */
  bool intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                 PrimitiveHit& hit, std::uint32_t skip_id = kNoId) const;

  /**
   * @brief Whether any primitive (other than skip_id's) is entered with t in (t_min, t_max]:
   *        intersect()'s answer without the search for the nearest (shadow rays).
   */
  bool occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                std::uint32_t skip_id = kNoId) const;

  /**
   * @brief Indices of the primitives whose horizontal footprint (the x-y extent of
   *        primitiveBounds(), widened by `margin` on every side) meets the 2-D segment
   *        (x0, y0) + s (ux, uy), s in [0, length], in ascending order (replacing `out`).
   *
   * A ray whose path projected on the ground stays within `margin` of that segment can only
   * enter these primitives: a lidar column (rays sharing an origin and a vertical half-plane)
   * collects them once and tests each of its rays against the short list instead of walking
   * the BVH per ray (Scene::cast). A 2-D walk of the BVH, so a few microseconds per segment.
   * @param ux, uy unit horizontal direction
   * @param length m, >= 0
   * @param margin m, >= 0
   */
  void collectAlongSegment(double x0, double y0, double ux, double uy, double length, double margin,
                           std::vector<std::uint32_t>& out) const;

  /// Map-frame bounds of primitive k (primitiveBounds(), computed once at construction).
  const Eigen::Vector3d& boundsLo(std::size_t k) const { return lo_[k]; }
  const Eigen::Vector3d& boundsHi(std::size_t k) const { return hi_[k]; }

  const std::vector<Primitive>& primitives() const { return primitives_; }
  std::size_t nodeCount() const { return nodes_.size(); }

private:
  struct Node
  {
    float lo[3], hi[3];
    std::uint32_t first;  ///< leaf: first index into order_; inner: index of the right child
    std::uint32_t count;  ///< leaf: primitive count (> 0); inner: 0 (left child is this + 1)
  };
  static constexpr int kMaxDepth = 48;
  /// intersect() (any = false) or occluded() (any = true: stop at the first entry found).
  bool traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                PrimitiveHit& hit, std::uint32_t skip_id, bool any) const;
  std::uint32_t build(std::uint32_t begin, std::uint32_t end, std::vector<Eigen::Vector3d>& lo,
                      std::vector<Eigen::Vector3d>& hi, std::vector<Eigen::Vector3d>& centre, int depth);

  std::vector<Primitive> primitives_;
  std::vector<Eigen::Vector3d> lo_, hi_;  ///< primitiveBounds() of each primitive
  std::vector<std::uint32_t> order_;      ///< primitive indices grouped by leaf
  std::vector<Node> nodes_;
};

}  // namespace sensors
}  // namespace avsp
