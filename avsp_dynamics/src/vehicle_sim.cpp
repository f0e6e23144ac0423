#include "avsp_dynamics/vehicle_sim.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include <ode/ode.h>

#include "obstacle_collision.hpp"
#include "sim_vehicle_base.hpp"

namespace avsp
{
namespace dynamics
{
namespace
{
using namespace sim;

void initOde()
{
  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
}
}  // namespace

struct World::Ode
{
  dWorldID world = nullptr;
  dJointGroupID contacts = nullptr;
  std::vector<dBodyID> agent_bodies;                         ///< one per World::agents_ entry (their mass, no gravity)
  std::vector<dBodyID> proxy_bodies;                         ///< one per World::proxies_ entry (their mass, no gravity)
  std::vector<AgentCollisionBody> agent_geoms, proxy_geoms;  ///< what ObstacleCollision gets
  /// Per vehicle, every body of it (the chassis and all jointed to it) and its pose relative to
  /// base_link as the vehicle was set down: World::setPose sets a vehicle down again.
  std::vector<std::vector<std::pair<dBodyID, Eigen::Isometry3d>>> vehicle_bodies;
  ~Ode()
  {
    if (contacts)
      dJointGroupDestroy(contacts);
    if (world)
      dWorldDestroy(world);
  }
};

/// One wheeled vehicle's ODE bodies, joints and actuators.
class SimVehicle : public SimVehicleBase
{
public:
  SimVehicle(dWorldID world, const VehicleModel& model, const Eigen::Isometry3d& pose, const std::string& name,
             const WorldOptions& options);
  ~SimVehicle() override;
  SimVehicle(const SimVehicle&) = delete;
  SimVehicle& operator=(const SimVehicle&) = delete;

