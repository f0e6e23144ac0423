// Obstacles and vehicle-vehicle contact (World::setObstacles, ODE collision only for them),
// checked against the geometry and against momentum: a building and a strong tree stop a
// fed_alpha launched at 15 m/s without tunnelling; its wheels climb a low rock; a shrub topples towards the travel and costs
// the vehicle the momentum the reported impulse says; a weak robot cannot push a shrub over; two
// vehicles collide; far from obstacles the run is bit-identical to one without them; bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>
#include <avsp_terrain/terrain_objects.hpp>

#include "avsp_dynamics/collision_counter.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp::dynamics;
namespace terrain = avsp::terrain;

namespace
{
const std::string kConfigDir = AVSP_VEHICLE_CONFIG_DIR;
/// m: the most any part of a vehicle may be inside a rigid obstacle (one 1 ms step at 15 m/s
/// is 15 mm, plus the 1 mm surface layer).
constexpr double kMaxPenetration = 0.05;

const terrain::SoilLibrary& soils()
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  return lib;
}

VehicleModel vehicle(const std::string& name)
{
  return loadVehicleModel(kConfigDir + "/" + name + ".yaml");
}

/// A level gravel terrain from x0 to x0 + size_x, y from -size_y / 2 to size_y / 2, at `res` m.
std::unique_ptr<terrain::DeformableTerrain> flatGround(double x0, double size_x, double size_y, double res = 0.1)
{
  const std::size_t nx = static_cast<std::size_t>(std::lround(size_x / res)) + 1;
  const std::size_t ny = static_cast<std::size_t>(std::lround(size_y / res)) + 1;
  return std::make_unique<terrain::DeformableTerrain>(
      terrain::ElevationGrid(x0, -0.5 * size_y, res, res, nx, ny, std::vector<float>(nx * ny, 0.f)),
      soils().get("gravel"), terrain::DeformableTerrain::Options{ true });
}

terrain::TerrainObject object(terrain::ObjectType type, double x, double y, double length, double width, double height,
                              double strength)
{
  terrain::TerrainObject o;
  o.type = type;
  o.x = x;
  o.y = y;
  o.length = length;
  o.width = width;
  o.height = height;
  o.strength = strength;
  return o;
}

/// The eight corners of a vehicle's collision boxes in map at its current pose.
std::vector<Eigen::Vector3d> chassisCorners(const VehicleModel& m, const VehicleState& s)
{
  std::vector<Eigen::Vector3d> out;
  for (const CollisionBox& b : m.collision_boxes)
    for (int k = 0; k < 8; ++k)
    {
      const Eigen::Vector3d local(k & 1 ? 0.5 : -0.5, k & 2 ? 0.5 : -0.5, k & 4 ? 0.5 : -0.5);
      out.push_back(s.pose * (b.pose * local.cwiseProduct(b.size)));
    }
  return out;
}

/// m, how far the vehicle's chassis boxes and wheel cylinders reach past the plane x = face.
double reachPast(const VehicleModel& m, const VehicleState& s, double face)
{
  double reach = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& c : chassisCorners(m, s))
    reach = std::max(reach, c.x() - face);
  for (const WheelSpec& w : m.wheels)
  {
    // A wheel's disc reaches r along every direction in its plane: its farthest x is the
    // centre + r |in-plane x|, plus the half width along the axle's x.
    const Eigen::Vector3d centre = s.pose * w.rest_position;
    const Eigen::Vector3d axle = s.pose.linear() * Eigen::Vector3d::UnitY();
    const double in_plane = std::sqrt(std::max(0.0, 1.0 - axle.x() * axle.x()));
    reach = std::max(reach, centre.x() + w.radius * in_plane + 0.5 * w.width * std::abs(axle.x()) - face);
  }
  return reach;
}

/// m, depth of a vehicle's chassis boxes inside a vertical cylinder of radius r at (x, y)
/// (negative: the gap), measured at the height of each box's centre.
double depthInCylinder(const VehicleModel& m, const VehicleState& s, double x, double y, double r)
{
  double depth = -std::numeric_limits<double>::infinity();
  for (const CollisionBox& b : m.collision_boxes)
  {
    const Eigen::Isometry3d box = s.pose * b.pose;
    const Eigen::Vector3d axis_point(x, y, box.translation().z());
    const Eigen::Vector3d local = box.inverse() * axis_point;
    const Eigen::Vector3d nearest = local.cwiseMax(-0.5 * b.size).cwiseMin(0.5 * b.size);
    depth = std::max(depth, r - (local - nearest).norm());
  }
  return depth;
}

