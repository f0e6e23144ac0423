#include "avsp_dynamics/partition_reach.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace avsp
{
namespace dynamics
{
namespace
{
struct Extent
{
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& half)
  {
    lo = lo.cwiseMin(p - half);
    hi = hi.cwiseMax(p + half);
  }
};

/// Half extent along a horizontal unit axis n of a box at `pose`, and its centre's coordinate.
void project(const Eigen::Isometry3d& pose, const VehicleBox& b, const Eigen::Vector2d& n, double& centre,
             double& radius)
{
  const Eigen::Vector3d c = pose * b.centre;
  centre = c.x() * n.x() + c.y() * n.y();
  const Eigen::Matrix3d& r = pose.linear();
  radius = 0.0;
  for (int k = 0; k < 3; ++k)
    radius += std::abs(r(0, k) * n.x() + r(1, k) * n.y()) * b.half[k];
}
}  // namespace

VehicleBox boundingBox(const VehicleModel& model, double margin)
{
  Extent e;
  for (const CollisionBox& b : model.collision_boxes)
  {
    // Every corner of the (possibly rotated) box.
    for (int s = 0; s < 8; ++s)
    {
      const Eigen::Vector3d corner(s & 1 ? 0.5 : -0.5, s & 2 ? 0.5 : -0.5, s & 4 ? 0.5 : -0.5);
      e.add(b.pose * corner.cwiseProduct(b.size), Eigen::Vector3d::Zero());
    }
  }
  for (const Body& b : model.bodies)
    e.add(b.rest_position, Eigen::Vector3d::Zero());
  for (const WheelSpec& w : model.wheels)
  {
    // A steered wheel turns about z: its radius bounds it along x and y alike.
    const double r = std::max(w.radius, std::hypot(w.radius, 0.5 * w.width));
    for (double travel : { w.suspension_lower, w.suspension_upper })
      e.add(w.rest_position + Eigen::Vector3d(0.0, 0.0, travel), Eigen::Vector3d(r, r, w.radius));
  }
  for (const TrackSpec& t : model.tracks)
  {
    for (const RoadWheelSpec& w : t.road_wheels)
    {
      // The road arm swings the wheel about its pivot: anywhere within the arm's reach.
      const double arm = (w.rest_position - w.pivot).norm();
      e.add(w.pivot, Eigen::Vector3d(arm + w.radius, 0.5 * w.width, arm + w.radius));
    }
    const double belt = t.road_wheels.empty() ? 0.0 : 0.5 * t.road_wheels.front().width;
    for (const Body& b : model.bodies)
    {
      if (b.link == t.sprocket_link)
        e.add(b.rest_position, Eigen::Vector3d(t.sprocket_radius, belt, t.sprocket_radius));
      else if (b.link == t.idler_link)
        e.add(b.rest_position, Eigen::Vector3d(t.idler_radius, belt, t.idler_radius));
    }
  }
  VehicleBox box;
  if (!(e.lo.x() <= e.hi.x()))  // nothing at all: a point at base_link
    e.add(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  box.centre = 0.5 * (e.lo + e.hi);
  box.half = 0.5 * (e.hi - e.lo) + Eigen::Vector3d::Constant(std::max(0.0, margin));
  return box;
}

double sweptReach(const VehicleBox& box, const Eigen::Vector3d& linear_velocity,
                  const Eigen::Vector3d& angular_velocity, double horizon, double max_acceleration)
{
  const double r = box.centre.norm() + box.half.norm();
  const double t = std::max(0.0, horizon);
  return (linear_velocity.norm() + angular_velocity.norm() * r) * t + 0.5 * std::max(0.0, max_acceleration) * t * t;
}

bool shadowsApart(const Eigen::Isometry3d& pose_a, const VehicleBox& a, double grow_a, const Eigen::Isometry3d& pose_b,
                  const VehicleBox& b, double grow_b)
{
  Eigen::Vector2d axes[6] = { Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 1.0) };
  int n = 2;
  for (const Eigen::Isometry3d* pose : { &pose_a, &pose_b })
    for (int k = 0; k < 2; ++k)
    {
      const Eigen::Vector2d h(pose->linear()(0, k), pose->linear()(1, k));
      const double len = h.norm();
      if (len > 1e-6)  // an axis standing upright has no horizontal direction
        axes[n++] = h / len;
    }
  for (int k = 0; k < n; ++k)
  {
    double ca, ra, cb, rb;
    project(pose_a, a, axes[k], ca, ra);
    project(pose_b, b, axes[k], cb, rb);
    if (std::abs(ca - cb) > ra + rb + grow_a + grow_b)
      return true;
  }
  return false;
}

}  // namespace dynamics
}  // namespace avsp
