// Dynamic agents in the ODE world (World::setAgents): bodies of their mass (a truck 10 t, a
// pedestrian 80 kg, a deer 100 kg) driven along their paths with bounded force. A truck crossing
// through a braked fed_alpha pushes it aside at its own speed without the two ever overlapping; a
// fed_alpha driven into a slowly crossing truck's side stops at it and shoves it less than
// momentum allows; one coasting into a standing pedestrian shoves the pedestrian ahead and loses
// what the collision of the two masses says; a deer walking into a braked M113 barely moves it;
// runs are bit-identical.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <avsp_terrain/agents.hpp>
#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp::dynamics;
namespace terrain = avsp::terrain;

namespace
{
/// m: the most any part of a vehicle may be inside an agent (a step's travel plus the 1 mm layer).
constexpr double kMaxPenetration = 0.05;

const terrain::SoilLibrary& soils()
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  return lib;
}

VehicleModel fedAlpha()
{
  return loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/fed_alpha.yaml");
}

/// Level gravel, 100 m x 100 m centred on the origin, 0.1 m cells.
std::unique_ptr<terrain::DeformableTerrain> flatGravel()
{
  const std::size_t n = 1001;
  return std::make_unique<terrain::DeformableTerrain>(
      terrain::ElevationGrid(-50.0, -50.0, 0.1, 0.1, n, n, std::vector<float>(n * n, 0.f)), soils().get("gravel"),
      terrain::DeformableTerrain::Options{ true });
}

terrain::Agent agent(const std::string& name, terrain::AgentType type, std::vector<Eigen::Vector2d> path, double speed,
                     const terrain::ElevationGrid& ground)
{
  terrain::AgentSpec s;
  s.name = name;
  s.type = type;
  s.path = std::move(path);
  s.speed = speed;
  return terrain::Agent(s, ground, "agents[0]");
}

/// Every corner of the vehicle's chassis boxes and the extreme points of its wheels (their
/// discs sampled every 10 deg), in map.
std::vector<Eigen::Vector3d> vehiclePoints(const VehicleModel& m, const VehicleState& s)
{
  std::vector<Eigen::Vector3d> out;
  for (const CollisionBox& b : m.collision_boxes)
    for (int k = 0; k < 8; ++k)
    {
      const Eigen::Vector3d local(k & 1 ? 0.5 : -0.5, k & 2 ? 0.5 : -0.5, k & 4 ? 0.5 : -0.5);
      out.push_back(s.pose * (b.pose * local.cwiseProduct(b.size)));
    }
  for (const WheelSpec& w : m.wheels)
    for (int k = 0; k < 36; ++k)
      for (double side : { -0.5, 0.5 })
      {
        const double a = k * M_PI / 18.0;
        const Eigen::Vector3d local =
            w.rest_position + Eigen::Vector3d(w.radius * std::cos(a), side * w.width, w.radius * std::sin(a));
        out.push_back(s.pose * local);
      }
  return out;
}

/// m: how far a point is inside a box (centre c, size, rotation r about z by yaw): the least
/// depth over its three axes (negative outside).
double depthInBox(const Eigen::Vector3d& p, const Eigen::Isometry3d& box, const Eigen::Vector3d& size)
{
  const Eigen::Vector3d local = box.inverse() * p;
  return (0.5 * size - local.cwiseAbs()).minCoeff();
}

