#include "avsp_dynamics/mobility.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include <avsp_terrain/agents.hpp>
#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/terramechanics.hpp>
#include <avsp_terrain/yaml_section.hpp>

#include "avsp_dynamics/drivetrain.hpp"
#include "avsp_dynamics/stuck_detector.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

namespace avsp
{
namespace dynamics
{
namespace mobility
{
namespace
{
constexpr double kG = 9.81;
constexpr double kDeg = M_PI / 180.0;
using terrain::SoilParameters;

const std::map<std::string, std::string>& manoeuvreTable()
{
  static const std::map<std::string, std::string> table{
    { "side_slope_hold", "braked across a side slope: horizontal drift over the run (m)" },
    { "side_slope_limit",
      "tilt table, braked across it: the angle it slides or tips at (deg), against min(slide, tip)" },
    { "grade_limit", "full throttle up a grade from rest: the steepest it climbs (deg)" },
    { "plane_hold_uphill", "braked facing up a plane: drift over the run (m)" },
    { "plane_hold_downhill", "braked facing down a plane: drift over the run (m)" },
    { "accel_0_10", "full throttle from rest: time to 10 m/s (s)" },
    { "top_speed", "full throttle: the speed it settles at (m/s)" },
    { "reverse_speed", "full throttle in reverse: the speed it settles at (m/s)" },
    { "braking", "full brake from `speed`: distance to a stop (m)" },
    { "braking_step_spread", "braking at 0.5, 1 and 2 ms steps: largest relative difference from 1 ms" },
    { "turn_radius", "steady turn at `speed` and `steering`: radius of the unsteered axle's path (m)" },
    { "parked_sinkage", "parked 60 s: mean sinkage of the running gear (m)" },
    { "parked_creep", "parked 60 s: chassis sinking from 2 s to 62 s (mm/min)" },
    { "parked_jitter", "parked: chassis height peak to peak over the last 10 s (mm)" },
    { "parked_settle", "parked: last time the chassis moved vertically faster than 1 mm/s (s)" },
    { "drop_settle", "dropped from 0.5 m: time from touchdown to rest (s)" },
    { "wheel_sinkage", "single-wheel rig, towed at its share of the weight: rolling sinkage (m)" },
    { "wheel_resistance", "single-wheel rig, towed: compaction resistance (N)" },
    { "wheel_drawbar", "single-wheel rig at `slip`: drawbar pull coefficient, (traction - resistance) / load" },
    { "agent_push", "a deer walking into the braked vehicle: the vehicle's displacement (m)" },
    { "high_centring", "full throttle into soft ground: 1 if stuck with the hull carrying it" },
  };
  return table;
}

// ------------------------------------------------------------------------------ the world

/// A plane of `soil` centred on the origin: z = gx x + gy y.
std::unique_ptr<terrain::DeformableTerrain> plane(const SoilParameters& soil, double half_x, double half_y, double cell,
                                                  double gx, double gy)
{
  const std::size_t nx = static_cast<std::size_t>(std::lround(2.0 * half_x / cell)) + 1;
  const std::size_t ny = static_cast<std::size_t>(std::lround(2.0 * half_y / cell)) + 1;
  std::vector<float> h(nx * ny);
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx; ++i)
      h[j * nx + i] = static_cast<float>(gx * (-half_x + i * cell) + gy * (-half_y + j * cell));
  return std::make_unique<terrain::DeformableTerrain>(terrain::ElevationGrid(-half_x, -half_y, cell, cell, nx, ny, h),
                                                      soil, terrain::DeformableTerrain::Options{ true });
}

/// base_link at (x, y) with yaw, tilted to the plane (roll, pitch), its running gear `clearance`
/// m above the ground.
Eigen::Isometry3d placeOn(const terrain::DeformableTerrain& t, const VehicleModel& m, double x, double y, double yaw,
                          double roll, double pitch, double clearance)
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  double z = -1e300;
  const double tilt = std::cos(roll) * std::cos(pitch);
  for (const auto& [p, r] : runningGear(m))
  {
    const Eigen::Vector3d q = pose.linear() * p;
    const auto ground = t.height(x + q.x(), y + q.y());
    if (!ground)
      throw std::runtime_error("mobility: the vehicle does not fit on the test ground");
    z = std::max(z, *ground + r / tilt - q.z());
  }
  pose.translation() = Eigen::Vector3d(x, y, z + clearance);
  return pose;
}

double weight(const VehicleModel& m)
{
  return m.total_mass * kG;
}

bool tracked(const VehicleModel& m)
{
  return m.drive_type == DriveType::kTracked;
}

/// m: the lateral distance between the left and right running gear's centres.
double trackWidth(const VehicleModel& m)
{
  double lo = 1e300, hi = -1e300;
  for (const auto& [p, r] : runningGear(m))
  {
    lo = std::min(lo, p.y());
    hi = std::max(hi, p.y());
  }
  return hi - lo;
}

// ------------------------------------------------------------------- closed forms

/// N: the drive's force on the ground at speed v (m/s) at full throttle (forward, or reverse).
double driveForce(const VehicleModel& m, double v, bool reverse = false)
{
  DrivetrainSpec d = m.drivetrain;
  if (reverse)
    d.max_speed = d.reverse_max_speed;
  if (tracked(m))
  {
    const double r = m.track.effectiveSprocketRadius();
    return wheelTorqueAvailable(d, v / r, r) / r;
  }
  const double r = m.wheels[0].radius;
  const double per = wheelTorqueAvailable(d, v / r, r) / r;
  return m.drive_type == DriveType::kSkidSteer ? 2.0 * per : per;
}

/// Janosi-Hanamoto's factor at full slip over a contact of length l: 1 - K/l (1 - e^(-l/K)).
double janosiFullSlip(const SoilParameters& soil, double length)
{
  const double k = soil.shear_modulus;
  return 1.0 - k / length * (1.0 - std::exp(-length / k));
}

/// m: a track's ground contact length.
double trackLength(const VehicleModel& m)
{
  return m.tracks[0].contactLength();
}

/// m: sinkage of a flat plate b x l pressed with load N into Bekker soil (first loading).
double plateSinkage(const SoilParameters& soil, double b, double l, double load)
{
  const double k = soil.k_c / std::min(b, l) + soil.k_phi;
  return std::pow(load / (b * l) / k, 1.0 / soil.n);
}

/// N: each wheel's normal load, standing on a grade theta rising along +x (statics of two axles:
/// the model's centre of mass, its height above the ground with the springs at their preload).
std::vector<double> wheelLoads(const VehicleModel& m, double theta)
{
  double mass = 0.0, x = 0.0, z = 0.0;
  for (const Body& b : m.bodies)
  {
    mass += b.mass;
    x += b.mass * b.com.x();
    z += b.mass * b.com.z();
  }
  x /= mass;
  z /= mass;
  double front = -1e300, rear = 1e300, unsprung = 0.0;
  for (const WheelSpec& w : m.wheels)
  {
    front = std::max(front, w.rest_position.x());
    rear = std::min(rear, w.rest_position.x());
    for (const Body& b : m.bodies)
      if (b.link == w.link)
        unsprung += b.mass;
  }
  const double ground = m.wheels[0].rest_position.z() - m.wheels[0].radius;
  const double h = z - ground - (1.0 - unsprung / mass) * m.suspension.preload_deflection;
  const double w = weight(m);
  const double on_front = front > rear ? (w * std::cos(theta) * (x - rear) - w * std::sin(theta) * h) / (front - rear)
                                       : 0.5 * w * std::cos(theta);
  std::size_t n_front = 0, n_rear = 0;
  for (const WheelSpec& wh : m.wheels)
    (wh.rest_position.x() > 0.5 * (front + rear) ? n_front : n_rear)++;
  std::vector<double> out;
  for (const WheelSpec& wh : m.wheels)
    out.push_back(wh.rest_position.x() > 0.5 * (front + rear) ? on_front / n_front
                                                              : (w * std::cos(theta) - on_front) / n_rear);
  return out;
}

/// N: the soil's (or surface's) resistance to the vehicle rolling forward on a grade theta at
/// speed v, closed forms: a tyre's f N on rigid ground; on soil, Bekker's rolling wheel
/// (rollingWheelOnBekkerSoil at its own load's rollingWheelSinkage), a wheel in the rut of one
/// ahead of it only compacting what it sinks below that rut (multi-pass: the difference of the
/// two compaction resistances; `multipass` false: every wheel on fresh soil), or a track's
/// b k z^(n+1) / (n+1); plus a track's internal resistance.
double resistance(const VehicleModel& m, const SoilParameters& soil, double theta, double v = 0.0,
                  bool multipass = true)
{
  const double normal = weight(m) * std::cos(theta);
  double r = 0.0;
  if (tracked(m))
  {
    r += m.total_mass * kG * (m.track.internal_resistance + m.track.internal_resistance_per_speed * v);
    if (soil.model == terrain::SinkageModel::kRigid)
      return r + soil.rolling_resistance * normal;
    const double b = m.track.shoe_width, l = trackLength(m);
    const double z = plateSinkage(soil, b, l, 0.5 * normal);
    const double k = soil.k_c / std::min(b, l) + soil.k_phi;
    return r + 2.0 * b * k * std::pow(z, soil.n + 1.0) / (soil.n + 1.0);
  }
  if (soil.model == terrain::SinkageModel::kRigid)
    return soil.rolling_resistance * normal;
  const std::vector<double> loads = wheelLoads(m, theta);
  std::vector<double> rut(m.wheels.size()), compaction(m.wheels.size());
  for (std::size_t i = 0; i < m.wheels.size(); ++i)
  {
    const WheelSpec& w = m.wheels[i];
    rut[i] = terrain::rollingWheelSinkage(soil, w.radius, w.width, loads[i]);
    compaction[i] = terrain::rollingWheelOnBekkerSoil(soil, w.radius, w.width, rut[i]).compaction_resistance;
  }
  for (std::size_t i = 0; i < m.wheels.size(); ++i)
  {
    const WheelSpec& w = m.wheels[i];
    // The nearest wheel ahead on the same line, if any.
    std::size_t ahead = i;
    for (std::size_t j = 0; j < m.wheels.size(); ++j)
    {
      const WheelSpec& o = m.wheels[j];
      if (o.rest_position.x() > w.rest_position.x() + 1e-6 &&
          std::abs(o.rest_position.y() - w.rest_position.y()) < 0.5 * std::min(o.width, w.width) &&
          (ahead == i || o.rest_position.x() < m.wheels[ahead].rest_position.x()))
        ahead = j;
    }
    r += ahead == i || !multipass ? compaction[i] : std::max(compaction[i] - compaction[ahead], 0.0);
  }
  return r;
}

/// m^2: the running gear's loaded area on the soil (for the cohesion's share).
double loadedArea(const VehicleModel& m, const SoilParameters& soil)
{
  if (tracked(m))
    return 2.0 * m.track.shoe_width * trackLength(m);
  double a = 0.0;
  for (const WheelSpec& w : m.wheels)
  {
    const double z = terrain::rollingWheelSinkage(soil, w.radius, w.width, weight(m) / m.wheels.size());
    a += w.width * w.radius * std::acos(1.0 - std::min(z, w.radius) / w.radius);
  }
  return a;
}

/// m: the length the soil is sheared over: a track's contact, or a wheel's loaded arc rolling at
/// its sinkage (r acos(1 - z / r)).
double shearLength(const VehicleModel& m, const SoilParameters& soil)
{
  if (tracked(m))
    return trackLength(m);
  const WheelSpec& w = m.wheels[0];
  const double z = terrain::rollingWheelSinkage(soil, w.radius, w.width, weight(m) / m.wheels.size());
  return w.radius * std::acos(1.0 - std::min(z, w.radius) / w.radius);
}

/// N: the ground's static shear strength under the whole vehicle at normal load W cos(theta):
/// Mohr-Coulomb's c A + N tan(phi), or the tyres' peak adhesion on pavement.
double staticShear(const VehicleModel& m, const SoilParameters& soil, double theta)
{
  const double normal = weight(m) * std::cos(theta);
  if (soil.model == terrain::SinkageModel::kRigid)
    return soil.friction_peak * normal;
  return soil.cohesion * loadedArea(m, soil) + normal * std::tan(soil.friction_angle);
}

/// N: the most the ground's shear gives a driven vehicle: the static strength developed over the
/// contact at full slip (Janosi-Hanamoto's mean over a contact of length l), or the peak adhesion.
double shearCapacity(const VehicleModel& m, const SoilParameters& soil, double theta)
{
  if (soil.model == terrain::SinkageModel::kRigid)
    return staticShear(m, soil, theta);
  return staticShear(m, soil, theta) * janosiFullSlip(soil, shearLength(m, soil));
}

/// rad: solves f(theta) = 0 for increasing f on [0, 80 deg] by bisection.
template <class F>
double solveAngle(F f)
{
  double lo = 0.0, hi = 80.0 * kDeg;
  if (f(lo) >= 0.0)
    return 0.0;
  for (int k = 0; k < 60; ++k)
  {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// ------------------------------------------------------------------- runs

struct Run
{
  Setup setup;
  VehicleModel model;
  SoilParameters soil;
  double step;
};

WorldOptions options(double step)
{
  WorldOptions o;
  o.step = step;
  return o;
}

/// Braked on a plane tilted about x (side slope: the vehicle faces along it, +x): horizontal drift
/// (m) over `hold` s after `settle` s (the vehicle leaning into the soil on its downhill side),
/// and the roll it ends at (rad).
std::pair<double, double> sideSlope(const Run& r, double theta, double settle, double hold)
{
  auto t = plane(r.soil, 15.0, 15.0, 0.1, 0.0, std::tan(theta));
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, 0.0, 0.0, theta, 0.0, 0.0));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  w.advance(settle);
  const Eigen::Vector3d start = w.state(id).pose.translation();
  w.advance(hold);
  const VehicleState& s = w.state(id);
  const Eigen::Vector3d d = s.pose.translation() - start;
  const double roll = std::atan2(s.pose.linear()(2, 1), s.pose.linear()(2, 2));
  return { std::hypot(d.x(), d.y()), roll };
}

/// What a tilt table found: the angle (rad) at which the braked vehicle slid or tipped.
struct Tilt
{
  double angle = 0.0;
  bool tipped = false;  ///< else slid (or held to `up_to`)
  bool held = false;    ///< neither, up to the table's last angle
  /// rad: at lift-off, the angle at which gravity through the centre of mass passes over the
  /// downhill wheels' contact line (the statics of tipping, from the geometry the vehicle has then)
  double statics = std::numeric_limits<double>::quiet_NaN();
  double body_roll = 0.0;  ///< rad, the body's roll on the level ground at the event
};

/// A tilt table: level ground, the vehicle braked across it, gravity tilted (about the vehicle's
/// heading, +x) from the vertical to 0.6 `guess` at 2 deg/s, then by 0.5 deg/s up to `up_to`: the
/// angle where it first slides (its running gear's centre sideways faster than 2 cm/s for 0.5 s;
/// the body rolling on its springs moves it a few mm/s) or tips (two-wheel lift:
/// its uphill running gear below 1 % of the weight for 0.2 s). Tilting gravity, not the ground,
/// the vehicle meets the table's angle quasi-statically, as on a real tilt table.
Tilt tiltTable(const Run& r, double guess, double up_to)
{
  auto t = plane(r.soil, 8.0, 8.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  w.advance(2.0);
  const double t0 = w.time(), start = 0.6 * guess, rate = 0.5 * kDeg, ramp = start / (2.0 * kDeg);
  Eigen::Vector3d gear_centre = Eigen::Vector3d::Zero();
  const auto gear = runningGear(r.model);
  for (const auto& [p, radius] : gear)
    gear_centre += p / static_cast<double>(gear.size());
  double sliding = 0.0, lifted = 0.0;
  Tilt out;
  for (;;)
  {
    const double since = w.time() - t0;
    const double angle = since < ramp ? start * since / ramp : start + rate * (since - ramp);
    if (angle > up_to)
    {
      out.angle = up_to;
      out.held = true;
      return out;
    }
    // The ground rises to the vehicle's left (+y): gravity's share along it points to -y.
    w.setGravity(Eigen::Vector3d(0.0, -std::sin(angle), -std::cos(angle)) * kG);
    w.step();
    const VehicleState& s = w.state(id);
    double uphill = 0.0;
    for (std::size_t i = 0; i < s.wheels.size(); ++i)
      if (r.model.wheels[i].rest_position.y() > 0.0)
        uphill += s.wheels[i].normal_force;
    for (const TrackState& tr : s.tracks)
      if (tr.side == "left")
        uphill += tr.normal_force;
    const Eigen::Vector3d gear_velocity = s.linear_velocity + s.angular_velocity.cross(s.pose.linear() * gear_centre);
    sliding = std::abs(gear_velocity.y()) > 0.02 ? sliding + r.step : 0.0;
    lifted = uphill < 0.01 * weight(r.model) ? lifted + r.step : 0.0;
    if (sliding >= 0.5 || lifted >= 0.2)
    {
      out.tipped = lifted >= 0.2;
      out.angle = angle;
      out.body_roll = std::atan2(s.pose.linear()(2, 1), s.pose.linear()(2, 2));
      // The lowest point of each downhill wheel's mid-plane (where its ground contact acts; the
      // wheel cambers with the body, its bottom moving uphill by r sin(roll)), the mean of them
      // the line the vehicle tips about.
      Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
      int count = 0;
      for (std::size_t i = 0; i < s.wheels.size(); ++i)
      {
        const WheelSpec& spec = r.model.wheels[i];
        if (spec.rest_position.y() > 0.0)
          continue;
        const Eigen::Vector3d centre =
            s.pose * (spec.rest_position + s.wheels[i].suspension_deflection * Eigen::Vector3d::UnitZ());
        const Eigen::Vector3d axle = s.pose.linear().col(1);
        Eigen::Vector3d down = -Eigen::Vector3d::UnitZ() + axle.z() * axle;
        down.normalize();
        pivot += centre + spec.radius * down;
        ++count;
      }
      if (count > 0)
      {
        pivot /= count;
        const Eigen::Vector3d arm = s.centre_of_mass - pivot;
        out.statics = std::atan2(arm.y(), arm.z());
      }
      return out;
    }
  }
}

/// Braked on a plane rising along +x, facing up (yaw 0) or down (yaw pi): drift (m).
double planeHold(const Run& r, double theta, bool downhill, double hold)
{
  auto t = plane(r.soil, 15.0, 12.0, 0.1, std::tan(theta), 0.0);
  World w(*t, options(r.step));
  const double yaw = downhill ? M_PI : 0.0;
  const double pitch = downhill ? theta : -theta;
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, 0.0, yaw, 0.0, pitch, 0.005));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  w.advance(2.0);
  const Eigen::Vector3d start = w.state(id).pose.translation();
  w.advance(hold);
  return (w.state(id).pose.translation() - start).norm();
}

/// The test driver's steering: holds the heading the vehicle started with (yaw 0), as a driver
/// on a straight run does (a vehicle at full throttle on loose soil is not directionally stable
/// by itself). Reversing, the steering turns the vehicle the other way.
double holdHeading(const VehicleState& s, bool reverse)
{
  const double yaw = std::atan2(s.pose.linear()(1, 0), s.pose.linear()(0, 0));
  const double steer = std::clamp(-2.0 * yaw - 0.5 * s.angular_velocity.z(), -1.0, 1.0);
  return reverse ? -steer : steer;
}

/// Full throttle up a grade theta from rest: m climbed along it in the last 4 of 9 s.
double climb(const Run& r, double theta)
{
  auto t = plane(r.soil, 30.0, 8.0, 0.1, std::tan(theta), 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, -20.0, 0.0, 0.0, 0.0, -theta, 0.005));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  w.advance(1.0);
  const auto drive = [&](double seconds) {
    for (long k = std::lround(seconds / r.step); k > 0; --k)
    {
      w.setCommand(id, DriveCommand{ 1.0, 0.0, holdHeading(w.state(id), false) });
      w.step();
    }
  };
  drive(5.0);
  const double x0 = w.state(id).pose.translation().x();
  drive(4.0);
  return (w.state(id).pose.translation().x() - x0) / std::cos(theta);
}

