#pragma once
/**
 * @file sim_vehicle_base.hpp
 * @brief Private to avsp_dynamics_core (not installed): the interface World holds for every
 *        simulated vehicle, wheeled (vehicle_sim.cpp) or tracked (tracked_vehicle.cpp), and the
 *        helpers both share: ODE/Eigen conversions, rigid lumping, and the soil contact handed
 *        to ODE (README.md, "Ground contact"), so that wheels and track segments meet the soil
 *        through the same code.
 */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <ode/ode.h>

#include <avsp_terrain/deformable_terrain.hpp>

#include "avsp_dynamics/external_wheel_soil.hpp"
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
  /**
   * @brief Reads the bodies back into state().
   * @param stepped true after an ODE step (the contacts' shear states advance), false when the
   *        bodies were set from outside (World::setVelocity)
   * @throw std::runtime_error if the physics diverged
   */
  virtual void afterStep(double time, bool stepped) = 0;
  /// The bodies were moved from outside (World::setPose): every contact's shear displacement
  /// and the servos' integrals start again from nothing, as for a vehicle set down there.
  virtual void forgetContacts() = 0;
  virtual const VehicleState& state() const = 0;
  /// The bodies that collide with obstacles and other vehicles (obstacle_collision.hpp).
  virtual VehicleBodies collisionBodies() const = 0;
  /// What obstacles and other vehicles did over the last step, into state().
  virtual void setCollisionReport(const CollisionReport& report) = 0;
  /// An external soil for the wheels from the next step on (null: the terrain alone).
  /// @throw std::invalid_argument for a vehicle without wheels (tracked)
  virtual void setExternalWheelSoil(std::shared_ptr<ExternalWheelSoil> soil)
  {
    if (soil)
      throw std::invalid_argument("vehicle '" + state().name + "' has tracks: an external wheel soil needs wheels");
  }
  /// Warnings raised since the last call (a contact's fault once per contact), oldest first.
  std::vector<std::string> takeWarnings()
  {
    std::vector<std::string> out;
    out.swap(warnings_);
    return out;
  }

protected:
  /// Counts a contact's fault (a non-finite force, left out of the step) and names it once,
  /// as "<kind> '<name>'" (e.g. wheel 'front_left'); `reported` is that contact's once-flag.
  /// Called for every contact every step: the message is built only when it is reported.
  void contactFault(bool fault, bool& reported, const char* kind, const std::string& name, const std::string& vehicle,
                    int& count)
  {
    if (!fault)
      return;
    ++count;
    if (reported)
      return;
    reported = true;
    warnings_.push_back(
        "vehicle '" + vehicle + "', " + kind + " '" + name +
        "': the ground contact gave a non-finite force; it had no ground contact that step (reported once)");
  }

  std::vector<std::string> warnings_;
};

/**
 * @brief Builds a tracked vehicle (tracked_vehicle.cpp).
 * @throw ConfigError naming the model's YAML (or URDF) and the key/link it cannot simulate;
 *        nothing is left in the world when it throws
 */
std::unique_ptr<SimVehicleBase> makeTrackedVehicle(dWorldID world, const VehicleModel& model,
                                                   const Eigen::Isometry3d& pose, const std::string& name,
                                                   const WorldOptions& options);

/**
 * @brief Builds a legged vehicle (legged_vehicle.cpp), standing in its stance at `pose`.
 * @throw ConfigError naming the model's YAML when it cannot be simulated
 */
std::unique_ptr<SimVehicleBase> makeLeggedVehicle(dWorldID world, const VehicleModel& model,
                                                  const Eigen::Isometry3d& pose, const std::string& name,
                                                  const WorldOptions& options);

