#include "avsp_dynamics/vehicle_model.hpp"

#include "avsp_dynamics/leg_kinematics.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>
#include <yaml-cpp/yaml.h>

#include <avsp_terrain/input_file.hpp>
#include <avsp_terrain/yaml_section.hpp>

namespace avsp
{
namespace dynamics
{
namespace
{
/// YAML map reader whose errors are ConfigErrors naming the file and key.
using Section = avsp::terrain::YamlSection<ConfigError>;

// --- Plausible physical ranges (issue 21, finding 5) -----------------------------------------
// Every physical value the loader reads, from the URDF or the YAML, is refused outside a range
// that every real ground vehicle lies inside, from a 1 kg toy robot to a ~200 t vehicle. The
// bounds are orders of magnitude, deliberately generous and not fitted to the reference
// vehicles: they refuse what is no vehicle at all (a 1e308 kg chassis, on which ODE aborts with
// !bSafeNormalize4Fault; a 1e-9 m wheel; a value three decades off), never a design. Lengths
// stop at kMaxDimension: 50 m is three times the largest self-propelled wheeled vehicles (ultra
// class mining haul trucks, about 15 m long). A test scales each reference vehicle to 1 kg and
// to 200 t (Froude similarity) and loads it.
struct Range
{
  double lo;
  double hi;
  const char* unit;                                             ///< with its leading space (" kg"); "" for ratios
  bool contains(double v) const { return v >= lo && v <= hi; }  // false for NaN
};

constexpr double kMaxDimension = 50.0;  // m
/// A 1 g part of a 1 kg toy robot up to the hull of a 200 t vehicle.
constexpr Range kLinkMass{ 1e-3, 2e5, " kg" };
/// The vehicle (its links together): a toy robot of 0.2 kg up to 300 t (a 200 t hull plus its
/// running gear and payload).
constexpr Range kVehicleMass{ 0.2, 3e5, " kg" };
/// Each principal moment I of a link of mass m as a radius of gyration sqrt(I / m): no body is
/// thinner than 0.1 mm about an axis through its centre of mass (a point mass has none, and ODE
/// divides by it) or wider than the largest vehicle; I <= m (50 m)^2 ties the inertia to the mass.
constexpr Range kGyrationRadius{ 1e-4, kMaxDimension, " m" };
/// Any link's origin, centre of mass or collision box from base_link at the rest pose.
constexpr Range kDistanceFromBase{ 0.0, kMaxDimension, " m" };
/// Chassis collision box edges: a 1 mm sensor housing up to the largest vehicle.
constexpr Range kBoxEdge{ 1e-3, kMaxDimension, " m" };
/// Wheel, road wheel, sprocket and idler cylinders: a toy's 5 mm wheel up to 5 m (the largest
/// tyres, 63-inch rim haul-truck tyres, are about 2 m in radius and 1.5 m wide).
constexpr Range kGearRadius{ 5e-3, 5.0, " m" };
constexpr Range kGearWidth{ 2e-3, 5.0, " m" };
/// Suspension joint limits (lower < 0 < upper): long-travel desert racers have about 1 m of
/// wheel travel in all; 2 m either way is no suspension.
constexpr Range kSuspensionLimit{ -2.0, 2.0, " m" };
/// Steering joint limits: at most half a turn either way.
constexpr Range kSteeringLimit{ -M_PI, M_PI, " rad" };
/// Road arm (torsion bar) joint limits: an arm swung more than a quarter turn from its rest
/// angle would be inside the hull or the ground.
constexpr Range kArmLimit{ -M_PI / 2.0, M_PI / 2.0, " rad" };
/// Road arm length, pivot to wheel centre.
constexpr Range kArmLength{ 1e-3, 5.0, " m" };
/// A vehicle with individually modelled track shoes has a few hundred links.
constexpr std::size_t kMaxLinks = 2000;

// The YAML's keys (SI units). With Froude similarity a torque goes as the mass to the 4/3 (a
// 1 kg toy's is about 5e-6 of a 10 t vehicle's): the lower bounds sit well below a toy's.
/// suspension.stiffness, per wheel: a toy's corner (0.25 kg) sags 0.25 m on 10 N/m; 1e9 N/m is
/// stiffer than the steel it is bolted to (firm_ground.vertical_stiffness has the same top).
constexpr Range kSuspensionStiffness{ 10.0, 1e9, " N/m" };
/// suspension.damping: critical damping of 50 t on 1e9 N/m is 1.4e7 N s/m.
constexpr Range kSuspensionDamping{ 0.0, 1e8, " N s/m" };
/// suspension.torsion_stiffness, per road arm: 2.5 g of toy on a 1 cm arm up to 20 t per arm.
constexpr Range kTorsionStiffness{ 0.01, 1e8, " N m/rad" };
constexpr Range kTorsionDamping{ 0.0, 1e7, " N m s/rad" };
/// suspension.preload_angle: the bar's static twist; past a quarter turn it is no torsion bar.
constexpr Range kPreloadAngle{ 0.0, M_PI / 2.0, " rad" };
/// steering.max_angle, the road wheel at full lock (3 to 80 deg): the geometry takes its tangent.
constexpr Range kSteeringAngle{ 0.05, 1.4, " rad" };
/// steering.max_rate: a hobby servo turns 60 deg in 0.1 s (10 rad/s).
constexpr Range kSteeringRate{ 0.01, 20.0, " rad/s" };
/// track.pitch: a toy's 2 mm rubber track up to 1 m excavator shoes; track.shoe_width likewise.
constexpr Range kTrackPitch{ 0.002, 1.0, " m" };
constexpr Range kSprocketTeeth{ 3.0, 100.0, "" };
constexpr Range kShoeWidth{ 0.005, 5.0, " m" };
/// track.internal_resistance: fractions of the weight (Bekker: a few per cent for steel tracks).
constexpr Range kInternalResistance{ 0.0, 0.3, "" };
constexpr Range kInternalResistancePerSpeed{ 0.0, 0.05, " per m/s" };
/// drivetrain.engine_max_torque: a toy's 0.1 mN m motor up to 1000 kN m (large diesels give
/// about 15 kN m at the crankshaft).
constexpr Range kEngineTorque{ 1e-4, 1e6, " N m" };
/// drivetrain.engine_max_power: 0.1 W up to 100 MW (the largest haul trucks have about 3.5 MW).
constexpr Range kEnginePower{ 0.1, 1e8, " W" };
/// drivetrain.gear_ratio, engine : wheel: an overdriven hub motor up to a 1000:1 micro gearmotor
/// times 5.
constexpr Range kGearRatio{ 0.1, 5000.0, "" };
/// drivetrain.efficiency: a toy's worm gear (about 0.3) down to 0.05; lossless at most.
constexpr Range kEfficiency{ 0.05, 1.0, "" };
/// drivetrain.max_speed: 1 cm/s up to 150 m/s (540 km/h; the fastest production cars do less);
/// reverse_max_speed from 1 cm/s to max_speed.
constexpr Range kMaxSpeed{ 0.01, 150.0, " m/s" };
/// brakes.max_torque, per wheel or sprocket: 1 mN m (a toy's 2 cm wheel stops 1 kg at 0.2 g
/// with 10 mN m) up to 10 MN m.
constexpr Range kBrakeTorque{ 1e-3, 1e7, " N m" };
/// firm_ground.longitudinal_stiffness and cornering_stiffness, per unit load (tyres 5-30).
constexpr Range kSlipStiffness{ 0.1, 100.0, "" };
/// firm_ground.relaxation_length: 1 mm up to 10 m (a long track's contact).
constexpr Range kRelaxationLength{ 0.001, 10.0, " m" };

std::string format(double v)
{
  std::ostringstream out;
  out << v;
  return out.str();
}

/// "[lo, hi]<unit>"
std::string rangeText(const Range& r)
{
  return "[" + format(r.lo) + ", " + format(r.hi) + "]" + r.unit;
}

/// "<what> <v><unit> is outside the plausible range [lo, hi]<unit>"
std::string outside(const std::string& what, double v, const Range& r)
{
  return what + " " + format(v) + r.unit + " is outside the plausible range " + rangeText(r);
}

/// `v`, read from `s`'s `key`, or a refusal naming the file, the key, `v` and the range.
double plausible(const Section& s, const std::string& key, double v, const Range& r, const std::string& why = "")
{
  if (!r.contains(v))
    s.fail(key, format(v) + r.unit + " is outside the plausible range " + rangeText(r) +
                    (why.empty() ? std::string() : " (" + why + ")"));
  return v;
}

/// "<what> is <d> m from base_link, outside the plausible range [0, 50] m"
std::string tooFar(const std::string& what, double distance)
{
  return what + " is " + format(distance) + " m from base_link, outside the plausible range " +
         rangeText(kDistanceFromBase);
}

/// Why a vehicle file is not read; the caller adds which file and what names it.
using FileRefused = avsp::terrain::InputFileRefused;

/// The whole text of a vehicle file (YAML or URDF): a regular file of at most 16 MiB.
/// @throw FileRefused with the reason (without the path)
std::string readVehicleFile(const std::string& path)
{
  return avsp::terrain::readInputFile(path, kMaxVehicleFileBytes, "a vehicle file");
}

/// The vehicle's YAML, read by readVehicleFile, as a Section (the checks of avsp_terrain's
/// loadYamlFile, which reads whatever the path names).
Section loadVehicleYaml(const std::string& path)
{
  std::string text;
  try
  {
    text = readVehicleFile(path);
  }
  catch (const FileRefused& e)
  {
    throw ConfigError(path + ": " + e.what());
  }
  YAML::Node doc;
  try
  {
    doc = YAML::Load(text);
  }
  catch (const YAML::Exception& e)
  {
    throw ConfigError(path + ": line " + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!doc.IsMap())
    throw ConfigError(path + ": the top level must be a map of keys");
  return Section(doc, path, "");
}

std::string directoryOf(const std::string& path)
{
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

Eigen::Isometry3d toIsometry(const urdf::Pose& p)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(Eigen::Vector3d(p.position.x, p.position.y, p.position.z));
  t.rotate(Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z));
  return t;
}

/// joints.*.max_torque of a legged vehicle: a toy servo's 1 mN m up to 10 kN m (a heavy
/// hydraulic leg's knee); joints.*.max_speed 0.1 to 100 rad/s.
constexpr Range kJointTorque{ 1e-3, 1e4, " N m" };
constexpr Range kJointSpeed{ 0.1, 100.0, " rad/s" };
/// joints.*.stiffness and damping (the joint PD): a toy servo's up to a heavy hydraulic leg's.
constexpr Range kJointStiffness{ 1e-3, 1e6, " N m/rad" };
constexpr Range kJointDamping{ 0.0, 1e4, " N m s/rad" };
/// stance.height: a toy's 5 cm up to 5 m; feet.pad_size 5 mm to 1 m.
constexpr Range kStanceHeight{ 0.05, 5.0, " m" };
constexpr Range kPadSize{ 0.005, 1.0, " m" };

/// Reads and checks the URDF: root, masses, inertias, sensor mounts.
class UrdfChecker
{
public:
  /// `text` is the file's content (read by readVehicleFile), `path` names it in errors.
  UrdfChecker(std::string path, const std::string& text, const std::string& yaml_file) : path_(std::move(path))
  {
    model_ = urdf::parseURDF(text);
    if (!model_)
      throw ConfigError(yaml_file + ": key 'urdf': '" + path_ + "' is not a valid URDF");
    if (!model_->getRoot() || model_->getRoot()->name != "base_link")
      fail("root link must be 'base_link'");
    if (model_->links_.size() > kMaxLinks)
      fail("has " + std::to_string(model_->links_.size()) + " links, more than the " + std::to_string(kMaxLinks) +
           " a vehicle plausibly has");
    // Every link at the rest pose within the largest vehicle's size of base_link (joint origins
    // of 1e308 m would put wheels where no contact or collision could be computed).
    for (const auto& kv : model_->links_)
    {
      const urdf::LinkSharedPtr& link = kv.second;
      if (!link->parent_joint)
        continue;
      const Eigen::Isometry3d pose = restPose(link->name);
      const double distance = pose.translation().norm();
      if (!pose.matrix().allFinite() || !kDistanceFromBase.contains(distance))
        fail("joint '" + link->parent_joint->name + "': " + tooFar("link '" + link->name + "' at rest", distance));
    }
  }