/// A flat run at full throttle (forward or reverse): speed (m/s, + along the heading) at each
/// 0.01 s for `duration` s, and the time it first reached `speed_mark` (s, -1 if never).
std::pair<std::vector<double>, double> fullThrottle(const Run& r, double duration, bool reverse, double speed_mark)
{
  const double length = 40.0 * duration + 60.0;
  auto t = plane(r.soil, 0.5 * length, 6.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const double x0 = reverse ? 0.5 * length - 20.0 : -0.5 * length + 20.0;
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, x0, 0.0, 0.0, 0.0, 0.0, 0.005));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  w.advance(1.0);
  DriveCommand c{ 1.0, 0.0, 0.0 };
  c.reverse = reverse;
  std::vector<double> speeds;
  double reached = -1.0;
  const double t0 = w.time();
  const int samples = static_cast<int>(std::lround(duration / 0.01));
  const long per_sample = std::lround(0.01 / r.step);
  for (int k = 0; k < samples; ++k)
  {
    for (long j = 0; j < per_sample; ++j)
    {
      c.steering = holdHeading(w.state(id), reverse);
      w.setCommand(id, c);
      w.step();
    }
    const double v = w.state(id).body_velocity.x() * (reverse ? -1.0 : 1.0);
    speeds.push_back(v);
    if (reached < 0.0 && v >= speed_mark)
      reached = w.time() - t0;
  }
  return { speeds, reached };
}

