// A tracked vehicle (M113-class) in ODE: hull, road wheels on torsion-bar arms, the belt as a
// speed constraint between a track's road wheels, one soil segment per road wheel through
// terrain.trackContact (T10). README.md ("How a tracked vehicle is built") says why.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <avsp_terrain/terramechanics.hpp>

#include "sim_vehicle_base.hpp"

namespace avsp
{
namespace dynamics
{
namespace
{
using namespace sim;

/// m/s: track speed at full steering and zero throttle (turning in place), trackedSides()'s
/// pivot fraction times max_speed. A walking pace: an M113 on firm soil then yaws at about
/// 0.5 rad/s.
constexpr double kPivotTrackSpeed = 1.0;
/// The explicit attachment of a road wheel to its arm (radial and lateral spring, axle
/// alignment) is as stiff as the step allows with margin: the wheel's mode on it has
/// h omega = 0.5 (explicit integration is stable below 2), damping ratio 0.5.
constexpr double kAttachStepOmega = 0.5;
constexpr double kAttachDampingRatio = 0.5;
/// Bump stops: this many times the torsion bar, critically damped on the wheel (as the
/// wheeled suspension's).
constexpr double kStopStiffnessFactor = 20.0;
/// m/s or rad/s: velocity error the constraint regularizations allow at full load (as wheeled).
constexpr double kRegularization = 1e-5;
/// m/s: the running gear's internal resistance is kinetic: it fades in linearly below this belt
/// speed (a held track feels none).
constexpr double kInternalResistanceFadeSpeed = 0.05;

/// The hull's pose and velocity at the start of a step (world axes).
struct Hull
{
  Eigen::Vector3d x;  ///< m, centre of mass
  Eigen::Matrix3d r;  ///< base_link orientation
  Eigen::Vector3d v;  ///< m/s at the centre of mass
  Eigen::Vector3d w;  ///< rad/s

  explicit Hull(dBodyID body)
    : x(vec(dBodyGetPosition(body))),
      r(rotationOf(body)),
      v(vec(dBodyGetLinearVel(body))),
      w(vec(dBodyGetAngularVel(body)))
  {
  }
  /// Axle direction (the hull's y) in the world.
  Eigen::Vector3d axle() const { return r.col(1); }
  /// m/s, the hull's velocity at world point p.
  Eigen::Vector3d pointVelocity(const Eigen::Vector3d& p) const { return v + w.cross(p - x); }
};

class TrackedVehicle : public SimVehicleBase
{
public:
  TrackedVehicle(dWorldID world, const VehicleModel& model, const Eigen::Isometry3d& pose, const std::string& name,
                 const WorldOptions& options);
  ~TrackedVehicle() override;
  TrackedVehicle(const TrackedVehicle&) = delete;
  TrackedVehicle& operator=(const TrackedVehicle&) = delete;

  void setCommand(const DriveCommand& command) override { command_ = command; }
  void beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times) override;
  void afterStep(double time, bool stepped) override { readState(time, stepped); }
  void forgetContacts() override
  {
    for (Side& side : sides_)
    {
      for (RoadWheel& w : side.wheels)
        w.ground.reset();
      side.servo.reset();
    }
    hull_->forgetContacts();
  }
  const VehicleState& state() const override { return state_; }
  VehicleBodies collisionBodies() const override;
  void setCollisionReport(const CollisionReport& r) override
  {
    state_.obstacle_contacts = r.contacts;
    state_.obstacle_rigid_contacts = r.rigid_contacts;
    state_.obstacle_impulse = r.impulse;
  }

private:
  /// Where a road wheel is on its arm, in hull axes (base_link): the arm swings about +y.
  struct Arm
  {
    double angle;             ///< rad about +y from the URDF pose
    double rate;              ///< rad/s
    double length;            ///< m, pivot to wheel centre in the arm's plane
    double radial_error;      ///< m, length minus the URDF arm length
    double radial_rate;       ///< m/s
    double lateral_error;     ///< m, out of the arm's plane
    double lateral_rate;      ///< m/s
    Eigen::Vector3d radial;   ///< unit, pivot to wheel centre in the arm's plane
    Eigen::Vector3d tangent;  ///< unit, the wheel centre's direction of motion for +angle
  };

