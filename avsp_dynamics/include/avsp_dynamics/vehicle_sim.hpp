#pragma once
/**
 * @file vehicle_sim.hpp
 * @brief The vehicle simulation: an ODE world with a fixed step that drives vehicles built
 *        from a VehicleModel over a DeformableTerrain. The soil, not ODE friction, makes the
 *        wheel-ground forces (avsp_terrain's T7-T12 contact, every step, with ruts).
 *
 * What a wheeled vehicle is in ODE:
 *  - a chassis body: every non-wheel URDF link lumped (mass, centre of mass, inertia tensor
 *    by the parallel-axis theorem);
 *  - one body per wheel (the wheel link's mass and inertia), joined to the chassis by a
 *    hinge2: axis 1 = chassis z (steering, and the suspension travels along it), axis 2 =
 *    the axle. The suspension spring-damper is the hinge2's implicit suspension
 *    (ERP = h k / (h k + c), CFM = 1 / (h k + c)), plus the YAML preload k * preload as a
 *    force pair so the URDF pose is the static ride height, plus bump stops at the URDF
 *    travel limits;
 *  - steering: a rate-limited actuator on the bicycle angle, Ackermann angles per wheel
 *    (AckermannGeometry), each tracked by the hinge2's axis-1 motor; unsteered wheels are
 *    locked by axis-1 stops at 0;
 *  - drivetrain: engine torque and power limit through gear ratio and efficiency (Ackermann)
 *    or one speed-servoed motor per side (skid-steer); open differentials split torque
 *    equally, locked ones hold equal speeds (see README: transfer torque solved each step);
 *    brakes are axis-2 velocity motors with the brake torque as their limit.
 *
 * Soil contact, per wheel per step: a WheelPatch from the wheel body's pose and velocity,
 * terrain.wheelContact(patch, h, deform), and its forces handed to ODE as one contact joint
 * at the wheel's lowest point: the normal force as an implicit spring-damper whose stiffness
 * is the soil's own (probed), traction and lateral force as friction rows bounded by what the
 * soil gives at the current slip (force-dependent slip = the soil's slip velocity per newton),
 * rolling and bulldozing resistance as a force at the wheel centre. README.md explains why.
 *
 * What a tracked vehicle is in ODE (README.md, "How a tracked vehicle is built"):
 *  - a hull body: every URDF link but the road wheels lumped (road arms, whose centre of mass
 *    is on their pivot, sprockets, idlers and the track belts included);
 *  - one body per road wheel, held on its trailing arm by explicit forces: a stiff spring-
 *    damper keeping the wheel centre on the arm's circle about its pivot and its axle parallel
 *    to the hull's, the torsion bar (YAML stiffness, damping, preload so that the URDF pose is
 *    the static ride height) and bump stops at the URDF arm limits. Explicit, so that each
 *    track's wheels form an ODE island of their own (ODE's exact solver costs the cube of an
 *    island's rows);
 *  - the belt as a kinematic constraint: a track's road wheels turn at one speed (ODE angular
 *    motors between neighbours), each carrying its share of the sprocket's, idler's and belt's
 *    rotating inertia; sprocket speed = road-wheel speed x wheel radius / (p N / 2 pi) (T10);
 *  - drive: trackedSides() speed fractions per sprocket, each side's speed servo limited to half
 *    the engine's torque/power through the gear ratio; brakes on the sprockets;
 *  - soil: one track segment per road wheel (ground length / road wheels, shoe width) under the
 *    wheel, terrain.trackContact() with the segment's place on the whole track (T10, T11), its
 *    forces handed to ODE as a wheel's (implicit normal spring, friction rows bounded by the
 *    soil's force, resistance at the wheel centre); on rigid-plastic (Bekker) soil the rut's
 *    floor holds the wheel up to the floor's force instead of a spring, and at rest the rows
 *    may take the soil's whole shear strength (README.md says why).
 *
 * Obstacles (World::setObstacles): ODE collision (dCollide) is used only between the vehicles'
 * chassis boxes (URDF <collision> boxes) and wheel cylinders and the terrain's objects
 * (avsp_terrain ObjectSet) or other vehicles; never with the ground, and never within one
 * vehicle. Rigid objects (strength +inf: buildings, barriers, rocks, large trees) are stiff
 * contacts with Coulomb friction; toppleable ones (shrubs, small trees, poles, fences) resist
 * with up to their strength and, when pushed that hard, topple through ObjectSet::push.
 */
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include <avsp_terrain/agents.hpp>
#include <avsp_terrain/deformable_terrain.hpp>

