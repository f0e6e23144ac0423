#include "avsp_dynamics/dem/wheel_rig.hpp"

#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include <ode/ode.h>

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace
{
constexpr double kGravity = 9.81;  // m/s^2, as DemWorld and the ODE vehicles
/// N: the motors' force and torque limit when they hold a speed: far above any soil force, so
/// the speed is held exactly (a rig's carriage and drive are stiff).
constexpr double kHold = 1e7;
}  // namespace

struct SingleWheelRig::Ode
{
  dWorldID world = nullptr;
  dBodyID wheel = nullptr;
  dJointID line = nullptr;  ///< linear motor: y velocity 0; x velocity held or free
  dJointID axle = nullptr;  ///< angular motor: no rotation about x and z; y spin held or free
  ~Ode()
  {
    if (world)
      dWorldDestroy(world);  // destroys its bodies and joints
  }
};

double bedSurface(const DemWorld& world, double x, double y, double length, double width)
{
  const auto particles = world.particles();
  const double step = maxRadius(world.parameters());
  double sum = 0.0;
  int n = 0;
  for (double u = x - 0.5 * length; u <= x + 0.5 * length + 1e-12; u += step)
    for (double v = y - 0.5 * width; v <= y + 0.5 * width + 1e-12; v += step)
    {
      const double h = surfaceProbe(particles, u, v, 0.5 * step);
      if (std::isfinite(h))
      {
        sum += h;
        ++n;
      }
    }
  if (n == 0)
    return -std::numeric_limits<double>::infinity();
  return sum / n - world.bed().surfaceBias();
}

SingleWheelRig::SingleWheelRig(DemWorld& world, const WheelRigSpec& spec, double x)
  : world_(world), spec_(spec), ode_(std::make_unique<Ode>())
{
  auto positive = [](const char* key, double v) {
    if (!std::isfinite(v) || v <= 0.0)
      throw DemParameterError(std::string("dem.rig.") + key + ": must be a finite number > 0 (got " +
                              std::to_string(v) + ")");
  };
  positive("radius", spec.radius);
  positive("width", spec.width);
  positive("load", spec.load);
  if (spec.facets < 12)
    throw DemParameterError("dem.rig.facets: at least 12 flat faces round the rim (got " + std::to_string(spec.facets) +
                            ")");
  const auto& d = world.domain();
  const double y = 0.5 * (d.y_min + d.y_max);
  ground_ = bedSurface(world, x, y, spec.radius, spec.width);
  const double outer = spec.radius + (spec.grousers > 0 ? spec.grouser_height : 0.0);
  const double top = world.highestTop(x - outer, x + outer, y - 0.5 * spec.width, y + 0.5 * spec.width);
  const Eigen::Vector3d centre(x, y, top + 0.002 + outer);
  body_ = world.addBody(wheelMesh(centre, Eigen::Vector3d::UnitY(), spec.radius, spec.width, spec.facets, spec.grousers,
                                  spec.grouser_height),
                        centre, Eigen::Vector3d::UnitY());
  world.setBodyVelocity(body_, Eigen::Vector3d(0, 0, -0.1), 0.0);
  for (int k = 0; k < 2000 && world.load(body_).force.z() < spec.load; ++k)
    world.step();
  world.setBodyVelocity(body_, Eigen::Vector3d::Zero(), 0.0);

  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
  ode_->world = dWorldCreate();
  dWorldSetGravity(ode_->world, 0, 0, -kGravity);
  ode_->wheel = dBodyCreate(ode_->world);
  dMass m;
  // A solid cylinder about y (ODE's direction 2) whose weight is the load.
  dMassSetCylinderTotal(&m, spec.load / kGravity, 2, spec.radius, spec.width);
  dBodySetMass(ode_->wheel, &m);
  const Eigen::Vector3d placed = world.load(body_).reference;
  dBodySetPosition(ode_->wheel, placed.x(), placed.y(), placed.z());
  dBodySetFiniteRotationMode(ode_->wheel, 1);
  dBodySetFiniteRotationAxis(ode_->wheel, 0, 1, 0);

  ode_->line = dJointCreateLMotor(ode_->world, nullptr);
  dJointAttach(ode_->line, ode_->wheel, nullptr);
  dJointSetLMotorNumAxes(ode_->line, 2);
  dJointSetLMotorAxis(ode_->line, 0, 0, 1, 0, 0);
  dJointSetLMotorAxis(ode_->line, 1, 0, 0, 1, 0);
  dJointSetLMotorParam(ode_->line, dParamFMax, 0.0);
  dJointSetLMotorParam(ode_->line, dParamVel2, 0.0);
  dJointSetLMotorParam(ode_->line, dParamFMax2, kHold);

  ode_->axle = dJointCreateAMotor(ode_->world, nullptr);
  dJointAttach(ode_->axle, ode_->wheel, nullptr);
  dJointSetAMotorMode(ode_->axle, dAMotorUser);
  dJointSetAMotorNumAxes(ode_->axle, 3);
  dJointSetAMotorAxis(ode_->axle, 0, 0, 1, 0, 0);
  dJointSetAMotorAxis(ode_->axle, 1, 0, 0, 1, 0);
  dJointSetAMotorAxis(ode_->axle, 2, 0, 0, 0, 1);
  dJointSetAMotorParam(ode_->axle, dParamVel, 0.0);
  dJointSetAMotorParam(ode_->axle, dParamFMax, kHold);
  dJointSetAMotorParam(ode_->axle, dParamFMax2, 0.0);
  dJointSetAMotorParam(ode_->axle, dParamVel3, 0.0);
  dJointSetAMotorParam(ode_->axle, dParamFMax3, kHold);
  state_.centre = placed;
  state_.sinkage = ground_ - (placed.z() - spec.radius);
}