  struct RoadWheel
  {
    const RoadWheelSpec* spec = nullptr;
    dBodyID body = nullptr;
    double mass = 0.0;                ///< kg, the wheel link
    double tilt_inertia = 0.0;        ///< kg m^2 about a horizontal diameter
    double spin_inertia = 0.0;        ///< kg m^2 about the axle, with its share of the track's rotating parts
    Eigen::Vector3d pivot_from_com;   ///< m, arm pivot from the hull's centre of mass, base_link axes
    Eigen::Vector3d arm;              ///< m, URDF wheel centre from the pivot, base_link axes
    double arm_length = 0.0;          ///< m
    double lift_sign = 1.0;           ///< +1 if a positive swing about +y lifts the wheel
    double lower = 0.0, upper = 0.0;  ///< rad about +y, the URDF arm limits
    double segment_offset = 0.0;      ///< m, its segment's centre from the track's centre, + forward
    // Explicit attachment gains (see kAttachStepOmega).
    double k_attach = 0.0, c_attach = 0.0, k_tilt = 0.0, c_tilt = 0.0;
    double drive_torque = 0.0;                            ///< N m about the axle this step
    Eigen::Vector3d arm_force = Eigen::Vector3d::Zero();  ///< N, the arm's force on the wheel this step
    double torsion_torque = 0.0;                          ///< N m about +y this step
    double spin_angle = 0.0;                              ///< rad, relative to the arm
    Arm arm_state{};                                      ///< where it is on its arm, at the start of this step
    double spin = 0.0;                                    ///< rad/s about the axle relative to the hull, this step
    // Ground contact of its track segment this step.
    bool contact = false;
    ContactFrame frame;
    terrain::ContactForces soil;
    dJointFeedback feedback{};
    GroundContact ground;         ///< the segment's shear state and joint (sim_vehicle_base.hpp)
    ResistanceMotor resistance;   ///< the ground's resistance at the wheel centre
    bool fault_reported = false;  ///< a non-finite contact force was reported once
  };

  struct Side
  {
    const TrackSpec* spec = nullptr;
    std::vector<RoadWheel> wheels;
    std::vector<dJointID> chain;  ///< angular motors: neighbouring road wheels at one speed
    dJointID brake = nullptr;     ///< angular motor, front road wheel to hull; enabled while braking
    SideServo servo;
    double radius = 0.0;           ///< m, road wheel radius (one per track)
    double spin_inertia = 0.0;     ///< kg m^2, all road wheels with the rotating parts, at road-wheel speed
    double segment_length = 0.0;   ///< m
    double contact_length = 0.0;   ///< m, first to last road wheel
    Eigen::Vector3d centre;        ///< m, mean road wheel rest position, base_link
    double sprocket_torque = 0.0;  ///< N m this step
    double brake_limit = 0.0;      ///< N m at the sprocket this step
    double sprocket_angle = 0.0, idler_angle = 0.0;  ///< rad
    double belt_speed = 0.0;                         ///< m/s, the belt relative to the hull this step, + forward drive
    double internal_resistance = 0.0;                ///< N, the running gear's losses this step
  };

  Arm armOf(const RoadWheel& w, const Hull& hull) const;
  /// Every wheel's arm state and spin relative to the hull, every track's belt speed.
  void measure(const Hull& hull);
  void updateDrivetrain(const Hull& hull);
  void suspend(RoadWheel& w, const Hull& hull);
  void soilContact(RoadWheel& w, const Side& side, const Hull& hull, terrain::DeformableTerrain& terrain,
                   dJointGroupID contacts, StepTimes* times);
  void readState(double time, bool integrate);
  void buildSide(std::size_t s, const std::vector<const Body*>& bodies, const Eigen::Isometry3d& pose);
  void initState(const std::string& name);