#include "avsp_dynamics/drivetrain.hpp"
#include "avsp_dynamics/external_wheel_soil.hpp"
#include "avsp_dynamics/vehicle_model.hpp"

struct dxBody;  // ODE's body (ode/ode.h's dBodyID points to one), opaque here

namespace avsp
{
namespace dynamics
{
/// ODE's solvers: exact (dWorldStep, Dantzig LCP) or iterative (dWorldQuickStep, SOR).
enum class Solver
{
  kExact,     ///< constraints met to rounding: brakes hold, no creep (default)
  kIterative  ///< cheaper per row for large worlds; a braked vehicle creeps (mm/s at 20 iterations)
};

/// Settings of a World. Invalid values throw std::invalid_argument naming the field.
struct WorldOptions
{
  double step = 0.001;     ///< s, fixed physics step (> 0, <= 0.01)
  double gravity = 9.81;   ///< m/s^2, along -z of the map (>= 0)
  std::uint64_t seed = 0;  ///< seeds ODE's solver (constraint order); same seed = same run
  Solver solver = Solver::kExact;
  int solver_iterations = 20;  ///< QuickStep iterations with Solver::kIterative (>= 1)
  bool deform_terrain = true;  ///< false: contacts leave no ruts (the terrain stays as it is)
  double contact_damping_ratio =
      0.7;               ///< of a contact's modes (a wheel on the ground, the ground's shear hold), [0, 2]
  bool profile = false;  ///< accumulate step timings (World::times())
};

/// What one wheel does this step (the contract's WheelContact, plus joint state). SI units.
struct WheelState
{
  std::string name;
  bool in_contact = false;
  double normal_force = 0.0;          ///< N, the soil's normal reaction (terrain model)
  double applied_normal_force = 0.0;  ///< N, normal force ODE applied over the last step
  double sinkage = 0.0;               ///< m, below the undeformed surface
  double slip = 0.0;                  ///< T8, [-1, 1]
  double slip_angle = 0.0;            ///< rad
  double traction_force = 0.0;        ///< N, longitudinal soil force applied over the last step, + forward
  double lateral_force = 0.0;         ///< N, lateral soil force applied over the last step, + to the left
  double resistance_force = 0.0;      ///< N, bulldozing + rolling (T12), Bekker's compaction, a tyre's rolling, >= 0
  /// N along the heading the resistance applied over the last step at the wheel centre (up to
  /// resistance_force, against the travel; at rest it holds the wheel up to that).
  double applied_resistance_force = 0.0;
  int contact_points = 0;              ///< terrain grid points under load
  double spin_rate = 0.0;              ///< rad/s relative to the chassis, + rolls forward
  double steering_angle = 0.0;         ///< rad, + = left
  double suspension_deflection = 0.0;  ///< m along chassis z from the URDF rest pose, + = up (bump)
  double drive_torque = 0.0;           ///< N m applied by the drivetrain this step
  double brake_torque_limit = 0.0;     ///< N m, the brake's torque limit this step
};

/**
 * @brief One track segment's soil contact this step: the patch of track under one road wheel
 *        (the contract's WheelContact, for a track). SI units; forces act on the vehicle.
 */
struct TrackSegmentState
{
  std::string name;  ///< the road wheel's URDF link, e.g. left_road_wheel_1
  bool in_contact = false;
  double normal_force = 0.0;              ///< N, the soil's normal reaction (terrain model)
  double applied_normal_force = 0.0;      ///< N, normal force ODE applied over the last step
  double sinkage = 0.0;                   ///< m, deepest point below the undeformed surface
  double slip = 0.0;                      ///< T8 with the sprocket's theoretical speed (T10), [-1, 1]
  double slip_angle = 0.0;                ///< rad
  double traction_force = 0.0;            ///< N, longitudinal soil force applied over the last step, + forward
  double lateral_force = 0.0;             ///< N, lateral soil force applied over the last step, + to the left
  double resistance_force = 0.0;          ///< N, compaction and bulldozing (T12 or Bekker's), >= 0
  double applied_resistance_force = 0.0;  ///< N along the heading, applied over the last step (as a wheel's)
  int contact_points = 0;                 ///< terrain grid points under load
  double length = 0.0;                    ///< m, the segment's ground length along the track
  double width = 0.0;                     ///< m, the shoe width
};

/// One road wheel on its torsion-bar arm: the URDF joints' positions (robot_state_publisher)
/// and the suspension's load. Angles about the joints' own axes, 0 at the URDF pose.
struct RoadWheelState
{
  std::string link;             ///< road wheel link, e.g. left_road_wheel_1
  std::string arm_joint;        ///< URDF revolute joint of the arm
  std::string spin_joint;       ///< URDF continuous joint of the wheel on the arm
  double arm_angle = 0.0;       ///< rad, arm_joint position (for the M113's +y axes: + lifts the wheel)
  double arm_rate = 0.0;        ///< rad/s
  double torsion_torque = 0.0;  ///< N m the torsion bar (preload, twist, damper, bump stop) applies to
                                ///< the arm, + pushes the wheel towards the ground
  double spin_angle = 0.0;      ///< rad, spin_joint position (integrated), in [-pi, pi]
  double spin_rate = 0.0;       ///< rad/s, spin_joint velocity (wheel relative to its arm), + rolls forward
};

/// One track (side) of a tracked vehicle after the last step. SI units.
struct TrackState
{
  std::string side;                         ///< left | right
  std::string sprocket_joint;               ///< URDF continuous joint
  std::string idler_joint;                  ///< URDF continuous joint
  double sprocket_speed = 0.0;              ///< rad/s relative to the hull, + drives forward
  double sprocket_angle = 0.0;              ///< rad, integrated, in [-pi, pi]
  double idler_speed = 0.0;                 ///< rad/s: track speed / idler radius
  double idler_angle = 0.0;                 ///< rad, integrated, in [-pi, pi]
  double track_speed = 0.0;                 ///< m/s, belt relative to the hull: T10, p N sprocket_speed / (2 pi)
  double ground_speed = 0.0;                ///< m/s, the hull's velocity at the track's centre along its heading
  double slip = 0.0;                        ///< T8 of the whole track: (track_speed - ground_speed) / track_speed
                                            ///< when driving, terrain::longitudinalSlip() in general, [-1, 1]
  double drive_torque = 0.0;                ///< N m at the sprocket this step (+ forward)
  double brake_torque_limit = 0.0;          ///< N m at the sprocket this step
  double normal_force = 0.0;                ///< N, sum of the segments' soil normal forces
  double traction_force = 0.0;              ///< N, sum of the segments' applied traction
  double resistance_force = 0.0;            ///< N, sum of the segments' resistance
  std::vector<RoadWheelState> road_wheels;  ///< front to rear (the model's order)
  std::vector<TrackSegmentState> segments;  ///< one per road wheel, the same order
};

/// One actuated joint of a legged vehicle after the last step (URDF convention, for joint_states).
struct LegJointState
{
  std::string name;       ///< the URDF joint, e.g. front_left_knee
  double position = 0.0;  ///< rad
  double velocity = 0.0;  ///< rad/s
  double effort = 0.0;    ///< N m the actuator applied over the last step (after its limits)
};

/// One foot of a legged vehicle: its pad's soil contact over the last step. SI units.
struct FootState
{
  std::string leg;  ///< e.g. front_left
  bool in_contact = false;
  double normal_force = 0.0;                           ///< N, the soil's (or a rigid surface's) normal reaction
  double applied_normal_force = 0.0;                   ///< N, vertical force ODE's contact applied over the last step
  double sinkage = 0.0;                                ///< m, the pad's deepest point below the undeformed surface
  double pressure = 0.0;                               ///< Pa, normal force over the pad's area
  double slip_velocity = 0.0;                          ///< m/s, the pad's speed over the ground (in its plane)
  int contact_points = 0;                              ///< terrain grid points under the pad
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< m, the foot sphere's centre, map
};

/// A vehicle's state after the last step.
struct VehicleState
{
  std::string name;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();      ///< base_link in map
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< m/s, base_link origin, map
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, map
  Eigen::Vector3d body_velocity = Eigen::Vector3d::Zero();     ///< m/s, base_link origin, base_link axes
  Eigen::Vector3d centre_of_mass = Eigen::Vector3d::Zero();    ///< m, all bodies, map
  double steering_angle = 0.0;     ///< rad, Ackermann bicycle angle (AckermannGeometry), + = left
  double engine_speed = 0.0;       ///< rad/s (skid-steer: mean of the side motors; tracked: gear ratio
                                   ///< x the faster sprocket's speed)
  double engine_torque = 0.0;      ///< N m at the crankshaft (skid-steer: sum of the side motors;
                                   ///< tracked: sum of both sprockets' |torque| / (efficiency x ratio))
  DriveCommand command;            ///< the command in force (clamped)
  std::vector<WheelState> wheels;  ///< wheeled vehicles, in model.wheels order; empty if tracked
  std::vector<TrackState> tracks;  ///< tracked vehicles: left, then right; empty if wheeled
  std::vector<LegJointState>
      joints;                   ///< legged vehicles: each leg's abduction, flexion, knee, legs in the model's order
  std::vector<FootState> feet;  ///< legged vehicles: one per leg, the model's order
  /// Legged vehicles: the trunk tipped more than 60 degrees from upright or down within 35 % of
  /// its stance height of the ground; stays set (a fallen robot does not get up by itself).
  bool fallen = false;
  /// Contact points with obstacles and other vehicles over the last step (0 = touching nothing).
  int obstacle_contacts = 0;
  /// Of those, the points with rigid obstacles (strength +inf) and other vehicles: what
  /// CollisionCounter counts as collisions (collision_counter.hpp).
  int obstacle_rigid_contacts = 0;
  /// N: the ground's normal force on the hull's underside (the chassis collision boxes' bottom
  /// faces) over the last step; > 0 when the vehicle has sunk to its belly or is high-centred.
  double hull_normal_force = 0.0;
  /// Steps in which a running gear's ground contact gave a non-finite force (that contact was
  /// left out of the step; World::takeWarnings() names it once).
  int contact_faults = 0;
  /// N s, impulse obstacles and other vehicles gave the vehicle over the last step (map frame):
  /// the rigid contacts' constraint forces and the toppleable objects' resistance, times the step.
  Eigen::Vector3d obstacle_impulse = Eigen::Vector3d::Zero();
};

/// Accumulated wall time of World::step() by part (World options.profile).
struct StepTimes
{
  std::uint64_t steps = 0;
  double ode = 0.0;        ///< s in the ODE step (dWorldStep or dWorldQuickStep)
  double contact = 0.0;    ///< s in wheelContact/trackContact (and a hull's plate contact)
  double other = 0.0;      ///< s in the rest (actuators, drivetrain, joints, telemetry)
  double collision = 0.0;  ///< s finding obstacle and vehicle-vehicle contacts and making their joints
};

class SimVehicleBase;     // one vehicle's ODE bodies and joints (src/sim_vehicle_base.hpp)
class ObstacleCollision;  // ODE collision with obstacles and between vehicles (obstacle_collision.cpp)

/**
 * @brief An ODE world with a fixed step driving vehicles over a deformable terrain.
 *
 * Single-threaded and deterministic: the same terrain, vehicles, commands and seed give
 * bit-identical trajectories (ODE's solver randomness is seeded per world and its state
 * saved between steps, so other worlds in the process do not disturb it).
 */
class World
{
public:
  /**
   * @param terrain the ground; must outlive the World (it is deformed by the wheels)
   * @throw std::invalid_argument naming the WorldOptions field that is out of range
   */
  explicit World(terrain::DeformableTerrain& terrain, const WorldOptions& options = WorldOptions());
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /**
   * @brief Builds a vehicle's ODE bodies and joints at `pose` (base_link in map), at rest,
   *        suspension at its URDF rest position. Wheeled (ackermann, skid_steer) or tracked.
   * @param name used in telemetry and errors; the model name when empty
   * @return the vehicle's index
   * @throw ConfigError naming the model's YAML and the key/link when the model cannot be
   *        simulated (a wheel or road wheel link without mass or off its axle, a track without
   *        road wheels, a sprocket, idler or belt link without mass; nothing is left in the
   *        world when it throws)
   * @throw std::invalid_argument when the pose is not finite
   */
  std::size_t addVehicle(const VehicleModel& model, const Eigen::Isometry3d& pose, const std::string& name = "");