namespace sim
{
using Clock = std::chrono::steady_clock;

static_assert(sizeof(dReal) == sizeof(double), "avsp_dynamics needs ODE built in double precision (libode-dev)");

/// m: a contact's normal row's virtual penetration (normal force / stiffness) never exceeds
/// this, so a contact whose soil reports little stiffness (a point just entering) still acts as
/// a spring.
constexpr double kMaxVirtualDepth = 0.02;
/// m/s: a hull plate's resistance (explicit, at the plate) fades linearly to 0 below this speed
/// so a hull at rest is not pushed back and forth by a force whose direction flips each step.
constexpr double kResistanceFadeSpeed = 0.1;
/// m: the shortest relaxation length a contact's shear uses (a wheel barely touching).
constexpr double kMinRelaxationLength = 0.05;
/// m/s: a contact rolling over its soil slower than this renews less of it than its loaded
/// length during the shear's build-up: its soil's displacement tends to the contact's own
/// everywhere (at rest), instead of growing from the leading edge (rolling, T11).
constexpr double kShearRenewalSpeed = 0.1;
/// m: the shortest length over which a contact's displacement spreads from its leading edge.
constexpr double kMinShearLength = 1e-4;

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
  dMassSetParameters(&m, mass, 0.0, 0.0, 0.0, inertia(0, 0), inertia(1, 1), inertia(2, 2), inertia(0, 1), inertia(0, 2),
                     inertia(1, 2));
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
  double mass = 0.0;                                  ///< kg
  Eigen::Vector3d com = Eigen::Vector3d::Zero();      ///< m, base_link
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  ///< kg m^2 about com, base_link axes
};

/// Mass, centre of mass and inertia (parallel-axis theorem) of `bodies`; mass 0 if none.
LumpedBody lump(const std::vector<const Body*>& bodies);

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
 * @return the unit normal; +z where a height is off the terrain or the slope overflows
 */
Eigen::Vector3d groundNormal(const terrain::DeformableTerrain& terrain, const Eigen::Vector3d& centre,
                             const Eigen::Vector3d& forward, double ahead, double beside);

/// What a running gear meets on rigid ground (a soil of model rigid): the surface's adhesion and
/// rolling resistance, and how far its tyre (or pad) is pressed into it.
struct FirmContact
{
  const terrain::SoilParameters* surface = nullptr;  ///< the rigid soil, nullptr: none under it
  double share = 0.0;                                ///< of the footprint on it (DeformableTerrain's rigid_share)
  double depth = 0.0;  ///< m, tyre deflection: radius - distance from centre to the ground plane
};

/// The rigid ground a gear of `radius` at `centre` meets, from the terrain's contact `soil`:
/// the surface under its rigid share and its deflection against the ground plane (unit normal
/// `normal`) there, smooth rather than the grid's points (a stiff tyre must not feel a 0.1 m
/// lattice). No surface when the footprint has no rigid part.
FirmContact firmContact(const terrain::DeformableTerrain& terrain, const terrain::ContactForces& soil,
                        const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& normal);

/**
 * @brief One running gear's contact with the ground (a wheel, or the track under one road
 *        wheel): the shear's transient state and what ODE gets each step (README.md, "Ground
 *        contact"). Used as prepare() -> terrain contact -> addJoint() -> ODE step -> finish().
 *
 * Tangentially the gear's surface is displaced u (m, in the contact's t1, t2) relative to the
 * ground it grips, relaxing as du/dt = v - (D / L) u (v the contact point's sliding velocity,
 * D = max(|v_long|, |v_theoretical|) the speed at which fresh ground enters, L the relaxation
 * length: the soil's loaded length, a tyre's own on rigid ground). The force is the soil's shear
 * with its soil displaced j = min(|u| x / l, |u|) x behind the leading edge (T7, T11; the terrain
 * integrates it: slip -u / l capped at |u|), l = L min(1, D / 0.1 m/s): rolling, the soil enters
 * at the leading edge (j = s x); at rest all of it has been under the gear since it stopped (j =
 * |u|, so a short contact holds by its whole strength); plus, on rigid ground, a brush tyre's at
 * the same displacement; in steady rolling u / L is the slip (T8), at rest u is a displacement
 * the ground resists elastically, so a braked vehicle holds on a slope up to the soil's
 * strength instead of creeping at a ratio of two speeds near 0. Each friction row is that force
 * linearised in u and made implicit in the step's velocity (ODE's surface motion and
 * force-dependent slip), bounded by the Mohr-Coulomb strength c A + N tan(phi) (+ mu N on
 * rigid ground), shared between the rows along the force's direction (a friction ellipse).
 */