  /// Refuses a joint whose limits lie outside `range` (`what` says which joint it is).
  void checkLimits(const urdf::Joint& j, const Range& range, const std::string& what) const
  {
    if (!j.limits)
      return;
    if (!range.contains(j.limits->lower) || !range.contains(j.limits->upper))
      fail("joint '" + j.name + "': limits [" + format(j.limits->lower) + ", " + format(j.limits->upper) + "]" +
           range.unit + " are outside the plausible range " + rangeText(range) + " (" + what + ")");
  }

  [[noreturn]] void fail(const std::string& reason) const { throw ConfigError(path_ + ": " + reason); }

  /// Pose of a link's origin in base_link with every joint at 0.
  Eigen::Isometry3d restPose(const std::string& link_name) const
  {
    urdf::LinkConstSharedPtr link = model_->getLink(link_name);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    while (link && link->parent_joint)
    {
      pose = toIsometry(link->parent_joint->parent_to_joint_origin_transform) * pose;
      link = model_->getLink(link->parent_joint->parent_link_name);
    }
    return pose;
  }

  std::vector<Body> bodies() const
  {
    std::vector<Body> out;
    for (const auto& kv : model_->links_)
    {
      const urdf::LinkSharedPtr& link = kv.second;
      if (!link->inertial)
        continue;
      const urdf::Inertial& in = *link->inertial;
      if (!std::isfinite(in.mass) || !(in.mass > 0.0))
        fail("link '" + link->name + "': mass must be > 0, got " + std::to_string(in.mass));
      if (!kLinkMass.contains(in.mass))
        fail("link '" + link->name + "': " + outside("mass", in.mass, kLinkMass));
      Eigen::Matrix3d inertia;
      inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      if (!inertia.allFinite())
        fail("link '" + link->name + "': inertia must be finite");
      const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia).eigenvalues();
      // Physical inertia tensors are positive definite and obey the triangle inequality.
      if (!(ev.minCoeff() > 0.0))
        fail("link '" + link->name + "': inertia must be positive definite");
      const double tol = 1e-9 * ev.maxCoeff();
      if (ev(0) + ev(1) < ev(2) - tol || ev(0) + ev(2) < ev(1) - tol || ev(1) + ev(2) < ev(0) - tol)
        fail("link '" + link->name + "': principal inertias violate the triangle inequality");
      for (int k = 0; k < 3; ++k)
      {
        const Range moment{ in.mass * kGyrationRadius.lo * kGyrationRadius.lo,
                            in.mass * kGyrationRadius.hi * kGyrationRadius.hi, " kg m^2" };
        if (!moment.contains(ev(k)))
          fail("link '" + link->name + "': " + outside("principal moment of inertia", ev(k), moment) +
               " for its mass " + format(in.mass) + " kg (a radius of gyration of " + format(kGyrationRadius.lo) +
               " to " + format(kGyrationRadius.hi) + " m)");
      }
      // The dynamics lumps and places bodies in base_link: express the tensor there, about
      // the centre of mass (URDF gives it in the <inertial> origin's frame).
      const Eigen::Isometry3d link_pose = restPose(link->name);
      const Eigen::Isometry3d inertial_pose = link_pose * toIsometry(in.origin);
      const Eigen::Matrix3d r = inertial_pose.linear();
      const double com_distance = inertial_pose.translation().norm();
      if (!inertial_pose.matrix().allFinite() || !kDistanceFromBase.contains(com_distance))
        fail("link '" + link->name + "': " + tooFar("its centre of mass", com_distance));
      out.push_back(Body{ link->name, in.mass, ev, link_pose.translation(), inertial_pose.translation(),
                          r * inertia * r.transpose() });
    }
    if (out.empty())
      fail("no link has an <inertial>: the vehicle has no mass");
    return out;
  }