  /**
   * @brief Takes a vehicle out of the world between steps: its bodies, joints and collision
   *        geoms are destroyed; the soil keeps its ruts. The vehicles added after it move down
   *        one index (k becomes k - 1), so a caller holding indices renumbers them.
   * @throw std::out_of_range for an unknown vehicle index (nothing changes)
   */
  void removeVehicle(std::size_t vehicle);

  /**
   * @brief Sets the command a vehicle follows from the next step on (fields clamped).
   * @throw CommandError naming the field when a field is NaN or infinite (the previous
   *        command stays in force)
   * @throw std::out_of_range for an unknown vehicle index
   */
  void setCommand(std::size_t vehicle, const DriveCommand& command);

  /**
   * @brief Sets every body of a vehicle moving at `velocity` (m/s, map), the chassis without
   *        rotation and each wheel spinning to roll along its heading (no slip): a vehicle
   *        launched at speed. Takes effect from the next step; state() shows it at once.
   * @throw std::out_of_range for an unknown vehicle index
   * @throw std::invalid_argument when the velocity is not finite
   */
  void setVelocity(std::size_t vehicle, const Eigen::Vector3d& velocity);

  /**
   * @brief Pushes vehicle k's chassis (a legged vehicle's trunk) at its centre of mass with
   *        `force` (N, map) over the next `duration` s (rounded to whole steps): a disturbance
   *        (a shove, a gust) for tests and scripted runs. Pushes add up.
   * @throw std::out_of_range for an unknown vehicle; std::invalid_argument for a force that is
   *        not finite or a duration that is not finite and >= 0
   */
  void push(std::size_t vehicle, const Eigen::Vector3d& force, double duration);

