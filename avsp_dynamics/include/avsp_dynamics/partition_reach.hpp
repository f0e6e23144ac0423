#pragma once
/**
 * @file partition_reach.hpp
 * @brief Where a vehicle can be within a short horizon, for the partitions' exchange: a
 *        partition may step an interval before its peers' last exchange has arrived when
 *        none of their vehicles can come near its own within that interval (conservative
 *        lookahead), and still get the answer of the strict lockstep.
 */
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace dynamics
{
/// A box in base_link axes that holds all of a vehicle's geometry at any suspension travel.
struct VehicleBox
{
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< m, base_link
  Eigen::Vector3d half = Eigen::Vector3d::Zero();    ///< m, half edge lengths along base_link x, y, z (>= 0)
};

/**
 * @brief The box round a vehicle model: its collision boxes, its wheels (radius, half width,
 *        the whole suspension travel), its road wheels, sprockets and idlers, and every link
 *        origin, with `margin` (m) added on every side.
 */
VehicleBox boundingBox(const VehicleModel& model, double margin = 0.05);

/**
 * @brief How far (m) any point of a vehicle's box may move in `horizon` s from a state with
 *        the given velocities (map frame, base_link origin), if no point of it accelerates by more
 *        than `max_acceleration` (m/s^2): (|v| + |w| r) T + a T^2 / 2, r the box's farthest corner
 *        from base_link's origin.
 */
double sweptReach(const VehicleBox& box, const Eigen::Vector3d& linear_velocity,
                  const Eigen::Vector3d& angular_velocity, double horizon, double max_acceleration);

/**
 * @brief Whether the shadows on the map's x-y plane of two boxes (each at a base_link pose,
 *        each grown by its `grow`, m, in every direction) are certainly apart: true only if a
 *        separating line exists among the boxes' horizontal axes and the map's x and y axes.
 *        false means "maybe touching" (never a false "apart").
 */
bool shadowsApart(const Eigen::Isometry3d& pose_a, const VehicleBox& a, double grow_a, const Eigen::Isometry3d& pose_b,
                  const VehicleBox& b, double grow_b);

}  // namespace dynamics
}  // namespace avsp