  urdf::JointConstSharedPtr joint(const Section& s, const std::string& key, int type, const char* type_name,
                                  const Eigen::Vector3d& axis) const
  {
    const std::string name = s.string(key);
    const urdf::JointConstSharedPtr j = model_->getJoint(name);
    if (!j)
      s.fail(key, "joint '" + name + "' is not in " + path_);
    if (j->type != type)
      s.fail(key, "joint '" + name + "' must be " + type_name + " in " + path_);
    const Eigen::Vector3d a(j->axis.x, j->axis.y, j->axis.z);
    if (type != urdf::Joint::FIXED && std::abs(std::abs(a.normalized().dot(axis)) - 1.0) > 1e-6)
    {
      std::ostringstream why;
      why << "joint '" << name << "' axis must be along (" << axis.transpose() << ") in " << path_;
      s.fail(key, why.str());
    }
    return j;
  }

  /// Radius and width of the child link's collision cylinder.
  void cylinder(const Section& s, const std::string& key, const urdf::JointConstSharedPtr& j, double& radius,
                double& width) const
  {
    const urdf::LinkConstSharedPtr link = model_->getLink(j->child_link_name);
    if (!link->collision || !link->collision->geometry || link->collision->geometry->type != urdf::Geometry::CYLINDER)
      s.fail(key, "link '" + link->name + "' needs a <collision> cylinder (wheel radius and width) in " + path_);
    const auto* cyl = static_cast<const urdf::Cylinder*>(link->collision->geometry.get());
    radius = cyl->radius;
    width = cyl->length;
    if (!(radius > 0.0) || !(width > 0.0))
      s.fail(key, "link '" + link->name + "' cylinder radius and length must be > 0 in " + path_);
    if (!kGearRadius.contains(radius))
      fail("link '" + link->name + "': " + outside("collision cylinder radius", radius, kGearRadius));
    if (!kGearWidth.contains(width))
      fail("link '" + link->name + "': " + outside("collision cylinder length (width)", width, kGearWidth));
    if (!link->inertial)
      s.fail(key, "link '" + link->name + "' needs an <inertial> (a wheel has mass) in " + path_);
  }

  std::map<std::string, Eigen::Vector3d> sensorMounts() const
  {
    std::map<std::string, Eigen::Vector3d> out;
    for (const std::string& name : requiredSensorLinks())
    {
      const urdf::LinkConstSharedPtr link = model_->getLink(name);
      if (!link)
        fail("sensor mount link '" + name + "' is missing");
      if (!link->parent_joint || link->parent_joint->type != urdf::Joint::FIXED)
        fail("sensor mount link '" + name + "' must hang from a fixed joint");
      out[name] = restPose(name).translation();
    }
    return out;
  }