  /**
   * @brief Sets a vehicle down again at `pose` (base_link), as addVehicle() did: every body
   *        of it (the chassis and all jointed to it) at its pose relative to base_link then,
   *        all velocities zero, every contact's shear state and servo forgotten: a teleport
   *        between steps. The soil is not touched. Takes effect from the next step; state()
   *        shows it at once.
   * @throw std::out_of_range for an unknown vehicle index
   * @throw std::invalid_argument when the pose is not finite or its rotation not orthonormal
   */
  void setPose(std::size_t vehicle, const Eigen::Isometry3d& pose);

  /**
   * @brief Gravity from the next step on (m/s^2, map frame; WorldOptions::gravity sets it along
   *        -z at construction). A tilt-table test tilts gravity over a level ground instead of
   *        tilting the ground: the same loads, normal and along the surface, as a slope.
   * @throw std::invalid_argument when the vector is not finite or its magnitude differs from
   *        WorldOptions::gravity by more than 1e-9 (the models that scale with the weight use it)
   */
  void setGravity(const Eigen::Vector3d& gravity);

  /**
   * @brief The vehicles collide with the objects of `objects` from the next step on, replacing
   *        any earlier set. Each object not grass and not toppled becomes a static geom standing
   *        on the terrain as it is now (from 0.5 m below the lowest ground under its footprint
   *        to its height above the ground at its centre): trees, shrubs and poles as upright
   *        cylinders of diameter (length + width) / 2, the rest as boxes of their footprint.
   *        Objects of finite strength topple through ObjectSet::push when a vehicle pushes them
   *        that hard (their `toppled` and `fall_direction` change) and stop colliding; objects
   *        toppled by anyone else stop colliding too.
   * @param objects kept by reference and modified: must outlive the World (or be replaced)
   * @throw std::invalid_argument naming the object (id, kind, position) when one has a length,
   *        width or height that is not finite and > 0, or stands off the terrain; the previous
   *        obstacles stay then
   */
  void setObstacles(terrain::ObjectSet& objects);
  /// Objects that became geoms in the last setObstacles() (0 without).
  std::size_t obstacleGeomCount() const;