/// From `v0` on flat ground, full brake: distance (m) to below 5 cm/s.
double brakingDistance(const Run& r, double v0)
{
  auto t = plane(r.soil, 60.0, 6.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, -50.0, 0.0, 0.0, 0.0, 0.0, 0.002));
  w.advance(1.0);  // settled, rolling free
  w.setVelocity(id, Eigen::Vector3d(v0, 0.0, 0.0));
  w.step();
  const double x0 = w.state(id).pose.translation().x();
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  while (w.state(id).body_velocity.x() > 0.05 && w.time() < 30.0)
    w.step();
  return w.state(id).pose.translation().x() - x0;
}

/// The closed model of a straight run: m_eff dv/dt = F_drive(v) - R(v) at the step, from rest.
struct Closed
{
  double time_to_mark = -1.0;  ///< s
  double speed = 0.0;          ///< m/s at the end
};

Closed closedRun(const VehicleModel& m, const SoilParameters& soil, double duration, double step, bool reverse,
                 double mark, bool multipass = true)
{
  // The spinning parts' inertia about their axles (base_link y) over their rolling radius
  // squared: wheels; a track's sprocket, idler, road wheels and circulating belt.
  double spin = 0.0;
  const auto add = [&](const std::string& link, double radius) {
    for (const Body& b : m.bodies)
      if (b.link == link)
        spin += b.inertia(1, 1) / (radius * radius);
  };
  for (const WheelSpec& w : m.wheels)
    add(w.link, w.radius);
  for (const TrackSpec& t : m.tracks)
  {
    add(t.sprocket_link, m.track.effectiveSprocketRadius());
    add(t.idler_link, t.idler_radius);
    for (const RoadWheelSpec& w : t.road_wheels)
      add(w.link, w.radius);
    // The belt circulating around the hull: its m v^2 / 2 on top of moving with the hull.
    for (const Body& b : m.bodies)
      if (b.link == t.belt_link)
        spin += b.mass;
  }
  const double m_eff = m.total_mass + spin;
  const double cap = tracked(m) || m.drive_type == DriveType::kSkidSteer
                         ? (reverse ? m.drivetrain.reverse_max_speed : m.drivetrain.max_speed)
                         : 1e300;  // a speed servo's target
  Closed out;
  // The resistance at rest once (its closed forms do not change with speed), a track's internal
  // resistance growing with it.
  const double at_rest = resistance(m, soil, 0.0, 0.0, multipass);
  const double per_speed = tracked(m) ? weight(m) * m.track.internal_resistance_per_speed : 0.0;
  double v = 0.0;
  for (double t = 0.0; t < duration; t += step)
  {
    if (out.time_to_mark < 0.0 && v >= mark)
      out.time_to_mark = t;
    const double f = driveForce(m, v, reverse) - at_rest - per_speed * v;
    v = std::min(v + f / m_eff * step, cap);
  }
  out.speed = v;
  return out;
}

