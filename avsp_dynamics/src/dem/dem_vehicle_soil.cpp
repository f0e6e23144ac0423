#include "avsp_dynamics/dem/dem_vehicle_soil.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <limits>
#include <string>

#include <Eigen/Geometry>

#include "parameter_error.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace
{
using detail::fail;
using detail::str;

/// A patch is made when its side's front wheel is this far (m) from touching the segment.
constexpr double kLead = 0.05;

}  // namespace

struct DemVehicleSoil::Side
{
  std::vector<std::size_t> wheels;  ///< indices into the vehicle's wheels, front (largest x) first
  double y_mid = 0.0;               ///< m, the strip's centre line
  double length = 0.0;              ///< m, front wheel's x - rear wheel's x at the first step
  double radius = 0.0;              ///< m, the side's largest wheel radius
  std::unique_ptr<MovingPatch> patch;
  std::vector<int> bodies;             ///< DEM body of each wheel, as `wheels`
  std::vector<Eigen::Vector3d> axles;  ///< each wheel's axle when it came on
  bool done = false;
};

DemVehicleSoil::DemVehicleSoil(BedTemplate bed, terrain::DeformableTerrain& terrain, const DemSegmentSpec& spec)
  : bed_(std::move(bed)), terrain_(terrain), spec_(spec)
{
  checkSegment(spec, bed_.length());
}

DemVehicleSoil::~DemVehicleSoil() = default;

std::size_t DemVehicleSoil::activePatches() const
{
  return static_cast<std::size_t>(
      std::count_if(sides_.begin(), sides_.end(), [](const auto& s) { return !!s->patch; }));
}

std::size_t DemVehicleSoil::particleCount() const
{
  std::size_t n = 0;
  for (const auto& s : sides_)
    if (s->patch)
      n += s->patch->world().particleCount();
  return n;
}

double DemVehicleSoil::share(double x, double r) const
{
  // The part of the wheel's diameter over the bed: 0 at x_min - r, 1 from x_min + r to
  // x_max - r, 0 again at x_max + r (the contact patch is about the wheel's centre).
  const double on = std::clamp((x - (spec_.x_min - r)) / (2.0 * r), 0.0, 1.0);
  const double off = std::clamp(((spec_.x_max + r) - x) / (2.0 * r), 0.0, 1.0);
  return std::min(on, off);
}

void DemVehicleSoil::buildSides(const std::vector<WheelKinematics>& wheels)
{
  const double rmax = maxRadius(bed_.parameters());
  const double half = 0.5 * bed_.width();
  std::vector<std::size_t> order(wheels.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return wheels[a].centre.y() < wheels[b].centre.y(); });
  for (std::size_t k = 0; k < order.size(); ++k)
  {
    if (k == 0 || wheels[order[k]].centre.y() - wheels[order[k - 1]].centre.y() > half)
      sides_.push_back(std::make_unique<Side>());
    sides_.back()->wheels.push_back(order[k]);
  }
  double previous_top = -std::numeric_limits<double>::infinity();
  for (auto& s : sides_)
  {
    std::stable_sort(s->wheels.begin(), s->wheels.end(),
                     [&](std::size_t a, std::size_t b) { return wheels[a].centre.x() > wheels[b].centre.x(); });
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t i : s->wheels)
    {
      const auto& w = wheels[i];
      lo = std::min(lo, w.centre.y() - 0.5 * w.width);
      hi = std::max(hi, w.centre.y() + 0.5 * w.width);
      s->radius = std::max(s->radius, w.radius);
    }
    s->y_mid = 0.5 * (lo + hi);
    if (hi - lo > bed_.width() - 4.0 * rmax)
      fail("template_width", "the wheels of a side span " + str(hi - lo) + " m across (wheel '" +
                                 wheels[s->wheels.front()].name + "'): a strip " + str(bed_.width()) +
                                 " m wide leaves less than two particle radii to each wall");
    if (s->y_mid - half < previous_top)
      fail("template_width", "strips " + str(bed_.width()) + " m wide round the vehicle's sides overlap (wheel '" +
                                 wheels[s->wheels.front()].name + "'): settle a narrower template");
    previous_top = s->y_mid + half;
    s->length = wheels[s->wheels.front()].centre.x() - wheels[s->wheels.back()].centre.x();
    // After a move the side's rear wheel must still be on the bed, clear of its rear wall.
    const double need = bed_.length() + spec_.front_margin + s->length + s->radius + 2.0 * rmax;
    if (spec_.patch_length < need - 1e-9)
      fail("patch.length", str(spec_.patch_length) + " m cannot hold a side's wheels (" + str(s->length) +
                               " m apart, radius " + str(s->radius) + " m): needs at least " + str(need) +
                               " m (a template length + front_margin + the wheels' spread + radius + two "
                               "particle radii)");
  }
  sides_built_ = true;
}