/// Bytes of what a step produced, for bit-identity.
std::vector<double> fingerprint(const VehicleState& s)
{
  std::vector<double> out(s.pose.data(), s.pose.data() + 16);
  for (const Eigen::Vector3d* v : { &s.linear_velocity, &s.angular_velocity, &s.centre_of_mass })
    out.insert(out.end(), v->data(), v->data() + 3);
  for (const WheelState& w : s.wheels)
    out.insert(out.end(), { w.normal_force, w.applied_normal_force, w.sinkage, w.slip, w.traction_force,
                            w.lateral_force, w.spin_rate, w.suspension_deflection });
  out.push_back(s.obstacle_contacts);
  out.insert(out.end(), s.obstacle_impulse.data(), s.obstacle_impulse.data() + 3);
  return out;
}

bool sameBits(const std::vector<double>& a, const std::vector<double>& b)
{
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

/// Speed of the whole vehicle's centre of mass from two consecutive states.
Eigen::Vector3d comVelocity(const Eigen::Vector3d& before, const Eigen::Vector3d& after, double h)
{
  return (after - before) / h;
}

/// A fed_alpha launched at `speed` along +x from base_link x = `x0` into whatever `objects`
/// holds, with `command` held; records the worst reach past `face` (or into a cylinder).
struct LaunchRun
{
  double max_reach = -std::numeric_limits<double>::infinity();  ///< m past the face, or into the cylinder
  double first_contact_time = -1.0;                             ///< s
  double impact_impulse_x = 0.0;        ///< N s, obstacle impulse over the first 20 ms of contact
  double impact_momentum_change = 0.0;  ///< N s, m_total x change of the COM x-velocity over the same steps
  VehicleState final;
  std::vector<std::vector<double>> trace;  ///< fingerprint per step
  std::uint32_t collisions = 0;            ///< CollisionCounter over the run
  int rigid_contact_steps = 0;             ///< steps with rigid contact points
};

enum class Target
{
  kPlane,
  kCylinder
};

LaunchRun launch(terrain::ObjectSet* objects, double speed, const DriveCommand& command, double seconds, Target target,
                 double face_or_x, double radius = 0.0)
{
  const VehicleModel m = vehicle("fed_alpha");
  auto ground = flatGround(-50.0, 80.0, 30.0);
  World world(*ground);
  if (objects)
    world.setObstacles(*objects);
  const std::size_t id = world.addVehicle(m, world.restingPose(m, -30.0, 0.0, 0.0, 0.0));
  // Settle on the suspension first, then launch.
  world.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  world.advance(0.5);
  world.setVelocity(id, Eigen::Vector3d(speed, 0.0, 0.0));
  world.setCommand(id, command);
  LaunchRun run;
  const double h = world.options().step;
  Eigen::Vector3d com = world.state(id).centre_of_mass;
  Eigen::Vector3d v_before = Eigen::Vector3d(speed, 0.0, 0.0);
  const auto steps = static_cast<long>(std::lround(seconds / h));
  CollisionCounter counter;
  for (long k = 0; k < steps; ++k)
  {
    world.step();
    const VehicleState& s = world.state(id);
    counter.update(s, world.time());
    run.rigid_contact_steps += s.obstacle_rigid_contacts > 0;
    const Eigen::Vector3d v = comVelocity(com, s.centre_of_mass, h);
    com = s.centre_of_mass;
    const double reach =
        target == Target::kPlane ? reachPast(m, s, face_or_x) : depthInCylinder(m, s, face_or_x, 0.0, radius);
    run.max_reach = std::max(run.max_reach, reach);
    if (s.obstacle_contacts > 0 && run.first_contact_time < 0.0)
      run.first_contact_time = world.time();
    if (run.first_contact_time >= 0.0 && world.time() <= run.first_contact_time + 0.02 + 1e-9)
    {
      run.impact_impulse_x += s.obstacle_impulse.x();
      run.impact_momentum_change += m.total_mass * (v.x() - v_before.x());
    }
    v_before = v;
    run.trace.push_back(fingerprint(s));
  }
  run.final = world.state(id);
  run.collisions = counter.count();
  return run;
}
}  // namespace

