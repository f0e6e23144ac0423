#include "avsp_dynamics/leg_kinematics.hpp"

#include <cmath>

namespace avsp
{
namespace dynamics
{
namespace
{
/// The rotation by `angle` about `axis` through `anchor`.
Eigen::Isometry3d about(const Eigen::Vector3d& anchor, const Eigen::Vector3d& axis, double angle)
{
  return Eigen::Translation3d(anchor) * Eigen::AngleAxisd(angle, axis) * Eigen::Translation3d(-anchor);
}

double wrapped(double angle)
{
  return std::atan2(std::sin(angle), std::cos(angle));
}
}  // namespace

LegPose legForward(const LegSpec& leg, const LegAngles& q)
{
  LegPose out;
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  for (int k = 0; k < 3; ++k)
  {
    // Joint k's anchor and axis ride on its parent (moved by m so far).
    m = m * about(leg.anchors[k], leg.axes[k], q[k]);
    out.motion[k] = m;
  }
  out.foot = out.motion[2] * leg.foot_centre;
  return out;
}

std::optional<LegAngles> legInverse(const LegSpec& leg, const Eigen::Vector3d& foot, bool knees_backward)
{
  // Abduction (about x through anchor 0): in the y-z plane the leg is the lateral offset d of
  // the flexion joint and, below it, the leg's length h in its own plane.
  const double sx = leg.axes[0].x() > 0.0 ? 1.0 : -1.0;
  const Eigen::Vector3d p = foot - leg.anchors[0];
  const double d = leg.anchors[1].y() - leg.anchors[0].y();
  const double r2 = p.y() * p.y() + p.z() * p.z();
  if (!(r2 > d * d))
    return std::nullopt;
  const double h = std::sqrt(r2 - d * d);
  const double qa = std::atan2(p.z(), p.y()) - std::atan2(-h, d);
  // The foot in the leg's plane (abduction undone), from the flexion joint.
  const Eigen::Vector3d in_plane =
      Eigen::AngleAxisd(-qa, Eigen::Vector3d::UnitX()) * p - (leg.anchors[1] - leg.anchors[0]);
  const double l1 = (leg.anchors[1] - leg.anchors[2]).norm(), l2 = (leg.anchors[2] - leg.foot_centre).norm();
  const double x = in_plane.x(), z = in_plane.z();
  const double c2 = (x * x + z * z - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
  if (!(c2 >= -1.0 && c2 <= 1.0))
    return std::nullopt;
  // A rotation by q about +y takes the straight-down link (0, 0, -l) to (-l sin q, 0, -l cos q).
  const double sy1 = leg.axes[1].y() > 0.0 ? 1.0 : -1.0, sy2 = leg.axes[2].y() > 0.0 ? 1.0 : -1.0;
  const double q2 = (knees_backward ? -1.0 : 1.0) * std::acos(c2);
  const double a = l1 + l2 * std::cos(q2), b = l2 * std::sin(q2);
  const double q1 = std::atan2(-x, -z) - std::atan2(b, a);
  return LegAngles{ sx * wrapped(qa), sy1 * q1, sy2 * q2 };
}

Eigen::Matrix3d legJacobian(const LegSpec& leg, const LegAngles& q)
{
  constexpr double kDelta = 1e-6;
  Eigen::Matrix3d j;
  for (int k = 0; k < 3; ++k)
  {
    LegAngles plus = q, minus = q;
    plus[k] += kDelta;
    minus[k] -= kDelta;
    j.col(k) = (legForward(leg, plus).foot - legForward(leg, minus).foot) / (2.0 * kDelta);
  }
  return j;
}

Eigen::Vector3d stanceFoot(const VehicleModel& model, const LegSpec& leg)
{
  return Eigen::Vector3d(leg.anchors[1].x(), leg.anchors[1].y(), leg.foot_radius - model.legged.stance_height);
}

LegAngles stanceAngles(const VehicleModel& model, const LegSpec& leg)
{
  const auto q = legInverse(leg, stanceFoot(model, leg), model.legged.knees_backward);
  if (!q)
    throw ConfigError(model.yaml_path + ": stance.height: leg '" + leg.name + "' cannot reach its stance");
  return *q;
}

}  // namespace dynamics
}  // namespace avsp