  void setCommand(const DriveCommand& command) override { command_ = command; }
  void beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times) override;
  void afterStep(double time, bool stepped) override;
  void forgetContacts() override
  {
    for (Wheel& w : wheels_)
      w.ground.reset();
    for (SideServo& s : servo_)
      s.reset();
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
  void setExternalWheelSoil(std::shared_ptr<ExternalWheelSoil> soil) override { external_ = std::move(soil); }

private:
  struct Wheel
  {
    const WheelSpec* spec = nullptr;
    dBodyID body = nullptr;
    dJointID joint = nullptr;
    double mass = 0.0;
    double spin_inertia = 0.0;                          ///< kg m^2 about the axle
    double lower = 0.0, upper = 0.0;                    ///< m, suspension travel
    double drive_torque = 0.0;                          ///< N m this step
    double brake_limit = 0.0;                           ///< N m this step
    bool contact = false;                               ///< a contact joint was made this step
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< contact frame of this step
    Eigen::Vector3d t1 = Eigen::Vector3d::UnitX(), t2 = Eigen::Vector3d::UnitY();
    terrain::ContactForces soil;
    dJointFeedback feedback{};
    GroundContact ground;                             ///< the contact's shear state and joint (sim_vehicle_base.hpp)
    ResistanceMotor resistance;                       ///< the ground's resistance at the wheel centre
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< m, where the contact acts this step
    bool fault_reported = false;                      ///< a non-finite contact force was reported once
    ExternalWheelLoad external;                       ///< the external soil's part this step (share 0: none)
  };

  /// Two wheels a locked differential turns at the same speed: an ODE angular motor between
  /// them holding zero relative spin about the bisector of their axles (exact for steered
  /// wheels too: both spins project on it by the same cos(half the angle between them)).
  struct Coupling
  {
    std::size_t a, b;
    dJointID motor;
  };

  /// rad/s relative to the chassis, + rolls forward (ODE's hinge2 rate is body 1 relative
  /// to body 2, i.e. the opposite sign).
  double spinRate(const Wheel& w) const { return -dJointGetHinge2Angle2Rate(w.joint); }
  /// rad, + = left (counter-clockwise about chassis z); ODE's hinge2 angle 1 has the
  /// opposite sign, and so has its axis-1 motor velocity.
  double steerAngle(const Wheel& w) const { return -dJointGetHinge2Angle1(w.joint); }
  void updateSteering();
  void updateDrivetrain();
  void updateCouplings();
  void updateSuspension();
  /// The terrain's contact of wheel w, its forces and stiffnesses times `share` (1: the whole).
  void soilContact(Wheel& w, terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times,
                   double share);
  /// The external soil's loads on the wheels for this step (external_ set), checked.
  void externalLoads();
  void couple(const std::string& key, const std::vector<std::pair<std::size_t, std::size_t>>& pairs);
  void buildWheel(std::size_t i, const Body& body, const Eigen::Isometry3d& pose);
  void lockDifferentials();

  VehicleModel model_;
  WorldOptions options_;
  std::shared_ptr<ExternalWheelSoil> external_;  ///< null: the terrain alone
  std::vector<WheelKinematics> kinematics_;      ///< scratch of externalLoads()
  std::vector<ExternalWheelLoad> loads_;         ///< the external soil's answer this step
  double now_ = 0.0;                             ///< s, world time after the last afterStep
  dWorldID world_;
  dBodyID chassis_ = nullptr;
  Eigen::Vector3d chassis_com_;  ///< m, lumped centre of mass in base_link
  double chassis_mass_ = 0.0;
  std::vector<Wheel> wheels_;
  std::unique_ptr<AckermannGeometry> geometry_;
  double steer_ = 0.0;  ///< rad, the actuator's bicycle angle
  double steer_torque_limit_ = 0.0;
  /// m/s or rad/s: velocity error the constraint regularizations allow at full load.
  const double regularization_ = 1e-5;
  std::vector<std::size_t> driven_front_, driven_rear_, driven_left_, driven_right_;
  std::vector<std::size_t> driven_;  ///< driven_front_ then driven_rear_ (Ackermann engine speed)
  std::vector<Coupling> couplings_;
  SideServo servo_[2];  ///< skid-steer speed servos, left and right
  double engine_speed_ = 0.0, engine_torque_ = 0.0;
  DriveCommand command_;
  VehicleState state_;
  std::unique_ptr<HullContact> hull_;
};

SimVehicle::SimVehicle(dWorldID world, const VehicleModel& model, const Eigen::Isometry3d& pose,
                       const std::string& name, const WorldOptions& options)
  : model_(model), options_(options), world_(world)
{
  // Everything that can reject the model is checked before the first ODE object exists, so
  // a rejected vehicle leaves nothing behind in the world.
  if (model_.drive_type == DriveType::kTracked)
    throw ConfigError(model_.yaml_path + ": key 'drive_type': tracked: build it with makeTrackedVehicle");
  if (model_.wheels.empty())
    throw ConfigError(model_.yaml_path + ": key 'wheels': a wheeled vehicle needs wheels");
  std::vector<const Body*> wheel_bodies(model_.wheels.size(), nullptr);
  for (std::size_t i = 0; i < model_.wheels.size(); ++i)
  {
    const WheelSpec& spec = model_.wheels[i];
    for (const Body& b : model_.bodies)
      if (b.link == spec.link)
        wheel_bodies[i] = &b;
    if (!wheel_bodies[i])
      throw ConfigError(model_.yaml_path + ": key 'wheels': wheel '" + spec.name + "': link '" + spec.link +
                        "' is not a body with mass in " + model_.urdf_path);
    if ((wheel_bodies[i]->com - spec.rest_position).norm() > 1e-3)
      throw ConfigError(model_.urdf_path + ": link '" + spec.link +
                        "': the centre of mass must be on the axle (inertial origin at the wheel centre)");
  }
  if (model_.drive_type == DriveType::kAckermann)
    geometry_ = std::make_unique<AckermannGeometry>(model_);

  // Chassis = every body that is not a wheel, lumped rigidly at the rest pose: mass, centre
  // of mass, inertia about it by the parallel-axis theorem.
  std::vector<const Body*> chassis_bodies;
  for (const Body& b : model_.bodies)
    if (std::find(wheel_bodies.begin(), wheel_bodies.end(), &b) == wheel_bodies.end())
      chassis_bodies.push_back(&b);
  const LumpedBody chassis = lump(chassis_bodies);
  chassis_mass_ = chassis.mass;
  if (!(chassis_mass_ > 0.0))
    throw ConfigError(model_.urdf_path + ": no link other than the wheels has mass: the chassis would be massless");
  chassis_com_ = chassis.com;
  hull_ = std::make_unique<HullContact>(model_, chassis_com_);
  const Eigen::Matrix3d& chassis_inertia = chassis.inertia;

  const Eigen::Matrix3d rot = pose.linear();
  chassis_ = dBodyCreate(world_);
  setMass(chassis_, chassis_mass_, chassis_inertia);
  const Eigen::Vector3d cp = pose * chassis_com_;
  dBodySetPosition(chassis_, cp.x(), cp.y(), cp.z());
  setRotation(chassis_, rot);

  wheels_.resize(model_.wheels.size());
  for (std::size_t i = 0; i < model_.wheels.size(); ++i)
    buildWheel(i, *wheel_bodies[i], pose);
  lockDifferentials();

  state_.name = name;
  state_.wheels.resize(wheels_.size());
  for (std::size_t i = 0; i < wheels_.size(); ++i)
    state_.wheels[i].name = model_.wheels[i].name;
  afterStep(0.0, false);
}

/// Wheel `i`'s body (from the URDF's `body`) and its hinge-2 to the chassis: suspension, brake
/// motor, steering stops.
void SimVehicle::buildWheel(std::size_t i, const Body& body, const Eigen::Isometry3d& pose)
{
  const Eigen::Matrix3d rot = pose.linear();
  const double h = options_.step;
  const double k = model_.suspension.stiffness, c = model_.suspension.damping;
  const WheelSpec& spec = model_.wheels[i];
  Wheel& w = wheels_[i];
  w.spec = &spec;
  w.mass = body.mass;
  w.spin_inertia = body.inertia(1, 1);
  w.lower = spec.suspension_lower;
  w.upper = spec.suspension_upper;
  w.body = dBodyCreate(world_);
  setMass(w.body, body.mass, body.inertia);
  const Eigen::Vector3d wp = pose * spec.rest_position;
  dBodySetPosition(w.body, wp.x(), wp.y(), wp.z());
  setRotation(w.body, rot);
  // A fast-spinning wheel integrated with the plain exponential map drifts off its axle;
  // ODE's finite rotation about the axle keeps it true (axis refreshed every step).
  dBodySetFiniteRotationMode(w.body, 1);

  w.joint = dJointCreateHinge2(world_, nullptr);
  dJointAttach(w.joint, chassis_, w.body);
  dJointSetHinge2Anchor(w.joint, wp.x(), wp.y(), wp.z());
  const Eigen::Vector3d a1 = rot * Eigen::Vector3d::UnitZ(), a2 = rot * Eigen::Vector3d::UnitY();
  const dReal axis1[3] = { a1.x(), a1.y(), a1.z() }, axis2[3] = { a2.x(), a2.y(), a2.z() };
  dJointSetHinge2Axes(w.joint, axis1, axis2);
  // Implicit spring-damper along axis 1 (ODE manual: ERP = hk/(hk+c), CFM = 1/(hk+c)).
  dJointSetHinge2Param(w.joint, dParamSuspensionERP, h * k / (h * k + c));
  dJointSetHinge2Param(w.joint, dParamSuspensionCFM, 1.0 / (h * k + c));
  // Brake motor on the axle: holds zero spin relative to the chassis; its torque limit is
  // set every step from the command (updateDrivetrain).
  dJointSetHinge2Param(w.joint, dParamVel2, 0.0);
  dJointSetHinge2Param(w.joint, dParamCFM2, regularization_ / model_.brakes.max_torque);
  if (spec.steering_joint.empty())
  {
    dJointSetHinge2Param(w.joint, dParamLoStop, 0.0);
    dJointSetHinge2Param(w.joint, dParamHiStop, 0.0);
  }
  else
  {
    // The geometry never asks more than max_angle of a wheel; the stops are a backstop.
    dJointSetHinge2Param(w.joint, dParamLoStop, -model_.steering.max_angle - 0.05);
    dJointSetHinge2Param(w.joint, dParamHiStop, model_.steering.max_angle + 0.05);
  }
  // Steering motor limit: half a wheel's share of the weight at its radius, far above what
  // turning the wheel about its own axis needs, so the actuator's rate sets the pace.
  steer_torque_limit_ =
      std::max(steer_torque_limit_, 0.5 * model_.total_mass * 9.81 / model_.wheels.size() * spec.radius);
}

/// Sorts the driven wheels by axle and side, and couples those a locked differential holds
/// at equal speed.
void SimVehicle::lockDifferentials()
{
  // Driven wheels by axle (Ackermann) or side (skid-steer), and the locked differentials.
  double mean_x = 0.0;
  for (const WheelSpec& w : model_.wheels)
    mean_x += w.rest_position.x() / model_.wheels.size();
  for (std::size_t i = 0; i < model_.wheels.size(); ++i)
  {
    const WheelSpec& w = model_.wheels[i];
    if (!w.driven)
      continue;
    (w.rest_position.x() > mean_x ? driven_front_ : driven_rear_).push_back(i);
    (w.rest_position.y() > 0.0 ? driven_left_ : driven_right_).push_back(i);
  }
  driven_ = driven_front_;
  driven_.insert(driven_.end(), driven_rear_.begin(), driven_rear_.end());
  // Locked differentials as wheel pairs held at equal speed: an axle (or a skid-steer side)
  // chains its driven wheels; a centre lock pairs each front wheel with the rear wheel on its
  // side (with open axle differentials this also keeps left-right speed differences equal
  // front and rear: see README, a slightly stiffer coupling than an ideal centre lock).
  auto chain = [](const std::vector<std::size_t>& wheels) {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (std::size_t n = 1; n < wheels.size(); ++n)
      out.emplace_back(wheels[n - 1], wheels[n]);
    return out;
  };
  if (model_.drive_type == DriveType::kAckermann)
  {
    couple("front", chain(driven_front_));
    couple("rear", chain(driven_rear_));
    std::vector<std::pair<std::size_t, std::size_t>> sides;
    for (std::size_t f : driven_front_)
    {
      // The rear wheel nearest in y on the same side.
      const double yf = model_.wheels[f].rest_position.y();
      std::size_t best = wheels_.size();
      double best_dy = std::numeric_limits<double>::infinity();
      for (std::size_t r : driven_rear_)
      {
        const double yr = model_.wheels[r].rest_position.y();
        if ((yr > 0.0) == (yf > 0.0) && std::abs(yr - yf) < best_dy)
        {
          best = r;
          best_dy = std::abs(yr - yf);
        }
      }
      if (best < wheels_.size())
        sides.emplace_back(f, best);
    }
    couple("center", sides);
  }
  else
  {
    couple("left", chain(driven_left_));
    couple("right", chain(driven_right_));
  }
}

SimVehicle::~SimVehicle()
{
  for (Coupling& c : couplings_)
    dJointDestroy(c.motor);
  for (Wheel& w : wheels_)
  {
    if (w.joint)
      dJointDestroy(w.joint);
    if (w.body)
      dBodyDestroy(w.body);
  }
  if (chassis_)
    dBodyDestroy(chassis_);
}

VehicleBodies SimVehicle::collisionBodies() const
{
  VehicleBodies b;
  b.chassis = chassis_;
  b.chassis_com = chassis_com_;
  b.mass = model_.total_mass;
  for (const Wheel& w : wheels_)
    b.wheels.push_back(CollisionWheel{ w.body, w.spec->radius, w.spec->width });
  return b;
}

void SimVehicle::couple(const std::string& key, const std::vector<std::pair<std::size_t, std::size_t>>& pairs)
{
  const auto it = model_.drivetrain.differentials.find(key);
  if (it == model_.drivetrain.differentials.end() || it->second != Differential::kLocked)
    return;
  for (const auto& p : pairs)
  {
    const dJointID motor = dJointCreateAMotor(world_, nullptr);
    dJointAttach(motor, wheels_[p.first].body, wheels_[p.second].body);
    dJointSetAMotorMode(motor, dAMotorUser);
    dJointSetAMotorNumAxes(motor, 1);
    dJointSetAMotorParam(motor, dParamVel, 0.0);
    // A locked differential transmits whatever torque it must: an unbounded motor. A tiny
    // compliance (1e-5 rad/s at the brake torque) keeps the exact solver's matrix regular
    // when the coupling is redundant with locked brakes or sticking tyres.
    dJointSetAMotorParam(motor, dParamFMax, dInfinity);
    dJointSetAMotorParam(motor, dParamCFM, regularization_ / model_.brakes.max_torque);
    couplings_.push_back(Coupling{ p.first, p.second, motor });
  }
  updateCouplings();
}

void SimVehicle::updateCouplings()
{
  for (Coupling& c : couplings_)
  {
    const Eigen::Vector3d axis = rotationOf(wheels_[c.a].body).col(1) + rotationOf(wheels_[c.b].body).col(1);
    const Eigen::Vector3d b = axis.normalized();
    dJointSetAMotorAxis(c.motor, 0, 0, b.x(), b.y(), b.z());
  }
}

void SimVehicle::updateSteering()
{
  const double h = options_.step;
  for (Wheel& w : wheels_)
    dJointSetHinge2Param(w.joint, dParamFMax, 0.0);
  if (!geometry_)
    return;
  const double target = command_.steering * geometry_->maxCentreAngle();
  const double max_step = model_.steering.max_rate * h;
  steer_ += std::clamp(target - steer_, -max_step, max_step);
  for (std::size_t i = 0; i < wheels_.size(); ++i)
  {
    Wheel& w = wheels_[i];
    if (w.spec->steering_joint.empty())
      continue;
    const double angle = geometry_->wheelAngle(i, steer_);
    // Velocity motor closing the angle error over 4 steps: implicit in ODE, so it tracks the
    // actuator without overshoot at any stiffness.
    dJointSetHinge2Param(w.joint, dParamVel, -(angle - steerAngle(w)) / (4.0 * h));
    dJointSetHinge2Param(w.joint, dParamFMax, steer_torque_limit_);
  }
}

void SimVehicle::updateDrivetrain()
{
  const double h = options_.step;
  const DrivetrainSpec& d = model_.drivetrain;
  for (Wheel& w : wheels_)
  {
    w.drive_torque = 0.0;
    w.brake_limit = command_.brake * model_.brakes.max_torque;
  }
  auto meanSpeed = [&](const std::vector<std::size_t>& ids, double& radius) {
    double s = 0.0;
    radius = 0.0;
    for (std::size_t i : ids)
    {
      s += spinRate(wheels_[i]) / ids.size();
      radius += wheels_[i].spec->radius / ids.size();
    }
    return s;
  };

  if (model_.drive_type == DriveType::kAckermann)
  {
    double radius = 0.0;
    const double speed = meanSpeed(driven_, radius);
    engine_speed_ = d.gear_ratio * speed;
    const double total = driveTorque(d, command_.throttle, command_.reverse, speed, radius);
    engine_torque_ = std::abs(total) / (d.efficiency * d.gear_ratio);
    // Open differentials split torque equally: centre between the driven axles, each axle
    // between its wheels. Locked ones move torque between their wheels through the couplings.
    const bool both = !driven_front_.empty() && !driven_rear_.empty();
    for (const auto* axle : { &driven_front_, &driven_rear_ })
      for (std::size_t i : *axle)
        wheels_[i].drive_torque = (both ? 0.5 : 1.0) * total / axle->size();
  }
  else
  {
    // One motor per side, speed-servoed to its share of max_speed (skid-steer mixing).
    // Reverse: both sides backwards at up to reverse_max_speed.
    const auto sides = skidSteerSides(command_.throttle, command_.steering);
    const double gear = command_.reverse ? -d.reverse_max_speed : d.max_speed;
    const double fraction[2] = { sides.first, sides.second };
    const std::vector<std::size_t>* ids[2] = { &driven_left_, &driven_right_ };
    engine_speed_ = engine_torque_ = 0.0;
    for (int s = 0; s < 2; ++s)
    {
      if (ids[s]->empty())
        continue;
      double radius = 0.0;
      const double speed = meanSpeed(*ids[s], radius);
      const double available = wheelTorqueAvailable(d, speed, radius);
      double inertia = 0.0;
      for (std::size_t i : *ids[s])
        inertia += wheels_[i].spin_inertia;
      double torque = 0.0;
      if (command_.brake > 0.0)
        servo_[s].reset();  // braking has priority; the servo restarts from rest
      else
        torque = servo_[s].torque(fraction[s] * gear / radius - speed, inertia, available, h);
      for (std::size_t i : *ids[s])
        wheels_[i].drive_torque = torque / ids[s]->size();
      engine_speed_ += 0.5 * d.gear_ratio * std::abs(speed);
      engine_torque_ += std::abs(torque) / (d.efficiency * d.gear_ratio);
    }
  }
  updateCouplings();

  for (Wheel& w : wheels_)
  {
    // ODE's hinge torque acts +axis on body 1 and -axis on body 2; the wheel is body 2.
    dJointAddHinge2Torques(w.joint, 0.0, -w.drive_torque);
    // Brake: a velocity motor holding zero spin relative to the chassis (target and compliance
    // set once in the constructor), up to its torque.
    dJointSetHinge2Param(w.joint, dParamFMax2, w.brake_limit);
  }
}

void SimVehicle::updateSuspension()
{
  const double k = model_.suspension.stiffness;
  const double c = model_.suspension.damping;
  // Bump stops: 20x the spring, critically damped on the wheel; explicit, and stable since
  // sqrt(20 k / m_wheel) * h stays far below 2 for any plausible wheel.
  const double k_stop = 20.0 * k;
  for (Wheel& w : wheels_)
  {
    dVector3 a1, a2, axis;
    dJointGetHinge2Anchor(w.joint, a1);
    dJointGetHinge2Anchor2(w.joint, a2);
    dJointGetHinge2Axis1(w.joint, axis);
    const Eigen::Vector3d n = vec(axis);
    const double q = (vec(a2) - vec(a1)).dot(n);
    dVector3 vw, vc;
    dBodyGetPointVel(w.body, a2[0], a2[1], a2[2], vw);
    dBodyGetPointVel(chassis_, a1[0], a1[1], a1[2], vc);
    const double q_rate = (vec(vw) - vec(vc)).dot(n);
    // The hinge2 spring is zero at the URDF pose; the preload makes that pose the static ride
    // height (k * preload_deflection carries the corner's weight there).
    double force = k * model_.suspension.preload_deflection;
    const double c_stop = 2.0 * std::sqrt(k_stop * w.mass) + c;
    if (q > w.upper)
      force += std::max(k_stop * (q - w.upper) + c_stop * q_rate, 0.0);
    else if (q < w.lower)
      force += std::min(k_stop * (q - w.lower) + c_stop * q_rate, 0.0);
    dBodyAddForceAtPos(chassis_, force * n.x(), force * n.y(), force * n.z(), a1[0], a1[1], a1[2]);
    dBodyAddForce(w.body, -force * n.x(), -force * n.y(), -force * n.z());
  }
}

void SimVehicle::soilContact(Wheel& w, terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times,
                             double share)
{
  const double h = options_.step;
  w.contact = false;
  w.soil = terrain::ContactForces();
  const Eigen::Vector3d centre = vec(dBodyGetPosition(w.body));
  const Eigen::Vector3d velocity = vec(dBodyGetLinearVel(w.body));
  const Eigen::Vector3d omega = vec(dBodyGetAngularVel(w.body));
  const Eigen::Vector3d axle = rotationOf(w.body).col(1);
  dBodySetFiniteRotationAxis(w.body, axle.x(), axle.y(), axle.z());
  Eigen::Vector3d forward = axle.cross(Eigen::Vector3d::UnitZ());
  if (forward.norm() < 0.3)
  {
    w.ground.reset();
    w.resistance.off();
    return;  // wheel lying on its side: the terrain's upright-wheel contact does not apply
  }
  forward.normalize();

  // The contact's frame: the ground's normal beside the wheel's own rut, the wheel's lowest
  // point along it, the heading in the ground plane.
  ContactFrame frame;
  frame.normal = groundNormal(terrain, centre, forward, w.spec->radius, 0.5 * w.spec->width + 0.5 * w.spec->radius);
  frame.t1 = (forward - forward.dot(frame.normal) * frame.normal).normalized();
  frame.t2 = frame.normal.cross(frame.t1);
  frame.point = centre - w.spec->radius * frame.normal;
  frame.point_velocity = velocity + omega.cross(frame.point - centre);
  w.normal = frame.normal;
  w.t1 = frame.t1;
  w.t2 = frame.t2;
  w.point = frame.point;

  terrain::WheelPatch patch;
  patch.centre = centre;
  patch.radius = w.spec->radius;
  patch.width = w.spec->width;
  patch.heading = std::atan2(forward.y(), forward.x());
  patch.spin_rate = omega.dot(axle);
  patch.velocity = velocity;
  patch.ground_slope = -frame.normal.dot(forward) / frame.normal.z();
  patch.shear_slip = w.ground.prepare(velocity.dot(frame.t1), patch.spin_rate * w.spec->radius, h);
  patch.shear_slip_given = true;
  patch.shear_cap = w.ground.shearCap();
  patch.travel = w.ground.travel();
  const auto start = times ? Clock::now() : Clock::time_point();
  w.soil = terrain.wheelContact(patch, h, options_.deform_terrain);
  if (times)
    times->contact += seconds(start, Clock::now());
  if (share < 1.0)
  {
    // The external soil carries the rest of the wheel: the terrain's share of each force and
    // of each stiffness (sinkage, slip and lengths are the terrain's own).
    terrain::ContactForces& f = w.soil;
    for (double* x : { &f.normal_force, &f.longitudinal_force, &f.lateral_force, &f.resistance_force,
                       &f.grass_resistance, &f.shear_strength, &f.shear_slope, &f.shear_cap_slope,
                       &f.shear_elastic_slope, &f.normal_stiffness, &f.unload_stiffness })
      *x *= share;
  }

  // Rigid ground under part of the footprint: the tyre's deflection against the ground plane.
  const FirmContact firm = firmContact(terrain, w.soil, centre, w.spec->radius, frame.normal);
  bool fault = false;
  w.contact = w.ground.addJoint(world_, contacts, w.body, w.mass, model_.total_mass / wheels_.size(), frame, w.soil,
                                firm, model_.firm_ground, options_, &w.feedback, fault);
  contactFault(fault, w.fault_reported, "wheel", w.spec->name, state_.name, state_.contact_faults);
  // Resistance (T12, Bekker's compaction, a tyre's rolling resistance) opposes the wheel's
  // travel, through the axle: bulldozing and compaction pressures act radially on a rigid wheel,
  // so they exert no torque about its centre.
  w.resistance.set(world_, w.body, w.contact ? w.ground.resistance() : 0.0, frame.t1,
                   regularization_ / (model_.total_mass * options_.gravity));
}

void SimVehicle::beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times)
{
  updateSteering();
  updateDrivetrain();
  updateSuspension();
  if (external_)
    externalLoads();
  for (std::size_t i = 0; i < wheels_.size(); ++i)
  {
    Wheel& w = wheels_[i];
    w.external = external_ ? loads_[i] : ExternalWheelLoad();
    const double share = w.external.share;
    if (share < 1.0)
      soilContact(w, terrain, contacts, times, 1.0 - share);
    else
    {
      // The external soil carries the whole wheel: no terrain contact, its shear forgotten.
      w.contact = false;
      w.soil = terrain::ContactForces();
      w.ground.reset();
      w.resistance.off();
      const Eigen::Vector3d axle = rotationOf(w.body).col(1);
      const Eigen::Vector3d forward = axle.cross(Eigen::Vector3d::UnitZ());
      w.normal = Eigen::Vector3d::UnitZ();
      w.t1 = forward.norm() > 1e-9 ? forward.normalized() : Eigen::Vector3d::UnitX();
      w.t2 = w.normal.cross(w.t1);
    }
    if (share > 0.0)
    {
      const Eigen::Vector3d& f = w.external.force;
      const Eigen::Vector3d& t = w.external.torque;
      dBodyAddForce(w.body, f.x(), f.y(), f.z());
      dBodyAddTorque(w.body, t.x(), t.y(), t.z());
    }
  }
  hull_->beforeStep(world_, contacts, chassis_, terrain, options_, times, warnings_, state_.name);
}

void SimVehicle::externalLoads()
{
  kinematics_.resize(wheels_.size());
  for (std::size_t i = 0; i < wheels_.size(); ++i)
  {
    const Wheel& w = wheels_[i];
    WheelKinematics& k = kinematics_[i];
    k.name = w.spec->name;
    k.centre = vec(dBodyGetPosition(w.body));
    k.velocity = vec(dBodyGetLinearVel(w.body));
    k.angular_velocity = vec(dBodyGetAngularVel(w.body));
    k.axle = rotationOf(w.body).col(1);
    k.radius = w.spec->radius;
    k.width = w.spec->width;
  }
  loads_.assign(wheels_.size(), ExternalWheelLoad());
  external_->advance(now_, options_.step, kinematics_, loads_);
  if (loads_.size() != wheels_.size())
    throw std::runtime_error("vehicle '" + state_.name + "': the external wheel soil answered for " +
                             std::to_string(loads_.size()) + " wheels of " + std::to_string(wheels_.size()));
  for (std::size_t i = 0; i < wheels_.size(); ++i)
  {
    const ExternalWheelLoad& l = loads_[i];
    if (!(l.share >= 0.0 && l.share <= 1.0) || !l.force.allFinite() || !l.torque.allFinite() ||
        !std::isfinite(l.sinkage) || !std::isfinite(l.slip))
      throw std::runtime_error("vehicle '" + state_.name + "', wheel '" + wheels_[i].spec->name +
                               "': the external wheel soil gave a share outside [0, 1] or a non-finite load");
  }
}

void SimVehicle::afterStep(double time, bool stepped)
{
  now_ = time;
  const Eigen::Vector3d p = vec(dBodyGetPosition(chassis_));
  const Eigen::Matrix3d r = rotationOf(chassis_);
  const Eigen::Vector3d v = vec(dBodyGetLinearVel(chassis_));
  const Eigen::Vector3d omega = vec(dBodyGetAngularVel(chassis_));
  if (!p.allFinite() || !v.allFinite() || !omega.allFinite() || !r.allFinite())
  {
    std::ostringstream why;
    why << "vehicle '" << state_.name << "' (" << model_.model << "): the physics diverged at t = " << time
        << " s (non-finite chassis state)";
    throw std::runtime_error(why.str());
  }
  hull_->afterStep(chassis_, stepped);
  state_.hull_normal_force = hull_->normalForce();
  state_.pose.linear() = r;
  state_.pose.translation() = p - r * chassis_com_;
  state_.linear_velocity = v + omega.cross(state_.pose.translation() - p);
  state_.angular_velocity = omega;
  state_.body_velocity = r.transpose() * state_.linear_velocity;
  state_.steering_angle = steer_;
  state_.engine_speed = engine_speed_;
  state_.engine_torque = engine_torque_;
  state_.command = command_;
  Eigen::Vector3d moment = chassis_mass_ * p;
  double mass = chassis_mass_;
  for (std::size_t i = 0; i < wheels_.size(); ++i)
  {
    Wheel& w = wheels_[i];
    WheelState& s = state_.wheels[i];
    if (w.contact && stepped)
    {
      dVector3 pv;
      dBodyGetPointVel(w.body, w.point.x(), w.point.y(), w.point.z(), pv);
      w.ground.finish(vec(pv));
    }
    moment += w.mass * vec(dBodyGetPosition(w.body));
    mass += w.mass;
    s.in_contact = w.contact;
    s.normal_force = w.contact ? w.ground.normalForce() : 0.0;
    s.applied_normal_force = w.contact ? vec(w.feedback.f1).dot(w.normal) : 0.0;
    s.sinkage = w.soil.sinkage;
    s.slip = w.soil.slip;
    s.slip_angle = w.soil.slip_angle;
    // What the rows applied (feedback), the soil's force as it acted on the vehicle.
    s.traction_force = w.contact ? vec(w.feedback.f1).dot(w.t1) : 0.0;
    s.lateral_force = w.contact ? vec(w.feedback.f1).dot(w.t2) : 0.0;
    if (w.external.share > 0.0)
    {
      // The external soil's part adds to the terrain's; where it carries most of the wheel,
      // its sinkage and slip are the wheel's.
      const Eigen::Vector3d& f = w.external.force;
      s.in_contact = s.in_contact || f.dot(w.normal) > 0.0;
      s.normal_force += f.dot(w.normal);
      s.applied_normal_force += f.dot(w.normal);
      s.traction_force += f.dot(w.t1);
      s.lateral_force += f.dot(w.t2);
      if (w.external.share >= 0.5)
      {
        s.sinkage = w.external.sinkage;
        s.slip = w.external.slip;
      }
    }
    s.resistance_force = w.contact ? w.ground.resistance() : 0.0;
    s.applied_resistance_force = w.resistance.applied(w.t1);
    s.contact_points = w.soil.contact_points;
    s.spin_rate = spinRate(w);
    s.steering_angle = steerAngle(w);
    dVector3 a1, a2, axis;
    dJointGetHinge2Anchor(w.joint, a1);
    dJointGetHinge2Anchor2(w.joint, a2);
    dJointGetHinge2Axis1(w.joint, axis);
    s.suspension_deflection = (vec(a2) - vec(a1)).dot(vec(axis));
    s.drive_torque = w.drive_torque;
    s.brake_torque_limit = w.brake_limit;
  }
  state_.centre_of_mass = moment / mass;
}

// ---------------------------------------------------------------------------------------

World::World(terrain::DeformableTerrain& terrain, const WorldOptions& options)
  : terrain_(terrain),
    options_(options),
    ode_(std::make_unique<Ode>()),
    collision_(std::make_unique<ObstacleCollision>(options.step))
{
  auto require = [](bool ok, const std::string& what) {
    if (!ok)
      throw std::invalid_argument("WorldOptions." + what);
  };
  require(std::isfinite(options.step) && options.step > 0.0 && options.step <= 0.01,
          "step must be in (0, 0.01] s, got " + std::to_string(options.step));
  require(std::isfinite(options.gravity) && options.gravity >= 0.0,
          "gravity must be finite and >= 0, got " + std::to_string(options.gravity));
  require(options.solver_iterations >= 1,
          "solver_iterations must be >= 1, got " + std::to_string(options.solver_iterations));
  require(std::isfinite(options.contact_damping_ratio) && options.contact_damping_ratio >= 0.0 &&
              options.contact_damping_ratio <= 2.0,
          "contact_damping_ratio must be in [0, 2], got " + std::to_string(options.contact_damping_ratio));
  initOde();
  ode_->world = dWorldCreate();
  ode_->contacts = dJointGroupCreate(0);
  dWorldSetGravity(ode_->world, 0.0, 0.0, -options.gravity);
  dWorldSetQuickStepNumIterations(ode_->world, options.solver_iterations);
  dWorldSetAutoDisableFlag(ode_->world, 0);
  rng_state_ = static_cast<unsigned long>(options.seed);
}

World::~World()
{
  collision_.reset();  // geoms before the bodies they ride on
  vehicles_.clear();   // bodies and joints before the world
}

std::size_t World::addVehicle(const VehicleModel& model, const Eigen::Isometry3d& pose, const std::string& name)
{
  if (!pose.matrix().allFinite())
    throw std::invalid_argument("World::addVehicle: pose of '" + (name.empty() ? model.model : name) +
                                "' is not finite");
  const std::string vehicle_name = name.empty() ? model.model : name;
  if (model.drive_type == DriveType::kTracked)
    vehicles_.push_back(makeTrackedVehicle(ode_->world, model, pose, vehicle_name, options_));
  else if (model.drive_type == DriveType::kLegged)
    vehicles_.push_back(makeLeggedVehicle(ode_->world, model, pose, vehicle_name, options_));
  else
    vehicles_.push_back(std::make_unique<SimVehicle>(ode_->world, model, pose, vehicle_name, options_));
  try
  {
    collision_->addVehicle(model.collision_boxes, vehicles_.back()->collisionBodies());
  }
  catch (...)
  {
    collision_->removeLastVehicle();
    vehicles_.pop_back();
    throw;
  }
  // Every body of the vehicle: all that the chassis reaches through joints (no contact joint
  // exists between steps; a joint to the static world has no body), as set down.
  std::vector<dBodyID> bodies{ vehicles_.back()->collisionBodies().chassis };
  for (std::size_t k = 0; k < bodies.size(); ++k)
    for (int j = 0; j < dBodyGetNumJoints(bodies[k]); ++j)
    {
      const dJointID joint = dBodyGetJoint(bodies[k], j);
      for (int side = 0; side < 2; ++side)
      {
        const dBodyID other = dJointGetBody(joint, side);
        if (other && std::find(bodies.begin(), bodies.end(), other) == bodies.end())
          bodies.push_back(other);
      }
    }
  const Eigen::Isometry3d base_inverse = vehicles_.back()->state().pose.inverse();
  std::vector<std::pair<dBodyID, Eigen::Isometry3d>> rest;
  for (dBodyID b : bodies)
  {
    const dReal* p = dBodyGetPosition(b);
    Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
    body.linear() = rotationOf(b);
    body.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
    rest.emplace_back(b, base_inverse * body);
  }
  ode_->vehicle_bodies.push_back(std::move(rest));
  return vehicles_.size() - 1;
}

void World::removeVehicle(std::size_t vehicle)
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::removeVehicle: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  const auto at = static_cast<std::ptrdiff_t>(vehicle);
  const dBodyID chassis = vehicles_[vehicle]->collisionBodies().chassis;
  pushes_.erase(std::remove_if(pushes_.begin(), pushes_.end(), [&](const Push& p) { return p.body == chassis; }),
                pushes_.end());
  collision_->removeVehicle(vehicle);  // geoms before the bodies they ride on
  vehicles_.erase(vehicles_.begin() + at);
  ode_->vehicle_bodies.erase(ode_->vehicle_bodies.begin() + at);
}

