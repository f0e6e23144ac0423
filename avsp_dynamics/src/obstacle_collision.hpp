#pragma once
/**
 * @file obstacle_collision.hpp
 * @brief Private to avsp_dynamics_core: ODE collision (dCollide) of the vehicles' chassis boxes
 *        and wheel cylinders with the terrain's objects (avsp_terrain ObjectSet) and with each
 *        other. Never with the ground: the soil model carries the running gear (vehicle_sim.cpp).
 *
 * - Rigid objects (strength +inf: buildings, barriers, rocks, large trees) and other vehicles:
 *   ODE contact joints, stiff (ERP 0.2, CFM a 1e-5 m/s creep at the vehicle's weight), Coulomb
 *   friction mu = kObstacleFriction, no bounce. The depth handed to ODE is the penetration less
 *   a 1 mm surface layer, capped so that ODE pushes out at no more than 0.2 m/s: the world's own
 *   dWorldSetContactSurfaceLayer / MaxCorrectingVel stay at ODE's defaults (0, inf) because the
 *   soil contact's normal row depends on them.
 * - Toppleable objects (finite strength: shrubs, small trees, poles, fences): an elastic
 *   resistance F = min(k d, strength) at the contact points, k = strength / yield deflection,
 *   applied as a force before the step. When k d reaches the strength, the object is pushed over
 *   with ObjectSet::push (the terrain, sensors and saved files see it) and its geom is disabled.
 * - Broad phase: the objects are static geoms in one quadtree space, each vehicle's geoms in its
 *   own simple space; per step each vehicle space is collided against the quadtree
 *   (dSpaceCollide2: a few AABB tests per nearby tree block) and against the other vehicles'
 *   spaces. A vehicle's own geoms are never collided with each other.
 */
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ode/ode.h>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/terrain_objects.hpp>

