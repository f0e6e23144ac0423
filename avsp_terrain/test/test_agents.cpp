// Dynamic agents: motion as a pure function of time against closed forms.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_terrain/agents.hpp"

using namespace avsp::terrain;

namespace
{
/// A plane z = a x + b y + c sampled at `cell` m over [-half, half]^2 (bilinear is exact on it).
ElevationGrid plane(double a, double b, double c, double half = 60.0, double cell = 0.5)
{
  const std::size_t n = static_cast<std::size_t>(std::lround(2.0 * half / cell)) + 1;
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(a * (-half + i * cell) + b * (-half + j * cell) + c);
  return ElevationGrid(-half, -half, cell, cell, n, n, std::move(h));
}

AgentSpec spec(std::vector<Eigen::Vector2d> path, double speed, double start = 0.0, bool loop = false,
               AgentType type = AgentType::kDeer, const std::string& name = "a")
{
  AgentSpec s;
  s.name = name;
  s.type = type;
  s.path = std::move(path);
  s.speed = speed;
  s.start_time = start;
  s.loop = loop;
  return s;
}

std::vector<Eigen::Vector2d> circle(double r, int n)
{
  std::vector<Eigen::Vector2d> p;
  for (int k = 0; k < n; ++k)
    p.emplace_back(r * std::cos(2 * M_PI * k / n), r * std::sin(2 * M_PI * k / n));
  return p;
}

std::string errorOf(const std::vector<AgentSpec>& specs, const ElevationGrid& ground)
{
  try
  {
    makeAgents(specs, ground);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Agents, StraightSegmentIsP0PlusVT)
{
  const ElevationGrid flat = plane(0, 0, 0);
  const Eigen::Vector2d p0(-10.0, 5.0), p1(20.0, -35.0);  // 50 m long (3-4-5)
  const Agent a(spec({ p0, p1 }, 2.5, 3.0), flat, "agents[0]");
  EXPECT_NEAR(a.length(), 50.0, 1e-9);
  const Eigen::Vector2d dir = (p1 - p0) / 50.0;
  for (double t = 3.0; t <= 23.0; t += 0.37)
  {
    const AgentState s = a.state(t);
    const Eigen::Vector2d expected = p0 + 2.5 * (t - 3.0) * dir;
    EXPECT_NEAR(s.position.x(), expected.x(), 1e-9) << t;
    EXPECT_NEAR(s.position.y(), expected.y(), 1e-9) << t;
    EXPECT_NEAR(s.yaw, std::atan2(dir.y(), dir.x()), 1e-12);
    if (t > 3.0)
    {
      EXPECT_TRUE(s.moving);
      EXPECT_NEAR(s.velocity.x(), 2.5 * dir.x(), 1e-12);
      EXPECT_NEAR(s.velocity.y(), 2.5 * dir.y(), 1e-12);
      EXPECT_NEAR(s.yaw_rate, 0.0, 1e-12);
    }
  }
  // After the end (t = 3 + 50 / 2.5 = 23 s): at the last point, still.
  for (double t : { 23.0 + 1e-9, 24.0, 1e6 })
  {
    const AgentState s = a.state(t);
    EXPECT_NEAR(s.position.x(), p1.x(), 1e-9);
    EXPECT_NEAR(s.position.y(), p1.y(), 1e-9);
    EXPECT_FALSE(s.moving);
    EXPECT_EQ(s.velocity.norm(), 0.0);
  }
}

TEST(Agents, BeforeStartTimeAtTheFirstPointStill)
{
  const ElevationGrid flat = plane(0, 0, 1.5);
  const Agent a(spec({ { 0, 0 }, { 10, 0 }, { 10, 10 } }, 1.4, 7.0), flat, "agents[0]");
  for (double t : { -5.0, 0.0, 3.0, 7.0 })
  {
    const AgentState s = a.state(t);
    EXPECT_EQ(s.position.x(), 0.0);
    EXPECT_EQ(s.position.y(), 0.0);
    EXPECT_NEAR(s.position.z(), 1.5, 1e-6);
    EXPECT_FALSE(s.moving);
    EXPECT_EQ(s.velocity.norm(), 0.0);
    EXPECT_NEAR(s.yaw, 0.0, 1e-9);  // along the path's first tangent
  }
  // 0.5 s after the start it has covered 0.7 m (on the first, nearly straight stretch: chord ~ arc).
  const AgentState s = a.state(7.5);
  EXPECT_TRUE(s.moving);
  EXPECT_NEAR(s.position.head<2>().norm(), 0.7, 1e-3);
  EXPECT_NEAR(s.velocity.head<2>().norm(), 1.4, 1e-12);
}

TEST(Agents, SpeedAlongACurvedPathIsExact)
{
  // A wiggly open path: the distance travelled, summed over small chords, is speed x time, and
  // the length is the sum of the chords (arc length parameterisation is exact).
  const ElevationGrid flat = plane(0, 0, 0);
  const Agent a(spec({ { -30, 0 }, { -10, 12 }, { 0, -5 }, { 8, 3 }, { 25, 20 }, { 30, -10 } }, 3.0), flat,
                "agents[0]");
  const double period = a.period();
  EXPECT_NEAR(period, a.length() / 3.0, 1e-12);
  const int steps = 20000;
  double chords = 0.0;
  double worst = 0.0;
  Eigen::Vector3d previous = a.state(0.0).position;
  for (int k = 1; k <= steps; ++k)
  {
    const double t = period * k / steps;
    const AgentState s = a.state(t);
    const double chord = (s.position - previous).head<2>().norm();
    chords += chord;
    // Each chord is the arc between the two times to O(h^2): v dt within 1e-5 relative.
    worst = std::max(worst, std::abs(chord - 3.0 * period / steps) / (3.0 * period / steps));
    previous = s.position;
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_NEAR(chords, a.length(), 1e-5 * a.length());
  // The velocity is the derivative of the position (central difference).
  for (double t : { 1.0, 7.3, 13.9, 21.2 })
  {
    const double h = 1e-5;
    const Eigen::Vector2d d = (a.state(t + h).position - a.state(t - h).position).head<2>() / (2 * h);
    EXPECT_NEAR((d - a.state(t).velocity.head<2>()).norm(), 0.0, 1e-5) << t;
    EXPECT_NEAR(d.norm(), 3.0, 1e-5) << t;
    // Yaw rate is the derivative of the yaw.
    const double dyaw = std::remainder(a.state(t + h).yaw - a.state(t - h).yaw, 2 * M_PI) / (2 * h);
    EXPECT_NEAR(a.state(t).yaw_rate, dyaw, 1e-4) << t;
  }
  // The path passes through every point.
  for (const Eigen::Vector2d& p : a.spec().path)
  {
    double nearest = std::numeric_limits<double>::infinity();
    for (int k = 0; k <= 40000; ++k)
      nearest = std::min(nearest, (a.state(period * k / 40000).position.head<2>() - p).norm());
    EXPECT_LT(nearest, 3.0 * period / 40000);
  }
}

TEST(Agents, LoopPeriodIsLengthOverSpeed)
{
  const ElevationGrid flat = plane(0, 0, 0);
  const double r = 20.0, v = 4.0, start = 2.0;
  const Agent a(spec(circle(r, 24), v, start, true), flat, "agents[0]");
  // 24 points on a circle: the centripetal spline stays within 0.2 % of it and is as long; being
  // only C1, its curvature jumps at the points (measured within 5.2 % of 1/r, with 12 points as with 24).
  EXPECT_NEAR(a.length(), 2 * M_PI * r, 2e-3 * 2 * M_PI * r);
  const double period = a.length() / v;
  EXPECT_NEAR(a.period(), period, 1e-12);
  for (double t : { 2.5, 9.1, 30.0, 31.4 })
  {
    const AgentState s = a.state(t), later = a.state(t + period), much_later = a.state(t + 7 * period);
    EXPECT_NEAR((s.position - later.position).norm(), 0.0, 1e-8) << t;
    EXPECT_NEAR((s.position - much_later.position).norm(), 0.0, 1e-7) << t;
    EXPECT_TRUE(later.moving);
    EXPECT_NEAR(s.position.head<2>().norm(), r, 0.002 * r);
    // Counter-clockwise: heading 90 deg left of the radius, turning left at v / r.
    const double radial = std::atan2(s.position.y(), s.position.x());
    EXPECT_NEAR(std::remainder(s.yaw - radial - M_PI / 2, 2 * M_PI), 0.0, 0.01);
    EXPECT_NEAR(s.yaw_rate, v / r, 0.06 * v / r) << t;
  }
  // Half a period on, it is on the other side of the circle (point 12, by symmetry).
  EXPECT_NEAR((a.state(start + 0.5 * period).position.head<2>() - Eigen::Vector2d(-r, 0)).norm(), 0.0, 1e-6);
  // The curvature sampled over the whole loop: within 6 % of 1 / r everywhere.
  for (double t = start + 0.01; t < start + period; t += 0.05)
    EXPECT_NEAR(a.state(t).yaw_rate, v / r, 0.06 * v / r) << t;
  // A loop closes smoothly: the heading at the start equals the heading one period on.
  EXPECT_NEAR(std::remainder(a.state(start + 1e-9).yaw - a.state(start + period - 1e-9).yaw, 2 * M_PI), 0.0, 1e-6);
}

TEST(Agents, HeightOnASlopedPlane)
{
  const double a = 0.12, b = -0.05, c = 3.0;  // 6.8 deg and 2.9 deg
  const ElevationGrid ground = plane(a, b, c);
  // Straight: z exactly the plane's, vertical speed v (a dx + b dy).
  const Agent line(spec({ { -40, -30 }, { 40, 30 } }, 2.0), ground, "agents[0]");
  for (double t = 0.0; t <= 50.0; t += 1.3)
  {
    const AgentState s = line.state(t);
    EXPECT_NEAR(s.position.z(), a * s.position.x() + b * s.position.y() + c, 2e-6) << t;  // float heights
    if (s.moving)
    {
      EXPECT_NEAR(s.velocity.z(), 2.0 * (a * 0.8 + b * 0.6), 1e-5);
    }
  }
  // Curved: still on the plane (linear between samples 0.1 m apart along the path).
  const Agent curve(spec({ { -40, 0 }, { -10, 30 }, { 20, -20 }, { 45, 10 } }, 5.0), ground, "agents[0]");
  for (double t = 0.0; t <= curve.period(); t += 0.77)
  {
    const AgentState s = curve.state(t);
    EXPECT_NEAR(s.position.z(), a * s.position.x() + b * s.position.y() + c, 1e-4) << t;
  }
}

TEST(Agents, StandingAgents)
{
  const ElevationGrid ground = plane(0.1, 0.0, 0.0);
  AgentSpec single = spec({ { 5, 5 } }, 0.0, 0.0, false, AgentType::kPedestrian);
  single.yaw = 1.2;
  const Agent one(single, ground, "agents[0]");
  const Agent two(spec({ { 5, 5 }, { 5, 15 } }, 0.0), ground, "agents[1]");
  for (double t : { 0.0, 10.0, 1e5 })
  {
    EXPECT_EQ(one.state(t).position, Eigen::Vector3d(5, 5, 0.5));
    EXPECT_EQ(one.state(t).yaw, 1.2);
    EXPECT_FALSE(one.state(t).moving);
    EXPECT_EQ(two.state(t).position.head<2>(), Eigen::Vector2d(5, 5));
    EXPECT_NEAR(two.state(t).yaw, M_PI / 2, 1e-12);
    EXPECT_EQ(two.state(t).velocity.norm(), 0.0);
  }
  EXPECT_TRUE(std::isinf(one.period()));
}

TEST(Agents, BodiesHaveTheStatedSizes)
{
  // Deer: 1.6 m rump to nose, 1.0 m at the shoulder (torso top), head up to 1.45 m.
  EXPECT_NEAR(agentSize(AgentType::kDeer).x(), 1.6, 1e-12);
  EXPECT_NEAR(agentSize(AgentType::kDeer).z(), 1.45, 1e-12);
  const AgentBox& torso = agentBoxes(AgentType::kDeer)[0];
  EXPECT_NEAR(torso.centre.z() + 0.5 * torso.size.z(), 1.0, 1e-12);
  EXPECT_EQ(agentSize(AgentType::kPedestrian), Eigen::Vector3d(0.3, 0.5, 1.75));
  EXPECT_TRUE(agentSize(AgentType::kTruck).isApprox(Eigen::Vector3d(8.0, 2.5, 3.2), 1e-12));
  for (AgentType t : { AgentType::kDeer, AgentType::kPedestrian, AgentType::kTruck })
  {
    // Every body stands on the ground (lowest point at z = 0).
    double lowest = 1e9;
    for (const AgentBox& b : agentBoxes(t))
      lowest = std::min(lowest, b.centre.z() - 0.5 * b.size.z());
    EXPECT_NEAR(lowest, 0.0, 1e-12) << toString(t);
    EXPECT_EQ(agentTypeFromString(toString(t)), t);
  }
  EXPECT_FALSE(agentTypeFromString("moose"));
  EXPECT_FALSE(agentTypeFromString("Deer"));
}

TEST(Agents, DeterministicToTheBit)
{
  const ElevationGrid ground = plane(0.03, 0.02, 1.0);
  const AgentSpec s = spec({ { -30, 0 }, { -10, 12 }, { 0, -5 }, { 8, 3 } }, 1.7, 0.4, true);
  const Agent a(s, ground, "agents[0]"), b(s, ground, "agents[0]");
  for (double t = 0.0; t < 100.0; t += 0.0137)
  {
    const AgentState x = a.state(t), y = b.state(t);
    EXPECT_EQ(x.position, y.position);
    EXPECT_EQ(x.velocity, y.velocity);
    EXPECT_EQ(x.yaw, y.yaw);
  }
}

TEST(Agents, BadSpecsNameTheKey)
{
  const ElevationGrid ground = plane(0, 0, 0);
  const AgentSpec good = spec({ { 0, 0 }, { 10, 0 } }, 1.0, 0.0, false, AgentType::kDeer, "deer");
  auto second = [&](AgentSpec bad) { return errorOf({ good, bad }, ground); };
  AgentSpec s = spec({ { 0, 0 }, { 10, 0 } }, -1.0, 0.0, false, AgentType::kDeer, "b");
  EXPECT_EQ(second(s), "agents[1].speed: must be finite and >= 0 m/s, got -1");
  s.speed = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(second(s).rfind("agents[1].speed: must be finite", 0), 0u) << second(s);
  s.speed = 1.0;
  s.start_time = -2.0;
  EXPECT_EQ(second(s), "agents[1].start_time: must be finite and >= 0 s, got -2");
  s.start_time = 0.0;
  s.path = { { 0, 0 } };
  EXPECT_EQ(second(s), "agents[1].path: a moving agent needs at least 2 points, got 1");
  s.path = { { 0, 0 }, { 5, 0 } };
  s.loop = true;
  EXPECT_EQ(second(s), "agents[1].path: a moving looping agent needs at least 3 points, got 2");
  s.path = { { 0, 0 }, { 5, 0 }, { 5, 5 }, { 0, 0 } };
  EXPECT_EQ(second(s).rfind("agents[1].path[0]: is within 1 mm of path[3] (a loop closes itself", 0), 0u) << second(s);
  s.loop = false;
  s.path = { { 0, 0 }, { std::nan(""), 0 } };
  EXPECT_EQ(second(s), "agents[1].path[1]: must be finite (x, y) m, got (nan, 0)");
  s.path = { { 0, 0 }, { 0, 0 } };
  EXPECT_EQ(second(s), "agents[1].path[1]: is within 1 mm of path[0]");
  s.path = {};
  EXPECT_EQ(second(s), "agents[1].path: needs at least one point");
  s.path = { { 0, 0 }, { 200, 0 } };
  EXPECT_EQ(second(s).rfind("agents[1].path: leaves the terrain at (", 0), 0u) << second(s);
  s.path = { { 0, 0 }, { 10, 0 } };
  s.name = "deer";
  EXPECT_EQ(second(s), "agents[1].name: 'deer' is used by another agent");
  s.name = "a/b";
  EXPECT_EQ(second(s).rfind("agents[1].name: 'a/b' must be letters", 0), 0u) << second(s);
  s.name = "";
  EXPECT_EQ(second(s), "agents[1].name: must not be empty");
  s.name = "b";
  s.yaw = INFINITY;
  EXPECT_EQ(second(s), "agents[1].yaw: must be finite (rad), got inf");
}
