// A legged vehicle in ODE (issue 24, first stage: it stands): every leg link a body, each joint
// an ODE hinge driven by an explicit PD with the actuator's torque and speed limits, the feet on
// the soil through the same plate contact as a hull's belly (terrain.trackContact, no sprocket),
// the trunk's box corners on the ground when it has fallen. docs/design/legged.md says why.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "avsp_dynamics/leg_kinematics.hpp"
#include "sim_vehicle_base.hpp"

namespace avsp
{
namespace dynamics
{
namespace
{
using namespace sim;

/// m: a foot's sole this far above the ground has no contact (one height lookup a step).
constexpr double kFootClearanceCheck = 0.02;
/// Fallen: the trunk's up axis more than 60 degrees from the vertical, or the trunk (base_link)
/// within this share of its stance height of the ground.
constexpr double kFallenUpZ = 0.5;
constexpr double kFallenHeightShare = 0.35;
/// The trunk's box corners on the ground (a fallen robot): each a stiff contact, 1 cm under the
/// whole weight, damped at ratio 1, Coulomb friction 0.6 (a plastic shell on soil or pavement).
constexpr double kCornerDeflection = 0.01;
constexpr double kCornerFriction = 0.6;

class LeggedVehicle : public SimVehicleBase
{
public:
  LeggedVehicle(dWorldID world, const VehicleModel& model, const Eigen::Isometry3d& pose, const std::string& name,
                const WorldOptions& options);
  ~LeggedVehicle() override;

  void setCommand(const DriveCommand& command) override;
  void beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times) override;
  void afterStep(double time, bool stepped) override;
  void forgetContacts() override
  {
    for (Leg& leg : legs_)
      leg.foot.ground.reset();
  }
  const VehicleState& state() const override { return state_; }
  VehicleBodies collisionBodies() const override
  {
    VehicleBodies b;
    b.chassis = trunk_;
    b.chassis_com = trunk_com_;
    b.mass = model_.total_mass;
    return b;
  }
  void setCollisionReport(const CollisionReport& report) override
  {
    state_.obstacle_contacts = report.contacts;
    state_.obstacle_rigid_contacts = report.rigid_contacts;
    state_.obstacle_impulse = report.impulse;
  }
  void setExternalWheelSoil(std::shared_ptr<ExternalWheelSoil> soil) override
  {
    if (soil)
      throw std::invalid_argument("vehicle '" + name_ + "' has legs: an external wheel soil needs wheels");
  }

private:
  struct Foot
  {
    GroundContact ground;
    bool contact = false;
    bool fault_reported = false;
    dJointFeedback feedback{};
    terrain::ContactForces soil;
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< m, world: the pad's centre this step
    Eigen::Vector3d local = Eigen::Vector3d::Zero();  ///< m, the foot sphere's centre in the shank body's frame
  };
  struct Leg
  {
    const LegSpec* spec = nullptr;
    std::array<dBodyID, 3> bodies{};   ///< hip, thigh, shank (with the foot)
    std::array<double, 3> masses{};    ///< kg
    std::array<dJointID, 3> hinges{};  ///< abduction, flexion, knee: body1 the child
    LegAngles stance{};                ///< rad, the joints' angles when the hinges were made
    LegAngles q{}, qd{}, torque{};     ///< rad, rad/s, N m (last step)
    Foot foot;
  };

  void actuate(Leg& leg, const Eigen::Matrix3d& trunk_rotation, int legs_in_contact);
  void footContact(Leg& leg, terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times,
                   const Eigen::Vector3d& forward);
  void trunkCorners(terrain::DeformableTerrain& terrain, dJointGroupID contacts);