SingleWheelRig::~SingleWheelRig() = default;

void SingleWheelRig::setCarriageSpeed(double v)
{
  dJointSetLMotorParam(ode_->line, dParamVel, std::isnan(v) ? 0.0 : v);
  dJointSetLMotorParam(ode_->line, dParamFMax, std::isnan(v) ? 0.0 : kHold);
}

void SingleWheelRig::setSpinRate(double omega)
{
  dJointSetAMotorParam(ode_->axle, dParamVel2, std::isnan(omega) ? 0.0 : omega);
  dJointSetAMotorParam(ode_->axle, dParamFMax2, std::isnan(omega) ? 0.0 : kHold);
}

void SingleWheelRig::step()
{
  const double h = world_.parameters().coupling_interval;
  const dReal* p = dBodyGetPosition(ode_->wheel);
  const dReal* v = dBodyGetLinearVel(ode_->wheel);
  const dReal* w = dBodyGetAngularVel(ode_->wheel);
  // The mesh moves at the body's velocity plus what closes the gap between the two over the
  // interval (rounding, and the ODE step's own velocity change last interval), so the DEM's
  // wheel stays where ODE's is.
  const Eigen::Vector3d ode_centre(p[0], p[1], p[2]);
  const Eigen::Vector3d mesh_centre = world_.load(body_).reference;
  world_.setBodyVelocity(body_, Eigen::Vector3d(v[0], v[1], v[2]) + (ode_centre - mesh_centre) / h, w[1]);
  world_.step();
  state_.soil = world_.load(body_);
  dBodyAddForce(ode_->wheel, state_.soil.force.x(), state_.soil.force.y(), state_.soil.force.z());
  dBodyAddTorque(ode_->wheel, state_.soil.torque.x(), state_.soil.torque.y(), state_.soil.torque.z());
  dRandSetSeed(0);  // the solver's only random input: fixed, so a run repeats bit for bit
  dWorldStep(ode_->world, h);

  const dReal* p1 = dBodyGetPosition(ode_->wheel);
  const dReal* v1 = dBodyGetLinearVel(ode_->wheel);
  const dReal* w1 = dBodyGetAngularVel(ode_->wheel);
  state_.centre = Eigen::Vector3d(p1[0], p1[1], p1[2]);
  state_.velocity = Eigen::Vector3d(v1[0], v1[1], v1[2]);
  state_.spin_rate = w1[1];
  state_.sinkage = ground_ - (state_.centre.z() - spec_.radius);
  const double vt = state_.spin_rate * spec_.radius;
  state_.slip = vt > 1e-9 ? 1.0 - state_.velocity.x() / vt : 0.0;
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