/// Steady turn: radius (m) of the unsteered axle's midpoint path over the last 4 of 10 s.
double turnRadius(const Run& r, double speed, double steering)
{
  auto t = plane(r.soil, 40.0, 40.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, -15.0, 0.0, 0.0, 0.0, 0.005));
  const AckermannGeometry geometry(r.model);
  w.advance(0.5);
  w.setVelocity(id, Eigen::Vector3d(speed, 0.0, 0.0));
  double integral = 0.0;
  std::vector<Eigen::Vector2d> path;
  while (w.time() < 10.5)
  {
    const VehicleState& s = w.state(id);
    const double error = speed - s.body_velocity.x();
    integral = std::clamp(integral + 0.3 * error * r.step, 0.0, 1.0);
    w.setCommand(id, DriveCommand{ std::clamp(0.5 * error + integral, 0.0, 1.0), error < -0.3 ? 0.3 : 0.0, steering });
    w.step();
    if (w.time() > 6.5 && w.stepCount() % 10 == 0)
    {
      const Eigen::Vector3d p = w.state(id).pose * Eigen::Vector3d(geometry.referenceX(), 0.0, 0.0);
      path.emplace_back(p.x(), p.y());
    }
  }
  return circleRadius(path);
}

/// s: the settling time of a height trace sampled every `dt` s: the last time it was farther
/// than `band` m from where it ends.
double settlingTime(const std::vector<double>& z, double dt, double band)
{
  for (std::size_t k = z.size(); k-- > 0;)
    if (std::abs(z[k] - z.back()) > band)
      return (static_cast<double>(k) + 1.0) * dt;
  return 0.0;
}

/// Parked: set down on the soil (touching it), brakes on, 62 s.
struct Parked
{
  double sinkage = 0.0;         ///< m, mean running-gear sinkage at the end
  double sinkage_closed = 0.0;  ///< m, closed form at each gear's own load, mean
  double creep = 0.0;           ///< mm/min, chassis z from 2 s to 62 s
  double jitter = 0.0;          ///< mm, chassis z peak to peak over the last 10 s
  double settle = 0.0;          ///< s, into 1 mm of the height it ends at
};