  dWorldID world_;
  VehicleModel model_;
  std::string name_;
  WorldOptions options_;
  dBodyID trunk_ = nullptr;
  Eigen::Vector3d trunk_com_ = Eigen::Vector3d::Zero();  ///< m, base_link
  std::vector<Eigen::Vector3d> corners_;                 ///< m, the trunk's box corners in the trunk body's frame
  std::vector<Leg> legs_;
  VehicleState state_;
};

LumpedBody lumpOf(const VehicleModel& model, const std::vector<std::string>& links)
{
  std::vector<const Body*> bodies;
  for (const Body& b : model.bodies)
    if (std::find(links.begin(), links.end(), b.link) != links.end())
      bodies.push_back(&b);
  return lump(bodies);
}

dBodyID makeBody(dWorldID world, const LumpedBody& lumped, const Eigen::Isometry3d& motion,
                 const Eigen::Isometry3d& pose)
{
  dBodyID body = dBodyCreate(world);
  // The body's axes are base_link's at rest moved with the link: its inertia about its centre
  // of mass in them is the rest pose's in base_link axes.
  setMass(body, lumped.mass, lumped.inertia);
  const Eigen::Vector3d com = pose * (motion * lumped.com);
  dBodySetPosition(body, com.x(), com.y(), com.z());
  setRotation(body, pose.linear() * motion.linear());
  return body;
}

LeggedVehicle::LeggedVehicle(dWorldID world, const VehicleModel& model, const Eigen::Isometry3d& pose,
                             const std::string& name, const WorldOptions& options)
  : world_(world), model_(model), name_(name), options_(options)
{
  // Everything that can refuse the model first: nothing is in the world when it throws.
  std::vector<std::string> leg_links;
  for (const LegSpec& l : model_.legs)
    leg_links.insert(leg_links.end(), { l.links[0], l.links[1], l.links[2], l.foot_link });
  std::vector<std::string> trunk_links;
  for (const Body& b : model_.bodies)
    if (std::find(leg_links.begin(), leg_links.end(), b.link) == leg_links.end())
      trunk_links.push_back(b.link);
  const LumpedBody trunk = lumpOf(model_, trunk_links);
  std::vector<std::array<LumpedBody, 3>> parts;
  std::vector<LegAngles> stances;
  for (const LegSpec& spec : model_.legs)
  {
    stances.push_back(stanceAngles(model_, spec));
    const std::vector<std::string> links[3] = { { spec.links[0] },
                                                { spec.links[1] },
                                                { spec.links[2], spec.foot_link } };
    parts.emplace_back();
    for (int k = 0; k < 3; ++k)
    {
      parts.back()[k] = lumpOf(model_, links[k]);
      if (!(parts.back()[k].mass > 0.0))
        throw ConfigError(model_.yaml_path + ": leg '" + spec.name + "' link '" + spec.links[k] +
                          "' has no mass in the URDF (every leg link needs an <inertial>)");
    }
  }
  if (!(trunk.mass > 0.0))
    throw ConfigError(model_.yaml_path + ": the trunk has no mass in the URDF");

  trunk_com_ = trunk.com;
  trunk_ = makeBody(world_, trunk, Eigen::Isometry3d::Identity(), pose);
  for (const CollisionBox& box : model_.collision_boxes)
    for (int c = 0; c < 8; ++c)
    {
      const Eigen::Vector3d corner(c & 1 ? 0.5 : -0.5, c & 2 ? 0.5 : -0.5, c & 4 ? 0.5 : -0.5);
      corners_.push_back(box.pose * corner.cwiseProduct(box.size) - trunk_com_);
    }

  legs_.reserve(model_.legs.size());  // the feet's joint feedback is registered by address each step
  for (std::size_t l = 0; l < model_.legs.size(); ++l)
  {
    const LegSpec& spec = model_.legs[l];
    Leg leg;
    leg.spec = &spec;
    leg.stance = stances[l];
    const LegPose at = legForward(spec, leg.stance);
    dBodyID parent = trunk_;
    for (int k = 0; k < 3; ++k)
    {
      leg.masses[k] = parts[l][k].mass;
      leg.bodies[k] = makeBody(world_, parts[l][k], at.motion[k], pose);
      // The joint rides on its parent: its anchor and axis where the parent's motion puts them.
      const Eigen::Isometry3d parent_motion = k == 0 ? Eigen::Isometry3d::Identity() : at.motion[k - 1];
      const Eigen::Vector3d anchor = pose * (parent_motion * spec.anchors[k]);
      const Eigen::Vector3d axis = pose.linear() * parent_motion.linear() * spec.axes[k];
      leg.hinges[k] = dJointCreateHinge(world_, nullptr);
      dJointAttach(leg.hinges[k], leg.bodies[k], parent);  // body1 the child: + angle = + URDF angle
      dJointSetHingeAnchor(leg.hinges[k], anchor.x(), anchor.y(), anchor.z());
      dJointSetHingeAxis(leg.hinges[k], axis.x(), axis.y(), axis.z());
      const LegJointSpec& limits = model_.legged.joints[k];
      dJointSetHingeParam(leg.hinges[k], dParamLoStop, limits.lower - leg.stance[k]);
      dJointSetHingeParam(leg.hinges[k], dParamHiStop, limits.upper - leg.stance[k]);
      parent = leg.bodies[k];
    }
    const Eigen::Vector3d foot_world = pose * at.foot;
    const Eigen::Vector3d shank = vec(dBodyGetPosition(leg.bodies[2]));
    leg.foot.local = rotationOf(leg.bodies[2]).transpose() * (foot_world - shank);
    leg.q = leg.stance;
    legs_.push_back(std::move(leg));
    for (int k = 0; k < 3; ++k)
      state_.joints.push_back(LegJointState{ spec.joints[k] });
    FootState foot;
    foot.leg = spec.name;
    state_.feet.push_back(foot);
  }
  state_.name = name_;
  afterStep(0.0, false);
}

LeggedVehicle::~LeggedVehicle()
{
  for (Leg& leg : legs_)
    for (int k = 2; k >= 0; --k)
    {
      dJointDestroy(leg.hinges[k]);
      dBodyDestroy(leg.bodies[k]);
    }
  dBodyDestroy(trunk_);
}

void LeggedVehicle::setCommand(const DriveCommand& command)
{
  if (command.throttle > 0.0 || command.steering != 0.0)
    throw CommandError("vehicle '" + name_ +
                       "' is legged: it stands (a gait controller driven by cmd_vel is issue 24's next stage); "
                       "throttle and steering must be 0");
  state_.command = command;
}

void LeggedVehicle::actuate(Leg& leg, const Eigen::Matrix3d& trunk_rotation, int legs_in_contact)
{
  // The stand: every leg held at its stance angles, so the trunk stands stance.height above
  // the plane of its feet and parallel to it (level on level ground).
  const LegAngles& target = leg.stance;
  // Gravity's share carried by this foot when it stands: the joints' torques that hold it,
  // -J^T F (F the ground's force on the foot, in the trunk's frame).
  Eigen::Vector3d feedforward = Eigen::Vector3d::Zero();
  if (leg.foot.contact && legs_in_contact > 0)
  {
    const Eigen::Vector3d up_force =
        trunk_rotation.transpose() * Eigen::Vector3d(0.0, 0.0, model_.total_mass * options_.gravity / legs_in_contact);
    feedforward = -legJacobian(*leg.spec, leg.q).transpose() * up_force;
  }
  for (int k = 0; k < 3; ++k)
  {
    const LegJointSpec& j = model_.legged.joints[k];
    double tau = j.stiffness * (target[k] - leg.q[k]) - j.damping * leg.qd[k] + feedforward(k);
    // The actuator: its peak torque, falling to none at its top speed when driving.
    double limit = j.max_torque;
    if (tau * leg.qd[k] > 0.0)
      limit *= std::max(0.0, 1.0 - std::abs(leg.qd[k]) / j.max_speed);
    tau = std::clamp(tau, -limit, limit);
    leg.torque[k] = tau;
    dJointAddHingeTorque(leg.hinges[k], tau);
  }
}

void LeggedVehicle::footContact(Leg& leg, terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times,
                                const Eigen::Vector3d& forward)
{
  Foot& f = leg.foot;
  f.contact = false;
  const double r = leg.spec->foot_radius;
  const Eigen::Vector3d centre = vec(dBodyGetPosition(leg.bodies[2])) + rotationOf(leg.bodies[2]) * f.local;
  const auto ground = terrain.height(centre.x(), centre.y());
  if (!ground || !(centre.z() - r - *ground < kFootClearanceCheck))
  {
    f.ground.reset();
    return;
  }
  Plate pad;
  pad.centre = centre - r * Eigen::Vector3d::UnitZ();
  pad.along = forward;
  pad.length = pad.width = model_.legged.pad_size;
  pad.body_mass = leg.masses[2];
  pad.mass_share = model_.total_mass / static_cast<double>(legs_.size());
  pad.resisted_mass = model_.total_mass;
  pad.firm_radius = r;
  bool fault = false;
  f.contact = plateContact(world_, contacts, leg.bodies[2], pad, model_.firm_ground, terrain, options_, times, f.ground,
                           &f.feedback, fault, &f.soil);
  contactFault(fault, f.fault_reported, "foot", leg.spec->name, name_, state_.contact_faults);
  f.point = pad.centre;
}

void LeggedVehicle::trunkCorners(terrain::DeformableTerrain& terrain, dJointGroupID contacts)
{
  const double h = options_.step;
  const double k = model_.total_mass * options_.gravity / kCornerDeflection;
  const double c = 2.0 * std::sqrt(k * model_.total_mass);
  const Eigen::Vector3d x = vec(dBodyGetPosition(trunk_));
  const Eigen::Matrix3d r = rotationOf(trunk_);
  for (const Eigen::Vector3d& local : corners_)
  {
    const Eigen::Vector3d p = x + r * local;
    const auto ground = terrain.height(p.x(), p.y());
    if (!ground || !(p.z() < *ground))
      continue;
    dContact contact{};
    contact.surface.mode = dContactSoftERP | dContactSoftCFM | dContactApprox1;
    contact.surface.mu = kCornerFriction;
    contact.surface.soft_erp = h * k / (h * k + c);
    contact.surface.soft_cfm = 1.0 / (h * k + c);
    contact.geom.pos[0] = p.x();
    contact.geom.pos[1] = p.y();
    contact.geom.pos[2] = p.z();
    contact.geom.normal[2] = 1.0;
    contact.geom.depth = *ground - p.z();
    dJointID j = dJointCreateContact(world_, contacts, &contact);
    dJointAttach(j, trunk_, nullptr);
  }
}

void LeggedVehicle::beforeStep(terrain::DeformableTerrain& terrain, dJointGroupID contacts, StepTimes* times)
{
  const Eigen::Matrix3d r = rotationOf(trunk_);
  int in_contact = 0;
  for (const Leg& leg : legs_)
    in_contact += leg.foot.contact ? 1 : 0;
  Eigen::Vector3d forward(r(0, 0), r(1, 0), 0.0);
  if (forward.norm() < 1e-6)
    forward = Eigen::Vector3d::UnitX();
  forward.normalize();
  for (Leg& leg : legs_)
  {
    actuate(leg, r, in_contact);
    footContact(leg, terrain, contacts, times, forward);
  }
  trunkCorners(terrain, contacts);
}

void LeggedVehicle::afterStep(double time, bool stepped)
{
  (void)time;
  const Eigen::Matrix3d r = rotationOf(trunk_);
  const Eigen::Vector3d x = vec(dBodyGetPosition(trunk_));
  if (!x.allFinite() || !r.allFinite())
    throw std::runtime_error("vehicle '" + name_ + "': the physics diverged (trunk position not finite)");
  state_.pose = Eigen::Isometry3d::Identity();
  state_.pose.linear() = r;
  state_.pose.translation() = x - r * trunk_com_;
  dVector3 v;
  const Eigen::Vector3d base = state_.pose.translation();
  dBodyGetPointVel(trunk_, base.x(), base.y(), base.z(), v);
  state_.linear_velocity = vec(v);
  state_.angular_velocity = vec(dBodyGetAngularVel(trunk_));
  state_.body_velocity = r.transpose() * state_.linear_velocity;
  dMass m;
  dBodyGetMass(trunk_, &m);
  Eigen::Vector3d weighted = m.mass * x;
  double total = m.mass;
  for (std::size_t l = 0; l < legs_.size(); ++l)
  {
    Leg& leg = legs_[l];
    for (int k = 0; k < 3; ++k)
    {
      leg.q[k] = leg.stance[k] + dJointGetHingeAngle(leg.hinges[k]);
      leg.qd[k] = dJointGetHingeAngleRate(leg.hinges[k]);
      LegJointState& js = state_.joints[3 * l + k];
      js.position = leg.q[k];
      js.velocity = leg.qd[k];
      js.effort = leg.torque[k];
      dBodyGetMass(leg.bodies[k], &m);
      weighted += m.mass * vec(dBodyGetPosition(leg.bodies[k]));
      total += m.mass;
    }
    Foot& f = leg.foot;
    FootState& fs = state_.feet[l];
    fs.position = vec(dBodyGetPosition(leg.bodies[2])) + rotationOf(leg.bodies[2]) * f.local;
    fs.in_contact = f.contact;
    fs.normal_force = fs.applied_normal_force = fs.sinkage = fs.pressure = fs.slip_velocity = 0.0;
    fs.contact_points = 0;
    if (f.contact)
    {
      dVector3 pv;
      dBodyGetPointVel(leg.bodies[2], f.point.x(), f.point.y(), f.point.z(), pv);
      if (stepped)
        f.ground.finish(vec(pv));
      fs.normal_force = f.ground.normalForce();
      fs.applied_normal_force = stepped ? f.feedback.f1[2] : 0.0;
      fs.sinkage = f.soil.sinkage;
      fs.pressure = fs.normal_force / (model_.legged.pad_size * model_.legged.pad_size);
      Eigen::Vector3d slide = vec(pv);
      slide.z() = 0.0;
      fs.slip_velocity = slide.norm();
      fs.contact_points = f.soil.contact_points;
    }
  }
  state_.centre_of_mass = weighted / total;
  if (!state_.fallen)
  {
    const bool tipped = r(2, 2) < kFallenUpZ;
    double soles = 0.0;
    for (std::size_t k = 0; k < legs_.size(); ++k)
      soles += state_.feet[k].position.z() - legs_[k].spec->foot_radius;
    // Down: base_link within 35 % of its stance height above its feet's soles (legs folded
    // under it, or lying on its belly).
    const bool down = base.z() - soles / legs_.size() < kFallenHeightShare * model_.legged.stance_height;
    state_.fallen = tipped || down;
  }
}

}  // namespace

std::unique_ptr<SimVehicleBase> makeLeggedVehicle(dWorldID world, const VehicleModel& model,
                                                  const Eigen::Isometry3d& pose, const std::string& name,
                                                  const WorldOptions& options)
{
  return std::make_unique<LeggedVehicle>(world, model, pose, name, options);
}

}  // namespace dynamics
}  // namespace avsp
