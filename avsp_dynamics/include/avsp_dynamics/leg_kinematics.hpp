#pragma once
/**
 * @file leg_kinematics.hpp
 * @brief A legged vehicle's leg (vehicle_model.hpp LegSpec) as a chain of three revolute joints:
 *        where its links and foot are for given joint angles (forward), the angles that put the
 *        foot somewhere (inverse, for the leg shape the model loader accepts: abduction about x,
 *        flexion about y beside it, knee about y below it, foot below the knee), the foot's
 *        Jacobian, and the stance a model stands in. ROS-free; base_link frame, SI units, joint
 *        angles as in the URDF (0: the leg straight down).
 */
#include <array>
#include <optional>

#include <Eigen/Geometry>

#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace dynamics
{
using LegAngles = std::array<double, 3>;  ///< rad: abduction, hip flexion, knee

/// Where a leg is at given joint angles.
struct LegPose
{
  /// Each link's (hip, thigh, shank) rigid motion from the rest pose (all joints 0) in base_link:
  /// a point p of the link at rest is at motion[k] * p.
  std::array<Eigen::Isometry3d, 3> motion;
  Eigen::Vector3d foot = Eigen::Vector3d::Zero();  ///< m, the foot sphere's centre in base_link
};

LegPose legForward(const LegSpec& leg, const LegAngles& q);

/**
 * @brief The joint angles that put the foot sphere's centre at `foot` (base_link), the knee
 *        bending the way `knees_backward` says (backward: the knee angle <= 0 for +y axes).
 * @return nothing when the point is out of the leg's reach (or too close to the hip)
 */
std::optional<LegAngles> legInverse(const LegSpec& leg, const Eigen::Vector3d& foot, bool knees_backward);

/// d foot / d q (3 x 3, base_link), by central differences of legForward (1e-6 rad).
Eigen::Matrix3d legJacobian(const LegSpec& leg, const LegAngles& q);

/// Where a leg's foot stands: its sphere's centre straight below the hip flexion joint, the
/// sole `model.legged.stance_height` below base_link.
Eigen::Vector3d stanceFoot(const VehicleModel& model, const LegSpec& leg);

/// The joint angles of a leg standing (stanceFoot). @throw ConfigError if the stance is out of reach
LegAngles stanceAngles(const VehicleModel& model, const LegSpec& leg);

}  // namespace dynamics
}  // namespace avsp