void World::setGravity(const Eigen::Vector3d& gravity)
{
  if (!gravity.allFinite() || std::abs(gravity.norm() - options_.gravity) > 1e-9 * std::max(1.0, options_.gravity))
    throw std::invalid_argument("World::setGravity: gravity must be finite with magnitude WorldOptions::gravity (" +
                                std::to_string(options_.gravity) + " m/s^2), got " + std::to_string(gravity.norm()));
  dWorldSetGravity(ode_->world, gravity.x(), gravity.y(), gravity.z());
}

void World::setVelocity(std::size_t vehicle, const Eigen::Vector3d& velocity)
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::setVelocity: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  if (!velocity.allFinite())
    throw std::invalid_argument("World::setVelocity: velocity of '" + vehicles_[vehicle]->state().name +
                                "' is not finite");
  const VehicleBodies b = vehicles_[vehicle]->collisionBodies();
  dBodySetLinearVel(b.chassis, velocity.x(), velocity.y(), velocity.z());
  dBodySetAngularVel(b.chassis, 0.0, 0.0, 0.0);
  for (const CollisionWheel& w : b.wheels)
  {
    // Rolling without slip: omega = (v . forward) / r about the axle (the body's y).
    const Eigen::Vector3d axle = rotationOf(w.body).col(1);
    const Eigen::Vector3d forward = axle.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d omega = velocity.dot(forward) / w.radius * axle;
    dBodySetLinearVel(w.body, velocity.x(), velocity.y(), velocity.z());
    dBodySetAngularVel(w.body, omega.x(), omega.y(), omega.z());
  }
  vehicles_[vehicle]->afterStep(time(), false);
}

