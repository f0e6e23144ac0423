#include "obstacle_collision.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace avsp
{
namespace dynamics
{
namespace
{
/// Contact points asked of dCollide per geom pair (a box on a box gives up to 8).
constexpr int kMaxContactsPerPair = 8;
/// m/s: velocity error the rigid contacts' CFM allows at the (lighter) vehicle's weight: keeps the
/// exact solver's matrix regular when several coplanar contact points are redundant.
constexpr double kContactCreep = 1e-5;
/// The explicit resistance of a toppleable object is a spring acting on one body: its stiffness
/// is kept below kExplicitStability * m / h^2 (omega h = 0.5, far inside explicit Euler's limit 2).
constexpr double kExplicitStability = 0.25;
/// m: target side of the quadtree's leaf blocks.
constexpr double kQuadtreeLeaf = 10.0;
/// Weight used to scale the contact regularization (not the world's gravity, which may be 0).
constexpr double kNominalGravity = 9.81;

// Geom user data: an index tagged with its kind (bits 0-1: 01 obstacle, 11 agent, x0 vehicle geom).
void* obstacleTag(std::size_t index)
{
  return reinterpret_cast<void*>((static_cast<std::uintptr_t>(index) << 2) | 1u);
}
void* agentTag(std::size_t index)
{
  return reinterpret_cast<void*>((static_cast<std::uintptr_t>(index) << 2) | 3u);
}
void* vehicleTag(std::size_t vehicle, std::size_t geom)
{
  return reinterpret_cast<void*>(((static_cast<std::uintptr_t>(vehicle) << 16) | geom) << 1);
}
struct Tag
{
  bool obstacle;           ///< not a vehicle's: a terrain object or an agent
  std::uint32_t index;     ///< obstacle or agent geom index, or vehicle index
  std::uint32_t geom = 0;  ///< geom index within the vehicle
  bool agent = false;
};
Tag decode(dGeomID g)
{
  const auto v = reinterpret_cast<std::uintptr_t>(dGeomGetData(g));
  if (v & 1u)
    return Tag{ true, static_cast<std::uint32_t>(v >> 2), 0, (v & 2u) != 0 };
  return Tag{ false, static_cast<std::uint32_t>(v >> 17), static_cast<std::uint32_t>((v >> 1) & 0xFFFFu) };
}

void setRotation(dGeomID g, const Eigen::Matrix3d& m, bool offset)
{
  const dMatrix3 r = { m(0, 0), m(0, 1), m(0, 2), 0.0, m(1, 0), m(1, 1), m(1, 2), 0.0, m(2, 0), m(2, 1), m(2, 2), 0.0 };
  if (offset)
    dGeomSetOffsetRotation(g, r);
  else
    dGeomSetRotation(g, r);
}

/// Round objects collide as upright cylinders, the rest as boxes of their footprint.
bool isRound(terrain::ObjectType type)
{
  return type == terrain::ObjectType::kTree || type == terrain::ObjectType::kShrub ||
         type == terrain::ObjectType::kPole;
}

std::string describe(const terrain::TerrainObject& o)
{
  std::ostringstream s;
  s << "object " << o.id << " (" << terrain::toString(o.type) << " at (" << o.x << ", " << o.y << "))";
  return s.str();
}
}  // namespace

ObstacleCollision::ObstacleCollision(double step) : step_(step)
{
}

ObstacleCollision::~ObstacleCollision()
{
  clearObstacles();
  clearAgents();
  for (VehicleGeoms& v : vehicles_)
    destroyVehicle(v);
}

void ObstacleCollision::clearAgents()
{
  for (dGeomID g : agent_geoms_)
    dGeomDestroy(g);
  agent_geoms_.clear();
  agent_geom_bodies_.clear();
  agent_ranges_.clear();
  if (agent_space_)
    dSpaceDestroy(agent_space_);
  agent_space_ = nullptr;
}

void ObstacleCollision::setAgents(const std::vector<AgentCollisionBody>& agents)
{
  clearAgents();
  if (agents.empty())
    return;
  agent_space_ = dSimpleSpaceCreate(nullptr);
  for (const AgentCollisionBody& a : agents)
  {
    AgentRange range;
    range.begin = agent_geoms_.size();
    range.body = a.body;
    for (const CollisionBox& b : a.boxes)
    {
      range.reach = std::max(range.reach, b.pose.translation().norm() + 0.5 * b.size.norm());
      const dGeomID g = dCreateBox(agent_space_, b.size.x(), b.size.y(), b.size.z());
      dGeomSetBody(g, a.body);
      dGeomSetOffsetPosition(g, b.pose.translation().x(), b.pose.translation().y(), b.pose.translation().z());
      setRotation(g, b.pose.linear(), true);
      dGeomSetData(g, agentTag(agent_geoms_.size()));
      agent_geoms_.push_back(g);
      agent_geom_bodies_.push_back(a.body);
    }
    range.end = agent_geoms_.size();
    agent_ranges_.push_back(range);
  }
}

void ObstacleCollision::clearObstacles()
{
  for (ObstacleGeom& o : obstacles_)
    dGeomDestroy(o.geom);
  obstacles_.clear();
  if (obstacle_space_)
    dSpaceDestroy(obstacle_space_);
  obstacle_space_ = nullptr;
  objects_ = nullptr;
}

void ObstacleCollision::destroyVehicle(VehicleGeoms& v)
{
  for (dGeomID g : v.geoms)
    dGeomDestroy(g);
  v.geoms.clear();
  if (v.space)
    dSpaceDestroy(v.space);
  v.space = nullptr;
}

void ObstacleCollision::setObstacles(terrain::ObjectSet& objects, const terrain::DeformableTerrain& terrain)
{
  // Everything is checked and measured before the first geom exists, so a rejected set leaves
  // the previous obstacles in place.
  struct Placed
  {
    const terrain::TerrainObject* object;
    double bottom, top;  ///< m, z of the geom's ends
  };
  std::vector<Placed> placed;
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x;
  double max_x = -min_x, max_y = -min_x;
  for (const terrain::TerrainObject& o : objects.all())
  {
    if (o.type == terrain::ObjectType::kGrass || o.toppled)
      continue;
    for (const auto& [name, value] :
         { std::pair<const char*, double>{ "length", o.length }, std::pair<const char*, double>{ "width", o.width },
           std::pair<const char*, double>{ "height", o.height } })
    {
      if (!std::isfinite(value) || !(value > 0.0))
      {
        std::ostringstream why;
        why << "World::setObstacles: " << describe(o) << ": " << name
            << " must be finite and > 0 m for the object to collide, got " << value;
        throw std::invalid_argument(why.str());
      }
    }
    const auto centre = terrain.height(o.x, o.y);
    if (!centre)
      throw std::invalid_argument("World::setObstacles: " + describe(o) + " is off the terrain");
    // The lowest ground under the footprint's corners, so no gap opens under a slope's downhill side.
    double ground_min = *centre;
    const double c = std::cos(o.yaw), s = std::sin(o.yaw);
    for (int corner = 0; corner < 4; ++corner)
    {
      const double u = (corner & 1 ? 0.5 : -0.5) * o.length, v = (corner & 2 ? 0.5 : -0.5) * o.width;
      const auto z = terrain.height(o.x + u * c - v * s, o.y + u * s + v * c);
      if (z)
        ground_min = std::min(ground_min, *z);
    }
    placed.push_back(Placed{ &o, ground_min - kObstacleBuryDepth, *centre + o.height });
    double hx = 0.0, hy = 0.0;
    terrain::footprintHalfExtents(o, hx, hy);
    min_x = std::min(min_x, o.x - hx);
    max_x = std::max(max_x, o.x + hx);
    min_y = std::min(min_y, o.y - hy);
    max_y = std::max(max_y, o.y + hy);
  }

  clearObstacles();
  objects_ = &objects;
  if (placed.empty())
    return;
  // A quadtree over the objects' extent with leaves of about kQuadtreeLeaf m: a vehicle's geoms
  // are tested only against the objects in the blocks their boxes overlap.
  const double half = 0.5 * std::max(max_x - min_x, max_y - min_y) + 1.0;
  const int depth = std::clamp(static_cast<int>(std::ceil(std::log2(2.0 * half / kQuadtreeLeaf))), 1, 8);
  const dVector3 centre = { 0.5 * (min_x + max_x), 0.5 * (min_y + max_y), 0.0 };
  const dVector3 extents = { half, half, 1e4 };
  obstacle_space_ = dQuadTreeSpaceCreate(nullptr, centre, extents, depth);
  obstacles_.reserve(placed.size());
  for (const Placed& p : placed)
  {
    const terrain::TerrainObject& o = *p.object;
    const double length = p.top - p.bottom;
    ObstacleGeom og;
    og.object = o.id;
    og.geom = isRound(o.type) ? dCreateCylinder(obstacle_space_, 0.25 * (o.length + o.width), length)
                              : dCreateBox(obstacle_space_, o.length, o.width, length);
    dGeomSetPosition(og.geom, o.x, o.y, 0.5 * (p.top + p.bottom));
    setRotation(og.geom, Eigen::AngleAxisd(o.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(), false);
    dGeomSetData(og.geom, obstacleTag(obstacles_.size()));
    og.toppleable = std::isfinite(o.strength);
    if (og.toppleable)
    {
      const double yield = std::min(kToppleYieldDeflection, 0.25 * std::min(o.length, o.width));
      og.stiffness = o.strength / yield;
    }
    obstacles_.push_back(og);
  }
}

void ObstacleCollision::addVehicle(const std::vector<CollisionBox>& boxes, const VehicleBodies& bodies)
{
  const std::size_t index = vehicles_.size();
  VehicleGeoms v;
  v.mass = bodies.mass;
  v.space = dSimpleSpaceCreate(nullptr);
  auto add = [&](dGeomID g, dBodyID body) {
    dGeomSetBody(g, body);
    dGeomSetData(g, vehicleTag(index, v.geoms.size()));
    v.geoms.push_back(g);
    v.bodies.push_back(body);
    dMass m;
    dBodyGetMass(body, &m);
    v.masses.push_back(m.mass);
  };
  for (const CollisionBox& b : boxes)
  {
    const dGeomID g = dCreateBox(v.space, b.size.x(), b.size.y(), b.size.z());
    add(g, bodies.chassis);
    // The chassis body's axes are base_link's; its origin is the lumped centre of mass.
    const Eigen::Vector3d offset = b.pose.translation() - bodies.chassis_com;
    dGeomSetOffsetPosition(g, offset.x(), offset.y(), offset.z());
    setRotation(g, b.pose.linear(), true);
  }
  // Bounding sphere round the chassis origin: its boxes, and each wheel where it is now plus
  // 0.5 m of suspension travel.
  v.centre = bodies.chassis;
  for (const CollisionBox& b : boxes)
    v.reach = std::max(v.reach, (b.pose.translation() - bodies.chassis_com).norm() + 0.5 * b.size.norm());
  const dReal* c = dBodyGetPosition(bodies.chassis);
  for (const CollisionWheel& w : bodies.wheels)
  {
    const dReal* p = dBodyGetPosition(w.body);
    const double d =
        std::sqrt((p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) + (p[2] - c[2]) * (p[2] - c[2]));
    v.reach = std::max(v.reach, d + std::hypot(w.radius, 0.5 * w.width) + 0.5);
  }
  for (const CollisionWheel& w : bodies.wheels)
  {
    const dGeomID g = dCreateCylinder(v.space, w.radius, w.width);
    add(g, w.body);
    // ODE's cylinder runs along its own z; the wheel's axle is its body's y.
    Eigen::Matrix3d r;
    r << 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0;
    setRotation(g, r, true);
  }
  vehicles_.push_back(std::move(v));
}

void ObstacleCollision::removeLastVehicle()
{
  if (vehicles_.empty())
    return;
  destroyVehicle(vehicles_.back());
  vehicles_.pop_back();
}

void ObstacleCollision::removeVehicle(std::size_t index)
{
  if (index >= vehicles_.size())
    throw std::out_of_range("ObstacleCollision::removeVehicle: no vehicle " + std::to_string(index));
  destroyVehicle(vehicles_[index]);
  vehicles_.erase(vehicles_.begin() + static_cast<std::ptrdiff_t>(index));
  // A geom's data names its vehicle's index (collect() reads it): the moved ones get their new one.
  for (std::size_t k = index; k < vehicles_.size(); ++k)
    for (std::size_t g = 0; g < vehicles_[k].geoms.size(); ++g)
      dGeomSetData(vehicles_[k].geoms[g], vehicleTag(k, g));
}

const CollisionReport& ObstacleCollision::report(std::size_t vehicle) const
{
  if (vehicle >= vehicles_.size())
    throw std::out_of_range("ObstacleCollision::report: no vehicle " + std::to_string(vehicle));
  return vehicles_[vehicle].report;
}

bool ObstacleCollision::near(dBodyID a, double reach_a, dBodyID b, double reach_b)
{
  const dReal* p = dBodyGetPosition(a);
  const dReal* q = dBodyGetPosition(b);
  const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2], r = reach_a + reach_b;
  return dx * dx + dy * dy + dz * dz <= r * r;
}

void ObstacleCollision::nearCallback(void* data, dGeomID o1, dGeomID o2)
{
  static_cast<ObstacleCollision*>(data)->collect(o1, o2);
}

void ObstacleCollision::collect(dGeomID g1, dGeomID g2)
{
  Tag t1 = decode(g1), t2 = decode(g2);
  if (t1.obstacle && t2.obstacle)
    return;
  // `a` is always a vehicle geom; between vehicles, the one with the lower index.
  if (t1.obstacle || (!t2.obstacle && t2.index < t1.index))
  {
    std::swap(g1, g2);
    std::swap(t1, t2);
  }
  if (!t2.obstacle && t2.index == t1.index)
    return;  // never self-collision
  if (t2.obstacle && !t2.agent)
  {
    const ObstacleGeom& o = obstacles_[t2.index];
    if (o.toppleable && objects_->get(o.object).toppled)
    {
      dGeomDisable(o.geom);  // pushed over elsewhere (by a wheel's soil contact, a file, ...)
      return;
    }
  }
  dContactGeom out[kMaxContactsPerPair];
  const int n = dCollide(g1, g2, kMaxContactsPerPair, out, sizeof(dContactGeom));
  for (int k = 0; k < n; ++k)
  {
    Hit h;
    h.vehicle_a = t1.index;
    h.geom_a = t1.geom;
    h.vehicle_b = t2.obstacle ? (t2.agent ? kAgent : kObstacle) : static_cast<std::int32_t>(t2.index);
    h.geom_b = t2.obstacle ? t2.index : t2.geom;
    h.order = k;
    h.contact = out[k];
    hits_.push_back(h);
  }
}

void ObstacleCollision::collide(dWorldID world, dJointGroupID group)
{
  for (VehicleGeoms& v : vehicles_)
    v.report = CollisionReport();
  hits_.clear();
  joints_.clear();
  // Vehicles and agents (or partitions' proxies) far apart are skipped on their bounding
  // spheres: with tens of vehicles the pairs, not the contacts, are the cost.
  for (std::size_t i = 0; i < vehicles_.size(); ++i)
  {
    const VehicleGeoms& vi = vehicles_[i];
    if (obstacle_space_)
      dSpaceCollide2(reinterpret_cast<dGeomID>(vi.space), reinterpret_cast<dGeomID>(obstacle_space_), this,
                     &ObstacleCollision::nearCallback);
    for (const AgentRange& a : agent_ranges_)
      if (near(vi.centre, vi.reach, a.body, a.reach))
        for (std::size_t g = a.begin; g < a.end; ++g)
          dSpaceCollide2(reinterpret_cast<dGeomID>(vi.space), agent_geoms_[g], this, &ObstacleCollision::nearCallback);
    for (std::size_t j = i + 1; j < vehicles_.size(); ++j)
      if (near(vi.centre, vi.reach, vehicles_[j].centre, vehicles_[j].reach))
        dSpaceCollide2(reinterpret_cast<dGeomID>(vi.space), reinterpret_cast<dGeomID>(vehicles_[j].space), this,
                       &ObstacleCollision::nearCallback);
  }
  if (hits_.empty())
    return;
  // The spaces' traversal order is theirs: sort, so joints and forces are made in an order that
  // depends only on the geometry (determinism).
  std::sort(hits_.begin(), hits_.end(), [](const Hit& x, const Hit& y) {
    if (x.vehicle_a != y.vehicle_a)
      return x.vehicle_a < y.vehicle_a;
    if (x.geom_a != y.geom_a)
      return x.geom_a < y.geom_a;
    if (x.vehicle_b != y.vehicle_b)
      return x.vehicle_b < y.vehicle_b;
    if (x.geom_b != y.geom_b)
      return x.geom_b < y.geom_b;
    return x.order < y.order;
  });

  pushToppleable();
  addRigidJoints(world, group);
}

bool ObstacleCollision::toppleable(const Hit& h) const
{
  return h.vehicle_b == kObstacle && obstacles_[h.geom_b].toppleable;
}

void ObstacleCollision::pushToppleable()
{
  // Toppleable objects: the elastic resistance of the deepest penetration, shared among the
  // contact points by depth; pushed over when it reaches the strength.
  pushes_.clear();
  for (const Hit& h : hits_)
  {
    if (!toppleable(h))
      continue;
    auto it = std::find_if(pushes_.begin(), pushes_.end(), [&](const Push& p) { return p.obstacle == h.geom_b; });
    if (it == pushes_.end())
    {
      pushes_.push_back(Push{ h.geom_b, 0.0, 0.0 });
      it = pushes_.end() - 1;
    }
    it->depth_max = std::max(it->depth_max, h.contact.depth);
    it->depth_sum += h.contact.depth;
  }
  for (const Push& p : pushes_)
  {
    if (!(p.depth_sum > 0.0))
      continue;
    ObstacleGeom& o = obstacles_[p.obstacle];
    const double strength = objects_->get(o.object).strength;
    double stiffness = o.stiffness;
    Eigen::Vector2d push = Eigen::Vector2d::Zero();  // horizontal force on the object (direction only)
    for (const Hit& h : hits_)
    {
      if (h.vehicle_b != kObstacle || h.geom_b != p.obstacle)
        continue;
      stiffness = std::min(stiffness, kExplicitStability * vehicles_[h.vehicle_a].masses[h.geom_a] / (step_ * step_));
      push -= h.contact.depth * Eigen::Vector2d(h.contact.normal[0], h.contact.normal[1]);
    }
    const double elastic = stiffness * p.depth_max;
    const double force = std::min(elastic, strength);
    for (const Hit& h : hits_)
    {
      if (h.vehicle_b != kObstacle || h.geom_b != p.obstacle)
        continue;
      VehicleGeoms& v = vehicles_[h.vehicle_a];
      const double f = force * h.contact.depth / p.depth_sum;
      const dReal* n = h.contact.normal;
      dBodyAddForceAtPos(v.bodies[h.geom_a], f * n[0], f * n[1], f * n[2], h.contact.pos[0], h.contact.pos[1],
                         h.contact.pos[2]);
      v.report.impulse += f * step_ * Eigen::Vector3d(n[0], n[1], n[2]);
      ++v.report.contacts;
    }
    // It gives at its strength: down it goes, towards where it was pushed (+x if straight down).
    if (elastic >= strength)
    {
      const double direction = push.squaredNorm() > 0.0 ? std::atan2(push.y(), push.x()) : 0.0;
      if (objects_->push(o.object, elastic, direction))
        dGeomDisable(o.geom);
    }
  }
}

void ObstacleCollision::addRigidJoints(dWorldID world, dJointGroupID group)
{
  // Rigid obstacles and other vehicles: stiff contact joints with Coulomb friction.
  std::size_t rigid = 0;
  for (const Hit& h : hits_)
    rigid += !toppleable(h);
  if (feedback_.size() < rigid)
    feedback_.resize(rigid);  // grows only: the joints point into it until afterStep()
  std::size_t j = 0;
  for (const Hit& h : hits_)
  {
    if (toppleable(h))
      continue;
    VehicleGeoms& va = vehicles_[h.vehicle_a];
    VehicleGeoms* vb = h.vehicle_b >= 0 ? &vehicles_[static_cast<std::size_t>(h.vehicle_b)] : nullptr;
    const double mass = vb ? std::min(va.mass, vb->mass) : va.mass;
    dContact ct{};
    ct.geom = h.contact;
    // Surface layer and push-out speed per contact: penetration beyond the layer is corrected at
    // ERP per step, at most kObstacleMaxCorrectingVelocity (depth * ERP / h).
    const double cap = kObstacleMaxCorrectingVelocity * step_ / kObstacleErp;
    ct.geom.depth = std::clamp(h.contact.depth - kObstacleSurfaceLayer, 0.0, cap);
    ct.surface.mode = dContactSoftERP | dContactSoftCFM | dContactApprox1;
    ct.surface.mu = kObstacleFriction;
    ct.surface.soft_erp = kObstacleErp;
    ct.surface.soft_cfm = kContactCreep / (mass * kNominalGravity);
    const dJointID joint = dJointCreateContact(world, group, &ct);
    // The second body: the other vehicle's, an agent's or a proxy's body (of its mass), or none
    // (the static world).
    dBodyID other = nullptr;
    if (vb)
      other = vb->bodies[h.geom_b];
    else if (h.vehicle_b == kAgent)
      other = agent_geom_bodies_[h.geom_b];
    dJointAttach(joint, va.bodies[h.geom_a], other);
    feedback_[j] = dJointFeedback{};
    dJointSetFeedback(joint, &feedback_[j]);
    joints_.push_back(RigidJoint{ h.vehicle_a, h.vehicle_b, vb != nullptr });
    ++va.report.contacts;
    ++va.report.rigid_contacts;
    if (vb)
    {
      ++vb->report.contacts;
      ++vb->report.rigid_contacts;
    }
    ++j;
  }
}

void ObstacleCollision::afterStep()
{
  for (std::size_t j = 0; j < joints_.size(); ++j)
  {
    const RigidJoint& r = joints_[j];
    const dJointFeedback& f = feedback_[j];
    vehicles_[r.vehicle_a].report.impulse += step_ * Eigen::Vector3d(f.f1[0], f.f1[1], f.f1[2]);
    if (r.body_b)
      vehicles_[static_cast<std::size_t>(r.vehicle_b)].report.impulse +=
          step_ * Eigen::Vector3d(f.f2[0], f.f2[1], f.f2[2]);
  }
  joints_.clear();
}

}  // namespace dynamics
}  // namespace avsp