// 15 m/s into a building (a solid box): 15 mm per step, so the chassis is at most one step's
// travel inside the wall before the contact stops it; the wall's impulse is the momentum lost.
TEST(Obstacles, BuildingStopsAVehicleAt15MetresPerSecondWithoutTunnelling)
{
  terrain::ObjectSet objects;
  // Near face at x = 0: 10 m deep, 14 m wide, 6 m tall.
  objects.add(
      object(terrain::ObjectType::kBuilding, 5.0, 0.0, 10.0, 14.0, 6.0, std::numeric_limits<double>::infinity()));
  const LaunchRun run = launch(&objects, 15.0, DriveCommand{ 1.0, 0.0, 0.0 }, 3.5, Target::kPlane, 0.0);
  ASSERT_GT(run.first_contact_time, 0.0) << "never reached the wall";
  std::printf(
      "building at 15 m/s: deepest reach past the wall %.1f mm; impulse over the first 20 ms %.0f N s, "
      "momentum change %.0f N s\n",
      1e3 * run.max_reach, run.impact_impulse_x, run.impact_momentum_change);
  EXPECT_LT(run.max_reach, kMaxPenetration);
  // Stopped on the near side, still pushing with full throttle.
  EXPECT_LT(run.final.linear_velocity.norm(), 0.1);
  EXPECT_LT(reachPast(vehicle("fed_alpha"), run.final, 0.0), kMaxPenetration);
  EXPECT_LT(run.final.pose.translation().x(), -2.0);
  EXPECT_NEAR(run.final.pose.translation().y(), 0.0, 0.1);  // straight in, straight stop
  // Over the impact the wall's impulse is what the vehicle lost (~ m v = 86 kN s); the soil's
  // share over 20 ms is a few percent at most.
  EXPECT_LT(run.impact_impulse_x, -0.9 * 5710.0 * 14.0);
  EXPECT_NEAR(run.impact_impulse_x, run.impact_momentum_change, 0.05 * std::abs(run.impact_momentum_change));
  // One collision (VehicleTelemetry.collisions): the impact, then full throttle against the wall
  // for ~1 s; whatever the contact points do meanwhile (they bounce off 2 cm for 0.7 s), it is
  // the same collision.
  EXPECT_GT(run.rigid_contact_steps, 500);
  EXPECT_EQ(run.collisions, 1u);
}

// A large tree is rigid: it stops the vehicle like a wall, the chassis never more than
// kMaxPenetration inside its trunk.
TEST(Obstacles, StrongTreeStopsTheVehicleLikeABuilding)
{
  terrain::ObjectSet objects;
  const double d = 0.5;
  objects.add(object(terrain::ObjectType::kTree, 0.0, 0.0, d, d, 15.0, std::numeric_limits<double>::infinity()));
  const LaunchRun run = launch(&objects, 15.0, DriveCommand{ 0.5, 0.0, 0.0 }, 3.0, Target::kCylinder, 0.0, 0.5 * d);
  ASSERT_GT(run.first_contact_time, 0.0);
  std::printf("large tree at 15 m/s: deepest chassis depth in the trunk %.1f mm\n", 1e3 * run.max_reach);
  EXPECT_LT(run.max_reach, kMaxPenetration);
  EXPECT_LT(run.final.linear_velocity.norm(), 0.1);
  EXPECT_LT(run.final.pose.translation().x(), -2.0);
  EXPECT_FALSE(objects.get(0).toppled);
  EXPECT_EQ(run.collisions, 1u);
}

// A rock (rigid box) 0.25 m high under the left wheels: the wheels climb it (a box edge pushes
// through the wheel's axle) and roll over its top instead of through it.
TEST(Obstacles, WheelsClimbALowRock)
{
  const VehicleModel m = vehicle("fed_alpha");
  auto ground = flatGround(-50.0, 80.0, 30.0);
  terrain::ObjectSet objects;
  const double height = 0.25;
  objects.add(object(terrain::ObjectType::kRock, 0.0, 0.95, 1.0, 0.8, height, std::numeric_limits<double>::infinity()));
  World world(*ground);
  world.setObstacles(objects);
  const std::size_t id = world.addVehicle(m, world.restingPose(m, -10.0, 0.0, 0.0, 0.0));
  world.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
  world.advance(0.5);
  world.setVelocity(id, Eigen::Vector3d(3.0, 0.0, 0.0));
  world.setCommand(id, DriveCommand{ 0.3, 0.0, 0.0 });
  const WheelSpec* front_left = nullptr;
  std::size_t index = 0;
  for (std::size_t k = 0; k < m.wheels.size(); ++k)
    if (m.wheels[k].name == "front_left")
    {
      front_left = &m.wheels[k];
      index = k;
    }
  ASSERT_NE(front_left, nullptr);
  auto wheelCentre = [&](const VehicleState& s) {
    return s.pose * (front_left->rest_position + s.wheels[index].suspension_deflection * Eigen::Vector3d::UnitZ());
  };
  // Over the rock's middle (|x| < 0.3 m of its 1 m length) the wheel's lowest point may not be
  // below the rock's top by more than the contact's surface layer and one step's settling.
  double lowest_on_top = std::numeric_limits<double>::infinity(), max_roll = 0.0;
  int contact_steps_on_top = 0;
  for (int k = 0; k < 5000; ++k)
  {
    world.step();
    const VehicleState& s = world.state(id);
    const Eigen::Vector3d c = wheelCentre(s);
    if (std::abs(c.x()) < 0.3)
    {
      lowest_on_top = std::min(lowest_on_top, c.z() - front_left->radius - height);
      contact_steps_on_top += s.obstacle_contacts > 0;
    }
    max_roll = std::max(max_roll, std::abs(std::atan2(s.pose.linear()(2, 1), s.pose.linear()(2, 2))));
  }
  std::printf(
      "0.25 m rock at 3 m/s: front left wheel's lowest point over the rock's middle %.1f mm above its top "
      "(%d steps in contact), largest roll %.3f rad\n",
      1e3 * lowest_on_top, contact_steps_on_top, max_roll);
  EXPECT_GT(lowest_on_top, -0.005);
  EXPECT_LT(lowest_on_top, 0.05);  // on it, not flying over it
  EXPECT_GT(contact_steps_on_top, 0);
  EXPECT_LT(max_roll, 0.2);
  EXPECT_GT(world.state(id).pose.translation().x(), 5.0);
  EXPECT_FALSE(objects.get(0).toppled);
}

