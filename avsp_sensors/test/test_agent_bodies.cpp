// Dynamic agents as scene bodies: a deer crossing in front of a sensor is hit where its boxes
// are at that time, with its type's reflectivity and its velocity; between its legs and above
// its back the rays pass; each box's velocity is the derivative of its centre (Doppler).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <avsp_terrain/agents.hpp>

#include "avsp_sensors/agent_bodies.hpp"
#include "avsp_sensors/scene.hpp"

using namespace avsp::sensors;
namespace terrain = avsp::terrain;

namespace
{
terrain::ElevationGrid flatGrid(double half = 50.0, double cell = 0.5)
{
  const std::size_t n = static_cast<std::size_t>(2 * half / cell) + 1;
  return terrain::ElevationGrid(-half, -half, cell, cell, n, n, std::vector<float>(n * n, 0.f));
}

terrain::Agent deer(std::vector<Eigen::Vector2d> path, double speed, bool loop, const terrain::ElevationGrid& g)
{
  terrain::AgentSpec s;
  s.name = "deer";
  s.type = terrain::AgentType::kDeer;
  s.path = std::move(path);
  s.speed = speed;
  s.loop = loop;
  return terrain::Agent(s, g, "agents[0]");
}

RayHit castX(const Scene& scene, double y, double z)
{
  Ray r;
  r.origin = Eigen::Vector3d(0.0, y, z);
  r.direction = Eigen::Vector3d::UnitX();
  r.max_range = 40.0;
  return scene.cast(r);
}
}  // namespace

TEST(AgentBodies, DeerCrossingIsHitWhereItIsAtThatTime)
{
  const terrain::ElevationGrid grid = flatGrid();
  // Crossing north along x = 10 at 2 m/s from y = -10: at y = 0 at t = 5 s (facing +y, so its
  // 0.4 m wide torso spans x = 9.8 .. 10.2 and its body y = -0.65 .. 0.95 with the head).
  const terrain::Agent a = deer({ { 10.0, -10.0 }, { 10.0, 20.0 } }, 2.0, false, grid);
  Scene scene(HeightField::fromGrid(grid));
  AgentReflectivities refl;
  scene.setBodies(agentBodies(a, 5.0, 7, refl));
  const RayHit torso = castX(scene, 0.0, 0.8);
  ASSERT_EQ(torso.kind, HitKind::kBody);
  EXPECT_EQ(torso.id, 7u);
  EXPECT_NEAR(torso.range, 9.8, 1e-9);
  EXPECT_FLOAT_EQ(torso.reflectivity, 0.3f);
  EXPECT_NEAR((torso.velocity - Eigen::Vector3d(0.0, 2.0, 0.0)).norm(), 0.0, 1e-9);
  // Above its back (1.2 m at the torso's middle: the head is 0.8 m ahead) and between its legs.
  EXPECT_FALSE(castX(scene, 0.0, 1.2).hit());
  EXPECT_FALSE(castX(scene, 0.0, 0.3).hit());
  // A front leg: 0.5 m ahead of the torso's centre; the nearer one 0.12 m to the deer's left
  // (-x when it faces +y), 0.1 m thick: its face at 10 - 0.12 - 0.05.
  const RayHit leg = castX(scene, 0.5, 0.3);
  ASSERT_EQ(leg.kind, HitKind::kBody);
  EXPECT_NEAR(leg.range, 10.0 - 0.12 - 0.05, 1e-9);
  // The head, 0.8 m ahead, up to 1.45 m.
  EXPECT_EQ(castX(scene, 0.8, 1.4).kind, HitKind::kBody);
  // Before it set off the ray at y = 0 passes (it waits at y = -10); long after, too.
  scene.setBodies(agentBodies(a, 0.0, 7, refl));
  EXPECT_FALSE(castX(scene, 0.0, 0.8).hit());
  scene.setBodies(agentBodies(a, 14.0, 7, refl));
  EXPECT_FALSE(castX(scene, 0.0, 0.8).hit());
  // Other types reflect as their material.
  terrain::AgentSpec truck = a.spec();
  truck.type = terrain::AgentType::kTruck;
  scene.setBodies(agentBodies(terrain::Agent(truck, grid, "agents[0]"), 5.0, 7, refl));
  EXPECT_FLOAT_EQ(castX(scene, 0.0, 2.0).reflectivity, 0.4f);
  EXPECT_NEAR(castX(scene, 0.0, 2.0).range, 10.0 - 1.25, 1e-9);
}

TEST(AgentBodies, BoxVelocityIsTheDerivativeOfItsCentre)
{
  const terrain::ElevationGrid grid = flatGrid();
  std::vector<Eigen::Vector2d> circle;
  for (int k = 0; k < 16; ++k)
    circle.emplace_back(15.0 * std::cos(k * M_PI / 8), 15.0 * std::sin(k * M_PI / 8));
  const terrain::Agent a = deer(circle, 6.0, true, grid);
  for (double t : { 0.7, 3.3, 9.1 })
  {
    const double h = 1e-5;
    const std::vector<Body> now = agentBodies(a, t, 0), before = agentBodies(a, t - h, 0),
                            after = agentBodies(a, t + h, 0);
    ASSERT_EQ(now.size(), terrain::agentBoxes(terrain::AgentType::kDeer).size());
    for (std::size_t k = 0; k < now.size(); ++k)
    {
      const Eigen::Vector3d d = (after[k].primitive.centre - before[k].primitive.centre) / (2 * h);
      EXPECT_NEAR((d - now[k].velocity).norm(), 0.0, 1e-4) << "t " << t << " box " << k;
      EXPECT_NEAR(now[k].angular_velocity.z(), a.state(t).yaw_rate, 1e-12);
    }
    // The head, 0.8 m ahead of the torso's centre, on a left turn of radius ~15 m: its velocity
    // differs from the torso's by w x r, |w r| = 0.8 v / 15 (less the spline's curvature error).
    EXPECT_GT((now[1].velocity - now[0].velocity).norm(), 0.8 * 6.0 / 15.0 * 0.9);
  }
}