/// m: how deep the vehicle and the agent overlap: the deepest of the vehicle's points (chassis
/// corners, wheel rims) inside the agent's boxes and, with `agent_faces`, of points on the agent's
/// boxes (a 5 cm grid on every face) inside the vehicle's chassis boxes; negative when apart (then
/// not a distance). A truck meets the vehicle's corners and rims first; a pedestrian, smaller than
/// the chassis, can sit between them (agent_faces: costly for a truck's 70 m² of faces per step).
double depthInAgent(const VehicleModel& m, const VehicleState& s, const Eigen::Isometry3d& agent_pose,
                    terrain::AgentType type, bool agent_faces = false)
{
  double deepest = -std::numeric_limits<double>::infinity();
  for (const terrain::AgentBox& b : terrain::agentBoxes(type))
  {
    const Eigen::Isometry3d box = agent_pose * Eigen::Translation3d(b.centre);
    for (const Eigen::Vector3d& p : vehiclePoints(m, s))
      deepest = std::max(deepest, depthInBox(p, box, b.size));
    if (!agent_faces)
      continue;
    // Points on the agent box's faces against the chassis boxes.
    const Eigen::Vector3i n = (b.size / 0.05).array().ceil().cast<int>().cwiseMax(1);
    for (int axis = 0; axis < 3; ++axis)
      for (double side : { -0.5, 0.5 })
        for (int i = 0; i <= n[(axis + 1) % 3]; ++i)
          for (int j = 0; j <= n[(axis + 2) % 3]; ++j)
          {
            Eigen::Vector3d local;
            local[axis] = side * b.size[axis];
            local[(axis + 1) % 3] = (static_cast<double>(i) / n[(axis + 1) % 3] - 0.5) * b.size[(axis + 1) % 3];
            local[(axis + 2) % 3] = (static_cast<double>(j) / n[(axis + 2) % 3] - 0.5) * b.size[(axis + 2) % 3];
            const Eigen::Vector3d p = box * local;
            for (const CollisionBox& c : m.collision_boxes)
              deepest = std::max(deepest, depthInBox(p, s.pose * c.pose, c.size));
          }
  }
  return deepest;
}
}  // namespace

TEST(Agents, TruckCrossingPushesABrakedVehicleAsideWithoutOverlap)
{
  auto ground = flatGravel();
  World world(*ground);
  const VehicleModel m = fedAlpha();
  const std::size_t car = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.01), "ego");
  world.setCommand(car, { 0.0, 1.0, 0.0 });
  // An 8 m, 10 t truck driving north at 3 m/s along x = 0: its front (centre + 4 m) reaches the
  // braked 4x4's right side (y = -0.95 m) at about t = 5 s. It pushes with up to 0.7 of its
  // weight (69 kN), more than the braked 4x4's grip (about 0.6 of its 56 kN): it keeps its pace.
  const double v = 3.0;
  std::vector<terrain::Agent> agents;
  agents.push_back(agent("truck", terrain::AgentType::kTruck, { { 0.0, -20.0 }, { 0.0, 40.0 } }, v, ground->base()));
  world.setAgents(agents);
  ASSERT_EQ(world.agentCount(), 1u);
  world.advance(1.0);  // settle
  const double y_settled = world.state(car).pose.translation().y();
  double deepest = -1.0, lag = 0.0;
  int contact_steps = 0;
  for (int k = 0; k < 9000; ++k)
  {
    world.step();
    const Eigen::Isometry3d truck = world.agentPose(0);
    lag = std::max(lag, world.agentState(0).position.y() - truck.translation().y());
    deepest = std::max(deepest, depthInAgent(m, world.state(car), truck, terrain::AgentType::kTruck));
    contact_steps += world.state(car).obstacle_contacts > 0;
  }
  EXPECT_LT(deepest, kMaxPenetration);
  EXPECT_GT(contact_steps, 3000);
  EXPECT_LT(lag, 0.5) << "the truck keeps (about) its path while it pushes";
  // Pushed along by the truck: at t = 10 s its front is at y = 14 m, the 4x4 just ahead of it
  // (half its width, 0.95 m), moving at the truck's speed.
  const VehicleState& s = world.state(car);
  const double front = world.agentPose(0).translation().y() + 4.0;
  EXPECT_GT(s.pose.translation().y(), y_settled + 10.0);
  EXPECT_NEAR(s.pose.translation().y(), front + 0.95, 0.5);
  EXPECT_NEAR(s.linear_velocity.y(), v, 0.3);
  EXPECT_LT(std::abs(s.pose.translation().x()), 1.0);  // pushed straight, not thrown off the side
  std::printf(
      "[agents] truck push: deepest %.1f mm, truck lag %.3f m, vehicle %.2f m ahead of the front, v_y %.3f "
      "m/s, x %.3f m\n",
      1e3 * deepest, lag, s.pose.translation().y() - front, s.linear_velocity.y(), s.pose.translation().x());
}