// A shrub (1500 N) in the path: it topples towards the travel, stays down, and costs the vehicle
// what the reported impulse says: bounded by its strength times the contact time.
TEST(Obstacles, ShrubToppleseAndTheVehiclePassesLosingLittleSpeed)
{
  const double strength = 1500.0, speed = 10.0;
  auto run = [&](bool with_shrub, terrain::ObjectSet& objects, std::vector<VehicleState>& states) {
    const VehicleModel m = vehicle("fed_alpha");
    auto ground = flatGround(-50.0, 80.0, 30.0);
    World world(*ground);
    if (with_shrub)
      objects.add(object(terrain::ObjectType::kShrub, 0.0, 0.0, 1.2, 1.0, 1.5, strength));
    world.setObstacles(objects);
    const std::size_t id = world.addVehicle(m, world.restingPose(m, -30.0, 0.0, 0.0, 0.0));
    world.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
    world.advance(0.5);
    world.setVelocity(id, Eigen::Vector3d(speed, 0.0, 0.0));
    world.setCommand(id, DriveCommand{ 0.0, 0.0, 0.0 });  // coasting: no controller to hide the loss
    for (int k = 0; k < 4500; ++k)
    {
      world.step();
      states.push_back(world.state(id));
    }
  };
  terrain::ObjectSet with, without;
  std::vector<VehicleState> a, b;
  run(true, with, a);
  run(false, without, b);
  const terrain::TerrainObject& shrub = with.get(0);
  ASSERT_TRUE(shrub.toppled);
  EXPECT_NEAR(shrub.fall_direction, 0.0, 0.05);  // towards +x, the travel
  const double h = 0.001, mass = 5710.0;
  double impulse = 0.0, peak_force = 0.0;
  std::size_t first = a.size(), last = 0;
  CollisionCounter counter;
  for (std::size_t k = 0; k < a.size(); ++k)
  {
    // A shrub is not a rigid obstacle: never a collision (it is reported as toppled instead).
    EXPECT_EQ(a[k].obstacle_rigid_contacts, 0) << "step " << k;
    counter.update(a[k], 0.001 * static_cast<double>(k + 1));
    if (a[k].obstacle_contacts == 0)
      continue;
    first = std::min(first, k);
    last = k;
    impulse += a[k].obstacle_impulse.x();
    peak_force = std::max(peak_force, a[k].obstacle_impulse.norm() / h);
  }
  ASSERT_LT(first, a.size()) << "never touched the shrub";
  EXPECT_EQ(counter.count(), 0u);
  const double contact_time = (last - first + 1) * h;
  // Momentum lost against the run without the shrub, 50 ms after the shrub went down.
  const std::size_t k = last + 50;
  const double lost = mass * (b[k].linear_velocity.x() - a[k].linear_velocity.x());
  std::printf(
      "shrub %.0f N at %.0f m/s: in contact %.0f ms, peak force %.0f N, impulse %.2f N s, momentum lost "
      "against the run without it %.2f N s\n",
      strength, speed, 1e3 * contact_time, peak_force, -impulse, lost);
  EXPECT_LE(peak_force, strength * (1.0 + 1e-9));  // resists with at most its strength
  EXPECT_LE(-impulse, strength * contact_time);
  // Elastic up to its strength over <= 0.1 m: about strength * 0.1 m / v / 2.
  EXPECT_GT(-impulse, 0.25 * strength * 0.1 / speed);
  EXPECT_NEAR(lost, -impulse, 0.25 * -impulse);
  // Down for good: no contact after it fell, and the vehicle rolled on well past it.
  for (std::size_t j = last + 1; j < a.size(); ++j)
    ASSERT_EQ(a[j].obstacle_contacts, 0) << "step " << j;
  EXPECT_TRUE(with.get(0).toppled);
  // Its rear (2.45 m behind base_link) well past the shrub, within a few cm of where it got to without it.
  EXPECT_GT(a.back().pose.translation().x() - 2.45, 2.0);
  EXPECT_NEAR(a.back().pose.translation().x(), b.back().pose.translation().x(), 0.05);
  EXPECT_GT(a.back().linear_velocity.x(), 0.99 * b.back().linear_velocity.x());
}