void World::push(std::size_t vehicle, const Eigen::Vector3d& force, double duration)
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::push: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  if (!force.allFinite() || !std::isfinite(duration) || !(duration >= 0.0))
    throw std::invalid_argument("World::push: the force on '" + vehicles_[vehicle]->state().name +
                                "' must be finite and its duration finite and >= 0");
  const auto steps = static_cast<std::uint64_t>(std::llround(duration / options_.step));
  pushes_.push_back(Push{ vehicles_[vehicle]->collisionBodies().chassis, force, steps_ + steps });
}

void World::setPose(std::size_t vehicle, const Eigen::Isometry3d& pose)
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::setPose: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  const std::string& name = vehicles_[vehicle]->state().name;
  if (!pose.matrix().allFinite())
    throw std::invalid_argument("World::setPose: pose of '" + name + "' is not finite");
  if (!(pose.linear().transpose() * pose.linear()).isIdentity(1e-9) || pose.linear().determinant() < 0.0)
    throw std::invalid_argument("World::setPose: the rotation of '" + name + "' is not a rotation");
  // Set down as when it was added: every body at its pose relative to base_link then (the
  // suspension unloaded, nothing turning), so it lands there as a vehicle placed there would.
  for (const auto& [b, rest] : ode_->vehicle_bodies[vehicle])
  {
    const Eigen::Isometry3d body = pose * rest;
    dBodySetPosition(b, body.translation().x(), body.translation().y(), body.translation().z());
    setRotation(b, body.linear());
    dBodySetLinearVel(b, 0.0, 0.0, 0.0);
    dBodySetAngularVel(b, 0.0, 0.0, 0.0);
  }
  vehicles_[vehicle]->forgetContacts();
  vehicles_[vehicle]->afterStep(time(), false);
}