  /**
   * @brief Dynamic agents (deer, pedestrians, trucks; avsp_terrain agents.hpp) in the world from
   *        the next step on, replacing any earlier ones. Each is a body of its type's mass
   *        (terrain::agentMass: a deer 100 kg, a pedestrian 80 kg, a truck 10 t) carrying its
   *        type's boxes (terrain::agentBoxes), driven along its path: every step a critically
   *        damped tracking force pushes it towards Agent::state(time() + step), bounded
   *        horizontally by terrain::agentPushForce. Vehicles meet it as bodies of that mass
   *        (contacts as with other vehicles, friction included): a carrier shoves a deer aside
   *        and barely notices, a truck pushes a braked 4x4 along. Off its path after a push, an
   *        agent returns to it within its force limit; sensors and agents_node keep drawing it
   *        on its path. obstacle_contacts/obstacle_impulse count the contacts.
   */
  void setAgents(std::vector<terrain::Agent> agents);
  std::size_t agentCount() const { return agents_.size(); }
  /// Agent k's state on its path at the world's time. @throw std::out_of_range
  terrain::AgentState agentState(std::size_t agent) const;
  /// Agent k's body (its frame: origin on the ground under it, x forward) now, where the
  /// dynamics have it (a vehicle may have pushed it off its path). @throw std::out_of_range
  Eigen::Isometry3d agentPose(std::size_t agent) const;