Parked parked(const Run& r)
{
  auto t = plane(r.soil, 8.0, 6.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  Parked out;
  std::vector<double> z;
  double lo = 1e300, hi = -1e300;
  const long steps = std::lround(62.0 / r.step), every = std::max(1L, std::lround(0.001 / r.step));
  for (long k = 1; k <= steps; ++k)
  {
    w.step();
    const double height = w.state(id).pose.translation().z();
    if (k % every == 0)
      z.push_back(height);
    if (k * r.step > 52.0)
    {
      lo = std::min(lo, height);
      hi = std::max(hi, height);
    }
  }
  const double z2 = z[static_cast<std::size_t>(std::lround(2.0 / (every * r.step))) - 1];
  out.creep = 1e3 * (z2 - z.back());
  out.jitter = 1e3 * (hi - lo);
  out.settle = settlingTime(z, every * r.step, 1e-3);
  // Sinkage against the closed forms at each gear's own load: a wheel pressed straight down
  // carries N on both halves of its arc (rigidWheelStaticSinkage at N / 2); a track segment is a
  // flat plate.
  const VehicleState& s = w.state(id);
  int n = 0;
  for (std::size_t i = 0; i < s.wheels.size(); ++i)
  {
    const WheelSpec& spec = r.model.wheels[i];
    out.sinkage += s.wheels[i].sinkage;
    out.sinkage_closed +=
        terrain::rigidWheelStaticSinkage(r.soil, spec.radius, spec.width, 0.5 * s.wheels[i].normal_force);
    ++n;
  }
  for (const TrackState& tr : s.tracks)
    for (const TrackSegmentState& seg : tr.segments)
    {
      out.sinkage += seg.sinkage;
      out.sinkage_closed += plateSinkage(r.soil, seg.width, seg.length, seg.normal_force);
      ++n;
    }
  out.sinkage /= n;
  out.sinkage_closed /= n;
  return out;
}

/// Dropped from 0.5 m onto flat ground, brakes on: s from touchdown into 1 mm of the height it
/// ends at (8 s run).
double dropSettle(const Run& r)
{
  auto t = plane(r.soil, 8.0, 6.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  double touchdown = -1.0;
  std::vector<double> z;
  const long steps = std::lround(8.0 / r.step), every = std::max(1L, std::lround(0.001 / r.step));
  for (long k = 1; k <= steps; ++k)
  {
    w.step();
    const VehicleState& s = w.state(id);
    bool touching = s.hull_normal_force > 0.0;
    for (const WheelState& wh : s.wheels)
      touching = touching || wh.in_contact;
    for (const TrackState& tr : s.tracks)
      for (const TrackSegmentState& seg : tr.segments)
        touching = touching || seg.in_contact;
    if (touchdown < 0.0 && touching)
      touchdown = w.time();
    if (k % every == 0)
      z.push_back(s.pose.translation().z());
  }
  if (touchdown < 0.0)
    throw std::runtime_error("mobility: the dropped vehicle never touched the ground");
  return settlingTime(z, every * r.step, 1e-3) - touchdown;
}

/// The single-wheel rig: the vehicle's first wheel (radius, width) rolled along at 1 m/s over
/// `soil` on a 0.1 m grid at its share of the weight, each step lowered until it carries it,
/// at `slip`: mean sinkage, resistance and traction over the second half of 6 m.
struct Rig
{
  double sinkage = 0.0, resistance = 0.0, traction = 0.0, length = 0.0;
};

Rig wheelRig(const Run& r, double slip)
{
  if (r.model.wheels.empty())
    throw std::runtime_error("mobility: the single-wheel rig needs a wheeled vehicle");
  const WheelSpec& spec = r.model.wheels[0];
  const double load = weight(r.model) / r.model.wheels.size();
  auto t = plane(r.soil, 4.5, 1.0, 0.1, 0.0, 0.0);
  const double dt = 0.001, v = 1.0, step = v * dt * 5.0;  // 5 mm per evaluation
  Rig out;
  int samples = 0;
  for (double x = -4.0; x < 2.0; x += step)
  {
    terrain::WheelPatch w;
    w.centre = Eigen::Vector3d(x, 0.013, spec.radius);
    w.radius = spec.radius;
    w.width = spec.width;
    w.velocity = Eigen::Vector3d(v, 0.0, 0.0);
    w.spin_rate = v / (1.0 - slip) / spec.radius;
    double lo = 0.0, hi = 0.9 * spec.radius;
    for (int k = 0; k < 50; ++k)
    {
      const double mid = 0.5 * (lo + hi);
      w.centre.z() = spec.radius - mid;
      (t->wheelContact(w, dt, false).normal_force < load ? lo : hi) = mid;
    }
    const double z = 0.5 * (lo + hi);
    w.centre.z() = spec.radius - z;
    const terrain::ContactForces f = t->wheelContact(w, step / v, true);
    if (x > -1.0)
    {
      out.sinkage += z;
      out.resistance += f.resistance_force;
      out.traction += f.longitudinal_force;
      out.length += f.contact_length;
      ++samples;
    }
  }
  out.sinkage /= samples;
  out.resistance /= samples;
  out.traction /= samples;
  out.length /= samples;
  return out;
}

/// A deer walking at 4 m/s into the braked vehicle's right side: the vehicle's horizontal
/// displacement (m) over 4 s.
double agentPush(const Run& r)
{
  auto t = plane(r.soil, 20.0, 20.0, 0.1, 0.0, 0.0);
  World w(*t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(*t, r.model, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01));
  w.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  terrain::AgentSpec deer;
  deer.name = "deer";
  deer.type = terrain::AgentType::kDeer;
  deer.path = { Eigen::Vector2d(0.0, -8.0), Eigen::Vector2d(0.0, 15.0) };
  deer.speed = 4.0;
  w.setAgents({ terrain::Agent(deer, t->base(), "deer") });
  w.advance(1.0);
  const Eigen::Vector3d start = w.state(id).pose.translation();
  int contacts = 0;
  for (int k = 0; k < 4000; ++k)
  {
    w.step();
    contacts += w.state(id).obstacle_contacts > 0;
  }
  if (contacts == 0)
    throw std::runtime_error("mobility: the deer never met the vehicle");
  const Eigen::Vector3d d = w.state(id).pose.translation() - start;
  return std::hypot(d.x(), d.y());
}

/// Full throttle from firm gravel into the soil: 1 when, within 20 s, it is stuck with its hull
/// on the ground (high-centred), else 0; `detail` says what happened.
double highCentring(const Run& r, std::string& detail)
{
  terrain::SoilLibrary library = terrain::SoilLibrary::load(r.setup.soils_yaml);
  const double half_x = 20.0, half_y = 6.0, cell = 0.1;
  const std::size_t nx = static_cast<std::size_t>(std::lround(2.0 * half_x / cell)) + 1;
  const std::size_t ny = static_cast<std::size_t>(std::lround(2.0 * half_y / cell)) + 1;
  std::vector<std::uint8_t> map(nx * ny);
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx; ++i)
      map[j * nx + i] = -half_x + i * cell < -8.0 ? 0 : 1;  // gravel, then the soil from x = -8 m
  terrain::DeformableTerrain t(
      terrain::ElevationGrid(-half_x, -half_y, cell, cell, nx, ny, std::vector<float>(nx * ny, 0.f)),
      { library.get("gravel"), r.soil }, map, terrain::DeformableTerrain::Options{ true });
  World w(t, options(r.step));
  const std::size_t id = w.addVehicle(r.model, placeOn(t, r.model, -14.0, 0.0, 0.0, 0.0, 0.0, 0.005));
  StuckDetector stuck;
  bool high_centred = false;
  while (w.time() < 20.0)
  {
    w.setCommand(id, DriveCommand{ 1.0, 0.0, holdHeading(w.state(id), false) });
    w.step();
    const VehicleState& s = w.state(id);
    if (stuck.update(r.model, s, w.time()) && s.hull_normal_force > 0.0)
      high_centred = true;
  }
  const VehicleState& s = w.state(id);
  std::ostringstream d;
  d << "x " << s.pose.translation().x() << " m, hull carries " << s.hull_normal_force / weight(r.model) * 100.0
    << " % of the weight, stuck " << (stuck.stuck() ? "yes" : "no");
  detail = d.str();
  return high_centred ? 1.0 : 0.0;
}

// ------------------------------------------------------------------- loading

using Section = terrain::YamlSection<std::runtime_error>;

Check checkOf(const Section& s)
{
  const std::string c = s.string("check");
  if (c == "closed_form")
    return Check::kClosedForm;
  if (c == "public")
    return Check::kPublic;
  if (c == "at_most")
    return Check::kAtMost;
  if (c == "at_least")
    return Check::kAtLeast;
  s.fail("check", "must be closed_form, public, at_most or at_least, got '" + c + "'");
}

double optional(const Section& s, const std::string& key, double fallback)
{
  return s.node()[key] ? s.number(key) : fallback;
}
}  // namespace