  VehicleModel model_;
  WorldOptions options_;
  dWorldID world_;
  dBodyID chassis_ = nullptr;
  Eigen::Vector3d chassis_com_;  ///< m, lumped centre of mass in base_link
  double chassis_mass_ = 0.0;
  std::vector<Side> sides_;       ///< left, right
  double sprocket_radius_ = 0.0;  ///< m, T10's p N / (2 pi)
  double engine_speed_ = 0.0, engine_torque_ = 0.0;
  DriveCommand command_;
  VehicleState state_;
  std::unique_ptr<HullContact> hull_;
};

const Body* findBody(const VehicleModel& m, const std::string& link)
{
  for (const Body& b : m.bodies)
    if (b.link == link)
      return &b;
  return nullptr;
}

namespace
{
/**
 * Everything that can reject a tracked model, checked before the first ODE object exists so
 * that a rejected vehicle leaves nothing behind in the world.
 * @return per track (left, right), its road wheels' bodies front to rear
 */
std::vector<std::vector<const Body*>> checkTrackedModel(const VehicleModel& m)
{
  auto fail = [&](const std::string& key, const std::string& why) {
    return ConfigError(m.yaml_path + ": key '" + key + "': " + why);
  };
  if (m.drive_type != DriveType::kTracked)
    throw fail("drive_type", "must be tracked to build a tracked vehicle");
  if (m.tracks.size() != 2 || m.tracks[0].side != "left" || m.tracks[1].side != "right")
    throw fail("tracks", "needs a left and a right track");
  if (!(m.track.pitch > 0.0))
    throw fail("track.pitch", "must be > 0");
  if (m.track.sprocket_teeth <= 0)
    throw fail("track.sprocket_teeth", "must be > 0");
  if (!(m.track.shoe_width > 0.0))
    throw fail("track.shoe_width", "must be > 0");
  if (!(m.torsion.torsion_stiffness > 0.0))
    throw fail("suspension.torsion_stiffness", "must be > 0");
  if (!(m.brakes.max_torque > 0.0))
    throw fail("brakes.max_torque", "must be > 0");
  std::vector<std::vector<const Body*>> wheel_bodies(2);
  for (std::size_t s = 0; s < 2; ++s)
  {
    const TrackSpec& t = m.tracks[s];
    const std::string key = "tracks[" + std::to_string(s) + "]";
    const std::string which = "the " + t.side + " track";
    if (t.road_wheels.size() < 2)
      throw fail(key + ".road_wheels",
                 which + " needs at least 2 road wheels, has " + std::to_string(t.road_wheels.size()));
    const struct
    {
      const std::string& link;
      const char* key;
      const char* what;
    } parts[] = { { t.sprocket_link, "sprocket_joint", "sprocket" },
                  { t.idler_link, "idler_joint", "idler" },
                  { t.belt_link, "belt_link", "belt" } };
    for (const auto& part : parts)
      if (!findBody(m, part.link))
        throw fail(key + "." + part.key,
                   which + "'s " + part.what + " link '" + part.link + "' is not a body with mass in " + m.urdf_path);
    if (!(t.idler_radius > 0.0))
      throw fail(key + ".idler_joint", which + "'s idler radius must be > 0");
    for (std::size_t i = 0; i < t.road_wheels.size(); ++i)
    {
      const RoadWheelSpec& w = t.road_wheels[i];
      const Body* b = findBody(m, w.link);
      if (!b)
        throw fail(key + ".road_wheels",
                   which + "'s road wheel link '" + w.link + "' is not a body with mass in " + m.urdf_path);
      if ((b->com - w.rest_position).norm() > 1e-3)
        throw ConfigError(m.urdf_path + ": link '" + w.link +
                          "': the centre of mass must be on the axle (inertial origin at the wheel centre)");
      if (!(w.radius > 0.0) || std::abs(w.radius - t.road_wheels[0].radius) > 1e-9)
        throw fail(key + ".road_wheels", which +
                                             "'s road wheels must share one radius > 0 (the belt turns them at "
                                             "one speed): '" +
                                             w.link + "' differs");
      const Eigen::Vector3d arm = w.rest_position - w.pivot;
      if (std::hypot(arm.x(), arm.z()) < 1e-3)
        throw fail(key + ".road_wheels", "arm '" + w.arm_joint + "' has no length (pivot on the wheel's axle)");
      if (!(w.arm_lower < 0.0 && w.arm_upper > 0.0))
        throw fail(key + ".road_wheels", "arm '" + w.arm_joint + "' needs limits with lower < 0 < upper");
      if (i > 0 && !(w.rest_position.x() < t.road_wheels[i - 1].rest_position.x()))
        throw fail(key + ".road_wheels", which + "'s road wheels must be listed front to rear");
      wheel_bodies[s].push_back(b);
    }
  }

  return wheel_bodies;
}
}  // namespace

TrackedVehicle::TrackedVehicle(dWorldID world, const VehicleModel& model, const Eigen::Isometry3d& pose,
                               const std::string& name, const WorldOptions& options)
  : model_(model), options_(options), world_(world)
{
  const std::vector<std::vector<const Body*>> wheel_bodies = checkTrackedModel(model_);
  sprocket_radius_ = model_.track.effectiveSprocketRadius();
  std::vector<const Body*> running;  // the road wheels: ODE bodies of their own
  for (const auto& side : wheel_bodies)
    running.insert(running.end(), side.begin(), side.end());

  // Hull = every body but the road wheels, lumped rigidly at the rest pose. The road arms'
  // centres of mass sit on their pivots (URDF), so they do not move with the swing; the
  // sprockets, idlers and belts turn about fixed axes or around the hull: their mass and
  // inertia go with the hull, their spin inertia also to the drive (below).
  std::vector<const Body*> hull_bodies;
  for (const Body& b : model_.bodies)
    if (std::find(running.begin(), running.end(), &b) == running.end())
      hull_bodies.push_back(&b);
  const LumpedBody hull = lump(hull_bodies);
  if (!(hull.mass > 0.0))
    throw ConfigError(model_.urdf_path + ": no link other than the road wheels has mass: the hull would be massless");
  chassis_mass_ = hull.mass;
  chassis_com_ = hull.com;
  hull_ = std::make_unique<HullContact>(model_, chassis_com_);

  const Eigen::Matrix3d rot = pose.linear();
  chassis_ = dBodyCreate(world_);
  setMass(chassis_, hull.mass, hull.inertia);
  const Eigen::Vector3d cp = pose * chassis_com_;
  dBodySetPosition(chassis_, cp.x(), cp.y(), cp.z());
  setRotation(chassis_, rot);

  sides_.resize(2);
  for (std::size_t s = 0; s < 2; ++s)
    buildSide(s, wheel_bodies[s], pose);
  initState(name);
  readState(0.0, false);
}

/// The road wheels' bodies, their belt couplings and the sprocket's brake of track `s`.
void TrackedVehicle::buildSide(std::size_t s, const std::vector<const Body*>& bodies, const Eigen::Isometry3d& pose)
{
  const double h = options_.step;
  const Eigen::Matrix3d rot = pose.linear();
  const Eigen::Vector3d y = rot * Eigen::Vector3d::UnitY();
  Side& side = sides_[s];
  const TrackSpec& t = model_.tracks[s];
  side.spec = &t;
  side.radius = t.road_wheels[0].radius;
  const std::size_t n = t.road_wheels.size();
  side.contact_length = t.contactLength();
  side.segment_length = side.contact_length / static_cast<double>(n);
  side.centre = Eigen::Vector3d::Zero();
  for (const RoadWheelSpec& w : t.road_wheels)
    side.centre += w.rest_position / static_cast<double>(n);
  // The belt couples the sprocket, the idler and the belt itself to the road wheels' spin:
  // at road-wheel speed omega the belt runs at r omega, the sprocket at r omega / r_s, the
  // idler at r omega / r_i. Their kinetic energy, as an inertia at road-wheel speed, is
  // shared by the road wheels (the belt's m v^2 / 2 of circulation on top of its
  // translation with the hull: the loop's mean velocity relative to the hull is zero).
  const double r = side.radius;
  const double reflected = findBody(model_, t.sprocket_link)->inertia(1, 1) * std::pow(r / sprocket_radius_, 2) +
                           findBody(model_, t.idler_link)->inertia(1, 1) * std::pow(r / t.idler_radius, 2) +
                           findBody(model_, t.belt_link)->mass * r * r;
  side.wheels.resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    const RoadWheelSpec& spec = t.road_wheels[i];
    const Body& body = *bodies[i];
    RoadWheel& w = side.wheels[i];
    w.spec = &spec;
    w.mass = body.mass;
    w.tilt_inertia = std::min(body.inertia(0, 0), body.inertia(2, 2));
    Eigen::Matrix3d inertia = body.inertia;
    inertia(1, 1) += reflected / static_cast<double>(n);
    w.spin_inertia = inertia(1, 1);
    side.spin_inertia += w.spin_inertia;
    w.pivot_from_com = spec.pivot - chassis_com_;
    w.arm = spec.rest_position - spec.pivot;
    w.arm_length = std::hypot(w.arm.x(), w.arm.z());
    // d(centre z) / d(angle about +y) = -arm x: a trailing arm (wheel behind the pivot) lifts.
    w.lift_sign = w.arm.x() < 0.0 ? 1.0 : -1.0;
    w.lower = spec.arm_axis_sign > 0.0 ? spec.arm_lower : -spec.arm_upper;
    w.upper = spec.arm_axis_sign > 0.0 ? spec.arm_upper : -spec.arm_lower;
    // Segments laid end to end along the whole ground length (front first), each centred
    // under its road wheel: the shear displacement (T11) grows over the whole track.
    w.segment_offset = 0.5 * side.contact_length - (static_cast<double>(i) + 0.5) * side.segment_length;
    const double omega2 = std::pow(kAttachStepOmega / h, 2);
    w.k_attach = omega2 * w.mass;
    w.c_attach = 2.0 * kAttachDampingRatio * std::sqrt(w.k_attach * w.mass);
    w.k_tilt = omega2 * w.tilt_inertia;
    w.c_tilt = 2.0 * kAttachDampingRatio * std::sqrt(w.k_tilt * w.tilt_inertia);

    w.body = dBodyCreate(world_);
    setMass(w.body, w.mass, inertia);
    const Eigen::Vector3d wp = pose * spec.rest_position;
    dBodySetPosition(w.body, wp.x(), wp.y(), wp.z());
    setRotation(w.body, rot);
    // Finite rotation about the axle keeps a fast-spinning wheel true (as wheeled).
    dBodySetFiniteRotationMode(w.body, 1);
  }
  // The belt turns its road wheels at one speed: an unbounded angular motor between
  // neighbours about the axle, with the same tiny compliance as the wheeled couplings.
  const double wheel_brake = model_.brakes.max_torque * side.radius / sprocket_radius_;
  for (std::size_t i = 1; i < n; ++i)
  {
    const dJointID motor = dJointCreateAMotor(world_, nullptr);
    dJointAttach(motor, side.wheels[i - 1].body, side.wheels[i].body);
    dJointSetAMotorMode(motor, dAMotorUser);
    dJointSetAMotorNumAxes(motor, 1);
    dJointSetAMotorAxis(motor, 0, 0, y.x(), y.y(), y.z());
    dJointSetAMotorParam(motor, dParamVel, 0.0);
    dJointSetAMotorParam(motor, dParamFMax, dInfinity);
    dJointSetAMotorParam(motor, dParamCFM, kRegularization / wheel_brake);
    side.chain.push_back(motor);
  }
  // The sprocket's brake, acting on the chain through its front road wheel: a motor holding
  // the wheel's spin relative to the hull at zero, up to the brake torque seen at the road
  // wheel. It joins the track's island to the hull's (a larger system for ODE's exact
  // solver), so it is enabled only while the brake is on. (Held against the hull's spin at
  // the start of the step instead, the track crept by the step's change of pitch rate:
  // rolling, to T8, on a slope where traction must hold the hull.)
  side.brake = dJointCreateAMotor(world_, nullptr);
  dJointAttach(side.brake, side.wheels[0].body, chassis_);
  dJointSetAMotorMode(side.brake, dAMotorUser);
  dJointSetAMotorNumAxes(side.brake, 1);
  dJointSetAMotorAxis(side.brake, 0, 0, y.x(), y.y(), y.z());
  dJointSetAMotorParam(side.brake, dParamVel, 0.0);
  dJointSetAMotorParam(side.brake, dParamFMax, 0.0);
  dJointSetAMotorParam(side.brake, dParamCFM, kRegularization / wheel_brake);
  dJointDisable(side.brake);
}

/// The state's names and sizes (tracks, road wheels, segments) from the model.
void TrackedVehicle::initState(const std::string& name)
{
  state_.name = name;
  state_.tracks.resize(2);
  for (std::size_t s = 0; s < 2; ++s)
  {
    const TrackSpec& t = model_.tracks[s];
    TrackState& ts = state_.tracks[s];
    ts.side = t.side;
    ts.sprocket_joint = t.sprocket_joint;
    ts.idler_joint = t.idler_joint;
    ts.road_wheels.resize(t.road_wheels.size());
    ts.segments.resize(t.road_wheels.size());
    for (std::size_t i = 0; i < t.road_wheels.size(); ++i)
    {
      ts.road_wheels[i].link = t.road_wheels[i].link;
      ts.road_wheels[i].arm_joint = t.road_wheels[i].arm_joint;
      ts.road_wheels[i].spin_joint = t.road_wheels[i].spin_joint;
      ts.segments[i].name = t.road_wheels[i].link;
      ts.segments[i].length = sides_[s].segment_length;
      ts.segments[i].width = model_.track.shoe_width;
    }
  }
}

TrackedVehicle::~TrackedVehicle()
{
  for (Side& side : sides_)
  {
    for (dJointID j : side.chain)
      dJointDestroy(j);
    if (side.brake)
      dJointDestroy(side.brake);
    for (RoadWheel& w : side.wheels)
      if (w.body)
        dBodyDestroy(w.body);
  }
  if (chassis_)
    dBodyDestroy(chassis_);
}

VehicleBodies TrackedVehicle::collisionBodies() const
{
  // The hull carries the URDF chassis boxes (the belts' included); road wheels collide as
  // cylinders, as a wheeled vehicle's wheels do.
  VehicleBodies b;
  b.chassis = chassis_;
  b.chassis_com = chassis_com_;
  b.mass = model_.total_mass;
  for (const Side& side : sides_)
    for (const RoadWheel& w : side.wheels)
      b.wheels.push_back(CollisionWheel{ w.body, w.spec->radius, w.spec->width });
  return b;
}

TrackedVehicle::Arm TrackedVehicle::armOf(const RoadWheel& w, const Hull& hull) const
{
  const Eigen::Vector3d c = vec(dBodyGetPosition(w.body));
  // Wheel centre from the pivot and its velocity relative to the hull, in hull axes.
  const Eigen::Vector3d r = hull.r.transpose() * (c - hull.x) - w.pivot_from_com;
  const Eigen::Vector3d u = hull.r.transpose() * (vec(dBodyGetLinearVel(w.body)) - hull.pointVelocity(c));
  Arm a;
  a.length = std::sqrt(r.x() * r.x() + r.z() * r.z());
  a.radial = Eigen::Vector3d(r.x(), 0.0, r.z()) / a.length;
  a.tangent = Eigen::Vector3d(a.radial.z(), 0.0, -a.radial.x());  // +y x radial
  // The rotation about +y taking the URDF arm to the current one.
  a.angle = std::atan2(w.arm.z() * r.x() - w.arm.x() * r.z(), w.arm.x() * r.x() + w.arm.z() * r.z());
  a.rate = u.dot(a.tangent) / a.length;
  a.radial_error = a.length - w.arm_length;
  a.radial_rate = u.dot(a.radial);
  a.lateral_error = r.y() - w.arm.y();
  a.lateral_rate = u.y();
  return a;
}

void TrackedVehicle::measure(const Hull& hull)
{
  const Eigen::Vector3d axle = hull.axle();
  for (Side& side : sides_)
  {
    // The belt turns the road wheels (chained at one spin): its speed relative to the hull.
    side.belt_speed = 0.0;
    for (RoadWheel& w : side.wheels)
    {
      w.arm_state = armOf(w, hull);
      w.spin = (vec(dBodyGetAngularVel(w.body)) - hull.w).dot(axle);
      side.belt_speed += side.radius * w.spin / static_cast<double>(side.wheels.size());
    }
  }
}

void TrackedVehicle::suspend(RoadWheel& w, const Hull& hull)
{
  const Arm& a = w.arm_state;
  // Torsion bar: zero twist with the arm drooped by preload_angle, so that at the URDF pose it
  // carries the static load; damper; explicit bump stops at the URDF limits (as wheeled:
  // sqrt(k_stop / I) h stays far below 2 for the wheel about its pivot).
  const double k = model_.torsion.torsion_stiffness, c = model_.torsion.torsion_damping;
  double torque = -k * (a.angle + w.lift_sign * model_.torsion.preload_angle) - c * a.rate;
  const double k_stop = kStopStiffnessFactor * k;
  const double c_stop = 2.0 * std::sqrt(k_stop * w.mass * w.arm_length * w.arm_length) + c;
  if (a.angle > w.upper)
    torque -= std::max(k_stop * (a.angle - w.upper) + c_stop * a.rate, 0.0);
  else if (a.angle < w.lower)
    torque -= std::min(k_stop * (a.angle - w.lower) + c_stop * a.rate, 0.0);
  w.torsion_torque = torque;

  // The arm holds the wheel centre on its circle about the pivot and in its plane (stiff
  // explicit spring-dampers standing in for the bearing), and the torsion bar's torque acts
  // on the wheel as a force along the circle. A massless arm hands the wheel's reaction to
  // the hull unchanged: the opposite force at the wheel centre.
  const Eigen::Vector3d f_hull =
      -(w.k_attach * a.radial_error + w.c_attach * a.radial_rate) * a.radial -
      (w.k_attach * a.lateral_error + w.c_attach * a.lateral_rate) * Eigen::Vector3d::UnitY() +
      (torque / a.length) * a.tangent;
  const Eigen::Vector3d f = hull.r * f_hull;
  w.arm_force = f;
  // The axle stays parallel to the hull's: a restoring torque about the misalignment, damping
  // the relative rotation except the spin. The drive torque turns the wheel about the axle.
  const Eigen::Vector3d axle = hull.axle();
  const Eigen::Vector3d misalignment = rotationOf(w.body).col(1).cross(axle);
  const Eigen::Vector3d relative = vec(dBodyGetAngularVel(w.body)) - hull.w;
  const Eigen::Vector3d tumble = relative - relative.dot(axle) * axle;
  const Eigen::Vector3d t = w.k_tilt * misalignment - w.c_tilt * tumble + w.drive_torque * axle;
  const dReal* c_w = dBodyGetPosition(w.body);
  dBodyAddForce(w.body, f.x(), f.y(), f.z());
  dBodyAddTorque(w.body, t.x(), t.y(), t.z());
  dBodyAddForceAtPos(chassis_, -f.x(), -f.y(), -f.z(), c_w[0], c_w[1], c_w[2]);
  dBodyAddTorque(chassis_, -t.x(), -t.y(), -t.z());
}

void TrackedVehicle::updateDrivetrain(const Hull& hull)
{
  const double h = options_.step;
  const DrivetrainSpec& d = model_.drivetrain;
  const auto fractions =
      trackedSides(command_.throttle, command_.steering, std::min(1.0, kPivotTrackSpeed / d.max_speed));
  const double fraction[2] = { fractions.first, fractions.second };
  // Reverse: both tracks backwards at up to reverse_max_speed (a pivot turn is the same).
  const double gear = command_.reverse && command_.throttle > 0.0 ? -d.reverse_max_speed : d.max_speed;
  // Sprocket rad/s relative to the hull.
  const double speed[2] = { sides_[0].belt_speed / sprocket_radius_, sides_[1].belt_speed / sprocket_radius_ };
  // One engine through the gear ratio drives both sprockets: it turns with the faster one and
  // each sprocket may take half of its torque (power limit and governor included).
  const double fast = std::max(std::abs(speed[0]), std::abs(speed[1]));
  const double available = 0.5 * wheelTorqueAvailable(d, fast, sprocket_radius_);
  engine_speed_ = d.gear_ratio * fast;
  engine_torque_ = 0.0;
  const Eigen::Vector3d axle = hull.axle();
  for (std::size_t s = 0; s < 2; ++s)
  {
    Side& side = sides_[s];
    const double to_wheel = side.radius / sprocket_radius_;  // road-wheel torque per sprocket torque
    double torque = 0.0;
    if (command_.brake > 0.0)
    {
      side.servo.reset();  // braking has priority; the servo restarts from rest
    }
    else
    {
      // Speed servo at the sprocket on the track's rotating inertia seen there.
      const double inertia = side.spin_inertia * to_wheel * to_wheel;
      torque =
          side.servo.torque(fraction[s] * (command_.throttle > 0.0 ? gear : d.max_speed) / sprocket_radius_ - speed[s],
                            inertia, available, h);
    }
    side.sprocket_torque = torque;
    side.brake_limit = command_.brake * model_.brakes.max_torque;
    engine_torque_ += std::abs(torque) / (d.efficiency * d.gear_ratio);
    // The running gear's own losses (pins, road wheels, idler): against the belt's motion
    // relative to the hull, at the road wheels (reaction on the hull).
    const double internal =
        0.5 * model_.total_mass * options_.gravity *
        (model_.track.internal_resistance + model_.track.internal_resistance_per_speed * std::abs(side.belt_speed)) *
        std::clamp(side.belt_speed / kInternalResistanceFadeSpeed, -1.0, 1.0);
    side.internal_resistance = std::abs(internal);
    for (RoadWheel& w : side.wheels)
      w.drive_torque = (torque * to_wheel - internal * side.radius) / static_cast<double>(side.wheels.size());
    for (dJointID j : side.chain)
      dJointSetAMotorAxis(j, 0, 0, axle.x(), axle.y(), axle.z());
    // Brake: the front road wheel (hence the chain) held still relative to the hull.
    if (side.brake_limit > 0.0)
    {
      dJointEnable(side.brake);
      dJointSetAMotorAxis(side.brake, 0, 0, axle.x(), axle.y(), axle.z());
      dJointSetAMotorParam(side.brake, dParamFMax, side.brake_limit * to_wheel);
    }
    else
    {
      dJointDisable(side.brake);
    }
  }
}

void TrackedVehicle::soilContact(RoadWheel& w, const Side& side, const Hull& hull, terrain::DeformableTerrain& terrain,
                                 dJointGroupID contacts, StepTimes* times)
{
  const double h = options_.step;
  w.contact = false;
  w.soil = terrain::ContactForces();
  const Eigen::Vector3d centre = vec(dBodyGetPosition(w.body));
  const Eigen::Vector3d velocity = vec(dBodyGetLinearVel(w.body));
  const Eigen::Vector3d omega = vec(dBodyGetAngularVel(w.body));
  const Eigen::Vector3d axle = hull.axle();
  dBodySetFiniteRotationAxis(w.body, axle.x(), axle.y(), axle.z());
  Eigen::Vector3d forward = axle.cross(Eigen::Vector3d::UnitZ());
  if (forward.norm() < 0.3)
  {
    w.ground.reset();
    w.resistance.off();
    return;  // hull on its side: the terrain's track patch does not apply
  }
  forward.normalize();

  // The segment under this wheel lies on the ground: a face at the wheel's lowest point along
  // the ground's normal (beside the track's rut), tilted with it, so on a slope it is pressed
  // evenly instead of digging its uphill end in. It moves with the wheel centre and is driven
  // at the belt speed the wheel's spin relative to the hull gives (T10: the belt runs relative
  // to the hull); the contact's rows act at the wheel's lowest point, whose velocity is the
  // hull's there less the belt speed: the belt's slip on the ground.
  const double radius = w.spec->radius;
  ContactFrame& frame = w.frame;
  frame.normal =
      groundNormal(terrain, centre, forward, 0.5 * side.segment_length, 0.5 * model_.track.shoe_width + 0.5 * radius);
  frame.t1 = (forward - forward.dot(frame.normal) * frame.normal).normalized();
  frame.t2 = frame.normal.cross(frame.t1);
  frame.point = centre - radius * frame.normal;
  frame.point_velocity = velocity + omega.cross(frame.point - centre);
  terrain::TrackPatch patch;
  patch.centre = frame.point;
  patch.heading = std::atan2(forward.y(), forward.x());
  patch.length = side.segment_length;
  patch.width = model_.track.shoe_width;
  patch.sprocket_pitch = model_.track.pitch;
  patch.sprocket_teeth = model_.track.sprocket_teeth;
  patch.sprocket_spin_rate = side.belt_speed / sprocket_radius_;
  patch.velocity = velocity;
  patch.track_length = side.contact_length;
  patch.segment_offset = w.segment_offset;
  patch.normal = frame.normal.z() >= 0.25 ? frame.normal : Eigen::Vector3d::UnitZ();
  patch.shear_slip = w.ground.prepare(velocity.dot(frame.t1), side.belt_speed, h);
  patch.shear_slip_given = true;
  patch.shear_cap = w.ground.shearCap();
  patch.travel = w.ground.travel();
  const auto start = times ? Clock::now() : Clock::time_point();
  w.soil = terrain.trackContact(patch, h, options_.deform_terrain);
  if (times)
    times->contact += seconds(start, Clock::now());

  // Rigid ground: the pads' deflection against the ground plane under the wheel.
  const FirmContact firm = firmContact(terrain, w.soil, centre, radius, frame.normal);
  const double mass_share = model_.total_mass / static_cast<double>(2 * side.wheels.size());
  bool fault = false;
  w.contact = w.ground.addJoint(world_, contacts, w.body, w.mass, mass_share, frame, w.soil, firm, model_.firm_ground,
                                options_, &w.feedback, fault);
  contactFault(fault, w.fault_reported, "track segment", w.spec->link, state_.name, state_.contact_faults);
  // Compaction and bulldozing (T12) push on the running gear against its travel: through the
  // road wheel's axle, not about it.
  w.resistance.set(world_, w.body, w.contact ? w.ground.resistance() : 0.0, frame.t1,
                   kRegularization / (model_.total_mass * options_.gravity));
}

void TrackedVehicle::beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times)
{
  // The arms and belts as afterStep() measured them (nothing moved since).
  const Hull hull(chassis_);
  updateDrivetrain(hull);
  for (Side& side : sides_)
  {
    for (RoadWheel& w : side.wheels)
    {
      suspend(w, hull);
      soilContact(w, side, hull, terrain, contacts, times);
    }
  }
  hull_->beforeStep(world_, contacts, chassis_, terrain, options_, times, warnings_, state_.name);
}