#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace dynamics
{
/// Coulomb friction coefficient of every obstacle and vehicle-vehicle contact: the low end of
/// rubber on dry concrete (kinetic 0.6-0.85, Engineering ToolBox's friction table); steel
/// bodywork on concrete or rock is of the same order. One value for all: an assumption.
constexpr double kObstacleFriction = 0.6;
/// ERP of the rigid contacts (the fraction of the penetration corrected per step).
constexpr double kObstacleErp = 0.2;
/// m: penetration allowed without correction (resting contacts do not jitter).
constexpr double kObstacleSurfaceLayer = 0.001;
/// m/s: fastest push-out of a penetration (so a deep one is not resolved by launching the vehicle).
constexpr double kObstacleMaxCorrectingVelocity = 0.2;
/// m: a toppleable object reaches its strength after this much penetration (its stems bend),
/// or after a quarter of its smaller footprint side if that is less. An assumption: no public
/// figure gives shrub stiffness; a green-wood trunk 0.1 m thick breaks at about 1 cm of deflection
/// at bumper height, a shrub's canopy gives over decimetres.
constexpr double kToppleYieldDeflection = 0.1;
/// m: object geoms reach this far below the lowest ground under their footprint, so a wheel
/// sunk in a rut still meets a rock's or wall's side.
constexpr double kObstacleBuryDepth = 0.5;

/// A wheel body that collides with obstacles (a cylinder about the body's y axis).
struct CollisionWheel
{
  dBodyID body = nullptr;
  double radius = 0.0;  ///< m
  double width = 0.0;   ///< m
};

/// The ODE bodies of one vehicle that can touch obstacles (SimVehicle::collisionBodies()).
struct VehicleBodies
{
  dBodyID chassis = nullptr;
  Eigen::Vector3d chassis_com = Eigen::Vector3d::Zero();  ///< m, chassis body origin in base_link
  std::vector<CollisionWheel> wheels;
  double mass = 0.0;  ///< kg, the whole vehicle (regularization of its contacts)
};

/// A dynamic agent's (World::setAgents) or a proxy's (World::addProxy) body and the boxes it
/// collides with.
struct AgentCollisionBody
{
  dBodyID body = nullptr;           ///< a body of its mass (no gravity): the world drives it, contacts push it
  std::vector<CollisionBox> boxes;  ///< in the body's frame (its origin at its centre of mass)
};

/// What obstacles and other vehicles did to one vehicle over the last step.
struct CollisionReport
{
  int contacts = 0;        ///< contact points
  int rigid_contacts = 0;  ///< of which with rigid obstacles and other vehicles (not toppleable objects)
  Eigen::Vector3d impulse = Eigen::Vector3d::Zero();  ///< N s on the vehicle, map
};

class ObstacleCollision
{
public:
  /// @param step s, the world's fixed step
  explicit ObstacleCollision(double step);
  ~ObstacleCollision();
  ObstacleCollision(const ObstacleCollision&) = delete;
  ObstacleCollision& operator=(const ObstacleCollision&) = delete;

  /**
   * @brief Replaces the obstacles by the objects of `objects` (kept by reference: it must
   *        outlive this), standing on `terrain` as it is now. Grass and toppled objects make no geom.
   * @throw std::invalid_argument naming the object (id, kind, position) whose size is not finite
   *        and positive or which is off the terrain; the previous obstacles stay then
   */
  void setObstacles(terrain::ObjectSet& objects, const terrain::DeformableTerrain& terrain);

  /**
   * @brief Replaces the agents' (and proxies') geoms by boxes riding on the given bodies.
   *        Vehicles meet them as rigid contacts (as other vehicles), momentum exchanged by the
   *        bodies' masses. Agents pass through obstacles and each other.
   */
  void setAgents(const std::vector<AgentCollisionBody>& agents);
  /// Removes the agents' geoms (before their bodies are destroyed).
  void clearAgents();

  /// Adds the geoms of a vehicle (boxes in base_link, chassis and wheels from `bodies`).
  void addVehicle(const std::vector<CollisionBox>& boxes, const VehicleBodies& bodies);
  /// Removes the geoms of the vehicle added last (World::addVehicle's rollback).
  void removeLastVehicle();
  /// Removes the geoms of vehicle `index`; the later vehicles move down one index (their geoms
  /// are tagged again). @throw std::out_of_range for an unknown index
  void removeVehicle(std::size_t index);

  /// Before the ODE step: finds the contacts, makes rigid contact joints in `group`, applies the
  /// toppleable objects' resistance and topples those that give.
  void collide(dWorldID world, dJointGroupID group);
  /// After the ODE step: the per-vehicle reports (impulses from the contact joints' feedback).
  void afterStep();

  /// @throw std::out_of_range for an unknown vehicle index
  const CollisionReport& report(std::size_t vehicle) const;
  std::size_t obstacleGeomCount() const { return obstacles_.size(); }

private:
  struct ObstacleGeom
  {
    dGeomID geom = nullptr;
    std::uint32_t object = 0;  ///< id in the ObjectSet
    bool toppleable = false;
    double stiffness = 0.0;  ///< N/m, toppleable only
  };
  struct VehicleGeoms
  {
    dSpaceID space = nullptr;
    std::vector<dGeomID> geoms;
    std::vector<dBodyID> bodies;  ///< body of each geom
    std::vector<double> masses;   ///< kg, mass of each geom's body
    double mass = 0.0;            ///< kg, whole vehicle
    CollisionReport report;
    dBodyID centre = nullptr;  ///< the chassis: the centre of the bounding sphere
    double reach = 0.0;        ///< m, bounding sphere radius round it (suspension travel included)
  };
  /// An agent's (or proxy's) geoms [begin, end) in agent_geoms_ and its bounding sphere.
  struct AgentRange
  {
    std::size_t begin = 0, end = 0;
    dBodyID body = nullptr;
    double reach = 0.0;  ///< m
  };
  /// Whether two bounding spheres (centres on the bodies) can touch.
  static bool near(dBodyID a, double reach_a, dBodyID b, double reach_b);
  /// Hit::vehicle_b of a contact with an obstacle, with an agent.
  static constexpr std::int32_t kObstacle = -1, kAgent = -2;
  /// One contact point found this step: `a` is a vehicle geom, `b` a vehicle, obstacle or agent geom.
  struct Hit
  {
    std::uint32_t vehicle_a = 0, geom_a = 0;  ///< vehicle index, geom index within it
    std::int32_t vehicle_b = kObstacle;       ///< vehicle index, kObstacle or kAgent
    std::uint32_t geom_b = 0;                 ///< geom index within vehicle_b, obstacle or agent geom index
    int order = 0;                            ///< index in dCollide's output
    dContactGeom contact;
  };
  struct RigidJoint
  {
    std::uint32_t vehicle_a;
    std::int32_t vehicle_b;
    bool body_b = false;  ///< the joint's second body is vehicle_b's (else the static world)
  };
  struct Push
  {
    std::uint32_t obstacle;
    double depth_max, depth_sum;
  };

  static void nearCallback(void* data, dGeomID o1, dGeomID o2);
  /// Whether a hit is on an object that topples (pushed, not a rigid joint).
  bool toppleable(const Hit& h) const;
  /// Toppleable objects hit this step: the vehicles feel their elastic resistance; pushed to
  /// their strength, they fall.
  void pushToppleable();
  /// Rigid obstacles and other vehicles: stiff contact joints with Coulomb friction.
  void addRigidJoints(dWorldID world, dJointGroupID group);
  void collect(dGeomID a, dGeomID b);
  void clearObstacles();
  void destroyVehicle(VehicleGeoms& v);

  double step_;
  terrain::ObjectSet* objects_ = nullptr;
  dSpaceID obstacle_space_ = nullptr;
  std::vector<ObstacleGeom> obstacles_;
  std::vector<VehicleGeoms> vehicles_;
  dSpaceID agent_space_ = nullptr;
  std::vector<dGeomID> agent_geoms_;
  std::vector<dBodyID> agent_geom_bodies_;  ///< body of each agent geom
  std::vector<AgentRange> agent_ranges_;    ///< per agent body
  // Per-step scratch, kept between steps so their capacity is reused (no allocation per step
  // once warmed up).
  std::vector<Hit> hits_;
  std::vector<Push> pushes_;
  std::vector<dJointFeedback> feedback_;
  std::vector<RigidJoint> joints_;
};

}  // namespace dynamics
}  // namespace avsp