  /// The <collision> boxes of every link not in `running_gear` (whose cylinders are wheels).
  std::vector<CollisionBox> collisionBoxes(const std::set<std::string>& running_gear) const
  {
    std::vector<CollisionBox> out;
    // links_ is a std::map: link-name order, the same on every load.
    for (const auto& kv : model_->links_)
    {
      const urdf::LinkSharedPtr& link = kv.second;
      if (running_gear.count(link->name))
        continue;
      for (const urdf::CollisionSharedPtr& c : link->collision_array)
      {
        if (!c || !c->geometry)
          continue;
        if (c->geometry->type != urdf::Geometry::BOX)
          fail("link '" + link->name +
               "': <collision> must be a box (chassis links collide with obstacles and other vehicles as boxes; "
               "only wheel, road wheel, sprocket and idler links have cylinders)");
        const urdf::Vector3& dim = static_cast<const urdf::Box*>(c->geometry.get())->dim;
        CollisionBox box;
        box.link = link->name;
        box.size = Eigen::Vector3d(dim.x, dim.y, dim.z);
        box.pose = restPose(link->name) * toIsometry(c->origin);
        if (!box.size.allFinite() || !(box.size.minCoeff() > 0.0) || !box.pose.matrix().allFinite())
          fail("link '" + link->name + "': <collision> box size must be finite and > 0 and its origin finite");
        for (int k = 0; k < 3; ++k)
          if (!kBoxEdge.contains(box.size(k)))
            fail("link '" + link->name + "': " + outside("<collision> box edge", box.size(k), kBoxEdge));
        if (!kDistanceFromBase.contains(box.pose.translation().norm()))
          fail("link '" + link->name + "': " + tooFar("its <collision> box's centre", box.pose.translation().norm()));
        out.push_back(box);
      }
    }
    if (out.empty())
      fail(
          "no link other than the running gear has a <collision> box: the vehicle could not collide with "
          "obstacles or other vehicles");
    return out;
  }