TEST(Agents, VehicleDrivenIntoACrossingTruckStopsAtItsSide)
{
  auto ground = flatGravel();
  World world(*ground);
  const VehicleModel m = fedAlpha();
  const std::size_t car = world.addVehicle(m, world.restingPose(m, -10.0, 0.0, 0.0, 0.01), "ego");
  // The 10 t truck crosses slowly north along x = 20 (its side at x = 18.75), covering y = 0 for 10 s.
  std::vector<terrain::Agent> agents;
  agents.push_back(agent("truck", terrain::AgentType::kTruck, { { 20.0, -2.0 }, { 20.0, 40.0 } }, 0.5, ground->base()));
  world.setAgents(agents);
  const double v0 = 8.0;
  world.setVelocity(car, { v0, 0.0, 0.0 });
  world.setCommand(car, { 0.3, 0.0, 0.0 });
  double deepest = -1.0, first_contact = -1.0, shoved = 0.0;
  for (int k = 0; k < 8000; ++k)
  {
    world.step();
    const VehicleState& s = world.state(car);
    const Eigen::Isometry3d truck = world.agentPose(0);
    deepest = std::max(deepest, depthInAgent(m, s, truck, terrain::AgentType::kTruck));
    shoved = std::max(shoved, truck.translation().x() - 20.0);
    if (first_contact < 0.0 && s.obstacle_contacts > 0)
      first_contact = world.time();
  }
  EXPECT_LT(deepest, kMaxPenetration);
  // Without the truck it would have passed x = 18.75 by t = 3.5 s (28.75 m at >= 8 m/s).
  EXPECT_GT(first_contact, 2.0);
  EXPECT_LT(first_contact, 3.7);
  const VehicleState& s = world.state(car);
  EXPECT_LT(s.pose.translation().x(), 18.75 + shoved);
  EXPECT_LT(std::abs(s.linear_velocity.x()), 0.3);  // held against the truck's side
  // Momentum: the plastic common speed u = m v / (m + M) shoved into the truck, which its push
  // force F (0.7 of its weight) less the 4x4's own drive (throttle 0.3 at low speed) stops within
  // (m + M) u^2 / (2 (F - F_drive)); the contact's push-out adds a little elastic rebound (1.25x).
  const double mt = terrain::agentMass(terrain::AgentType::kTruck);
  const double u = m.total_mass * v0 / (m.total_mass + mt);
  const double drive = 0.3 * wheelTorqueAvailable(m.drivetrain, 0.0, m.wheels[0].radius) / m.wheels[0].radius;
  EXPECT_GT(shoved, 0.0);
  EXPECT_LT(shoved,
            1.25 * (m.total_mass + mt) * u * u / (2.0 * (terrain::agentPushForce(terrain::AgentType::kTruck) - drive)));
  std::printf(
      "[agents] into the truck's side: first contact %.3f s, deepest %.1f mm, x %.3f m, v_x %.3f m/s, truck "
      "shoved %.3f m\n",
      first_contact, 1e3 * deepest, s.pose.translation().x(), s.linear_velocity.x(), shoved);
}