void World::setObstacles(terrain::ObjectSet& objects)
{
  collision_->setObstacles(objects, terrain_);
}

void World::setAgents(std::vector<terrain::Agent> agents)
{
  collision_->clearAgents();  // geoms before the bodies they ride on
  for (dBodyID b : ode_->agent_bodies)
    dBodyDestroy(b);
  ode_->agent_bodies.clear();
  agents_ = std::move(agents);
  std::vector<AgentCollisionBody> bodies;
  for (const terrain::Agent& a : agents_)
  {
    // A body of the agent's mass (a box of its bounds, uniform), its origin at the centre of
    // mass (ODE's rule), the boxes placed about it. It carries itself (no gravity: the path is
    // on the ground); driveAgents() pushes it along its path with bounded force.
    const terrain::AgentType type = a.spec().type;
    const Eigen::Vector3d size = terrain::agentSize(type), centre = terrain::agentBoundsCentre(type);
    AgentCollisionBody c;
    c.body = dBodyCreate(ode_->world);
    dMass mass;
    dMassSetBoxTotal(&mass, terrain::agentMass(type), size.x(), size.y(), size.z());
    dBodySetMass(c.body, &mass);
    dBodySetGravityMode(c.body, 0);
    for (const terrain::AgentBox& box : terrain::agentBoxes(type))
    {
      CollisionBox cb;
      cb.link = a.spec().name;
      cb.pose = Eigen::Isometry3d(Eigen::Translation3d(box.centre - centre));
      cb.size = box.size;
      c.boxes.push_back(cb);
    }
    ode_->agent_bodies.push_back(c.body);
    bodies.push_back(std::move(c));
  }
  ode_->agent_geoms = std::move(bodies);
  updateKinematicGeoms();
  // Start exactly on the path, at the path's velocity.
  const double t0 = time(), h = options_.step;
  for (std::size_t k = 0; k < agents_.size(); ++k)
  {
    const terrain::AgentState a = agents_[k].state(t0), b = agents_[k].state(t0 + h);
    const Eigen::Vector3d centre = terrain::agentBoundsCentre(agents_[k].spec().type);
    const Eigen::Vector3d p = a.position + Eigen::AngleAxisd(a.yaw, Eigen::Vector3d::UnitZ()) * centre;
    const dBodyID body = ode_->agent_bodies[k];
    dBodySetPosition(body, p.x(), p.y(), p.z());
    const dQuaternion q = { std::cos(0.5 * a.yaw), 0.0, 0.0, std::sin(0.5 * a.yaw) };
    dBodySetQuaternion(body, q);
    const Eigen::Vector3d v = (b.position - a.position) / h;
    dBodySetLinearVel(body, v.x(), v.y(), v.z());
    dBodySetAngularVel(body, 0.0, 0.0, std::remainder(b.yaw - a.yaw, 2.0 * M_PI) / h);
  }
  driveAgents();
}

