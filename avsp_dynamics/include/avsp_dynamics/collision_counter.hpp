#pragma once
/**
 * @file collision_counter.hpp
 * @brief How many collisions a vehicle has had (VehicleTelemetry.collisions): rigid contacts
 *        (rigid obstacles: buildings, barriers, rocks, large trees; and other vehicles) begun.
 *        The core owns the rule so the node's count and the core's tests agree.
 *
 * A collision begins at a step with rigid contact points after at least `separation` seconds
 * of world time and `travel` metres of horizontal base_link travel without any (or at the first such
 * step). A stiff contact chatters: an impact touches, bounces off a few centimetres and settles
 * back over the next second (a fed_alpha into a wall at 15 m/s: 0.7 s and 2 cm off), and a
 * vehicle leaning on a wall loses and regains a contact point now and then; those are one
 * collision, not hundreds. (So a parked vehicle that another hits twice counts one collision;
 * the one that backed off and hit again counts two.)
 * Toppleable objects (shrubs, small trees, poles, fences) are not collisions: pushing one over
 * is reported on /terrain/toppled.
 */
#include <cstdint>

#include <Eigen/Core>

#include "avsp_dynamics/vehicle_sim.hpp"

namespace avsp
{
namespace dynamics
{
/// Counts rigid contacts begun (see the file's description).
class CollisionCounter
{
public:
  /// @throw std::invalid_argument if separation (s) or travel (m) is not finite and >= 0
  explicit CollisionCounter(double separation = 0.5, double travel = 0.5);

  /**
   * @brief Feeds one step: `rigid_contacts` contact points with rigid obstacles or other
   *        vehicles over the step ending at world time `time` (s, non-decreasing), with the
   *        vehicle's base_link at `position` (m, map).
   * @return whether a new collision began at this step
   */
  bool update(int rigid_contacts, double time, const Eigen::Vector3d& position);
  /// update(state.obstacle_rigid_contacts, time, state.pose.translation())
  bool update(const VehicleState& state, double time)
  {
    return update(state.obstacle_rigid_contacts, time, state.pose.translation());
  }

  /// Collisions begun so far.
  std::uint32_t count() const { return count_; }
  /// Whether the last step had rigid contact points.
  bool inContact() const { return in_contact_; }

private:
  double separation_;
  double travel_;
  double last_contact_ = 0.0;  ///< s, world time of the last step with rigid contact points
  double travelled_ = 0.0;     ///< m, horizontal base_link path length since then
  Eigen::Vector3d last_position_ = Eigen::Vector3d::Zero();
  bool touched_ = false;  ///< any rigid contact so far (last_contact_ is valid)
  bool in_contact_ = false;
  std::uint32_t count_ = 0;
};

}  // namespace dynamics
}  // namespace avsp