  /**
   * @brief Adds a vehicle simulated by another process (a dynamics partition) as a proxy: a
   *        body of the model's mass and inertia carrying its collision boxes and a box round
   *        each wheel and road wheel (2 radius x width x 2 radius), without gravity. Vehicles
   *        of this world meet it as they meet another vehicle (rigid contacts, counts and
   *        impulses) and push it between exchanges; setProxyState() puts it back where its own
   *        process has it. It does not touch the terrain, obstacles or agents (its own process
   *        handles those). It rests at the origin, far below any vehicle, until placed.
   * @param name used in errors
   * @return the proxy's index
   */
  std::size_t addProxy(const VehicleModel& model, const std::string& name);
  /**
   * @brief Places proxy k with base_link at `pose` (map) now, moving at `linear_velocity`
   *        (m/s, base_link origin, map) and `angular_velocity` (rad/s, map); from there it
   *        flies on at them (its body under ODE, pushed by this world's vehicles) until the
   *        next call.
   * @throw std::out_of_range for an unknown proxy; std::invalid_argument when a value is not finite
   */
  void setProxyState(std::size_t proxy, const Eigen::Isometry3d& pose, const Eigen::Vector3d& linear_velocity,
                     const Eigen::Vector3d& angular_velocity);
  /**
   * @brief Removes proxy k (its vehicle left its partition's run): its body and boxes go; the
   *        later proxies' indices move down by one. Between steps.
   * @throw std::out_of_range for an unknown proxy
   */
  void removeProxy(std::size_t proxy);
  std::size_t proxyCount() const { return proxies_.size(); }
  /// Proxy k's base_link pose now (map), where its body is. @throw std::out_of_range
  Eigen::Isometry3d proxyPose(std::size_t proxy) const;