void World::updateKinematicGeoms()
{
  std::vector<AgentCollisionBody> all = ode_->agent_geoms;
  all.insert(all.end(), ode_->proxy_geoms.begin(), ode_->proxy_geoms.end());
  collision_->setAgents(all);
}

std::size_t World::addProxy(const VehicleModel& model, const std::string& name)
{
  AgentCollisionBody c;
  c.boxes = model.collision_boxes;
  auto wheel_box = [&](const Eigen::Vector3d& centre, double radius, double width) {
    CollisionBox b;
    b.link = name;
    b.pose = Eigen::Isometry3d(Eigen::Translation3d(centre));
    b.size = Eigen::Vector3d(2.0 * radius, width, 2.0 * radius);
    if (!(b.size.allFinite() && b.size.minCoeff() > 0.0))
      throw std::invalid_argument("World::addProxy: '" + name + "' has a wheel of radius " + std::to_string(radius) +
                                  " m and width " + std::to_string(width) + " m");
    c.boxes.push_back(b);
  };
  for (const WheelSpec& w : model.wheels)
    wheel_box(w.rest_position, w.radius, w.width);
  for (const TrackSpec& t : model.tracks)
    for (const RoadWheelSpec& w : t.road_wheels)
      wheel_box(w.rest_position, w.radius, std::max(w.width, model.track.shoe_width));
  // A body of the vehicle's mass and inertia (all its links lumped at the rest pose), its origin
  // at the centre of mass (ODE's rule), the boxes placed about it; no gravity (it does not
  // touch the ground: its own process carries it). Between two exchanges it flies on at its
  // velocities and this world's vehicles push it as they would the vehicle itself: a collision
  // across partitions exchanges momentum as one between two bodies of those masses, instead of
  // against an immovable (kinematic) one that hands back twice the closing speed.
  std::vector<const Body*> links;
  for (const Body& b : model.bodies)
    links.push_back(&b);
  const sim::LumpedBody lumped = sim::lump(links);
  if (!(lumped.mass > 0.0))
    throw std::invalid_argument("World::addProxy: '" + name + "' has no mass");
  for (CollisionBox& b : c.boxes)
    b.pose.translation() -= lumped.com;
  c.body = dBodyCreate(ode_->world);
  dMass mass;
  const Eigen::Matrix3d& i = lumped.inertia;
  dMassSetParameters(&mass, lumped.mass, 0.0, 0.0, 0.0, i(0, 0), i(1, 1), i(2, 2), i(0, 1), i(0, 2), i(1, 2));
  dBodySetMass(c.body, &mass);
  dBodySetGravityMode(c.body, 0);
  dBodySetFiniteRotationMode(c.body, 1);     // a yawing proxy turns by omega dt exactly each step
  dBodySetPosition(c.body, 0.0, 0.0, -1e4);  // out of reach until placed
  ode_->proxy_bodies.push_back(c.body);
  ode_->proxy_geoms.push_back(std::move(c));
  Proxy p;
  p.name = name;
  p.com = lumped.com;
  p.pose.translation() = Eigen::Vector3d(0.0, 0.0, -1e4);
  p.since = time();
  proxies_.push_back(p);
  collision_->clearAgents();  // geoms before the change of list
  updateKinematicGeoms();
  return proxies_.size() - 1;
}