class GroundContact
{
public:
  /// The shear slip (longitudinal, lateral; force direction) for the terrain this step, after
  /// relaxing the displacement over the step at travel speed v_long and running-gear speed v_t.
  Eigen::Vector2d prepare(double v_long, double v_theoretical, double step);

  /**
   * @brief This step's contact joint on `body`: the soil's normal force (implicit spring of the
   *        soil's stiffness) and, on rigid ground, the tyre's (its vertical stiffness); the
   *        friction rows as above. Also applies the rolling and bulldozing resistance.
   * @param body_mass kg, the wheel's (or road wheel's): the normal row's damping
   * @param mass_share kg, the share of the vehicle this contact holds tangentially
   * @return false (no joint, displacement forgotten) when nothing carries the gear, or when a
   *         force came out non-finite (`fault` set; nothing reaches ODE)
   */
  bool addJoint(dWorldID world, dJointGroupID contacts, dBodyID body, double body_mass, double mass_share,
                const ContactFrame& frame, const terrain::ContactForces& soil, const FirmContact& firm,
                const FirmGroundSpec& firm_spec, const WorldOptions& options, dJointFeedback* feedback, bool& fault);

  /// After the step: the displacement from the contact point's velocity then (m/s, world).
  void finish(const Eigen::Vector3d& point_velocity);
  /// Off the ground: the displacement is gone.
  void reset();

  const Eigen::Vector2d& displacement() const { return u_; }
  /// m, this step's cap on the soil's shear displacement (WheelPatch::shear_cap): |u| relaxed.
  double shearCap() const { return decayed_.norm(); }
  /// +1 or -1: the way the contact's leading edge faces (for the terrain's patch), kept through
  /// a standstill: it turns only when the gear moves the other way faster than 5 cm/s.
  int travel() const { return travel_; }
  double normalForce() const { return normal_; }           ///< N, soil and tyre, this step
  double firmNormalForce() const { return firm_normal_; }  ///< N, the tyre's part
  double resistance() const { return resistance_; }        ///< N, applied at the centre this step

private:
  /// The soil's shear at the relaxed displacement, its stiffness in the two rows, its strength.
  void soilShear(const terrain::ContactForces& soil, Eigen::Vector2d& force, Eigen::Vector2d& stiffness,
                 double& capacity) const;
  /// Keeps this step's loads (normal, firm share, rolling resistance) and the next step's
  /// relaxation lengths. `firm_surface`: the rigid ground under the contact, nullptr: none.
  void keepLoads(const terrain::ContactForces& soil, double soil_normal, const terrain::SoilParameters* firm_surface,
                 double firm_normal, const FirmGroundSpec& firm_spec);

  Eigen::Vector2d u_ = Eigen::Vector2d::Zero();        ///< m, displacement after the last step
  Eigen::Vector2d decayed_ = Eigen::Vector2d::Zero();  ///< m, relaxed over this step (before the gear moves)
  double decay_ = 1.0;                                 ///< this step's relaxation factor 1 / (1 + h D / L)
  double step_ = 0.0;                                  ///< s
  double soil_length_ = 0.0;   ///< m, the soil's relaxation length (its loaded length last step)
  double shear_length_ = 0.0;  ///< m, this step's l: the displacement spreads from the leading edge over it
  double relaxation_ = 0.0;    ///< m, this contact's relaxation length (soil and tyre, by load)
  double limit_ = 0.0;         ///< m, largest displacement (full slip)
  /// m, the elastic part of this step's displacement: force / initial slope (soil: strength / K;
  /// tyre: C_x F_z / L). What a gear that stops sliding keeps when it moves back.
  double elastic_ = 0.0;
  /// The contact point slid (faster than 5 cm/s, or at full slip) since it last held
  /// elastically: its displacement is mostly plastic.
  bool sliding_ = false;
  double k_elastic_ = 0.0;     ///< N/m, the initial (elastic) slope of this step's force
  double k_along_ = 0.0;       ///< N/m, the force's slope along the displacement this step
  double travel_speed_ = 0.0;  ///< m/s, this step's D (prepare)
  /// Unloading after a slide: elastic about `reversal_` (the displacement it moved back from),
  /// `back_` the gear's motion since, the curve's coordinate moving `gain_` times as far.
  bool unloading_ = false;
  Eigen::Vector2d reversal_ = Eigen::Vector2d::Zero(), back_ = Eigen::Vector2d::Zero();
  double gain_ = 1.0;
  bool active_ = false;  ///< a joint was made this step
  int travel_ = 1;
  Eigen::Vector3d t1_ = Eigen::Vector3d::UnitX(), t2_ = Eigen::Vector3d::UnitY();
  double normal_ = 0.0, firm_normal_ = 0.0, resistance_ = 0.0;
};