void DemVehicleSoil::startSide(Side& s, const std::vector<WheelKinematics>& wheels)
{
  for (std::size_t i : s.wheels)
    if (share(wheels[i].centre.x(), wheels[i].radius) > 0.0)
      fail("segment.x_min", "wheel '" + wheels[i].name + "' is on the segment (x = " + str(wheels[i].centre.x()) +
                                " m) before its patch was made: start the vehicle before x_min - radius - " +
                                str(kLead) + " m");
  PatchSpec p;
  p.x_start = spec_.x_min;
  p.x_end = spec_.x_max;
  p.y_min = s.y_mid - 0.5 * bed_.width();
  p.length = spec_.patch_length;
  p.front_margin = spec_.front_margin;
  p.clearance = 2.0 * s.radius + 0.2;
  // Room for the side's wheels while the patch lives: from when its front wheel is kLead from
  // the bed until its rear wheel has left it, with a step's travel to spare.
  p.domain_before = s.length + 2.0 * s.radius + kLead + 0.1;
  p.domain_after = s.length + 2.0 * s.radius + 0.1;
  s.patch = std::make_unique<MovingPatch>(bed_, terrain_, p);
  s.patch->world().settle(spec_.settle_time);
  for (std::size_t i : s.wheels)
  {
    const auto& w = wheels[i];
    try
    {
      s.bodies.push_back(
          s.patch->world().addBody(wheelMesh(w.centre, w.axle, w.radius, w.width, spec_.facets), w.centre, w.axle));
    }
    catch (const DemParameterError& e)
    {
      fail("segment", "wheel '" + w.name + "' does not fit in the DEM domain (" + e.what() +
                          "): the ground before or after the segment lies outside the bed's height range");
    }
    s.axles.push_back(w.axle);
  }
}