void World::setProxyState(std::size_t proxy, const Eigen::Isometry3d& pose, const Eigen::Vector3d& linear_velocity,
                          const Eigen::Vector3d& angular_velocity)
{
  if (proxy >= proxies_.size())
    throw std::out_of_range("World::setProxyState: no proxy " + std::to_string(proxy) + " (have " +
                            std::to_string(proxies_.size()) + ")");
  if (!pose.matrix().allFinite() || !linear_velocity.allFinite() || !angular_velocity.allFinite())
    throw std::invalid_argument("World::setProxyState: state of proxy '" + proxies_[proxy].name + "' is not finite");
  Proxy& p = proxies_[proxy];
  p.pose = pose;
  p.linear_velocity = linear_velocity;
  p.angular_velocity = angular_velocity;
  p.since = time();
  p.placed = false;
  driveProxies();
}

void World::removeProxy(std::size_t proxy)
{
  if (proxy >= proxies_.size())
    throw std::out_of_range("World::removeProxy: no proxy " + std::to_string(proxy) + " (have " +
                            std::to_string(proxies_.size()) + ")");
  const auto at = static_cast<std::ptrdiff_t>(proxy);
  collision_->clearAgents();  // geoms before the body they ride on
  dBodyDestroy(ode_->proxy_bodies[proxy]);
  ode_->proxy_bodies.erase(ode_->proxy_bodies.begin() + at);
  ode_->proxy_geoms.erase(ode_->proxy_geoms.begin() + at);
  proxies_.erase(proxies_.begin() + at);
  updateKinematicGeoms();
}

Eigen::Isometry3d World::proxyPose(std::size_t proxy) const
{
  if (proxy >= proxies_.size())
    throw std::out_of_range("World::proxyPose: no proxy " + std::to_string(proxy) + " (have " +
                            std::to_string(proxies_.size()) + ")");
  const dBodyID body = ode_->proxy_bodies[proxy];
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotationOf(body);
  pose.translation() = vec(dBodyGetPosition(body)) - pose.linear() * proxies_[proxy].com;
  return pose;
}

void World::driveProxies()
{
  // A proxy is put where its process says once per exchange; in between ODE moves it.
  for (std::size_t k = 0; k < proxies_.size(); ++k)
  {
    Proxy& p = proxies_[k];
    if (p.placed)
      continue;
    p.placed = true;
    const dBodyID body = ode_->proxy_bodies[k];
    const Eigen::Vector3d arm = p.pose.linear() * p.com;
    const Eigen::Vector3d centre = p.pose.translation() + arm;
    const Eigen::Vector3d v = p.linear_velocity + p.angular_velocity.cross(arm);
    dBodySetPosition(body, centre.x(), centre.y(), centre.z());
    const Eigen::Quaterniond q(p.pose.linear());
    const dQuaternion dq = { q.w(), q.x(), q.y(), q.z() };
    dBodySetQuaternion(body, dq);
    dBodySetLinearVel(body, v.x(), v.y(), v.z());
    dBodySetAngularVel(body, p.angular_velocity.x(), p.angular_velocity.y(), p.angular_velocity.z());
  }
}

terrain::AgentState World::agentState(std::size_t agent) const
{
  if (agent >= agents_.size())
    throw std::out_of_range("World::agentState: no agent " + std::to_string(agent) + " (have " +
                            std::to_string(agents_.size()) + ")");
  return agents_[agent].state(time());
}

Eigen::Isometry3d World::agentPose(std::size_t agent) const
{
  if (agent >= agents_.size())
    throw std::out_of_range("World::agentPose: no agent " + std::to_string(agent) + " (have " +
                            std::to_string(agents_.size()) + ")");
  const dBodyID body = ode_->agent_bodies[agent];
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotationOf(body);
  pose.translation() =
      vec(dBodyGetPosition(body)) - pose.linear() * terrain::agentBoundsCentre(agents_[agent].spec().type);
  return pose;
}

void World::driveAgents()
{
  // Each agent is pushed towards where its path puts it one step from now, at its path's
  // velocity there: a critically damped tracking (2 Hz... 20 rad/s) of position and heading,
  // its force bounded by what the agent can push with (agentPushForce) horizontally, so a
  // vehicle shoves a deer aside while a truck holds its way; upright and on the ground (its
  // height held firmly: it stands on the terrain).
  constexpr double kOmega = 20.0, kZeta = 1.0;
  const double t0 = time(), h = options_.step;
  for (std::size_t k = 0; k < agents_.size(); ++k)
  {
    const terrain::AgentType type = agents_[k].spec().type;
    const terrain::AgentState a = agents_[k].state(t0), b = agents_[k].state(t0 + h);
    const Eigen::Vector3d centre = terrain::agentBoundsCentre(type);
    const Eigen::Vector3d target = b.position + Eigen::AngleAxisd(b.yaw, Eigen::Vector3d::UnitZ()) * centre;
    const Eigen::Vector3d target_velocity = (b.position - a.position) / h;
    const dBodyID body = ode_->agent_bodies[k];
    const double mass = terrain::agentMass(type);
    const Eigen::Vector3d x = vec(dBodyGetPosition(body)), v = vec(dBodyGetLinearVel(body));
    Eigen::Vector3d force = mass * (kOmega * kOmega * (target - x) + 2.0 * kZeta * kOmega * (target_velocity - v));
    const double push = terrain::agentPushForce(type);
    const double horizontal = std::hypot(force.x(), force.y());
    if (horizontal > push)
    {
      force.x() *= push / horizontal;
      force.y() *= push / horizontal;
    }
    dBodyAddForce(body, force.x(), force.y(), force.z());
    // Heading and uprightness: a torque about the rotation from the body's to the path's.
    const Eigen::Matrix3d r = rotationOf(body);
    const Eigen::Matrix3d wanted = Eigen::AngleAxisd(b.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::AngleAxisd error(wanted * r.transpose());
    const Eigen::Vector3d omega = vec(dBodyGetAngularVel(body));
    const Eigen::Vector3d omega_target(0.0, 0.0, std::remainder(b.yaw - a.yaw, 2.0 * M_PI) / h);
    dMass m;
    dBodyGetMass(body, &m);
    const Eigen::Matrix3d inertia_body =
        (Eigen::Matrix3d() << m.I[0], m.I[1], m.I[2], m.I[4], m.I[5], m.I[6], m.I[8], m.I[9], m.I[10]).finished();
    const Eigen::Vector3d torque =
        r * inertia_body * r.transpose() *
        (kOmega * kOmega * error.angle() * error.axis() + 2.0 * kZeta * kOmega * (omega_target - omega));
    dBodyAddTorque(body, torque.x(), torque.y(), torque.z());
  }
}

std::size_t World::obstacleGeomCount() const
{
  return collision_->obstacleGeomCount();
}

std::size_t World::vehicleCount() const
{
  return vehicles_.size();
}

void World::setCommand(std::size_t vehicle, const DriveCommand& command)
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::setCommand: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  vehicles_[vehicle]->setCommand(clampedCommand(command));
}