  const urdf::ModelInterface& model() const { return *model_; }

private:
  std::string path_;
  urdf::ModelInterfaceSharedPtr model_;
};

/// m, max minus min of the wheels' rest positions along base axis `axis` (0 = x, 1 = y).
double wheelSpread(const std::vector<WheelSpec>& wheels, int axis)
{
  if (wheels.empty())
    return 0.0;
  double lo = wheels.front().rest_position(axis), hi = lo;
  for (const WheelSpec& w : wheels)
  {
    lo = std::min(lo, w.rest_position(axis));
    hi = std::max(hi, w.rest_position(axis));
  }
  return hi - lo;
}

Differential differential(const Section& s, const std::string& key)
{
  const std::string v = s.string(key);
  if (v == "open")
    return Differential::kOpen;
  if (v == "locked")
    return Differential::kLocked;
  s.fail(key, "must be 'open' or 'locked', got '" + v + "'");
}

void readWheels(const Section& root, const UrdfChecker& urdf, VehicleModel& m)
{
  for (const Section& w : root.sequence("wheels"))
  {
    w.allowOnly({ "name", "spin_joint", "suspension_joint", "steering_joint", "driven" });
    WheelSpec spec;
    spec.name = w.string("name");
    const auto spin = urdf.joint(w, "spin_joint", urdf::Joint::CONTINUOUS, "continuous", Eigen::Vector3d::UnitY());
    spec.spin_joint = spin->name;
    spec.link = spin->child_link_name;
    urdf.cylinder(w, "spin_joint", spin, spec.radius, spec.width);
    const auto susp = urdf.joint(w, "suspension_joint", urdf::Joint::PRISMATIC, "prismatic", Eigen::Vector3d::UnitZ());
    spec.suspension_joint = susp->name;
    if (!susp->limits || !(susp->limits->lower < 0.0 && susp->limits->upper > 0.0))
      w.fail("suspension_joint", "joint '" + susp->name + "' needs limits with lower < 0 < upper (travel, m)");
    urdf.checkLimits(*susp, kSuspensionLimit, "suspension travel");
    spec.suspension_lower = susp->limits->lower;
    spec.suspension_upper = susp->limits->upper;
    if (w.node()["steering_joint"])
    {
      const auto steer = urdf.joint(w, "steering_joint", urdf::Joint::REVOLUTE, "revolute", Eigen::Vector3d::UnitZ());
      spec.steering_joint = steer->name;
      urdf.checkLimits(*steer, kSteeringLimit, "steering, at most half a turn either way");
    }
    spec.driven = w.boolean("driven");
    spec.rest_position = urdf.restPose(spec.link).translation();
    m.wheels.push_back(spec);
  }
}

void readTracks(const Section& root, const UrdfChecker& urdf, VehicleModel& m)
{
  std::set<std::string> sides;
  for (const Section& t : root.sequence("tracks"))
  {
    t.allowOnly({ "side", "sprocket_joint", "idler_joint", "belt_link", "road_wheels" });
    TrackSpec spec;
    spec.side = t.string("side");
    if (spec.side != "left" && spec.side != "right")
      t.fail("side", "must be 'left' or 'right', got '" + spec.side + "'");
    if (!sides.insert(spec.side).second)
      t.fail("side", "'" + spec.side + "' is listed twice");
    double width = 0.0;
    const auto sprocket =
        urdf.joint(t, "sprocket_joint", urdf::Joint::CONTINUOUS, "continuous", Eigen::Vector3d::UnitY());
    spec.sprocket_joint = sprocket->name;
    spec.sprocket_link = sprocket->child_link_name;
    urdf.cylinder(t, "sprocket_joint", sprocket, spec.sprocket_radius, width);
    const auto idler = urdf.joint(t, "idler_joint", urdf::Joint::CONTINUOUS, "continuous", Eigen::Vector3d::UnitY());
    spec.idler_joint = idler->name;
    spec.idler_link = idler->child_link_name;
    urdf.cylinder(t, "idler_joint", idler, spec.idler_radius, width);
    // The belt circulates around the hull: its mass moves with the hull and, at track speed,
    // adds rotating inertia to the drive (the dynamics needs to know which link it is).
    spec.belt_link = t.string("belt_link");
    const urdf::LinkConstSharedPtr belt = urdf.model().getLink(spec.belt_link);
    if (!belt)
      t.fail("belt_link", "link '" + spec.belt_link + "' is not in " + m.urdf_path);
    if (!belt->inertial)
      t.fail("belt_link", "link '" + spec.belt_link + "' needs an <inertial> (the belt's mass) in " + m.urdf_path);
    if (!belt->parent_joint || belt->parent_joint->type != urdf::Joint::FIXED)
      t.fail("belt_link",
             "link '" + spec.belt_link + "' must hang from a fixed joint (it moves with the hull) in " + m.urdf_path);
    for (const Section& r : t.sequence("road_wheels"))
    {
      r.allowOnly({ "arm_joint", "spin_joint" });
      RoadWheelSpec wheel;
      const auto arm = urdf.joint(r, "arm_joint", urdf::Joint::REVOLUTE, "revolute", Eigen::Vector3d::UnitY());
      wheel.arm_joint = arm->name;
      const auto spin = urdf.joint(r, "spin_joint", urdf::Joint::CONTINUOUS, "continuous", Eigen::Vector3d::UnitY());
      wheel.spin_joint = spin->name;
      if (spin->parent_link_name != arm->child_link_name)
        r.fail("spin_joint", "joint '" + spin->name + "' must hang from the arm link '" + arm->child_link_name + "'");
      wheel.link = spin->child_link_name;
      wheel.arm_link = arm->child_link_name;
      urdf.cylinder(r, "spin_joint", spin, wheel.radius, wheel.width);
      wheel.rest_position = urdf.restPose(wheel.link).translation();
      const Eigen::Isometry3d arm_pose = urdf.restPose(wheel.arm_link);
      wheel.pivot = arm_pose.translation();
      wheel.arm_axis_sign =
          (arm_pose.linear() * Eigen::Vector3d(arm->axis.x, arm->axis.y, arm->axis.z)).y() < 0.0 ? -1.0 : 1.0;
      if (!arm->limits || !(arm->limits->lower < 0.0 && arm->limits->upper > 0.0))
        r.fail("arm_joint", "joint '" + arm->name + "' needs limits with lower < 0 < upper (arm travel, rad)");
      urdf.checkLimits(*arm, kArmLimit, "road arm swing, at most a quarter turn either way");
      wheel.arm_lower = arm->limits->lower;
      wheel.arm_upper = arm->limits->upper;
      if ((wheel.rest_position - wheel.pivot).norm() < 1e-3)
        r.fail("arm_joint", "joint '" + arm->name + "' sits on the wheel's axle: a road arm needs a length");
      if (!kArmLength.contains((wheel.rest_position - wheel.pivot).norm()))
        urdf.fail(
            "joint '" + arm->name + "': " +
            outside("road arm length (pivot to wheel centre)", (wheel.rest_position - wheel.pivot).norm(), kArmLength));
      spec.road_wheels.push_back(wheel);
    }
    if (spec.road_wheels.size() < 2)
      t.fail("road_wheels", "a track needs at least 2 road wheels");
    m.tracks.push_back(spec);
  }
  if (sides.size() != 2)
    root.fail("tracks", "needs exactly one 'left' and one 'right' track");
  // Left first, then right, whatever the file's order.
  if (m.tracks.front().side != "left")
    std::swap(m.tracks.front(), m.tracks.back());

  const Section track = root.map("track");
  track.allowOnly({ "pitch", "sprocket_teeth", "shoe_width", "internal_resistance" });
  m.track.pitch = plausible(track, "pitch", track.positive("pitch"), kTrackPitch);
  m.track.sprocket_teeth = track.positiveInt("sprocket_teeth");
  plausible(track, "sprocket_teeth", m.track.sprocket_teeth, kSprocketTeeth);
  m.track.shoe_width = plausible(track, "shoe_width", track.positive("shoe_width"), kShoeWidth);
  const Section internal = track.map("internal_resistance");
  internal.allowOnly({ "coefficient", "per_speed" });
  m.track.internal_resistance = plausible(internal, "coefficient", internal.nonNegative("coefficient"),
                                          kInternalResistance, "a fraction of the weight");
  m.track.internal_resistance_per_speed = plausible(internal, "per_speed", internal.nonNegative("per_speed"),
                                                    kInternalResistancePerSpeed, "a fraction of the weight per m/s");
  // T10 turns sprocket speed into track speed with p N / 2 pi; the URDF sprocket must agree.
  for (const TrackSpec& t : m.tracks)
  {
    const double r = m.track.effectiveSprocketRadius();
    if (std::abs(r - t.sprocket_radius) > 0.05 * t.sprocket_radius)
    {
      std::ostringstream why;
      why << "pitch * sprocket_teeth / (2 pi) = " << r << " m differs by more than 5% from the URDF sprocket radius "
          << t.sprocket_radius << " m of '" << t.sprocket_joint << "'";
      track.fail("sprocket_teeth", why.str());
    }
  }
}

/// The running gear's brush model on rigid surfaces (the URDF cannot hold it).
void readFirmGround(const Section& root, VehicleModel& m)
{
  const Section f = root.map("firm_ground");
  f.allowOnly({ "vertical_stiffness", "longitudinal_stiffness", "cornering_stiffness", "relaxation_length" });
  FirmGroundSpec& g = m.firm_ground;
  g.vertical_stiffness = f.positive("vertical_stiffness");
  // Below what holds a quarter of the vehicle with 0.2 m of deflection, a "tyre" is a spring
  // nobody drives on (a typo's 1e3 for 1e6); above 1e9 N/m the contact is stiffer than steel.
  const double weight_share = m.total_mass * 9.81 /
                              std::max<std::size_t>(1, m.wheels.size() + m.legs.size() +
                                                           2 * (m.tracks.empty() ? 0 : m.tracks[0].road_wheels.size()));
  if (g.vertical_stiffness < weight_share / 0.2 || g.vertical_stiffness > 1e9)
    f.fail("vertical_stiffness", format(g.vertical_stiffness) + " N/m must be between " + format(weight_share / 0.2) +
                                     " N/m (0.2 m of deflection under its share of the weight) and 1e9 N/m");
  g.longitudinal_stiffness = plausible(f, "longitudinal_stiffness", f.positive("longitudinal_stiffness"),
                                       kSlipStiffness, "C_x / F_z per unit slip");
  g.cornering_stiffness =
      plausible(f, "cornering_stiffness", f.positive("cornering_stiffness"), kSlipStiffness, "C_alpha / F_z per rad");
  g.relaxation_length = plausible(f, "relaxation_length", f.positive("relaxation_length"), kRelaxationLength);
}

void readDrivetrain(const Section& root, VehicleModel& m)
{
  const Section d = root.map("drivetrain");
  d.allowOnly({ "engine_max_torque", "engine_max_power", "gear_ratio", "efficiency", "max_speed", "reverse_max_speed",
                "differentials" });
  m.drivetrain.engine_max_torque = plausible(d, "engine_max_torque", d.positive("engine_max_torque"), kEngineTorque);
  m.drivetrain.engine_max_power = plausible(d, "engine_max_power", d.positive("engine_max_power"), kEnginePower);
  m.drivetrain.gear_ratio = plausible(d, "gear_ratio", d.positive("gear_ratio"), kGearRatio);
  m.drivetrain.efficiency = plausible(d, "efficiency", d.positive("efficiency"), kEfficiency);
  m.drivetrain.max_speed = plausible(d, "max_speed", d.positive("max_speed"), kMaxSpeed);
  m.drivetrain.reverse_max_speed = d.positive("reverse_max_speed");
  if (m.drivetrain.reverse_max_speed > m.drivetrain.max_speed)
    d.fail("reverse_max_speed", "must not exceed max_speed");
  plausible(d, "reverse_max_speed", m.drivetrain.reverse_max_speed, kMaxSpeed);
  const Section diffs = d.map("differentials");
  const std::set<std::string> names = m.drive_type == DriveType::kAckermann
                                          ? std::set<std::string>{ "front", "rear", "center" }
                                          : std::set<std::string>{ "left", "right" };
  diffs.allowOnly(names);
  for (const std::string& n : names)
    m.drivetrain.differentials[n] = differential(diffs, n);
}
}  // namespace

const std::vector<std::string>& requiredSensorLinks()
{
  static const std::vector<std::string> links{ "lidar", "radar", "gps", "imu" };
  return links;
}

const char* toString(DriveType type)
{
  switch (type)
  {
    case DriveType::kAckermann:
      return "ackermann";
    case DriveType::kSkidSteer:
      return "skid_steer";
    case DriveType::kTracked:
      return "tracked";
    case DriveType::kLegged:
      return "legged";
  }
  return "?";
}

double TrackSpec::contactLength() const
{
  if (road_wheels.empty())
    return 0.0;
  return road_wheels.front().rest_position.x() - road_wheels.back().rest_position.x();
}

double TrackParameters::effectiveSprocketRadius() const
{
  return pitch * sprocket_teeth / (2.0 * M_PI);
}

namespace
{
/// m, max minus min of the legs' hip flexion joints along base axis `axis` (their feet's at stance).
double hipSpread(const std::vector<LegSpec>& legs, int axis)
{
  if (legs.empty())
    return 0.0;
  double lo = legs.front().anchors[1](axis), hi = lo;
  for (const LegSpec& l : legs)
  {
    lo = std::min(lo, l.anchors[1](axis));
    hi = std::max(hi, l.anchors[1](axis));
  }
  return hi - lo;
}
}  // namespace

double VehicleModel::wheelbase() const
{
  if (drive_type == DriveType::kLegged)
    return hipSpread(legs, 0);
  if (drive_type == DriveType::kTracked)
    return tracks.empty() ? 0.0 : tracks.front().contactLength();
  return wheelSpread(wheels, 0);
}

double VehicleModel::trackWidth() const
{
  if (drive_type == DriveType::kLegged)
    return hipSpread(legs, 1);
  if (drive_type == DriveType::kTracked)
  {
    if (tracks.size() != 2)
      return 0.0;
    return tracks[0].road_wheels.front().rest_position.y() - tracks[1].road_wheels.front().rest_position.y();
  }
  return wheelSpread(wheels, 1);
}

namespace
{
/// drive_type, and the top-level keys that drive type allows.
void readDriveType(const Section& root, VehicleModel& m)
{
  const std::string drive = root.string("drive_type");
  if (drive == "ackermann")
  {
    m.drive_type = DriveType::kAckermann;
    root.allowOnly(
        { "model", "urdf", "drive_type", "wheels", "suspension", "steering", "drivetrain", "brakes", "firm_ground" });
  }
  else if (drive == "skid_steer")
  {
    m.drive_type = DriveType::kSkidSteer;
    root.allowOnly({ "model", "urdf", "drive_type", "wheels", "suspension", "drivetrain", "brakes", "firm_ground" });
  }
  else if (drive == "tracked")
  {
    m.drive_type = DriveType::kTracked;
    root.allowOnly(
        { "model", "urdf", "drive_type", "tracks", "track", "suspension", "drivetrain", "brakes", "firm_ground" });
  }
  else if (drive == "legged")
  {
    m.drive_type = DriveType::kLegged;
    root.allowOnly({ "model", "urdf", "drive_type", "legs", "joints", "stance", "feet", "firm_ground" });
  }
  else
  {
    root.fail("drive_type", "must be ackermann, skid_steer, tracked or legged, got '" + drive + "'");
  }
}

/// One joint kind's YAML entry (joints.<kind>), its limits within every leg's URDF joint of
/// that kind.
LegJointSpec readLegJoint(const Section& joints, const char* kind)
{
  const Section j = joints.map(kind);
  j.allowOnly({ "lower", "upper", "max_torque", "max_speed", "stiffness", "damping" });
  LegJointSpec out;
  out.lower = j.number("lower");
  out.upper = j.number("upper");
  if (!(out.lower < out.upper) || out.lower < -M_PI || out.upper > M_PI)
    j.fail("upper", "the range [lower, upper] must have lower < upper within [-pi, pi] rad, got [" + format(out.lower) +
                        ", " + format(out.upper) + "]");
  out.max_torque = plausible(j, "max_torque", j.positive("max_torque"), kJointTorque, "the actuator's peak");
  out.max_speed = plausible(j, "max_speed", j.positive("max_speed"), kJointSpeed);
  out.stiffness = plausible(j, "stiffness", j.positive("stiffness"), kJointStiffness, "the joint PD's gain");
  out.damping = plausible(j, "damping", j.nonNegative("damping"), kJointDamping, "the joint PD's gain");
  return out;
}

/// The legs (legs, joints, stance, feet), checked against the URDF: each leg a chain base_link
/// -> abduction (about x) -> hip flexion (about y, beside it) -> knee (about y, below it) -> the
/// foot's sphere (below the knee), the shape leg_kinematics.hpp solves.
void readLeggedRunningGear(const Section& root, const UrdfChecker& urdf, VehicleModel& m)
{
  static const char* const kKinds[3] = { "abduction", "flexion", "knee" };
  static const char* const kKeys[3] = { "abduction_joint", "flexion_joint", "knee_joint" };
  const Section js = root.map("joints");
  js.allowOnly({ "abduction", "flexion", "knee" });
  for (int k = 0; k < 3; ++k)
    m.legged.joints[k] = readLegJoint(js, kKinds[k]);
  const Eigen::Vector3d axes[3] = { Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitY() };
  std::set<std::string> names;
  for (const Section& l : root.sequence("legs"))
  {
    l.allowOnly({ "name", "abduction_joint", "flexion_joint", "knee_joint", "foot_link" });
    LegSpec leg;
    leg.name = l.string("name");
    if (!names.insert(leg.name).second)
      l.fail("name", "leg '" + leg.name + "' is named twice");
    std::string parent = "base_link";
    for (int k = 0; k < 3; ++k)
    {
      const auto j = urdf.joint(l, kKeys[k], urdf::Joint::REVOLUTE, "revolute", axes[k]);
      if (j->parent_link_name != parent)
        l.fail(kKeys[k], "joint '" + j->name + "' must hang from link '" + parent + "' (a leg is a chain)");
      const LegJointSpec& spec = m.legged.joints[k];
      if (!j->limits || spec.lower < j->limits->lower - 1e-9 || spec.upper > j->limits->upper + 1e-9)
        l.fail(kKeys[k], "joint '" + j->name + "': joints." + kKinds[k] + " [" + format(spec.lower) + ", " +
                             format(spec.upper) + "] rad must lie within its URDF limits in " + m.urdf_path);
      leg.joints[k] = j->name;
      leg.links[k] = j->child_link_name;
      const Eigen::Isometry3d pose = urdf.restPose(leg.links[k]);
      leg.anchors[k] = pose.translation();
      leg.axes[k] = (pose.linear() * Eigen::Vector3d(j->axis.x, j->axis.y, j->axis.z)).normalized();
      parent = leg.links[k];
    }
    leg.foot_link = l.string("foot_link");
    const urdf::LinkConstSharedPtr foot = urdf.model().getLink(leg.foot_link);
    if (!foot || !foot->parent_joint || foot->parent_joint->type != urdf::Joint::FIXED ||
        foot->parent_joint->parent_link_name != parent)
      l.fail("foot_link",
             "link '" + leg.foot_link + "' must hang from '" + parent + "' by a fixed joint in " + m.urdf_path);
    if (!foot->collision || !foot->collision->geometry || foot->collision->geometry->type != urdf::Geometry::SPHERE)
      l.fail("foot_link", "link '" + leg.foot_link + "' needs a <collision> sphere (the foot) in " + m.urdf_path);
    leg.foot_radius = static_cast<const urdf::Sphere*>(foot->collision->geometry.get())->radius;
    if (!kGearRadius.contains(leg.foot_radius))
      l.fail("foot_link", outside("foot sphere radius", leg.foot_radius, kGearRadius));
    leg.foot_centre = (urdf.restPose(leg.foot_link) * toIsometry(foot->collision->origin)).translation();
    // The shape leg_kinematics.hpp solves: the flexion joint beside the abduction joint (only
    // y apart), the knee straight below the flexion joint, the foot straight below the knee.
    const auto apart = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, int free_axis) {
      Eigen::Vector3d d = a - b;
      d(free_axis) = 0.0;
      return d.norm() > 1e-6;
    };
    if (apart(leg.anchors[1], leg.anchors[0], 1))
      l.fail("flexion_joint", "joint '" + leg.joints[1] + "' must sit beside '" + leg.joints[0] +
                                  "' (the same x and z in base_link at rest)");
    if (apart(leg.anchors[2], leg.anchors[1], 2) || !(leg.anchors[2].z() < leg.anchors[1].z()))
      l.fail("knee_joint", "joint '" + leg.joints[2] + "' must sit straight below '" + leg.joints[1] + "' at rest");
    if (apart(leg.foot_centre, leg.anchors[2], 2) || !(leg.foot_centre.z() < leg.anchors[2].z()))
      l.fail("foot_link", "link '" + leg.foot_link + "' must sit straight below '" + leg.joints[2] + "' at rest");
    m.legs.push_back(leg);
  }
  if (m.legs.empty())
    root.fail("legs", "a legged vehicle needs at least one leg");
  const Section st = root.map("stance");
  st.allowOnly({ "height", "knees" });
  m.legged.stance_height = plausible(st, "height", st.positive("height"), kStanceHeight);
  const std::string knees = st.string("knees");
  if (knees != "backward" && knees != "forward")
    st.fail("knees", "must be backward or forward, got '" + knees + "'");
  m.legged.knees_backward = knees == "backward";
  for (const LegSpec& leg : m.legs)
  {
    const double reach = (leg.anchors[1] - leg.anchors[2]).norm() + (leg.anchors[2] - leg.foot_centre).norm();
    const double need = m.legged.stance_height - leg.foot_radius + leg.anchors[1].z();
    if (!(need < 0.98 * reach) || !(need > 0.2 * reach))
      st.fail("height", format(m.legged.stance_height) + " m puts leg '" + leg.name +
                            "' outside 20-98 % of its reach (" + format(reach) + " m from hip to foot centre)");
  }
  const Section f = root.map("feet");
  f.allowOnly({ "pad_size" });
  m.legged.pad_size = plausible(f, "pad_size", f.positive("pad_size"), kPadSize);
}

/// A tracked vehicle's tracks and torsion-bar suspension.
void readTrackedRunningGear(const Section& root, const UrdfChecker& urdf, VehicleModel& m)
{
  readTracks(root, urdf, m);
  const Section s = root.map("suspension");
  s.allowOnly({ "torsion_stiffness", "torsion_damping", "preload_angle" });
  m.torsion.torsion_stiffness =
      plausible(s, "torsion_stiffness", s.positive("torsion_stiffness"), kTorsionStiffness, "per road arm");
  m.torsion.torsion_damping =
      plausible(s, "torsion_damping", s.nonNegative("torsion_damping"), kTorsionDamping, "per road arm");
  m.torsion.preload_angle = plausible(s, "preload_angle", s.nonNegative("preload_angle"), kPreloadAngle);
}

/// A wheeled vehicle's wheels, suspension and (Ackermann) steering, checked against the URDF.
void readWheeledRunningGear(const Section& root, const UrdfChecker& urdf, VehicleModel& m)
{
  readWheels(root, urdf, m);
  const Section s = root.map("suspension");
  s.allowOnly({ "stiffness", "damping", "preload_deflection" });
  m.suspension.stiffness = plausible(s, "stiffness", s.positive("stiffness"), kSuspensionStiffness, "per wheel");
  m.suspension.damping = plausible(s, "damping", s.nonNegative("damping"), kSuspensionDamping, "per wheel");
  // At most the travel (below): the URDF's suspension limits bound it.
  m.suspension.preload_deflection = s.nonNegative("preload_deflection");
  for (const WheelSpec& w : m.wheels)
  {
    if (m.suspension.preload_deflection > w.suspension_upper - w.suspension_lower)
      s.fail("preload_deflection", "exceeds the suspension travel of joint '" + w.suspension_joint + "'");
  }
  bool any_steered = false, any_driven = false;
  for (const WheelSpec& w : m.wheels)
  {
    any_steered = any_steered || !w.steering_joint.empty();
    any_driven = any_driven || w.driven;
  }
  if (!any_driven)
    root.fail("wheels", "no wheel is driven");
  if (m.drive_type == DriveType::kAckermann)
  {
    if (!any_steered)
      root.fail("wheels", "an ackermann vehicle needs at least one steering_joint");
    const Section st = root.map("steering");
    st.allowOnly({ "max_angle", "max_rate" });
    m.steering.max_angle =
        plausible(st, "max_angle", st.positive("max_angle"), kSteeringAngle, "the road wheel's angle at full lock");
    m.steering.max_rate = plausible(st, "max_rate", st.positive("max_rate"), kSteeringRate);
    for (const WheelSpec& w : m.wheels)
    {
      if (w.steering_joint.empty())
        continue;
      const auto j = urdf.model().getJoint(w.steering_joint);
      if (!j->limits || m.steering.max_angle > std::min(-j->limits->lower, j->limits->upper) + 1e-9)
        st.fail("max_angle", "exceeds the limits of joint '" + w.steering_joint + "' in " + m.urdf_path);
    }
  }
  else if (any_steered)
  {
    root.fail("wheels", "a skid_steer vehicle steers by wheel speed; remove steering_joint");
  }
}

/// The chassis collision boxes: every <collision> that is not a wheel's or a track's cylinder.
std::vector<CollisionBox> chassisCollisionBoxes(const UrdfChecker& urdf, const VehicleModel& m)
{
  std::set<std::string> running_gear;
  for (const WheelSpec& w : m.wheels)
    running_gear.insert(w.link);
  for (const LegSpec& l : m.legs)
    running_gear.insert(l.foot_link);
  for (const TrackSpec& t : m.tracks)
  {
    running_gear.insert(urdf.model().getJoint(t.sprocket_joint)->child_link_name);
    running_gear.insert(urdf.model().getJoint(t.idler_joint)->child_link_name);
    for (const RoadWheelSpec& r : t.road_wheels)
      running_gear.insert(r.link);
  }
  return urdf.collisionBoxes(running_gear);
}
}  // namespace

