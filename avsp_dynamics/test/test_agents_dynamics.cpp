// Dynamic agents in the ODE world (World::setAgents): kinematic bodies that follow their path
// whatever the vehicles do. A truck crossing through a braked fed_alpha pushes it aside at its own
// speed without the two ever overlapping; a fed_alpha driven into a slowly crossing truck's side
// stops at it; one launched at a standing pedestrian stops at it (and passes where it would be
// without the pedestrian); runs are bit-identical.
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

terrain::Agent agent(const std::string& name, terrain::AgentType type, std::vector<Eigen::Vector2d> path,
                     double speed, const terrain::ElevationGrid& ground)
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
        const Eigen::Vector3d local = w.rest_position + Eigen::Vector3d(w.radius * std::cos(a), side * w.width,
                                                                        w.radius * std::sin(a));
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
double depthInAgent(const VehicleModel& m, const VehicleState& s, const terrain::AgentState& a,
                    terrain::AgentType type, bool agent_faces = false)
{
  const Eigen::Isometry3d agent_pose =
      Eigen::Translation3d(a.position) * Eigen::AngleAxisd(a.yaw, Eigen::Vector3d::UnitZ());
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
  // An 8 m truck driving north at 3 m/s along x = 0: its front (centre + 4 m) reaches the
  // braked 4x4's right side (y = -0.95 m) at about t = 5 s.
  const double v = 3.0;
  std::vector<terrain::Agent> agents;
  agents.push_back(agent("truck", terrain::AgentType::kTruck, { { 0.0, -20.0 }, { 0.0, 40.0 } }, v, ground->base()));
  world.setAgents(agents);
  ASSERT_EQ(world.agentCount(), 1u);
  world.advance(1.0);  // settle
  const double y_settled = world.state(car).pose.translation().y();
  double deepest = -1.0;
  int contact_steps = 0;
  for (int k = 0; k < 9000; ++k)
  {
    world.step();
    // The truck follows its pure function of time, whatever it pushes.
    const terrain::AgentState a = world.agentState(0);
    EXPECT_NEAR(a.position.y(), -20.0 + v * world.time(), 1e-9);
    deepest = std::max(deepest, depthInAgent(m, world.state(car), a, terrain::AgentType::kTruck));
    contact_steps += world.state(car).obstacle_contacts > 0;
  }
  EXPECT_LT(deepest, kMaxPenetration);
  EXPECT_GT(contact_steps, 3000);
  // Pushed along by the truck: at t = 10 s its front is at y = 14 m, the 4x4 just ahead of it
  // (half its width, 0.95 m), moving at the truck's speed.
  const VehicleState& s = world.state(car);
  const double front = -20.0 + v * world.time() + 4.0;
  EXPECT_GT(s.pose.translation().y(), y_settled + 10.0);
  EXPECT_NEAR(s.pose.translation().y(), front + 0.95, 0.5);
  EXPECT_NEAR(s.linear_velocity.y(), v, 0.3);
  EXPECT_LT(std::abs(s.pose.translation().x()), 1.0);  // pushed straight, not thrown off the side
  std::printf("[agents] truck push: deepest %.1f mm, vehicle %.2f m ahead of the front, v_y %.3f m/s, x %.3f m\n",
              1e3 * deepest, s.pose.translation().y() - front, s.linear_velocity.y(), s.pose.translation().x());
}

TEST(Agents, VehicleDrivenIntoACrossingTruckStopsAtItsSide)
{
  auto ground = flatGravel();
  World world(*ground);
  const VehicleModel m = fedAlpha();
  const std::size_t car = world.addVehicle(m, world.restingPose(m, -10.0, 0.0, 0.0, 0.01), "ego");
  // The truck crosses slowly north along x = 20 (its side at x = 18.75), covering y = 0 for 10 s.
  std::vector<terrain::Agent> agents;
  agents.push_back(agent("truck", terrain::AgentType::kTruck, { { 20.0, -2.0 }, { 20.0, 40.0 } }, 0.5, ground->base()));
  world.setAgents(agents);
  world.setVelocity(car, { 8.0, 0.0, 0.0 });
  world.setCommand(car, { 0.3, 0.0, 0.0 });
  double deepest = -1.0, first_contact = -1.0;
  for (int k = 0; k < 8000; ++k)
  {
    world.step();
    const VehicleState& s = world.state(car);
    deepest = std::max(deepest, depthInAgent(m, s, world.agentState(0), terrain::AgentType::kTruck));
    if (first_contact < 0.0 && s.obstacle_contacts > 0)
      first_contact = world.time();
  }
  EXPECT_LT(deepest, kMaxPenetration);
  // Without the truck it would have passed x = 18.75 by t = 3.5 s (28.75 m at >= 8 m/s).
  EXPECT_GT(first_contact, 2.0);
  EXPECT_LT(first_contact, 3.7);
  const VehicleState& s = world.state(car);
  EXPECT_LT(s.pose.translation().x(), 18.75);
  EXPECT_LT(std::abs(s.linear_velocity.x()), 0.2);  // held against the truck's side
  std::printf("[agents] into the truck's side: first contact %.3f s, deepest %.1f mm, x %.3f m, v_x %.3f m/s\n",
              first_contact, 1e3 * deepest, s.pose.translation().x(), s.linear_velocity.x());
}

TEST(Agents, VehicleLaunchedAtAStandingPedestrianStops)
{
  const VehicleModel m = fedAlpha();
  auto run = [&](bool with_pedestrian, double& deepest) {
    auto ground = flatGravel();
    World world(*ground);
    const std::size_t car = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0, 0.01), "ego");
    std::vector<terrain::Agent> agents;
    if (with_pedestrian)
      agents.push_back(agent("walker", terrain::AgentType::kPedestrian, { { 15.0, 0.0 } }, 0.0, ground->base()));
    world.setAgents(agents);
    world.setVelocity(car, { 5.0, 0.0, 0.0 });
    world.setCommand(car, { 0.0, 0.0, 0.0 });  // coasting
    deepest = -1.0;
    const terrain::AgentState standing = terrain::AgentState{ Eigen::Vector3d(15.0, 0.0, 0.0), 0.0, {}, 0.0, false };
    for (int k = 0; k < 5000; ++k)
    {
      world.step();
      deepest = std::max(deepest, depthInAgent(m, world.state(car), standing, terrain::AgentType::kPedestrian, true));
    }
    return world.state(car);
  };
  double deepest_with = 0.0, deepest_without = 0.0;
  const VehicleState with = run(true, deepest_with);
  const VehicleState without = run(false, deepest_without);
  EXPECT_GT(deepest_without, 0.1);  // coasting on, it would run right through where the pedestrian stands
  EXPECT_LT(deepest_with, kMaxPenetration);
  EXPECT_LT(with.linear_velocity.norm(), 0.1);
  EXPECT_LT(with.pose.translation().x(), 15.0 - 0.15);
  EXPECT_GT(without.pose.translation().x(), 16.0);  // its base_link past where the pedestrian stands
  std::printf("[agents] pedestrian: deepest %.1f mm, stopped at x %.3f m (%.3f m/s); without it x %.2f m\n",
              1e3 * deepest_with, with.pose.translation().x(), with.linear_velocity.norm(), without.pose.translation().x());
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
    agents.push_back(agent("deer", terrain::AgentType::kDeer, { { 5.0, -5.0 }, { 5.0, 5.0 }, { 9.0, 9.0 } }, 4.0,
                           ground->base()));
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