// A skid-steer robot of 80 kg starting 2 cm from a 1500 N shrub cannot push it over: its soil
// traction (a few hundred N) is far below the strength and its run-up gives it a few J against
// the 75 J (1500 N x 0.1 m / 2) the shrub stores before it gives. The shrub stands, the robot is
// held, and the shrub's force balances the robot's traction. (From 1.5 m away the same robot
// arrives at 1.9 m/s with 144 J and does push it over: the resistance is elastic, not a wall.)
TEST(Obstacles, WeakPushLeavesAShrubStanding)
{
  const VehicleModel m = vehicle("tracer_x");
  auto ground = flatGround(-10.0, 20.0, 10.0, 0.05);
  terrain::ObjectSet objects;
  objects.add(object(terrain::ObjectType::kShrub, 1.5, 0.0, 1.0, 1.0, 1.0, 1500.0));
  World world(*ground);
  world.setObstacles(objects);
  // Chassis front 0.475 m ahead of base_link; the shrub's face at x = 1.0.
  ASSERT_NEAR(m.collision_boxes[0].pose.translation().x() + 0.5 * m.collision_boxes[0].size.x(), 0.475, 1e-9);
  const std::size_t id = world.addVehicle(m, world.restingPose(m, 1.0 - 0.475 - 0.02, 0.0, 0.0, 0.0));
  world.setCommand(id, DriveCommand{ 1.0, 0.0, 0.0 });
  world.advance(4.0);
  double force = 0.0, traction = 0.0;
  const int n = 500;
  for (int k = 0; k < n; ++k)
  {
    world.step();
    force += world.state(id).obstacle_impulse.x() / world.options().step / n;
    for (const WheelState& w : world.state(id).wheels)
      traction += w.traction_force / n;
  }
  const VehicleState& s = world.state(id);
  std::printf("tracer_x against a 1500 N shrub: shrub force %.0f N, soil traction %.0f N\n", -force, traction);
  EXPECT_FALSE(objects.get(0).toppled);
  EXPECT_GT(s.obstacle_contacts, 0);
  EXPECT_LT(s.linear_velocity.norm(), 0.02);
  // Front of the chassis (0.475 m ahead of base_link) within the shrub's yield depth.
  EXPECT_LT(s.pose.translation().x() + 0.475 - 1.0, 0.1);
  EXPECT_GT(-force, 0.0);
  EXPECT_LT(-force, 1500.0);
  EXPECT_NEAR(-force, traction, 0.05 * traction);
}

// World::removeVehicle between steps: a at -20 m runs at 8 m/s towards b (0 m) and c (12 m),
// parked in its way; b is taken out just before a reaches it. a passes b's place (b's geoms are
// gone) and runs into c, now index 1 (its geoms tagged again: the contact is reported on index 1,
// equal and opposite to a's). Unknown indices throw and change nothing; the same script gives the
// same bits twice; a vehicle added after a removal takes the next index.
TEST(Obstacles, RemovedVehicleLeavesTheWorldAndTheOthersKeepColliding)
{
  const VehicleModel m = vehicle("fed_alpha");
  struct Run
  {
    std::vector<double> a, c;  ///< fingerprints at the end
    double a_x_at_removal = 0.0, a_max_x = 0.0, c_x_before = 0.0, c_x_after = 0.0, worst_third_law = 0.0;
    double largest_impulse = 0.0;
    std::size_t count_after = 0, readded = 0;
    std::string c_name;
  };
  const auto run = [&] {
    Run r;
    auto ground = flatGround(-40.0, 80.0, 20.0);
    World world(*ground);
    const std::size_t a = world.addVehicle(m, world.restingPose(m, -20.0, 0.0, 0.0, 0.0), "a");
    const std::size_t b = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.0), "b");
    world.addVehicle(m, world.restingPose(m, 12.0, 0.0, 0.0, 0.0), "c");
    for (std::size_t v = 0; v < 3; ++v)
      world.setCommand(v, DriveCommand{ 0.0, 1.0, 0.0 });
    world.advance(0.5);
    world.setVelocity(a, Eigen::Vector3d(8.0, 0.0, 0.0));
    world.setCommand(a, DriveCommand{ 0.0, 0.0, 0.0 });
    // 1.5 s at 8 m/s: a's front (about 2.5 m ahead of its origin) is a metre short of b's rear.
    world.advance(1.5);
    EXPECT_EQ(world.state(b).obstacle_contacts, 0u);
    r.a_x_at_removal = world.state(a).pose.translation().x();
    r.c_x_before = world.state(2).pose.translation().x();
    EXPECT_THROW(world.removeVehicle(3), std::out_of_range);
    EXPECT_EQ(world.vehicleCount(), 3u) << "a refused removal changes nothing";
    world.removeVehicle(b);
    r.count_after = world.vehicleCount();
    const std::size_t c = 1;  // c moved down one index
    r.c_name = world.state(c).name;
    world.setCommand(c, DriveCommand{ 0.0, 0.0, 0.0 });  // c unbraked: a pushes it
    for (int k = 0; k < 3000; ++k)
    {
      world.step();
      const VehicleState &sa = world.state(a), &sc = world.state(c);
      r.a_max_x = std::max(r.a_max_x, sa.pose.translation().x());
      r.worst_third_law = std::max(r.worst_third_law, (sa.obstacle_impulse + sc.obstacle_impulse).norm());
      r.largest_impulse = std::max(r.largest_impulse, sc.obstacle_impulse.norm());
    }
    r.c_x_after = world.state(c).pose.translation().x();
    r.a = fingerprint(world.state(a));
    r.c = fingerprint(world.state(c));
    r.readded = world.addVehicle(m, world.restingPose(m, -30.0, 0.0, 0.0, 0.0), "b");
    world.step();
    return r;
  };
  const Run first = run(), second = run();
  std::printf(
      "b removed with a at x = %.2f m; a then reached x = %.2f m (b stood at 0) and pushed c from %.2f to %.2f m; "
      "largest impulse on c %.1f N s, |impulse a + impulse c| <= %.3g N s\n",
      first.a_x_at_removal, first.a_max_x, first.c_x_before, first.c_x_after, first.largest_impulse,
      first.worst_third_law);
  EXPECT_EQ(first.count_after, 2u);
  EXPECT_EQ(first.c_name, "c");
  EXPECT_LT(first.a_x_at_removal, -3.0);
  EXPECT_GT(first.a_max_x, 3.0) << "a stopped where b was: b's geoms are still there";
  EXPECT_LT(first.a_max_x, first.c_x_after - 4.8) << "a passed through c";
  EXPECT_GT(first.c_x_after, first.c_x_before + 0.1) << "c was not pushed";
  EXPECT_GT(first.largest_impulse, 10.0) << "no contact reported on c's new index";
  EXPECT_LT(first.worst_third_law, 1e-9 * first.largest_impulse);
  EXPECT_EQ(first.readded, 2u);
  EXPECT_TRUE(sameBits(first.a, second.a));
  EXPECT_TRUE(sameBits(first.c, second.c));
}