  /**
   * @brief A soil outside the terrain's for vehicle k's wheels from the next step on
   *        (external_wheel_soil.hpp: the DEM moving patch); null: the terrain alone again.
   * @throw std::out_of_range for an unknown vehicle; std::invalid_argument for a tracked one
   */
  void setExternalWheelSoil(std::size_t vehicle, std::shared_ptr<ExternalWheelSoil> soil);

  /// One physics step of options().step seconds.
  void step();
  /// Steps until `seconds` more have elapsed (rounded to whole steps).
  void advance(double seconds);

  double time() const { return static_cast<double>(steps_) * options_.step; }  ///< s
  std::uint64_t stepCount() const { return steps_; }
  const WorldOptions& options() const { return options_; }
  std::size_t vehicleCount() const;

  /// State after the last step. @throw std::out_of_range for an unknown vehicle index
  const VehicleState& state(std::size_t vehicle) const;
  /// @throw std::out_of_range naming the vehicle and the wheel if it has no such wheel
  const WheelState& wheel(std::size_t vehicle, const std::string& wheel_name) const;

  /**
   * @brief A base_link pose at (x, y) with heading yaw (rad), tilted to the plane fitted (least
   *        squares) through the ground under its running gear, whose lowest wheel sits
   *        `clearance` m above the terrain; level on level ground.
   * @throw std::invalid_argument if a wheel is off the terrain
   */
  Eigen::Isometry3d restingPose(const VehicleModel& model, double x, double y, double yaw,
                                double clearance = 0.0) const;

  const StepTimes& times() const { return times_; }
  /// Warnings the vehicles raised since the last call (e.g. a wheel's contact gave a non-finite
  /// force: once per wheel, naming the vehicle and the wheel), oldest first.
  std::vector<std::string> takeWarnings();
  terrain::DeformableTerrain& terrain() { return terrain_; }

private:
  /// A proxy's last known state (setProxyState) and when it was given.
  struct Proxy
  {
    std::string name;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero(), angular_velocity = Eigen::Vector3d::Zero();
    double since = 0.0;                             ///< s, world time of `pose`
    Eigen::Vector3d com = Eigen::Vector3d::Zero();  ///< m, its centre of mass in base_link
    bool placed = true;                             ///< its body is where `pose` put it (then ODE moves it on)
  };
  void driveAgents();
  void driveProxies();
  /// Hands the agents' and proxies' bodies to the collision (agents first).
  void updateKinematicGeoms();
  std::vector<Proxy> proxies_;  ///< their bodies are in Ode (same order)
  /// A push() in force: on `body` until (not including) step `until_step`.
  struct Push
  {
    ::dxBody* body;  ///< its chassis
    Eigen::Vector3d force;
    std::uint64_t until_step;
  };
  std::vector<Push> pushes_;
  struct Ode;  // ODE handles
  terrain::DeformableTerrain& terrain_;
  WorldOptions options_;
  std::unique_ptr<Ode> ode_;
  std::vector<std::unique_ptr<SimVehicleBase>> vehicles_;
  std::unique_ptr<ObstacleCollision> collision_;
  std::vector<terrain::Agent> agents_;  ///< their bodies are in Ode (same order)
  std::uint64_t steps_ = 0;
  unsigned long rng_state_ = 0;  ///< ODE's dRand state between this world's steps
  StepTimes times_;
};

}  // namespace dynamics
}  // namespace avsp