void TrackedVehicle::readState(double time, bool integrate)
{
  const Hull hull(chassis_);
  if (!hull.x.allFinite() || !hull.v.allFinite() || !hull.w.allFinite() || !hull.r.allFinite())
  {
    std::ostringstream why;
    why << "vehicle '" << state_.name << "' (" << model_.model << "): the physics diverged at t = " << time
        << " s (non-finite hull state)";
    throw std::runtime_error(why.str());
  }
  measure(hull);
  hull_->afterStep(chassis_, integrate);
  state_.hull_normal_force = hull_->normalForce();
  const double h = integrate ? options_.step : 0.0;
  auto wrap = [](double angle) { return std::remainder(angle, 2.0 * M_PI); };
  state_.pose.linear() = hull.r;
  state_.pose.translation() = hull.x - hull.r * chassis_com_;
  state_.linear_velocity = hull.pointVelocity(state_.pose.translation());
  state_.angular_velocity = hull.w;
  state_.body_velocity = hull.r.transpose() * state_.linear_velocity;
  state_.steering_angle = 0.0;
  state_.engine_speed = engine_speed_;
  state_.engine_torque = engine_torque_;
  state_.command = command_;
  Eigen::Vector3d moment = chassis_mass_ * hull.x;
  double mass = chassis_mass_;
  Eigen::Vector3d forward = hull.axle().cross(Eigen::Vector3d::UnitZ());
  forward = forward.norm() > 1e-9 ? forward.normalized() : Eigen::Vector3d(hull.r.col(0));
  for (std::size_t s = 0; s < sides_.size(); ++s)
  {
    Side& side = sides_[s];
    TrackState& ts = state_.tracks[s];
    ts.track_speed = side.belt_speed;
    ts.sprocket_speed = ts.track_speed / sprocket_radius_;
    ts.idler_speed = ts.track_speed / side.spec->idler_radius;
    side.sprocket_angle = wrap(side.sprocket_angle + ts.sprocket_speed * h);
    side.idler_angle = wrap(side.idler_angle + ts.idler_speed * h);
    ts.sprocket_angle = side.sprocket_angle;
    ts.idler_angle = side.idler_angle;
    const Eigen::Vector3d centre = hull.x + hull.r * (side.centre - chassis_com_);
    ts.ground_speed = hull.pointVelocity(centre).dot(forward);
    ts.slip = terrain::regularisedSlip(ts.track_speed, ts.ground_speed);
    ts.drive_torque = side.sprocket_torque;
    ts.brake_torque_limit = side.brake_limit;
    ts.normal_force = ts.traction_force = ts.resistance_force = 0.0;
    for (std::size_t i = 0; i < side.wheels.size(); ++i)
    {
      RoadWheel& w = side.wheels[i];
      moment += w.mass * vec(dBodyGetPosition(w.body));
      mass += w.mass;
      const Arm& a = w.arm_state;
      RoadWheelState& rw = ts.road_wheels[i];
      rw.arm_angle = w.spec->arm_axis_sign * a.angle;
      rw.arm_rate = w.spec->arm_axis_sign * a.rate;
      rw.torsion_torque = -w.lift_sign * w.torsion_torque;
      // The wheel turns on its arm, which itself swings about the same (hull y) axis.
      rw.spin_rate = w.spin - a.rate;
      w.spin_angle = wrap(w.spin_angle + rw.spin_rate * h);
      rw.spin_angle = w.spin_angle;

      if (w.contact && integrate)
      {
        dVector3 pv;
        dBodyGetPointVel(w.body, w.frame.point.x(), w.frame.point.y(), w.frame.point.z(), pv);
        w.ground.finish(vec(pv));
      }
      TrackSegmentState& seg = ts.segments[i];
      seg.in_contact = w.contact;
      seg.applied_normal_force = w.contact ? vec(w.feedback.f1).dot(w.frame.normal) : 0.0;
      seg.normal_force = w.contact ? w.ground.normalForce() : 0.0;
      seg.sinkage = w.soil.sinkage;
      seg.slip = w.soil.slip;
      seg.slip_angle = w.soil.slip_angle;
      // What the rows applied (feedback): the soil's force as it acted on the vehicle.
      seg.traction_force = w.contact ? vec(w.feedback.f1).dot(w.frame.t1) : 0.0;
      seg.lateral_force = w.contact ? vec(w.feedback.f1).dot(w.frame.t2) : 0.0;
      seg.resistance_force = w.contact ? w.ground.resistance() : 0.0;
      seg.applied_resistance_force = w.resistance.applied(w.frame.t1);
      seg.contact_points = w.soil.contact_points;
      ts.normal_force += seg.normal_force;
      ts.traction_force += seg.traction_force;
      ts.resistance_force += seg.resistance_force;
    }
  }
  state_.centre_of_mass = moment / mass;
}
}  // namespace

std::unique_ptr<SimVehicleBase> makeTrackedVehicle(dWorldID world, const VehicleModel& model,
                                                   const Eigen::Isometry3d& pose, const std::string& name,
                                                   const WorldOptions& options)
{
  return std::make_unique<TrackedVehicle>(world, model, pose, name, options);
}

}  // namespace dynamics
}  // namespace avsp