// A fed_alpha at 8 m/s runs into the back of another at rest (unbraked): they collide instead
// of passing through each other, the contact forces are equal and opposite, and the total
// momentum survives the impact (nearly plastic: they part slowly).
TEST(Obstacles, TwoVehiclesCollideRatherThanPassThrough)
{
  const VehicleModel m = vehicle("fed_alpha");
  auto ground = flatGround(-40.0, 80.0, 20.0);
  World world(*ground);
  const std::size_t a = world.addVehicle(m, world.restingPose(m, -20.0, 0.0, 0.0, 0.0), "a");
  const std::size_t b = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.0), "b");
  for (std::size_t v : { a, b })
    world.setCommand(v, DriveCommand{ 0.0, 1.0, 0.0 });
  world.advance(0.5);
  const double speed = 8.0;
  world.setVelocity(a, Eigen::Vector3d(speed, 0.0, 0.0));
  for (std::size_t v : { a, b })
    world.setCommand(v, DriveCommand{ 0.0, 0.0, 0.0 });
  const double h = world.options().step;
  double max_overlap = -1.0, worst_third_law = 0.0, largest_impulse = 0.0;
  Eigen::Vector3d com_a = world.state(a).centre_of_mass, com_b = world.state(b).centre_of_mass;
  double p_before = 0.0, p_previous = 0.0, va_after = 0.0, vb_after = 0.0;
  long contact_step = -1;
  CollisionCounter collisions_a, collisions_b;
  for (long k = 0; k < 3000; ++k)
  {
    world.step();
    const VehicleState &sa = world.state(a), &sb = world.state(b);
    collisions_a.update(sa, world.time());
    collisions_b.update(sb, world.time());
    EXPECT_EQ(sa.obstacle_rigid_contacts, sb.obstacle_rigid_contacts);  // one contact, seen from both sides
    const double va = comVelocity(com_a, sa.centre_of_mass, h).x(), vb = comVelocity(com_b, sb.centre_of_mass, h).x();
    com_a = sa.centre_of_mass;
    com_b = sb.centre_of_mass;
    // a's front face (its max x) against b's rear face (its min x).
    double front_a = -1e9, rear_b = 1e9;
    for (const Eigen::Vector3d& c : chassisCorners(m, sa))
      front_a = std::max(front_a, c.x());
    for (const Eigen::Vector3d& c : chassisCorners(m, sb))
      rear_b = std::min(rear_b, c.x());
    max_overlap = std::max(max_overlap, front_a - rear_b);
    worst_third_law = std::max(worst_third_law, (sa.obstacle_impulse + sb.obstacle_impulse).norm());
    largest_impulse = std::max(largest_impulse, sa.obstacle_impulse.norm());
    if (sa.obstacle_contacts > 0 && contact_step < 0)
    {
      contact_step = k;
      p_before = p_previous;  // this step's velocities already carry the contact's impulse
    }
    if (contact_step >= 0 && k == contact_step + 30)
    {
      va_after = va;
      vb_after = vb;
    }
    p_previous = m.total_mass * (va + vb);
  }
  ASSERT_GE(contact_step, 0) << "the vehicles never touched";
  const double p_after = m.total_mass * (va_after + vb_after);
  std::printf(
      "rear-end at %.0f m/s: deepest overlap %.1f mm; |impulse a + impulse b| <= %.3g N s (largest %.0f N s); "
      "total momentum %.0f -> %.0f N s 30 ms later, a %.2f m/s, b %.2f m/s\n",
      speed, 1e3 * max_overlap, worst_third_law, largest_impulse, p_before, p_after, va_after, vb_after);
  EXPECT_LT(max_overlap, kMaxPenetration);
  EXPECT_LT(worst_third_law, 1e-9 * largest_impulse);
  EXPECT_NEAR(p_after, p_before, 0.03 * p_before);
  // Nearly plastic: the contact has no bounce; what separates them after is the vehicles' own
  // give (the soil's shear under b's sliding wheels, suspension): restitution e = (vb - va) /
  // v_approach at most 0.15 (measured 0.10; a rigid, elastic contact would give 1).
  const double approach = p_before / m.total_mass;  // b was at rest
  const double restitution = (vb_after - va_after) / approach;
  std::printf("restitution %.3f\n", restitution);
  EXPECT_GE(restitution, -0.02);  // a does not overtake (pass through) b
  EXPECT_LT(restitution, 0.15);
  // One collision each (a pushes b on at the common speed: they may touch again, the same collision).
  EXPECT_EQ(collisions_a.count(), 1u);
  EXPECT_EQ(collisions_b.count(), 1u);
  // Never through: a stays behind b.
  EXPECT_LT(world.state(a).pose.translation().x(), world.state(b).pose.translation().x() - 4.8);
}