/// A brush tyre's force (N, force direction) at displacement u (m) on rigid ground under normal
/// load `normal` (N), and its stiffness diagonal (N/m, >= 0) in the two rows.
struct BrushForce
{
  Eigen::Vector2d force = Eigen::Vector2d::Zero();
  Eigen::Vector2d stiffness = Eigen::Vector2d::Zero();
  double capacity = 0.0;  ///< N, peak adhesion x load
};
/**
 * @brief The brush model with combined slip (Pacejka, Tire and Vehicle Dynamics, ch. 3; Fiala):
 *        theoretical slips kappa = -u_x / L, tan(alpha) = -u_y / L, sigma = |(C_x kappa,
 *        C_y tan alpha)| / (3 mu F_z), F = mu F_z (3 sigma - 3 sigma^2 + sigma^3) up to full
 *        sliding at sigma = 1, along (C_x kappa, C_y tan alpha); mu falls linearly from the
 *        peak to the sliding coefficient as the combined slip goes from 0 to 1 (Fiala's).
 */
BrushForce brushForce(const Eigen::Vector2d& u, double normal, const FirmGroundSpec& spec, double friction_peak,
                      double friction_sliding);

/// A flat plate on a body pressed into the ground this step (plateContact): a hull plate, a foot's pad.
struct Plate
{
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< m, world: the middle of its ground face
  Eigen::Vector3d along = Eigen::Vector3d::UnitX();  ///< unit, world: its length's direction
  /// unit, world: its face's normal (up, out of the ground); none: it lies on the ground (a pad
  /// under a foot's sphere turns with the ground, not with the body).
  std::optional<Eigen::Vector3d> face_normal;
  double length = 0.0, width = 0.0;  ///< m
  double body_mass = 0.0;            ///< kg, of the body it is on (its normal row's damping)
  double mass_share = 0.0;           ///< kg, of the vehicle it holds tangentially
  double resisted_mass = 0.0;        ///< kg, that its compaction resistance slows (the fade's)
  /// The rigid surface it meets on rigid ground (a steel belly on pavement); nullptr: the
  /// terrain's own rigid soil under a sphere of `firm_radius` (a rubber foot).
  const terrain::SoilParameters* firm_surface = nullptr;
  double firm_radius = 0.0;  ///< m
};

/**
 * @brief One plate's soil contact this step through its GroundContact: the terrain's sliding
 *        plate (terrain.trackContact with no sprocket: Bekker pressure or the simple model's,
 *        Mohr-Coulomb shear, ruts), on rigid ground `firm_spec`'s stiff contact, handed to ODE as
 *        a joint on `body` (feedback into `feedback`); its compaction and bulldozing applied at
 *        the plate against its travel.
 * @param soil_out if given, the terrain's forces this step
 * @return false (no joint) when nothing carries it or a force came out non-finite (`fault` set)
 */
bool plateContact(dWorldID world, dJointGroupID contacts, dBodyID body, const Plate& plate,
                  const FirmGroundSpec& firm_spec, terrain::DeformableTerrain& terrain, const WorldOptions& options,
                  StepTimes* times, GroundContact& ground, dJointFeedback* feedback, bool& fault,
                  terrain::ContactForces* soil_out = nullptr);

