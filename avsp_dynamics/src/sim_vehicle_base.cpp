#include "sim_vehicle_base.hpp"

#include <limits>

namespace avsp
{
namespace dynamics
{
namespace sim
{
LumpedBody lump(const std::vector<const Body*>& bodies)
{
  LumpedBody out;
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (const Body* b : bodies)
  {
    out.mass += b->mass;
    moment += b->mass * b->com;
  }
  if (!(out.mass > 0.0))
    return out;
  out.com = moment / out.mass;
  for (const Body* b : bodies)
    out.inertia += b->inertia + pointInertia(b->mass, b->com - out.com);
  return out;
}

Eigen::Vector3d groundNormal(const terrain::DeformableTerrain& terrain, const Eigen::Vector3d& centre,
                             const Eigen::Vector3d& forward, double ahead, double beside)
{
  const Eigen::Vector3d left = Eigen::Vector3d::UnitZ().cross(forward);
  const double a = ahead, b = beside;
  double hgt[2][2];
  for (int i = 0; i < 2; ++i)
  {
    for (int j = 0; j < 2; ++j)
    {
      const Eigen::Vector3d p = centre + (i ? a : -a) * forward + (j ? b : -b) * left;
      const auto z = terrain.height(p.x(), p.y());
      if (!z)
        return Eigen::Vector3d::UnitZ();
      hgt[i][j] = *z;
    }
  }
  const double slope_fwd = (hgt[1][0] + hgt[1][1] - hgt[0][0] - hgt[0][1]) / (4.0 * a);
  const double slope_left = (hgt[0][1] + hgt[1][1] - hgt[0][0] - hgt[1][0]) / (4.0 * b);
  const Eigen::Vector3d n = (Eigen::Vector3d::UnitZ() - slope_fwd * forward - slope_left * left).normalized();
  // Heights finite but absurd (a 1e38 m spike) overflow the slope: no normal, as off the terrain.
  return n.allFinite() ? n : Eigen::Vector3d::UnitZ();
}

Eigen::Vector2d GroundContact::prepare(double v_long, double v_theoretical, double step)
{
  step_ = step;
  constexpr double kTravelTurn = 0.05;  // m/s
  if (std::abs(v_long) > kTravelTurn)
    travel_ = v_long > 0.0 ? 1 : -1;
  else if (std::abs(v_theoretical) > kTravelTurn)
    travel_ = v_theoretical > 0.0 ? 1 : -1;
  // Implicit relaxation over the step (stable at any speed): u <- (u + h v) / (1 + h D / L).
  const double speed = std::max(std::abs(v_long), std::abs(v_theoretical));
  travel_speed_ = speed;
  const double length = std::max(relaxation_, kMinRelaxationLength);
  decay_ = 1.0 / (1.0 + step * speed / length);
  decayed_ = decay_ * u_;
  const double soil_length = std::max(soil_length_, kMinRelaxationLength);
  shear_length_ = std::max(soil_length * std::min(1.0, speed / kShearRenewalSpeed), kMinShearLength);
  return -decayed_ / shear_length_;
}

void GroundContact::reset()
{
  u_.setZero();
  decayed_.setZero();
  sliding_ = unloading_ = false;
  elastic_ = k_elastic_ = k_along_ = 0.0;
  active_ = false;
  normal_ = firm_normal_ = resistance_ = 0.0;
}

FirmContact firmContact(const terrain::DeformableTerrain& terrain, const terrain::ContactForces& soil,
                        const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& normal)
{
  FirmContact firm;
  if (soil.rigid_soil >= 0 && soil.rigid_share > 0.0)
  {
    firm.surface = &terrain.palette()[static_cast<std::size_t>(soil.rigid_soil)];
    firm.share = soil.rigid_share;
    if (const auto ground = terrain.height(centre.x(), centre.y()))
      firm.depth = radius - (centre.z() - *ground) * normal.z();
  }
  return firm;
}

BrushForce brushForce(const Eigen::Vector2d& u, double normal, const FirmGroundSpec& spec, double friction_peak,
                      double friction_sliding)
{
  BrushForce out;
  if (!(normal > 0.0))
    return out;
  const double length = spec.relaxation_length;
  const double kappa = -u.x() / length, tan_alpha = -u.y() / length;
  const double combined = std::min(std::hypot(kappa, tan_alpha), 1.0);
  const double mu = friction_peak - (friction_peak - friction_sliding) * combined;
  out.capacity = friction_peak * normal;
  const double cx = spec.longitudinal_stiffness * normal, cy = spec.cornering_stiffness * normal;
  const double scale = 3.0 * mu * normal;
  const double sx = cx * kappa / scale, sy = cy * tan_alpha / scale;
  const double sigma = std::hypot(sx, sy);
  // d(sigma_x)/d(u_x) = -C_x / (3 mu F_z L): the force's slope in u, taken at this mu.
  const double gx = cx / (scale * length), gy = cy / (scale * length);
  if (sigma < 1.0)
  {
    // F = mu F_z q(sigma) (sx, sy), q = 3 - 3 sigma + sigma^2; dF_x/dsx = mu F_z (q + q' sx^2 / sigma).
    const double q = 3.0 - 3.0 * sigma + sigma * sigma, dq = -3.0 + 2.0 * sigma;
    out.force = mu * normal * q * Eigen::Vector2d(sx, sy);
    const double wx = sigma > 0.0 ? sx * sx / sigma : 0.0, wy = sigma > 0.0 ? sy * sy / sigma : 0.0;
    out.stiffness = mu * normal * Eigen::Vector2d((q + dq * wx) * gx, (q + dq * wy) * gy);
  }
  else
  {
    out.force = mu * normal * Eigen::Vector2d(sx, sy) / sigma;
    const double s3 = sigma * sigma * sigma;
    out.stiffness = mu * normal * Eigen::Vector2d(sy * sy / s3 * gx, sx * sx / s3 * gy);
  }
  return out;
}

bool GroundContact::addJoint(dWorldID world, dJointGroupID contacts, dBodyID body, double body_mass, double mass_share,
                             const ContactFrame& frame, const terrain::ContactForces& soil, const FirmContact& firm,
                             const FirmGroundSpec& firm_spec, const WorldOptions& options, dJointFeedback* feedback,
                             bool& fault)
{
  fault = false;
  active_ = false;
  normal_ = firm_normal_ = resistance_ = 0.0;
  const double h = options.step, zeta = options.contact_damping_ratio;
  // Normal: the soil's force, and on rigid ground the tyre's (its deflection times its stiffness,
  // for the share of the footprint there).
  const double soil_normal = soil.normal_force > 0.0 ? soil.normal_force : 0.0;
  const bool on_firm = firm.surface && firm.share > 0.0 && firm.depth > 0.0;
  const double k_firm = on_firm ? firm.share * firm_spec.vertical_stiffness : 0.0;
  const double firm_normal = on_firm ? k_firm * firm.depth : 0.0;
  const double f_n = soil_normal + firm_normal;
  if (!(f_n > 0.0))
  {
    reset();
    return false;
  }
  // The soil's implicit stiffness: its loading slope, raised where the (stiffer) unloading line
  // would be too stiff for the step to follow explicitly (h^2 k / m < 1 on the difference).
  const double k_load = soil_normal > 0.0 ? std::max(soil.normal_stiffness, 0.0) : 0.0;
  const double k_soil = soil_normal > 0.0 ? std::max(k_load, soil.unload_stiffness - body_mass / (h * h)) : 0.0;
  const double kp = std::max({ k_soil + k_firm, f_n / kMaxVirtualDepth, 1e3 });
  const double kd = 2.0 * zeta * (std::sqrt(k_load * body_mass) + std::sqrt(k_firm * body_mass));

  // Tangential: the soil's shear at the relaxed displacement (the terrain was given it), the
  // tyre's on rigid ground, their stiffness in u and the strength that bounds them.
  Eigen::Vector2d force = Eigen::Vector2d::Zero(), stiffness = Eigen::Vector2d::Zero();
  double capacity = 0.0;
  const double du = decayed_.norm();
  if (soil_normal > 0.0)
    soilShear(soil, force, stiffness, capacity);
  if (on_firm)
  {
    const BrushForce tyre =
        brushForce(decayed_, firm_normal, firm_spec, firm.surface->friction_peak, firm.surface->friction_sliding);
    force += tyre.force;
    stiffness += tyre.stiffness;
    capacity += tyre.capacity;
  }
  if (!force.allFinite() || !stiffness.allFinite() || !std::isfinite(capacity) || !std::isfinite(f_n) ||
      !std::isfinite(kp) || !std::isfinite(kd))
  {
    fault = true;
    reset();
    return false;
  }

  dContact ct{};
  ct.surface.mode = dContactSoftERP | dContactSoftCFM | dContactMu2 | dContactFDir1 | dContactSlip1 | dContactSlip2 |
                    dContactMotion1 | dContactMotion2;
  // Normal row = implicit spring (kp) + damper (kd) whose force at the current state is the
  // ground's: depth = F / kp. Stiff soils and tyres stay stable at any step: the solver takes
  // the stiffness implicitly instead of the step overshooting it.
  ct.surface.soft_erp = h * kp / (h * kp + kd);
  ct.surface.soft_cfm = 1.0 / (h * kp + kd);
  ct.geom.depth = f_n / kp;
  for (int a = 0; a < 3; ++a)
  {
    ct.geom.pos[a] = frame.point[a];
    ct.geom.normal[a] = frame.normal[a];
    ct.fdir1[a] = frame.t1[a];
  }
  // Friction rows: F = F(u~) - c (a - 1) u / h - (J a h + c a) v, the force at the relaxed
  // displacement less its stiffness J and a damper c on du/dt over the step, implicit in the
  // step's sliding velocity v: ODE's surface motion m and force-dependent slip k with
  // v = m - k F. The damper acts on the displacement's change, not on v, so steady rolling keeps
  // the soil's own force; at rest it damps the ground's elastic hold critically (zeta).
  const double a = decay_, b = decay_ * h;
  const double magnitude = force.norm();
  const double k_elastic =
      (soil_normal > 0.0 ? soil.shear_elastic_slope : 0.0) +
      (on_firm ? firm_spec.longitudinal_stiffness * firm_normal / firm_spec.relaxation_length : 0.0);
  elastic_ = k_elastic > 0.0 ? magnitude / k_elastic : 0.0;
  k_elastic_ = k_elastic;
  // The force's slope along the displacement (what unloading on the curve would follow).
  const Eigen::Vector2d dir = du > 1e-12 ? Eigen::Vector2d(decayed_ / du) : Eigen::Vector2d(1.0, 0.0);
  k_along_ = dir.x() * dir.x() * stiffness.x() + dir.y() * dir.y() * stiffness.y();
  const bool has_direction = magnitude > 1e-9 * capacity;
  double bound[2], slip[2], motion[2];
  for (int r = 0; r < 2; ++r)
  {
    const double k = std::max(stiffness[r], 1e-6 * f_n / std::max(limit_, kMinRelaxationLength));
    const double c = 2.0 * zeta * std::sqrt(k * mass_share);
    slip[r] = 1.0 / (b * k + a * c);
    motion[r] = (force[r] - c * (a - 1.0) * u_[r] / h) * slip[r];
    // The strength shared along the force's direction (a friction ellipse; a row never gets
    // less than 0.3 of it, so a new demand across the force can still be met).
    bound[r] = capacity * (has_direction ? std::max(std::abs(force[r]) / magnitude, 0.3) : 1.0);
  }
  ct.surface.mu = bound[0];
  ct.surface.mu2 = bound[1];
  ct.surface.slip1 = slip[0];
  ct.surface.slip2 = slip[1];
  ct.surface.motion1 = motion[0];
  ct.surface.motion2 = motion[1];
  if (!std::isfinite(slip[0]) || !std::isfinite(slip[1]) || !std::isfinite(motion[0]) || !std::isfinite(motion[1]))
  {
    fault = true;
    reset();
    return false;
  }
  const dJointID joint = dJointCreateContact(world, contacts, &ct);
  dJointAttach(joint, body, nullptr);
  dJointSetFeedback(joint, feedback);

  active_ = true;
  t1_ = frame.t1;
  t2_ = frame.t2;
  keepLoads(soil, soil_normal, on_firm ? firm.surface : nullptr, firm_normal, firm_spec);
  return true;
}

void GroundContact::soilShear(const terrain::ContactForces& soil, Eigen::Vector2d& force, Eigen::Vector2d& stiffness,
                              double& capacity) const
{
  const double du = decayed_.norm();
  force = Eigen::Vector2d(soil.longitudinal_force, soil.lateral_force);
  capacity = soil.shear_strength;
  // N/m of displacement, along it: through the slip (-u / l) and the cap (|u|); at u = 0 the
  // lesser of the two limits (the soil displaced by s x, or all of it by |u|).
  const double magnitude = force.norm();
  const double through_slip = soil.shear_slope / std::max(shear_length_, kMinShearLength);
  const double radial =
      du > 1e-12 ? through_slip + soil.shear_cap_slope
                 : (soil.shear_cap_slope > 0.0 ? std::min(through_slip, soil.shear_cap_slope) : through_slip);
  const double transverse = du > 1e-12 ? magnitude / du : radial;
  for (int r = 0; r < 2; ++r)
  {
    const double along = du > 1e-12 ? decayed_[r] * decayed_[r] / (du * du) : 1.0;
    stiffness[r] = radial * along + transverse * (1.0 - along);
  }
}

void GroundContact::keepLoads(const terrain::ContactForces& soil, double soil_normal,
                              const terrain::SoilParameters* firm_surface, double firm_normal,
                              const FirmGroundSpec& firm_spec)
{
  const bool on_firm = firm_surface != nullptr;
  const double f_n = soil_normal + firm_normal;
  normal_ = f_n;
  firm_normal_ = firm_normal;
  resistance_ = (soil_normal > 0.0 ? soil.resistance_force : 0.0) +
                (on_firm ? firm_surface->rolling_resistance * firm_normal : 0.0);
  // Relaxation lengths for the next step: the soil's loaded length, a tyre's own, by load.
  if (soil_normal > 0.0)
    soil_length_ = std::max(soil.contact_length, kMinRelaxationLength);
  relaxation_ = (soil_normal * (soil_normal > 0.0 ? soil_length_ : 0.0) +
                 firm_normal * (on_firm ? firm_spec.relaxation_length : 0.0)) /
                f_n;
  limit_ = std::max(soil_normal > 0.0 ? soil_length_ : 0.0, on_firm ? firm_spec.relaxation_length : 0.0);
}

void GroundContact::finish(const Eigen::Vector3d& point_velocity)
{
  if (!active_)
    return;
  const Eigen::Vector2d v(point_velocity.dot(t1_), point_velocity.dot(t2_));
  const Eigen::Vector2d moved = decay_ * step_ * v;
  // Sliding: the contact point moves over the ground faster than its elastic hold could let
  // it (a skid, a spinning or locked wheel), not the micro-motion of a contact at rest.
  constexpr double kSlidingSpeed = 0.05;  // m/s
  if (v.norm() > kSlidingSpeed)
    sliding_ = true;
  if (unloading_)
  {
    // Elastic about the reversal point (Masing-like): back and forth on the elastic slope, so
    // a contact that holds after a slide neither springs back by its slip nor ratchets; past
    // the reversal point forwards, or down to its elastic part, it is on the curve again.
    back_ += moved;
    if (back_.dot(reversal_) >= 0.0)
    {
      u_ = reversal_ + back_;
      unloading_ = false;
    }
    else
    {
      u_ = reversal_ + gain_ * back_;
      if (u_.norm() <= elastic_ || u_.dot(reversal_) <= 0.0)
        unloading_ = sliding_ = false;
    }
  }
  else if (sliding_ && travel_speed_ < kShearRenewalSpeed && moved.dot(decayed_) < 0.0 && decayed_.norm() > elastic_ &&
           k_along_ > 0.0 && k_elastic_ > k_along_)
  {
    // A slid contact that has (nearly) stopped moves back: most of its displacement is
    // plastic (the soil has failed, the tread has slid), so it unloads on the elastic slope
    // k_elastic, stiffer than the curve's k_along there: the curve's coordinate moves
    // k_elastic / k_along times as far, the force staying continuous. A braked vehicle that
    // skids to a stop then springs back by force / k_elastic (1-5 cm), not by its whole slip.
    unloading_ = true;
    reversal_ = decayed_;
    back_ = moved;
    gain_ = k_elastic_ / k_along_;
    u_ = reversal_ + gain_ * back_;
  }
  else
  {
    u_ = decayed_ + moved;
  }
  const double magnitude = u_.norm();
  if (magnitude > limit_)
  {
    u_ *= limit_ / magnitude;  // full slip: the displacement of a sliding contact
    sliding_ = true;
    unloading_ = false;
  }
}

namespace
{
/// m: a hull plate this far above the ground under its lowest corner is not in contact.
constexpr double kHullClearanceCheck = 0.05;
/// Steel (or aluminium) belly plates on pavement: Coulomb friction about 0.5 (an assumption; the
/// common tables give 0.4-0.6 for metal on concrete), stiff (5 mm under the whole weight).
constexpr double kHullFriction = 0.5;
constexpr double kHullDeflectionUnderWeight = 0.005;
}  // namespace

HullContact::HullContact(const VehicleModel& model, const Eigen::Vector3d& chassis_com)
  : chassis_com_(chassis_com), total_mass_(model.total_mass)
{
  for (const CollisionBox& box : model.collision_boxes)
  {
    const Eigen::Matrix3d r = box.pose.linear();
    const Eigen::Vector3d bottom = box.pose.translation() - 0.5 * box.size.z() * r.col(2);
    const int along = std::max(1, static_cast<int>(std::lround(box.size.x() / 1.0)));
    for (int a = 0; a < along; ++a)
      for (int b = 0; b < 2; ++b)
      {
        BellyPlate p;
        p.length = box.size.x() / along;
        p.width = 0.5 * box.size.y();
        p.along = r.col(0);
        p.across = r.col(1);
        p.up = r.col(2);
        p.centre = bottom + (-0.5 * box.size.x() + (a + 0.5) * p.length) * p.along +
                   (b == 0 ? -0.25 : 0.25) * box.size.y() * p.across;
        plates_.push_back(p);
      }
  }
  firm_.vertical_stiffness =
      model.total_mass * 9.81 / kHullDeflectionUnderWeight / std::max<std::size_t>(1, plates_.size());
  firm_.longitudinal_stiffness = 30.0;
  firm_.cornering_stiffness = 30.0;
  firm_.relaxation_length = 0.5;
  steel_.name = "steel on pavement";
  steel_.model = terrain::SinkageModel::kRigid;
  steel_.friction_peak = kHullFriction;
  steel_.friction_sliding = kHullFriction;
}

void HullContact::beforeStep(dWorldID world, dJointGroupID contacts, dBodyID chassis,
                             terrain::DeformableTerrain& terrain, const WorldOptions& options, StepTimes* times,
                             std::vector<std::string>& warnings, const std::string& vehicle)
{
  normal_ = 0.0;
  const Eigen::Matrix3d r = rotationOf(chassis);
  const Eigen::Vector3d x = vec(dBodyGetPosition(chassis));
  const Eigen::Vector3d base = x - r * chassis_com_;  // base_link origin
  for (BellyPlate& p : plates_)
  {
    p.contact = false;
    const Eigen::Vector3d centre = base + r * p.centre;
    const Eigen::Vector3d up = r * p.up, along = r * p.along, across = r * p.across;
    if (up.z() < 0.25)
    {
      p.ground.reset();  // the hull on its side or roof: not a belly any more
      continue;
    }
    // Cheap rejection: the plate's lowest corner well above the ground there.
    double lowest = std::numeric_limits<double>::infinity();
    for (const double su : { -0.5, 0.5 })
      for (const double sv : { -0.5, 0.5 })
      {
        const Eigen::Vector3d c = centre + su * p.length * along + sv * p.width * across;
        if (const auto g = terrain.height(c.x(), c.y()))
          lowest = std::min(lowest, c.z() - *g);
      }
    if (!(lowest < kHullClearanceCheck))
    {
      p.ground.reset();
      continue;
    }
    Plate plate;
    plate.centre = centre;
    plate.along = along;
    plate.face_normal = up;
    plate.length = p.length;
    plate.width = p.width;
    plate.body_mass = total_mass_;
    plate.mass_share = total_mass_ / plates_.size();
    plate.resisted_mass = total_mass_;
    plate.firm_surface = &steel_;
    bool fault = false;
    p.contact =
        plateContact(world, contacts, chassis, plate, firm_, terrain, options, times, p.ground, &p.feedback, fault);
    if (fault && !p.fault_reported)
    {
      p.fault_reported = true;
      warnings.push_back("vehicle '" + vehicle +
                         "': a hull plate's ground contact gave a non-finite force; it was left out of that step "
                         "(reported once)");
    }
    if (!p.contact)
      continue;
    p.point = centre;
    normal_ += p.ground.normalForce();
  }
}

bool plateContact(dWorldID world, dJointGroupID contacts, dBodyID body, const Plate& plate,
                  const FirmGroundSpec& firm_spec, terrain::DeformableTerrain& terrain, const WorldOptions& options,
                  StepTimes* times, GroundContact& ground, dJointFeedback* feedback, bool& fault,
                  terrain::ContactForces* soil_out)
{
  const double h = options.step;
  const Eigen::Vector3d& centre = plate.centre;
  dVector3 pv;
  dBodyGetPointVel(body, centre.x(), centre.y(), centre.z(), pv);
  const Eigen::Vector3d velocity = vec(pv);
  Eigen::Vector3d forward(plate.along.x(), plate.along.y(), 0.0);
  if (forward.norm() < 1e-6)
    return false;
  forward.normalize();
  ContactFrame frame;
  // A pad lying on the ground takes the ground's slope from beyond its own rut (its walls
  // would tilt it); a hull plate from its edges, as before.
  const double margin = plate.face_normal ? 0.0 : plate.firm_radius;
  frame.normal = groundNormal(terrain, centre, forward, 0.5 * plate.length + margin, 0.5 * plate.width + margin);
  frame.t1 = (forward - forward.dot(frame.normal) * frame.normal).normalized();
  frame.t2 = frame.normal.cross(frame.t1);
  frame.point = centre;
  frame.point_velocity = velocity;
  terrain::TrackPatch patch;
  patch.centre = centre;
  patch.heading = std::atan2(forward.y(), forward.x());
  patch.length = plate.length;
  patch.width = plate.width;
  patch.sprocket_pitch = 1.0;  // no sprocket: a plate sliding over the ground
  patch.sprocket_teeth = 1;
  patch.sprocket_spin_rate = 0.0;
  patch.velocity = velocity;
  patch.normal = plate.face_normal ? *plate.face_normal : frame.normal;
  patch.shear_slip = ground.prepare(velocity.dot(frame.t1), 0.0, h);
  patch.shear_slip_given = true;
  patch.shear_cap = ground.shearCap();
  patch.travel = ground.travel();
  const auto start = times ? Clock::now() : Clock::time_point();
  const terrain::ContactForces soil = terrain.trackContact(patch, h, options.deform_terrain);
  if (times)
    times->contact += seconds(start, Clock::now());
  if (soil_out)
    *soil_out = soil;
  FirmContact firm;
  if (plate.firm_surface)
  {
    if (soil.rigid_soil >= 0 && soil.rigid_share > 0.0)
    {
      firm.surface = plate.firm_surface;
      firm.share = soil.rigid_share;
      if (const auto g = terrain.height(centre.x(), centre.y()))
        firm.depth = (*g - centre.z()) * frame.normal.z();
    }
  }
  else
  {
    firm = firmContact(terrain, soil, centre + plate.firm_radius * frame.normal, plate.firm_radius, frame.normal);
  }
  if (!ground.addJoint(world, contacts, body, plate.body_mass, plate.mass_share, frame, soil, firm, firm_spec, options,
                       feedback, fault))
    return false;
  // Compaction and bulldozing ahead of the plate, where it acts (not at the centre of mass).
  const double fade = std::max(kResistanceFadeSpeed, h * ground.resistance() / plate.resisted_mass);
  const double push = -ground.resistance() * std::clamp(velocity.dot(frame.t1) / fade, -1.0, 1.0);
  dBodyAddForceAtPos(body, push * frame.t1.x(), push * frame.t1.y(), push * frame.t1.z(), centre.x(), centre.y(),
                     centre.z());
  return true;
}

void HullContact::afterStep(dBodyID chassis, bool stepped)
{
  if (!stepped)
    return;
  for (BellyPlate& p : plates_)
  {
    if (!p.contact)
      continue;
    dVector3 pv;
    dBodyGetPointVel(chassis, p.point.x(), p.point.y(), p.point.z(), pv);
    p.ground.finish(vec(pv));
  }
}

void ResistanceMotor::set(dWorldID world, dBodyID body, double resistance, const Eigen::Vector3d& t1, double cfm)
{
  if (!(resistance > 0.0))
  {
    off();
    return;
  }
  if (!motor_)
  {
    motor_ = dJointCreateLMotor(world, nullptr);
    dJointAttach(motor_, body, nullptr);
    dJointSetLMotorNumAxes(motor_, 1);
    dJointSetLMotorParam(motor_, dParamVel, 0.0);
    dJointSetFeedback(motor_, &feedback_);
  }
  dJointEnable(motor_);
  on_ = true;
  dJointSetLMotorAxis(motor_, 0, 0, t1.x(), t1.y(), t1.z());
  dJointSetLMotorParam(motor_, dParamFMax, resistance);
  dJointSetLMotorParam(motor_, dParamCFM, cfm);
}

void ResistanceMotor::off()
{
  if (motor_)
    dJointDisable(motor_);
  on_ = false;
}

double ResistanceMotor::applied(const Eigen::Vector3d& t1) const
{
  return on_ ? vec(feedback_.f1).dot(t1) : 0.0;
}

}  // namespace sim
}  // namespace dynamics
}  // namespace avsp