// The collision count's rule on given contact sequences: a collision begins at the first step with
// rigid contact points after >= 0.5 s without any.
TEST(CollisionCounter, CountsContactsBegunAfterASeparation)
{
  CollisionCounter c(0.5, 0.5);
  auto at = [](double x) { return Eigen::Vector3d(x, 0.0, 0.0); };
  EXPECT_FALSE(c.update(0, 0.001, at(0.0)));
  EXPECT_EQ(c.count(), 0u);
  EXPECT_TRUE(c.update(3, 0.002, at(0.0)));  // first contact: a collision
  EXPECT_TRUE(c.inContact());
  EXPECT_FALSE(c.update(2, 0.003, at(0.0)));    // the same one goes on
  EXPECT_FALSE(c.update(0, 0.004, at(-0.01)));  // bounces off ...
  EXPECT_FALSE(c.inContact());
  EXPECT_FALSE(c.update(1, 0.010, at(0.0)));  // ... and touches again 7 ms later: the same collision
  EXPECT_EQ(c.count(), 1u);
  // Off for 0.5 s and 0.2 m back and forth (0.4 m of travel): still the same.
  EXPECT_FALSE(c.update(0, 0.3, at(-0.2)));
  EXPECT_FALSE(c.update(1, 0.6, at(0.0)));
  // Off for 0.499 s after 2 m of travel: the same.
  EXPECT_FALSE(c.update(0, 0.7, at(-1.0)));
  EXPECT_FALSE(c.update(1, 1.099, at(0.0)));
  EXPECT_EQ(c.count(), 1u);
  // Off for 0.6 s and 1 m of travel: a new one.
  EXPECT_FALSE(c.update(0, 1.4, at(-0.5)));
  EXPECT_TRUE(c.update(1, 1.7, at(0.0)));
  EXPECT_EQ(c.count(), 2u);
  EXPECT_FALSE(c.update(0, 5.0, at(-3.0)));
  EXPECT_TRUE(c.update(4, 10.0, at(0.0)));
  EXPECT_EQ(c.count(), 3u);
  EXPECT_THROW(CollisionCounter(-1.0), std::invalid_argument);
  EXPECT_THROW(CollisionCounter(std::nan("")), std::invalid_argument);
  EXPECT_THROW(CollisionCounter(0.5, -0.1), std::invalid_argument);
}