const std::vector<std::pair<std::string, std::string>>& manoeuvres()
{
  static const std::vector<std::pair<std::string, std::string>> list(manoeuvreTable().begin(), manoeuvreTable().end());
  return list;
}

std::vector<Case> loadMatrix(const std::string& yaml_path)
{
  const Section root = terrain::loadYamlFile<std::runtime_error>(yaml_path);
  root.allowOnly({ "cases" });
  std::vector<Case> out;
  std::set<std::string> ids;
  for (const Section& s : root.sequence("cases"))
  {
    s.allowOnly({ "id", "vehicle", "soil", "manoeuvre", "check", "slope_deg", "speed", "steering", "slip", "duration",
                  "step", "tolerance", "tolerance_abs", "value", "unit", "source" });
    Case c;
    c.id = s.string("id");
    if (!ids.insert(c.id).second)
      s.fail("id", "'" + c.id + "' is used twice");
    c.vehicle = s.string("vehicle");
    c.soil = s.string("soil");
    c.manoeuvre = s.string("manoeuvre");
    if (!manoeuvreTable().count(c.manoeuvre))
      s.fail("manoeuvre", "unknown: '" + c.manoeuvre + "'");
    c.check = checkOf(s);
    c.slope_deg = optional(s, "slope_deg", 0.0);
    if (!(c.slope_deg >= 0.0 && c.slope_deg < 60.0))
      s.fail("slope_deg", "must be in [0, 60)");
    c.speed = optional(s, "speed", 0.0);
    c.steering = optional(s, "steering", 0.0);
    c.slip = optional(s, "slip", 0.0);
    if (!(c.slip >= 0.0 && c.slip < 1.0))
      s.fail("slip", "must be in [0, 1)");
    c.duration = optional(s, "duration", 0.0);
    c.step = optional(s, "step", 0.001);
    if (!(c.step > 0.0 && c.step <= 0.01))
      s.fail("step", "must be in (0, 0.01] s");
    c.tolerance = optional(s, "tolerance", 0.1);
    if (!(c.tolerance > 0.0 && c.tolerance < 1.0))
      s.fail("tolerance", "must be in (0, 1)");
    if (s.node()["tolerance_abs"])
    {
      if (c.check != Check::kClosedForm)
        s.fail("tolerance_abs", "applies to closed_form checks only");
      c.tolerance_abs = s.number("tolerance_abs");
      if (!(c.tolerance_abs > 0.0))
        s.fail("tolerance_abs", "must be > 0");
    }
    if (c.check != Check::kClosedForm)
      c.value = s.number("value");
    c.unit = s.string("unit");
    c.source = s.string("source");
    out.push_back(c);
  }
  return out;
}