VehicleModel loadVehicleModel(const std::string& yaml_path)
{
  const Section root = loadVehicleYaml(yaml_path);

  try
  {
    VehicleModel m;
    m.yaml_path = yaml_path;
    m.model = root.string("model");
    // Scenarios name a vehicle by its file (config/vehicles/<model>.yaml) and the nodes by its
    // `model`: a file that says it is another vehicle would run under two names.
    const std::string stem = std::filesystem::path(yaml_path).stem().string();
    if (m.model != stem)
      root.fail("model", "'" + m.model + "' contradicts the file's name '" + stem +
                             "' (config/vehicles/<model>.yaml: the key must be the file's name without .yaml)");
    readDriveType(root, m);

    const std::string urdf_rel = root.string("urdf");
    m.urdf_path = (!urdf_rel.empty() && urdf_rel[0] == '/') ? urdf_rel : directoryOf(yaml_path) + "/" + urdf_rel;
    std::string urdf_text;
    try
    {
      urdf_text = readVehicleFile(m.urdf_path);
    }
    catch (const FileRefused& e)
    {
      root.fail("urdf", "'" + m.urdf_path + "' " + e.what());
    }
    const UrdfChecker urdf(m.urdf_path, urdf_text, yaml_path);
    m.bodies = urdf.bodies();
    for (const Body& b : m.bodies)
      m.total_mass += b.mass;
    if (!kVehicleMass.contains(m.total_mass))
      urdf.fail(outside("the links' total mass", m.total_mass, kVehicleMass));
    m.sensor_mounts = urdf.sensorMounts();

    if (m.drive_type == DriveType::kTracked)
      readTrackedRunningGear(root, urdf, m);
    else if (m.drive_type == DriveType::kLegged)
      readLeggedRunningGear(root, urdf, m);
    else
      readWheeledRunningGear(root, urdf, m);

    m.collision_boxes = chassisCollisionBoxes(urdf, m);
    readFirmGround(root, m);
    if (m.drive_type == DriveType::kLegged)
      return m;  // no drivetrain or brakes: the joints' actuators
    readDrivetrain(root, m);
    const Section b = root.map("brakes");
    b.allowOnly({ "max_torque" });
    m.brakes.max_torque = plausible(b, "max_torque", b.positive("max_torque"), kBrakeTorque, "per wheel or sprocket");
    return m;
  }
  catch (const YAML::Exception& e)
  {
    // yaml-cpp throws for shapes Section does not anticipate (e.g. a key that is a list).
    throw ConfigError(yaml_path + ": line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

std::vector<std::pair<Eigen::Vector3d, double>> runningGear(const VehicleModel& model)
{
  std::vector<std::pair<Eigen::Vector3d, double>> out;
  for (const WheelSpec& w : model.wheels)
    out.emplace_back(w.rest_position, w.radius);
  for (const TrackSpec& t : model.tracks)
    for (const RoadWheelSpec& w : t.road_wheels)
      out.emplace_back(w.rest_position, w.radius);
  for (const LegSpec& l : model.legs)
    out.emplace_back(stanceFoot(model, l), l.foot_radius);
  return out;
}

}  // namespace dynamics
}  // namespace avsp