// Collision must not disturb the soil-only physics: with obstacles far from the path the run is
// bit-identical to one without any; with collisions, two runs are bit-identical.
TEST(Obstacles, FarFromObstaclesTheRunIsBitIdenticalAndCollisionsAreDeterministic)
{
  auto drive = [](terrain::ObjectSet* objects) {
    const VehicleModel m = vehicle("fed_alpha");
    auto ground = flatGround(-50.0, 100.0, 60.0);
    World world(*ground);
    if (objects)
      world.setObstacles(*objects);
    const std::size_t id = world.addVehicle(m, world.restingPose(m, -30.0, 0.0, 0.0, 0.01));
    world.setCommand(id, DriveCommand{ 0.4, 0.0, 0.3 });
    std::vector<std::vector<double>> trace;
    for (int k = 0; k < 3000; ++k)
    {
      world.step();
      trace.push_back(fingerprint(world.state(id)));
    }
    return trace;
  };
  terrain::ObjectSet far;
  const double inf = std::numeric_limits<double>::infinity();
  far.add(object(terrain::ObjectType::kBuilding, 30.0, 20.0, 10.0, 8.0, 5.0, inf));
  far.add(object(terrain::ObjectType::kTree, -20.0, -20.0, 0.5, 0.5, 12.0, inf));
  far.add(object(terrain::ObjectType::kShrub, 10.0, -25.0, 1.5, 1.2, 1.5, 900.0));
  far.add(object(terrain::ObjectType::kRock, -40.0, 25.0, 1.0, 0.8, 0.5, inf));
  far.add(object(terrain::ObjectType::kGrass, -25.0, 0.0, 5.0, 5.0, 0.5, 0.0));  // under the path: never collides
  const auto plain = drive(nullptr);
  const auto with = drive(&far);
  ASSERT_EQ(plain.size(), with.size());
  for (std::size_t k = 0; k < plain.size(); ++k)
    ASSERT_TRUE(sameBits(plain[k], with[k])) << "diverged at step " << k;

  // With collisions (the building crash): two runs, bit for bit.
  terrain::ObjectSet wall1, wall2;
  for (terrain::ObjectSet* w : { &wall1, &wall2 })
  {
    w->add(object(terrain::ObjectType::kBuilding, 5.0, 0.0, 10.0, 14.0, 6.0, inf));
    w->add(object(terrain::ObjectType::kShrub, -10.0, 0.3, 1.0, 1.0, 1.5, 800.0));
  }
  const LaunchRun r1 = launch(&wall1, 15.0, DriveCommand{ 1.0, 0.0, 0.0 }, 3.0, Target::kPlane, 0.0);
  const LaunchRun r2 = launch(&wall2, 15.0, DriveCommand{ 1.0, 0.0, 0.0 }, 3.0, Target::kPlane, 0.0);
  ASSERT_EQ(r1.trace.size(), r2.trace.size());
  for (std::size_t k = 0; k < r1.trace.size(); ++k)
    ASSERT_TRUE(sameBits(r1.trace[k], r2.trace[k])) << "diverged at step " << k;
  ASSERT_TRUE(wall1.get(1).toppled);
  EXPECT_EQ(std::memcmp(&wall1.get(1).fall_direction, &wall2.get(1).fall_direction, sizeof(double)), 0);
}

TEST(Obstacles, BadInputGivesClearErrorsNamingTheObject)
{
  auto ground = flatGround(-10.0, 20.0, 10.0);
  World world(*ground);
  const double inf = std::numeric_limits<double>::infinity();
  // The ObjectSet itself refuses non-finite or non-positive footprints, naming the object.
  terrain::ObjectSet objects;
  objects.add(object(terrain::ObjectType::kBuilding, 5.0, 0.0, 4.0, 4.0, 3.0, inf));
  try
  {
    objects.add(object(terrain::ObjectType::kRock, 2.0, 1.0, NAN, 1.0, 0.5, inf));
    ADD_FAILURE() << "a NaN length was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("object 1 (rock at (2, 1)): length"), std::string::npos) << e.what();
  }
  world.setObstacles(objects);
  EXPECT_EQ(world.obstacleGeomCount(), 1u);

  // Height 0 is a valid ObjectSet entry (a marker) but not something to collide with.
  terrain::ObjectSet flat;
  flat.add(object(terrain::ObjectType::kShrub, 0.0, 0.0, 1.0, 1.0, 1.0, 500.0));
  flat.add(object(terrain::ObjectType::kRock, 3.0, -1.5, 1.0, 1.0, 0.0, inf));
  try
  {
    world.setObstacles(flat);
    ADD_FAILURE() << "a rock 0 m tall was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find("object 1 (rock at (3, -1.5))"), std::string::npos) << what;
    EXPECT_NE(what.find("height must be finite and > 0 m"), std::string::npos) << what;
  }
  EXPECT_EQ(world.obstacleGeomCount(), 1u);  // the previous set stays

  terrain::ObjectSet away;
  away.add(object(terrain::ObjectType::kTree, 50.0, 0.0, 0.3, 0.3, 8.0, inf));
  try
  {
    world.setObstacles(away);
    ADD_FAILURE() << "an object off the terrain was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("object 0 (tree at (50, 0)) is off the terrain"), std::string::npos)
        << e.what();
  }

  const VehicleModel m = vehicle("fed_alpha");
  const std::size_t id = world.addVehicle(m, world.restingPose(m, -5.0, 0.0, 0.0, 0.0));
  EXPECT_THROW(world.setVelocity(id, Eigen::Vector3d(NAN, 0.0, 0.0)), std::invalid_argument);
  EXPECT_THROW(world.setVelocity(id + 1, Eigen::Vector3d::Zero()), std::out_of_range);
}