void World::setExternalWheelSoil(std::size_t vehicle, std::shared_ptr<ExternalWheelSoil> soil)
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::setExternalWheelSoil: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  vehicles_[vehicle]->setExternalWheelSoil(std::move(soil));
}

void World::step()
{
  StepTimes* times = options_.profile ? &times_ : nullptr;
  const double contacts_before = times ? times->contact : 0.0;
  const auto t0 = times ? Clock::now() : Clock::time_point();
  for (auto& v : vehicles_)
    v->beforeStep(terrain_, ode_->contacts, times);
  driveAgents();
  driveProxies();
  for (const Push& p : pushes_)
    if (steps_ < p.until_step)
      dBodyAddForce(p.body, p.force.x(), p.force.y(), p.force.z());
  pushes_.erase(
      std::remove_if(pushes_.begin(), pushes_.end(), [&](const Push& p) { return steps_ + 1 >= p.until_step; }),
      pushes_.end());
  const auto tc = times ? Clock::now() : Clock::time_point();
  collision_->collide(ode_->world, ode_->contacts);
  const auto t1 = times ? Clock::now() : Clock::time_point();
  // ODE's QuickStep may shuffle constraints with its global generator: run it from this
  // world's own state so results do not depend on other worlds or earlier runs.
  dRandSetSeed(rng_state_);
  if (options_.solver == Solver::kExact)
    dWorldStep(ode_->world, options_.step);
  else
    dWorldQuickStep(ode_->world, options_.step);
  rng_state_ = dRandGetSeed();
  const auto t2 = times ? Clock::now() : Clock::time_point();
  collision_->afterStep();
  dJointGroupEmpty(ode_->contacts);
  ++steps_;
  for (std::size_t i = 0; i < vehicles_.size(); ++i)
  {
    vehicles_[i]->afterStep(time(), true);
    vehicles_[i]->setCollisionReport(collision_->report(i));
  }
  if (times)
  {
    const auto t3 = Clock::now();
    const double contacts = times->contact;
    times->ode += seconds(t1, t2);
    times->collision += seconds(tc, t1);
    // beforeStep's time less what the contacts added to their own counters this step.
    times->other += seconds(t0, tc) - (contacts - contacts_before) + seconds(t2, t3);
    ++times->steps;
  }
}

std::vector<std::string> World::takeWarnings()
{
  std::vector<std::string> out;
  for (auto& v : vehicles_)
    for (std::string& w : v->takeWarnings())
      out.push_back(std::move(w));
  return out;
}

void World::advance(double seconds_to_go)
{
  const auto n = static_cast<std::uint64_t>(std::llround(seconds_to_go / options_.step));
  for (std::uint64_t k = 0; k < n; ++k)
    step();
}

const VehicleState& World::state(std::size_t vehicle) const
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("World::state: no vehicle " + std::to_string(vehicle) + " (have " +
                            std::to_string(vehicles_.size()) + ")");
  return vehicles_[vehicle]->state();
}

const WheelState& World::wheel(std::size_t vehicle, const std::string& wheel_name) const
{
  const VehicleState& s = state(vehicle);
  std::string known;
  for (const WheelState& w : s.wheels)
  {
    if (w.name == wheel_name)
      return w;
    known += (known.empty() ? "" : ", ") + w.name;
  }
  throw std::out_of_range("vehicle '" + s.name + "' has no wheel '" + wheel_name + "' (wheels: " + known + ")");
}

Eigen::Isometry3d World::restingPose(const VehicleModel& model, double x, double y, double yaw, double clearance) const
{
  const std::vector<std::pair<Eigen::Vector3d, double>> gear = runningGear(model);
  if (gear.empty())
    throw std::invalid_argument("World::restingPose: '" + model.model + "' has no wheels to rest on");
  const Eigen::Isometry3d heading(Eigen::Translation3d(x, y, 0.0) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  // The ground under the gear, as a plane z = a + b x' + c y' in the heading's frame (least
  // squares): on a slope the vehicle is set down on it, not level with its downhill gear in
  // the air (it would drop, and slide or tip as it lands).
  Eigen::MatrixXd fit(gear.size(), 3);
  Eigen::VectorXd heights(gear.size());
  for (std::size_t k = 0; k < gear.size(); ++k)
  {
    const Eigen::Vector3d p = heading * gear[k].first;
    const auto ground = terrain_.height(p.x(), p.y());
    if (!ground)
    {
      std::ostringstream why;
      why << "World::restingPose: "
          << (k < model.wheels.size() ? "wheel '" + model.wheels[k].name + "'" : "a road wheel") << " of '"
          << model.model << "' at (" << p.x() << ", " << p.y() << ") is off the terrain";
      throw std::invalid_argument(why.str());
    }
    fit.row(static_cast<Eigen::Index>(k)) << 1.0, gear[k].first.x(), gear[k].first.y();
    heights(static_cast<Eigen::Index>(k)) = *ground;
  }
  double b = 0.0, c = 0.0;
  if (gear.size() >= 3)
  {
    const Eigen::Vector3d plane = fit.colPivHouseholderQr().solve(heights);
    if (plane.allFinite())
    {
      b = plane(1);
      c = plane(2);
    }
  }
  // Nose up by atan(b); the left side up so that the body's y axis lies in the plane.
  const double pitch = -std::atan(b), roll = std::atan(c / std::sqrt(1.0 + b * b));
  Eigen::Isometry3d pose = heading;
  if (pitch != 0.0)
    pose.rotate(Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()));
  if (roll != 0.0)
    pose.rotate(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
  // Each gear r along the plane's normal above the ground under it: r / n_z vertically.
  const double rise = std::sqrt(1.0 + b * b + c * c);
  double z = -std::numeric_limits<double>::infinity();
  for (const auto& [rest, radius] : gear)
  {
    const Eigen::Vector3d q = pose.linear() * rest;
    const auto ground = terrain_.height(x + q.x(), y + q.y());
    if (ground)
      z = std::max(z, *ground + radius * rise - q.z());
  }
  if (!std::isfinite(z))
    throw std::invalid_argument("World::restingPose: '" + model.model + "' has no wheels to rest on");
  pose.translation().z() = z + clearance;
  return pose;
}

}  // namespace dynamics
}  // namespace avsp
