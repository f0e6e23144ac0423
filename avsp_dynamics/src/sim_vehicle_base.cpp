#include "sim_vehicle_base.hpp"

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
  return (Eigen::Vector3d::UnitZ() - slope_fwd * forward - slope_left * left).normalized();
}

dJointID addSoilJoint(dWorldID world, dJointGroupID contacts, dBodyID body, double mass, const ContactFrame& frame,
                      const terrain::ContactForces& soil, double stiffness, double min_slip,
                      const WorldOptions& options, dJointFeedback* feedback, bool normal_spring)
{
  const double h = options.step;
  const double f_n = soil.normal_force;
  const double kp = std::max({ stiffness, f_n / kMaxVirtualDepth, 1e3 });
  const double kd = 2.0 * options.contact_damping_ratio * std::sqrt(kp * mass);

  dContact ct{};
  ct.surface.mode = dContactSoftERP | dContactSoftCFM | dContactMu2 | dContactFDir1 | dContactSlip1 | dContactSlip2;
  // Normal row = implicit spring (kp) + damper (kd) whose force at the current state is the
  // soil's: depth = F / kp. Stiff soils (asphalt) stay stable at any step: the solver takes
  // the stiffness implicitly instead of the step overshooting it.
  if (normal_spring)
  {
    ct.surface.soft_erp = h * kp / (h * kp + kd);
    ct.surface.soft_cfm = 1.0 / (h * kp + kd);
    ct.geom.depth = f_n / kp;
  }
  else
  {
    // Inert: no push-out, and a compliance so large the row can only take a force of the
    // order of 1e-3 N per m/s of approach (the exact solver needs its matrix regular).
    ct.surface.soft_erp = 0.0;
    ct.surface.soft_cfm = 1e3;
    ct.geom.depth = 0.0;
  }
  for (int a = 0; a < 3; ++a)
  {
    ct.geom.pos[a] = frame.point[a];
    ct.geom.normal[a] = frame.normal[a];
    ct.fdir1[a] = frame.t1[a];
  }
  // Friction rows: force-dependent slip v = slip * F reproduces the soil's force at the
  // current slip velocity (slip = |v| / |F|) and, being implicit, can only bring the slip
  // velocity towards zero within the step, never across it; the bound |F| keeps the row
  // from giving more than the soil does at this slip (T7's limit). The row takes the soil's
  // magnitude and always opposes the contact's sliding: shear on a wheel never pushes along
  // the slip (at near-zero or reversing speeds T8's sign is ill-conditioned; applied as an
  // explicit force it fed the wheel's spin back on itself within a few steps).
  const double soil_force[2] = { soil.longitudinal_force, soil.lateral_force };
  const Eigen::Vector3d dirs[2] = { frame.t1, frame.t2 };
  double bound[2] = { 0.0, 0.0 }, slip[2] = { 0.0, 0.0 };
  for (int r = 0; r < 2; ++r)
  {
    // A row bounded by a force far below the load (rounding, no slip) is left out: its
    // [-bound, bound] box is degenerate for the exact LCP solver.
    bound[r] = std::abs(soil_force[r]) > 1e-6 * f_n ? std::abs(soil_force[r]) : 0.0;
    if (bound[r] > 0.0)
      slip[r] = std::abs(frame.point_velocity.dot(dirs[r])) / bound[r];
  }
  ct.surface.mu = bound[0];
  ct.surface.mu2 = bound[1];
  ct.surface.slip1 = std::max(slip[0], min_slip);
  ct.surface.slip2 = std::max(slip[1], min_slip);
  const dJointID joint = dJointCreateContact(world, contacts, &ct);
  dJointAttach(joint, body, nullptr);
  dJointSetFeedback(joint, feedback);
  return joint;
}

void applyResistance(dBodyID body, double mass, double resistance, const Eigen::Vector3d& t1,
                     const Eigen::Vector3d& velocity, double step)
{
  const double v_travel = velocity.dot(t1);
  const double fade = std::max(kResistanceFadeSpeed, step * resistance / mass);
  const double r_force = -resistance * std::clamp(v_travel / fade, -1.0, 1.0);
  dBodyAddForce(body, r_force * t1.x(), r_force * t1.y(), r_force * t1.z());
}

}  // namespace sim
}  // namespace dynamics
}  // namespace avsp