TEST(Agents, VehicleCoastingIntoAStandingPedestrianShovesIt)
{
  const VehicleModel m = fedAlpha();
  struct Run
  {
    double deepest = -1.0, speed_after = 0.0, pedestrian_x = 8.0;
  };
  auto run = [&](bool with_pedestrian) {
    auto ground = flatGravel();
    World world(*ground);
    const std::size_t car = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.01), "ego");
    std::vector<terrain::Agent> agents;
    if (with_pedestrian)
      agents.push_back(agent("walker", terrain::AgentType::kPedestrian, { { 8.0, 0.0 } }, 0.0, ground->base()));
    world.setAgents(agents);
    world.setVelocity(car, { 5.0, 0.0, 0.0 });
    world.setCommand(car, { 0.0, 0.0, 0.0 });  // coasting
    Run out;
    for (int k = 0; k < 2000; ++k)  // the front meets the pedestrian at about 1.2 s
    {
      world.step();
      if (with_pedestrian)
      {
        out.deepest = std::max(
            out.deepest, depthInAgent(m, world.state(car), world.agentPose(0), terrain::AgentType::kPedestrian, true));
        out.pedestrian_x = world.agentPose(0).translation().x();
      }
    }
    out.speed_after = world.state(car).linear_velocity.x();
    return out;
  };
  const Run with = run(true), without = run(false);
  EXPECT_LT(with.deepest, kMaxPenetration);
  // 80 kg against 5.7 t: at the impact the vehicle loses about m_p / (m + m_p) of its speed (the
  // pedestrian, holding its place with half its weight, takes a little more over the push).
  const double mp = terrain::agentMass(terrain::AgentType::kPedestrian);
  const double loss = without.speed_after - with.speed_after;
  EXPECT_GT(with.deepest, -0.1) << "they met";
  EXPECT_GT(loss, 0.5 * 3.5 * mp / (m.total_mass + mp));
  EXPECT_LT(loss, 0.3);
  EXPECT_GT(with.pedestrian_x, 8.0 + 1.0) << "the pedestrian is shoved ahead";
  std::printf("[agents] pedestrian: deepest %.1f mm, speed %.3f m/s (%.3f without), pedestrian at x %.2f m\n",
              1e3 * with.deepest, with.speed_after, without.speed_after, with.pedestrian_x);
}

TEST(Agents, DeerWalkingIntoABrakedCarrierBarelyMovesIt)
{
  auto ground = flatGravel();
  World world(*ground);
  const VehicleModel m = loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/m113.yaml");
  const std::size_t carrier = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.01), "m113");
  world.setCommand(carrier, { 0.0, 1.0, 0.0 });
  // A 100 kg deer walks north at 4 m/s straight into the carrier's right side.
  std::vector<terrain::Agent> agents;
  agents.push_back(agent("deer", terrain::AgentType::kDeer, { { 0.0, -8.0 }, { 0.0, 20.0 } }, 4.0, ground->base()));
  world.setAgents(agents);
  world.advance(1.0);
  const Eigen::Vector3d before = world.state(carrier).pose.translation();
  int contact_steps = 0;
  for (int k = 0; k < 4000; ++k)
  {
    world.step();
    contact_steps += world.state(carrier).obstacle_contacts > 0;
  }
  const Eigen::Vector3d moved = world.state(carrier).pose.translation() - before;
  EXPECT_GT(contact_steps, 100);
  // The deer pushes with at most its weight against the 12.3 t carrier's braked grip: a
  // centimetre at most (the kinematic deer shoved it 1.55 m).
  EXPECT_LT(std::hypot(moved.x(), moved.y()), 0.01);
  std::printf("[agents] deer into the M113: %d contact steps, carrier moved %.1f mm\n", contact_steps,
              1e3 * std::hypot(moved.x(), moved.y()));
}

TEST(Agents, RunsWithAgentsAreBitIdentical)
{
  auto run = [] {
    auto ground = flatGravel();
    World world(*ground);
    const VehicleModel m = fedAlpha();
    const std::size_t car = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.01), "ego");
    world.setCommand(car, { 0.0, 1.0, 0.0 });
    std::vector<terrain::Agent> agents;
    agents.push_back(agent("truck", terrain::AgentType::kTruck, { { 0.0, -9.0 }, { 0.0, 40.0 } }, 3.0, ground->base()));
    agents.push_back(
        agent("deer", terrain::AgentType::kDeer, { { 5.0, -5.0 }, { 5.0, 5.0 }, { 9.0, 9.0 } }, 4.0, ground->base()));
    world.setAgents(agents);
    world.advance(2.5);
    const VehicleState& s = world.state(car);
    std::vector<double> out(s.pose.data(), s.pose.data() + 16);
    out.insert(out.end(), s.linear_velocity.data(), s.linear_velocity.data() + 3);
    out.insert(out.end(), s.obstacle_impulse.data(), s.obstacle_impulse.data() + 3);
    return out;
  };
  const std::vector<double> a = run(), b = run();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0);
}

TEST(Agents, AgentStateOutOfRangeThrows)
{
  auto ground = flatGravel();
  World world(*ground);
  EXPECT_THROW(world.agentState(0), std::out_of_range);
}