double circleRadius(const std::vector<Eigen::Vector2d>& pts)
{
  Eigen::MatrixXd a(pts.size(), 3);
  Eigen::VectorXd b(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k)
  {
    a(k, 0) = pts[k].x();
    a(k, 1) = pts[k].y();
    a(k, 2) = 1.0;
    b(k) = -pts[k].squaredNorm();
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(b);
  return std::sqrt(0.25 * (c(0) * c(0) + c(1) * c(1)) - c(2));
}

Eigen::Isometry3d placeOnGround(const terrain::DeformableTerrain& ground, const VehicleModel& model, double x, double y,
                                double yaw, double roll, double pitch, double clearance)
{
  return placeOn(ground, model, x, y, yaw, roll, pitch, clearance);
}

std::string criterion(const Case& c)
{
  std::ostringstream o;
  switch (c.check)
  {
    case Check::kAtMost:
      o << "<= " << c.value;
      break;
    case Check::kAtLeast:
      o << ">= " << c.value;
      break;
    default:
      if (std::isfinite(c.tolerance_abs))
        o << "+-" << c.tolerance_abs;
      else
        o << "+-" << 100.0 * c.tolerance << " %";
  }
  return o.str();
}

namespace
{
/// What one manoeuvre measured, and the closed form(s) it is judged against.
struct Measurement
{
  double value = std::numeric_limits<double>::quiet_NaN();
  double closed = std::numeric_limits<double>::quiet_NaN();
  double closed_low = std::numeric_limits<double>::quiet_NaN();  // a closed form's lower bound, if it has one
  std::ostringstream detail;
};

void sideSlopeLimit(Run& r, Measurement& x)
{
  const VehicleModel& m = r.model;
  const SoilParameters& soil = r.soil;
  // The closed forms: sliding at tan(theta) = (c A + W cos(theta) tan(phi)) / (W cos(theta))
  // (pavement: the tyres' peak adhesion), tipping at the static stability factor t / (2 h).
  auto flat = plane(soil, 8.0, 6.0, 0.1, 0.0, 0.0);
  World w(*flat, options(r.step));
  const std::size_t id = w.addVehicle(m, placeOn(*flat, m, 0.0, 0.0, 0.0, 0.0, 0.0, 0.005));
  w.advance(2.0);
  const double h = w.state(id).centre_of_mass.z() - *flat->height(0.0, 0.0);
  const double tip = std::atan(trackWidth(m) / (2.0 * h));
  const double slide = solveAngle([&](double a) { return weight(m) * std::sin(a) - staticShear(m, soil, a); });
  const Tilt tilt = tiltTable(r, std::min(slide, tip), std::min(1.4 * std::min(slide, tip), 55.0 * kDeg));
  // A sprung vehicle tips below the rigid t / (2h): its body rolls on the springs and its wheels
  // camber with it, moving the centre of mass downhill and the contact line uphill. When it
  // tips, the reference is then the statics of the geometry it has at lift-off.
  const double tip_reference = tilt.tipped && std::isfinite(tilt.statics) ? tilt.statics : tip;
  x.closed = std::min(slide, tip_reference) / kDeg;
  x.value = tilt.angle / kDeg;
  x.detail << (tilt.held     ? "held to the table's end"
               : tilt.tipped ? "tipped (two-wheel lift)"
                             : "slid")
           << ", body roll " << tilt.body_roll / kDeg << " deg";
  if (tilt.tipped && std::isfinite(tilt.statics))
    x.detail << ", statics at lift-off " << tilt.statics / kDeg << " deg";
  x.detail << "; slide limit " << slide / kDeg << " deg, rigid tip limit " << tip / kDeg << " deg (t/2h, h " << h
           << " m)";
}

void gradeLimit(const Case& c, Run& r, Measurement& x)
{
  const VehicleModel& m = r.model;
  const SoilParameters& soil = r.soil;
  // Engine: the drive's force at a crawl = W sin(theta) + R(theta); soil: the ground's shear
  // at full slip less R = W sin(theta) (pavement: peak adhesion). R: resistance() closed forms.
  // Multi-axle vehicles on soil: between every wheel compacting fresh soil (single pass) and
  // the rear wheels only compacting below the front ruts (multi-pass); slip sinkage and the
  // ruts' rebound put the vehicle between.
  const double f_low = driveForce(m, 0.3);
  double engine = 0.0, ground = 0.0, limit[2];
  for (const bool multipass : { false, true })
  {
    engine =
        solveAngle([&](double a) { return weight(m) * std::sin(a) + resistance(m, soil, a, 0.3, multipass) - f_low; });
    ground = solveAngle([&](double a) {
      return weight(m) * std::sin(a) + resistance(m, soil, a, 0.3, multipass) - shearCapacity(m, soil, a);
    });
    limit[multipass] = std::min(engine, ground);
    x.detail << (multipass ? "; multi-pass" : "single pass") << ": engine limit " << engine / kDeg
             << " deg, ground limit " << ground / kDeg << " deg";
  }
  x.closed_low = limit[0] / kDeg;
  x.closed = limit[1] / kDeg;
  const double guess = (c.check == Check::kPublic ? c.value : x.closed) * kDeg;
  double lo = 0.5 * guess, hi = std::min(1.4 * guess, 55.0 * kDeg);
  for (int i = 0; i < 6; ++i)
  {
    const double mid = 0.5 * (lo + hi);
    (climb(r, mid) > 0.5 ? lo : hi) = mid;
  }
  x.value = 0.5 * (lo + hi) / kDeg;
}

void braking(const Case& c, Run& r, Measurement& x)
{
  const VehicleModel& m = r.model;
  const SoilParameters& soil = r.soil;
  const std::string& k = c.manoeuvre;
  // Brakes that can lock the running gear (their force beyond the peak adhesion): between
  // braking at the peak adhesion all the way, v0^2 / (2 (mu_p + f) g) (the gear still rolling,
  // at the slip of the peak: a tracked vehicle's belt, sprocket and road wheels take a while to
  // stop), and locking at once, the tyre's (brush) shear displacement u building over the
  // relaxation length L as it slides, du/ds = 1 - u/L, its friction falling from mu_p to the
  // sliding mu_s with u/L: g [(mu_s + f) d + (mu_p - mu_s) L (1 - e^(-d/L))] = v0^2 / 2. Weaker
  // brakes: v0^2 / (2 a), a = their force over the mass plus f g.
  const double v0 = c.speed;
  const double brake_force = tracked(m) ? 2.0 * m.brakes.max_torque / m.track.effectiveSprocketRadius()
                                        : m.wheels.size() * m.brakes.max_torque / m.wheels[0].radius;
  if (soil.model != terrain::SinkageModel::kRigid)
    throw std::runtime_error("mobility: braking cases are on rigid surfaces");
  const bool locks = brake_force > soil.friction_peak * weight(m);
  const double f = soil.rolling_resistance, mu_p = soil.friction_peak, mu_s = soil.friction_sliding;
  const double relaxation = m.firm_ground.relaxation_length;
  double locked = 0.0;
  {
    double lo = 0.0, hi = v0 * v0 / (2.0 * (mu_s + f) * kG);
    for (int i = 0; i < 60; ++i)
    {
      const double d = 0.5 * (lo + hi);
      const double work = kG * ((mu_s + f) * d + (mu_p - mu_s) * relaxation * (1.0 - std::exp(-d / relaxation)));
      (work < 0.5 * v0 * v0 ? lo : hi) = d;
    }
    locked = 0.5 * (lo + hi);
  }
  const double a = brake_force / m.total_mass + f * kG;
  const double distance = brakingDistance(r, v0);
  if (k == "braking")
  {
    x.value = distance;
    if (locks)
    {
      x.closed_low = v0 * v0 / (2.0 * (mu_p + f) * kG);
      x.closed = locked;
    }
    else
    {
      x.closed = v0 * v0 / (2.0 * a);
    }
    x.detail << (locks ? "brakes can lock the running gear" : "brakes below the adhesion");
  }
  else
  {
    double spread = 0.0;
    for (const double step : { 0.0005, 0.002 })
    {
      Run other = r;
      other.step = step;
      const double d = brakingDistance(other, v0);
      spread = std::max(spread, std::abs(d / distance - 1.0));
      x.detail << step * 1e3 << " ms: " << d << " m; ";
    }
    x.detail << "1 ms: " << distance << " m";
    x.value = spread;
  }
}

void parkedFigures(const Case& c, Run& r, Measurement& x)
{
  const std::string& k = c.manoeuvre;
  static std::map<std::string, Parked> cache;  // one run serves the four figures
  const std::string key = c.vehicle + "/" + c.soil + "/" + std::to_string(c.step);
  if (!cache.count(key))
    cache[key] = parked(r);
  const Parked& p = cache[key];
  if (k == "parked_sinkage")
  {
    x.value = p.sinkage;
    x.closed = p.sinkage_closed;
  }
  else
  {
    x.value = k == "parked_creep" ? p.creep : k == "parked_jitter" ? p.jitter : p.settle;
  }
  x.detail << "sinkage " << p.sinkage << " m, creep " << p.creep << " mm/min, jitter " << p.jitter << " mm, settled at "
           << p.settle << " s";
}

void wheelRigFigures(const Case& c, Run& r, Measurement& x)
{
  const VehicleModel& m = r.model;
  const SoilParameters& soil = r.soil;
  const std::string& k = c.manoeuvre;
  const WheelSpec& spec = m.wheels.at(0);
  const double load = weight(m) / m.wheels.size();
  const Rig rig = wheelRig(r, k == "wheel_drawbar" ? c.slip : 0.0);
  const double z = terrain::rollingWheelSinkage(soil, spec.radius, spec.width, load);
  const double rc = terrain::rollingWheelOnBekkerSoil(soil, spec.radius, spec.width, z).compaction_resistance;
  if (k == "wheel_sinkage")
  {
    x.value = rig.sinkage;
    x.closed = z;
  }
  else if (k == "wheel_resistance")
  {
    x.value = rig.resistance;
    x.closed = rc;
  }
  else
  {
    // Janosi-Hanamoto over the rolling wheel's loaded arc with the rim's pressure there, less
    // its compaction resistance, both at the closed-form sinkage.
    x.value = (rig.traction - rig.resistance) / load;
    x.closed = (terrain::rollingWheelTraction(soil, spec.radius, spec.width, z, c.slip) - rc) / load;
    x.detail << "traction " << rig.traction << " N (closed form "
             << terrain::rollingWheelTraction(soil, spec.radius, spec.width, z, c.slip) << "), ";
  }
  x.detail << "sinkage " << rig.sinkage << " m (closed form " << z << "), loaded length " << rig.length << " m";
}

/// Runs the case's manoeuvre.
void measure(const Case& c, Run& r, Measurement& x)
{
  const VehicleModel& m = r.model;
  const SoilParameters& soil = r.soil;
  const double theta = c.slope_deg * kDeg;
  const std::string& k = c.manoeuvre;
  if (k == "side_slope_hold")
  {
    const auto [drift, roll] = sideSlope(r, theta, 2.0, c.duration > 0.0 ? c.duration : 5.0);
    x.value = drift;
    x.detail << "roll " << roll / kDeg << " deg";
  }
  else if (k == "side_slope_limit")
    sideSlopeLimit(r, x);
  else if (k == "grade_limit")
    gradeLimit(c, r, x);
  else if (k == "plane_hold_uphill" || k == "plane_hold_downhill")
    x.value = planeHold(r, theta, k == "plane_hold_downhill", c.duration > 0.0 ? c.duration : 10.0);
  else if (k == "accel_0_10")
  {
    const auto [speeds, reached] = fullThrottle(r, 30.0, false, 10.0);
    x.value = reached;
    // On soil: between the rear wheels only compacting below the front ruts (multi-pass, the
    // quicker) and every wheel on fresh soil.
    x.closed = closedRun(m, soil, 30.0, r.step, false, 10.0, false).time_to_mark;
    x.closed_low = closedRun(m, soil, 30.0, r.step, false, 10.0, true).time_to_mark;
  }
  else if (k == "top_speed" || k == "reverse_speed")
  {
    const bool reverse = k == "reverse_speed";
    const double duration = c.duration > 0.0 ? c.duration : 40.0;
    const auto [speeds, reached] = fullThrottle(r, duration, reverse, 1e9);
    x.value = speeds.back();
    x.closed = closedRun(m, soil, duration, r.step, reverse, 1e9, true).speed;
    x.closed_low = closedRun(m, soil, duration, r.step, reverse, 1e9, false).speed;
    x.detail << "2 s before the end " << speeds[speeds.size() - 201] << " m/s";
  }
  else if (k == "braking" || k == "braking_step_spread")
    braking(c, r, x);
  else if (k == "turn_radius")
  {
    if (m.drive_type != DriveType::kAckermann)
      throw std::runtime_error("mobility: turn_radius needs an Ackermann vehicle");
    const AckermannGeometry geometry(m);
    x.closed = geometry.wheelbase() / std::tan(c.steering * geometry.maxCentreAngle());
    x.value = turnRadius(r, c.speed, c.steering);
  }
  else if (k == "parked_sinkage" || k == "parked_creep" || k == "parked_jitter" || k == "parked_settle")
    parkedFigures(c, r, x);
  else if (k == "drop_settle")
    x.value = dropSettle(r);
  else if (k == "wheel_sinkage" || k == "wheel_resistance" || k == "wheel_drawbar")
    wheelRigFigures(c, r, x);
  else if (k == "agent_push")
    x.value = agentPush(r);
  else if (k == "high_centring")
  {
    std::string d;
    x.value = highCentring(r, d);
    x.detail << d;
  }
  else
    throw std::runtime_error("mobility: no manoeuvre '" + k + "'");
}

/// Judges the measurement by the case's check: value, reference(s), error, pass.
void judge(const Case& c, Measurement& x, Result& out)
{
  double closed = x.closed;
  const double closed_low = x.closed_low;
  std::ostringstream& detail = x.detail;
  switch (c.check)
  {
    case Check::kClosedForm:
      // A closed form with two bounds: the error is from the nearer one, 0 between them.
      if (std::isfinite(closed_low) && std::abs(closed_low - closed) > 1e-12 * std::abs(closed))
      {
        out.reference_low = std::min(closed_low, closed);
        closed = std::max(closed_low, closed);
        out.error = out.value < out.reference_low ? out.value / out.reference_low - 1.0
                    : out.value > closed          ? out.value / closed - 1.0
                                                  : 0.0;
      }
      else
      {
        out.error = out.value / closed - 1.0;
      }
      out.reference = closed;
      if (std::isfinite(c.tolerance_abs))
      {
        // An absolute tolerance (a figure near 0, such as a drawbar pull coefficient).
        const double low = std::isfinite(out.reference_low) ? out.reference_low : closed;
        out.error = out.value < low ? out.value - low : out.value > closed ? out.value - closed : 0.0;
        out.pass = std::isfinite(closed) && std::abs(out.error) <= c.tolerance_abs;
      }
      else
      {
        out.pass = std::isfinite(closed) && std::abs(out.error) <= c.tolerance;
      }
      break;
    case Check::kPublic:
      out.reference = c.value;
      out.error = out.value / c.value - 1.0;
      out.pass = std::abs(out.error) <= c.tolerance;
      if (std::isfinite(closed))
        detail << (detail.tellp() > 0 ? "; " : "") << "closed form " << closed;
      break;
    case Check::kAtMost:
      out.reference = c.value;
      out.error = out.value - c.value;
      out.pass = out.value <= c.value;
      break;
    case Check::kAtLeast:
      out.reference = c.value;
      out.error = out.value - c.value;
      out.pass = out.value >= c.value;
      break;
  }
  out.pass = out.pass && std::isfinite(out.value);
}
}  // namespace

Result run(const Case& c, const Setup& setup)
{
  const auto start = std::chrono::steady_clock::now();
  const terrain::SoilLibrary library = terrain::SoilLibrary::load(setup.soils_yaml);
  Run r{ setup, loadVehicleModel(setup.vehicle_dir + "/" + c.vehicle + ".yaml"), library.get(c.soil), c.step };
  Measurement x;
  measure(c, r, x);
  Result out;
  out.value = x.value;
  judge(c, x, out);
  out.detail = x.detail.str();
  out.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace mobility
}  // namespace dynamics
}  // namespace avsp
