#pragma once
/**
 * @file sim_vehicle_base.hpp
 * @brief Private to avsp_dynamics_core (not installed): the interface World holds for every
 *        simulated vehicle, wheeled (vehicle_sim.cpp) or tracked (tracked_vehicle.cpp), and the
 *        helpers both share: ODE/Eigen conversions, rigid lumping, and the soil contact handed
 *        to ODE (README.md, "Soil contact"), so that wheels and track segments meet the soil
 *        through the same code.
 */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <ode/ode.h>

#include <avsp_terrain/deformable_terrain.hpp>

#include "avsp_dynamics/vehicle_model.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"
#include "obstacle_collision.hpp"

namespace avsp
{
namespace dynamics
{
/// One vehicle's ODE bodies, joints and actuators, as World drives it every step:
/// setCommand (any time), beforeStep (actuators and contact joints), ODE's step, afterStep.
class SimVehicleBase
{
public:
  virtual ~SimVehicleBase() = default;
  /// The command in force from the next step on (already clamped by World::setCommand).
  virtual void setCommand(const DriveCommand& command) = 0;
  /// Actuator torques, explicit forces and this step's soil contact joints (into `contacts`,
  /// emptied by World after the step); adds the soil contacts' times to `times` if given.
  virtual void beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times) = 0;
  /// Reads the bodies back into state(); @throw std::runtime_error if the physics diverged
  virtual void afterStep(double time) = 0;
  virtual const VehicleState& state() const = 0;
  /// The bodies that collide with obstacles and other vehicles (obstacle_collision.hpp).
  virtual VehicleBodies collisionBodies() const = 0;
  /// What obstacles and other vehicles did over the last step, into state().
  virtual void setCollisionReport(const CollisionReport& report) = 0;
};

/**
 * @brief Builds a tracked vehicle (tracked_vehicle.cpp).
 * @throw ConfigError naming the model's YAML (or URDF) and the key/link it cannot simulate;
 *        nothing is left in the world when it throws
 */
std::unique_ptr<SimVehicleBase> makeTrackedVehicle(dWorldID world, const VehicleModel& model,
                                                   const Eigen::Isometry3d& pose, const std::string& name,
                                                   const WorldOptions& options);

namespace sim
{
using Clock = std::chrono::steady_clock;

static_assert(sizeof(dReal) == sizeof(double), "avsp_dynamics needs ODE built in double precision (libode-dev)");

/// m: the stiffness probe lowers the wheel (or track segment) this much (far above float
/// rounding of the terrain's state, ~1e-9 m, far below any sinkage that matters).
constexpr double kProbeDepth = 1e-5;
/// m: the normal row's virtual penetration (soil force / stiffness) never exceeds this, so a
/// contact whose probe found no stiffness (no new grid point loaded) still acts as a spring.
constexpr double kMaxVirtualDepth = 0.02;
/// m/s: resistance (T12) is a kinetic force; below this speed it fades linearly to 0 so a
/// wheel at rest is not pushed back and forth by a force whose direction flips each step.
constexpr double kResistanceFadeSpeed = 0.1;

inline Eigen::Vector3d vec(const dReal* v)
{
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

inline Eigen::Matrix3d rotationOf(dBodyID body)
{
  const dReal* r = dBodyGetRotation(body);  // 3x4, row-major
  Eigen::Matrix3d m;
  m << r[0], r[1], r[2], r[4], r[5], r[6], r[8], r[9], r[10];
  return m;
}

inline void setRotation(dBodyID body, const Eigen::Matrix3d& m)
{
  dMatrix3 r = { m(0, 0), m(0, 1), m(0, 2), 0.0, m(1, 0), m(1, 1), m(1, 2), 0.0, m(2, 0), m(2, 1), m(2, 2), 0.0 };
  dBodySetRotation(body, r);
}

inline void setMass(dBodyID body, double mass, const Eigen::Matrix3d& inertia)
{
  dMass m;
  dMassSetParameters(&m, mass, 0.0, 0.0, 0.0, inertia(0, 0), inertia(1, 1), inertia(2, 2), inertia(0, 1),
                     inertia(0, 2), inertia(1, 2));
  dBodySetMass(body, &m);
}

/// Parallel-axis term: inertia of a point mass m at offset d.
inline Eigen::Matrix3d pointInertia(double m, const Eigen::Vector3d& d)
{
  return m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
}

inline double seconds(Clock::time_point a, Clock::time_point b)
{
  return std::chrono::duration<double>(b - a).count();
}

/// Several URDF bodies held rigidly together at the rest pose, as one rigid body.
struct LumpedBody
{
  double mass = 0.0;                                    ///< kg
  Eigen::Vector3d com = Eigen::Vector3d::Zero();        ///< m, base_link
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();    ///< kg m^2 about com, base_link axes
};

/// Mass, centre of mass and inertia (parallel-axis theorem) of `bodies`; mass 0 if none.
LumpedBody lump(const std::vector<const Body*>& bodies);

/// Reuse of a contact's soil stiffness probe (see soilContact in README.md): a probe costs as
/// much as the contact, so it is kept while the contact keeps its load (within 10 %) for up
/// to `interval` steps.
struct StiffnessProbe
{
  double stiffness = 0.0;     ///< N/m, 0 = none
  double probed_force = 0.0;  ///< N, soil normal force when probed
  int steps_since_probe = 0;

  /// Counts this step; true when a new probe is due at soil force f_n (N).
  bool due(double f_n, int interval)
  {
    ++steps_since_probe;
    return stiffness <= 0.0 || steps_since_probe >= interval || std::abs(f_n - probed_force) > 0.1 * probed_force;
  }
  /// Records a probe: soil force `probed` (N) kProbeDepth deeper than the contact's f_n.
  void record(double probed, double f_n)
  {
    stiffness = (probed - f_n) / kProbeDepth;
    probed_force = f_n;
    steps_since_probe = 0;
  }
};

/// One running-gear contact's frame this step (world axes).
struct ContactFrame
{
  Eigen::Vector3d point;           ///< m, where ODE applies the soil's forces
  Eigen::Vector3d normal;          ///< ground normal (up)
  Eigen::Vector3d t1;              ///< along the running gear's heading, in the ground plane
  Eigen::Vector3d t2;              ///< normal x t1 (to the left)
  Eigen::Vector3d point_velocity;  ///< m/s, of the body at `point`
};

/**
 * @brief The ground's slope around a contact from four heights beside its own rut (outside
 *        its width, ahead and behind): the rut's walls must not tilt the normal, or its
 *        back-and-front depth difference would act as a second, spurious rolling resistance.
 * @param ahead m, the heights are taken this far ahead of and behind `centre`
 * @param beside m, and this far to either side
 * @return the unit normal; +z where a height is off the terrain
 */
Eigen::Vector3d groundNormal(const terrain::DeformableTerrain& terrain, const Eigen::Vector3d& centre,
                             const Eigen::Vector3d& forward, double ahead, double beside);

/**
 * @brief Hands one contact's soil forces to ODE as a contact joint on `body` (README.md, "Soil
 *        contact"): the normal force as an implicit spring-damper of stiffness kp (the soil's,
 *        at least f_n / kMaxVirtualDepth and 1e3 N/m) whose force at the current state is the
 *        soil's; traction and lateral force as friction rows bounded by the soil's forces, with
 *        force-dependent slip = the sliding velocity per newton (never below min_slip).
 * @param mass kg, the body's: the damper is contact_damping_ratio of its mode on kp
 * @param normal_spring false: the joint's normal row is left inert (a damper of 1e-3 N s/m):
 *        the caller carries the normal force by other means (tracked_vehicle.cpp's hold on
 *        rigid-plastic soil); the friction rows are the same
 * @return the contact joint (in `contacts`), with `feedback` attached
 */
dJointID addSoilJoint(dWorldID world, dJointGroupID contacts, dBodyID body, double mass, const ContactFrame& frame,
                      const terrain::ContactForces& soil, double stiffness, double min_slip,
                      const WorldOptions& options, dJointFeedback* feedback, bool normal_spring = true);

/**
 * @brief Resistance (T12) as a force at the body's centre opposing its travel along t1: the
 *        soil's compaction and bulldozing pressures, faded to 0 below kResistanceFadeSpeed (or
 *        the speed the force would reverse within a step) so that a body at rest is not pushed.
 */
void applyResistance(dBodyID body, double mass, double resistance, const Eigen::Vector3d& t1,
                     const Eigen::Vector3d& velocity, double step);

/**
 * @brief Speed servo of one drive side (a skid-steer side's motor, a track's sprocket): PI,
 *        the proportional gain half dead-beat on the side's own rotating inertia (the vehicle's
 *        mass behind it only slows the loop), the integral over 0.1 s removing the load's
 *        steady error, without wind-up (it integrates only while the torque is not saturated).
 */
class SideServo
{
public:
  /**
   * @param error rad/s, target minus actual speed
   * @param inertia kg m^2 on the side's axis
   * @param available N m, torque limit (both signs)
   * @return N m, torque to apply
   */
  double torque(double error, double inertia, double available, double step)
  {
    const double kp = 0.5 * inertia / step;
    const double proposal = integral_ + kp * error;
    const double out = std::clamp(proposal, -available, available);
    if (out == proposal)  // integrate only when not saturated (no wind-up)
      integral_ = std::clamp(integral_ + kp / 0.1 * error * step, -available, available);
    return out;
  }
  /// Braking has priority: the servo restarts from rest.
  void reset() { integral_ = 0.0; }

private:
  double integral_ = 0.0;  ///< N m
};

}  // namespace sim
}  // namespace dynamics
}  // namespace avsp