void DemVehicleSoil::runSide(Side& s, double step, const std::vector<WheelKinematics>& wheels,
                             std::vector<ExternalWheelLoad>& loads)
{
  DemWorld& world = s.patch->world();
  const double ci = world.parameters().coupling_interval;
  const long intervals = std::lround(step / ci);
  if (intervals < 1 || std::abs(intervals * ci - step) > 1e-9 * step)
    fail("coupling_interval",
         str(ci) + " s: the vehicle's step (" + str(step) + " s) must be a whole number of coupling intervals");
  const double half = 0.5 * bed_.width() - 2.0 * maxRadius(bed_.parameters());
  const double cos_max = std::cos(spec_.max_yaw_deg * M_PI / 180.0);
  for (std::size_t k = 0; k < s.wheels.size(); ++k)
  {
    const auto& w = wheels[s.wheels[k]];
    if (std::abs(w.centre.y() - s.y_mid) + 0.5 * w.width > half)
      fail("segment", "wheel '" + w.name + "' left its DEM strip sideways (y = " + str(w.centre.y()) +
                          " m, strip centre " + str(s.y_mid) + " m): cross the segment along +x");
    if (w.axle.dot(s.axles[k]) < cos_max)
      fail("patch.max_yaw_deg", "wheel '" + w.name + "' turned more than " + str(spec_.max_yaw_deg) +
                                    " deg on the DEM segment (its mesh keeps the axle it came on with)");
    // The mesh moves at the wheel's velocity plus what closes the gap to ODE's wheel over the
    // step, so the DEM's wheel stays where ODE's is (as SingleWheelRig).
    const Eigen::Vector3d gap = w.centre - world.load(s.bodies[k]).reference;
    world.setBodyVelocity(s.bodies[k], w.velocity + gap / step, w.angular_velocity.dot(s.axles[k]));
  }
  std::vector<Eigen::Vector3d> force(s.wheels.size(), Eigen::Vector3d::Zero()), torque = force;
  for (long n = 0; n < intervals; ++n)
  {
    world.step();
    for (std::size_t k = 0; k < s.wheels.size(); ++k)
    {
      const BodyLoad l = world.load(s.bodies[k]);
      force[k] += l.force / static_cast<double>(intervals);
      torque[k] += l.torque / static_cast<double>(intervals);
    }
  }
  report_.coupling_intervals += static_cast<std::uint64_t>(intervals);
  for (std::size_t k = 0; k < s.wheels.size(); ++k)
  {
    const std::size_t i = s.wheels[k];
    const auto& w = wheels[i];
    ExternalWheelLoad& out = loads[i];
    out.share = share(w.centre.x(), w.radius);
    out.force = force[k];
    out.torque = torque[k];
    // Sinkage below the ground the patch was cut to (the terrain is written only behind), in
    // the terrain's convention: the rim rests on the particles' tops, which stand the
    // template's surface bias above the ground on undisturbed soil (writeBack subtracts it).
    const auto ground = terrain_.height(w.centre.x(), w.centre.y());
    out.sinkage = ground ? *ground + bed_.surfaceBias() - (w.centre.z() - w.radius) : 0.0;
    const Eigen::Vector3d forward = s.axles[k].cross(Eigen::Vector3d::UnitZ()).normalized();
    const double vt = w.angular_velocity.dot(s.axles[k]) * w.radius;
    out.slip = vt > 1e-9 ? 1.0 - w.velocity.dot(forward) / vt : 0.0;
    report_.energy -= (force[k].dot(w.velocity) + torque[k].dot(w.angular_velocity)) * step;
    if (out.share >= 1.0)
    {
      sinkage_sum_ += out.sinkage;
      slip_sum_ += out.slip;
      ++carried_;
      report_.max_sinkage = std::max(report_.max_sinkage, out.sinkage);
    }
  }
}

void DemVehicleSoil::advance(double time, double step, const std::vector<WheelKinematics>& wheels,
                             std::vector<ExternalWheelLoad>& loads)
{
  if (!sides_built_)
    buildSides(wheels);
  for (auto& side : sides_)
  {
    Side& s = *side;
    if (s.done)
      continue;
    const auto& front = wheels[s.wheels.front()];
    if (!s.patch && front.centre.x() + front.radius + kLead >= spec_.x_min)
      startSide(s, wheels);
    if (!s.patch)
      continue;
    if (s.patch->follow(front.centre.x()))
      ++report_.relocations;
    const auto& rear = wheels[s.wheels.back()];
    if (rear.centre.x() - rear.radius > spec_.x_max)
    {
      // The side has crossed: its bed's surface into the terrain, its particles freed.
      s.patch->finish();
      report_.points_written += s.patch->pointsWritten();
      s.patch.reset();
      s.done = true;
      continue;
    }
    runSide(s, step, wheels, loads);
    for (std::size_t i : s.wheels)
      if (loads[i].share > 0.0 && report_.entered < 0.0)
        report_.entered = time;
  }
  report_.peak_particles = std::max(report_.peak_particles, particleCount());
  report_.crossed = !sides_.empty() && std::all_of(sides_.begin(), sides_.end(), [](const auto& s) { return s->done; });
  if (report_.crossed && report_.left < 0.0)
    report_.left = time;
  if (carried_ > 0)
  {
    report_.mean_sinkage = sinkage_sum_ / static_cast<double>(carried_);
    report_.mean_slip = slip_sum_ / static_cast<double>(carried_);
  }
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