/**
 * @brief The hull's underside against the ground: the bottom face of every chassis collision box
 *        (URDF <collision>, model.collision_boxes), split into plates about 1 m long and half the
 *        face wide, each a sliding plate in the soil contact (terrain.trackContact with no
 *        sprocket: Bekker pressure, Mohr-Coulomb shear, ruts where the belly drags) or on rigid
 *        ground a stiff steel-on-pavement contact, through GroundContact like the running gear.
 *        A vehicle sunk to its belly, or high-centred on a ridge, rests on it and is stopped by
 *        its friction. Plates more than 5 cm above the ground cost two height lookups a step.
 */
class HullContact
{
public:
  /// @param chassis_com m, the chassis body's origin (its centre of mass) in base_link
  HullContact(const VehicleModel& model, const Eigen::Vector3d& chassis_com);
  /// This step's plate contacts on `chassis` (joints into `contacts`).
  void beforeStep(dWorldID world, dJointGroupID contacts, dBodyID chassis, terrain::DeformableTerrain& terrain,
                  const WorldOptions& options, StepTimes* times, std::vector<std::string>& warnings,
                  const std::string& vehicle);
  /// After the step (stepped: after an ODE step): the plates' shear states.
  void afterStep(dBodyID chassis, bool stepped);
  /// N, the ground's normal force on the hull this step (0: the hull touches nothing).
  double normalForce() const { return normal_; }
  /// Every plate's shear displacement forgotten (SimVehicleBase::forgetContacts).
  void forgetContacts()
  {
    for (BellyPlate& p : plates_)
      p.ground.reset();
  }

private:
  struct BellyPlate
  {
    Eigen::Vector3d centre;            ///< m, on the box's bottom face, base_link at rest
    Eigen::Vector3d along;             ///< unit, the box's x in base_link
    Eigen::Vector3d across;            ///< unit, the box's y in base_link
    Eigen::Vector3d up;                ///< unit, into the box from its bottom face, base_link
    double length = 0.0, width = 0.0;  ///< m
    GroundContact ground;
    bool contact = false;
    bool fault_reported = false;
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< m, world, where the contact acts this step
    dJointFeedback feedback{};
  };
  std::vector<BellyPlate> plates_;
  Eigen::Vector3d chassis_com_;
  double total_mass_ = 0.0;
  double normal_ = 0.0;
  FirmGroundSpec firm_;            ///< steel on pavement
  terrain::SoilParameters steel_;  ///< the friction of steel on pavement (a rigid "soil")
};

/**
 * @brief Resistance (T12, Bekker's compaction, a tyre's rolling resistance) on a running gear:
 *        a linear motor on the body's centre along the travel t1, holding its velocity there at
 *        0 with at most the resistance: implicit, so the soil's resistance stops a vehicle that
 *        pushes less than it (a vehicle stalled on a slope does not creep on a faded force) and
 *        opposes its travel in full when it moves, with no chatter at rest. Enabled only while
 *        the resistance is > 0 (it joins the body's island).
 */
class ResistanceMotor
{
public:
  ResistanceMotor() = default;
  ResistanceMotor(const ResistanceMotor&) = delete;
  ResistanceMotor& operator=(const ResistanceMotor&) = delete;
  ResistanceMotor(ResistanceMotor&& other) noexcept : motor_(other.motor_), on_(other.on_)
  {
    other.motor_ = nullptr;
    if (motor_)
      dJointSetFeedback(motor_, &feedback_);
  }
  ~ResistanceMotor()
  {
    if (motor_)
      dJointDestroy(motor_);
  }
  /// This step's resistance (N, >= 0) on `body` along unit t1 (world); `cfm` keeps the exact
  /// solver's matrix regular (m/s per N at which it may creep when redundant).
  void set(dWorldID world, dBodyID body, double resistance, const Eigen::Vector3d& t1, double cfm);
  void off();
  /// N along t1 (the last set()'s) the motor applied over the last step (negative: against
  /// the travel), 0 when off.
  double applied(const Eigen::Vector3d& t1) const;

private:
  dJointID motor_ = nullptr;
  bool on_ = false;
  dJointFeedback feedback_{};
};

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
