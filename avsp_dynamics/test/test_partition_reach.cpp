// partition_reach: the bounding box of a vehicle model, the reach of its motion, and the
// separation test of two boxes' shadows that lets a partition step before its peers' exchange.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "avsp_dynamics/partition_reach.hpp"
#include "avsp_dynamics/vehicle_model.hpp"

using namespace avsp::dynamics;

namespace
{
Eigen::Isometry3d pose(double x, double y, double z, double yaw, double pitch = 0.0, double roll = 0.0)
{
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  p.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return p;
}

VehicleBox box(double cx, double cy, double cz, double hx, double hy, double hz)
{
  VehicleBox b;
  b.centre = Eigen::Vector3d(cx, cy, cz);
  b.half = Eigen::Vector3d(hx, hy, hz);
  return b;
}

std::string configDir()
{
  return AVSP_VEHICLE_CONFIG_DIR;
}
}  // namespace

TEST(BoundingBox, OneCollisionBoxAndAWheelExactly)
{
  VehicleModel m;
  CollisionBox c;
  c.pose.translation() = Eigen::Vector3d(0.5, 0.0, 0.3);
  c.size = Eigen::Vector3d(2.0, 1.0, 0.5);
  m.collision_boxes.push_back(c);
  WheelSpec w;
  w.radius = 0.3;
  w.width = 0.8;  // hypot(0.3, 0.4) = 0.5: a steered wheel's horizontal reach
  w.suspension_lower = -0.1;
  w.suspension_upper = 0.05;
  w.rest_position = Eigen::Vector3d(1.8, 0.0, 0.0);
  m.wheels.push_back(w);
  const VehicleBox b = boundingBox(m, 0.0);
  // x: box -0.5 .. 1.5, wheel 1.3 .. 2.3; y: box -0.5 .. 0.5, wheel -0.5 .. 0.5;
  // z: box 0.05 .. 0.55, wheel -0.1 - 0.3 .. 0.05 + 0.3.
  EXPECT_NEAR(b.centre.x(), 0.5 * (-0.5 + 2.3), 1e-12);
  EXPECT_NEAR(b.half.x(), 0.5 * (2.3 + 0.5), 1e-12);
  EXPECT_NEAR(b.centre.y(), 0.0, 1e-12);
  EXPECT_NEAR(b.half.y(), 0.5, 1e-12);
  EXPECT_NEAR(b.centre.z(), 0.5 * (-0.4 + 0.55), 1e-12);
  EXPECT_NEAR(b.half.z(), 0.5 * (0.55 + 0.4), 1e-12);
  const VehicleBox g = boundingBox(m, 0.1);
  EXPECT_NEAR(g.half.x(), b.half.x() + 0.1, 1e-12);
  EXPECT_NEAR(g.half.z(), b.half.z() + 0.1, 1e-12);
}

TEST(BoundingBox, HoldsEveryPartOfTheReferenceVehicles)
{
  for (const char* name : { "m113", "mrzr", "tracer_x", "fed_alpha" })
  {
    SCOPED_TRACE(name);
    const VehicleModel m = loadVehicleModel(configDir() + "/" + name + ".yaml");
    const VehicleBox b = boundingBox(m, 0.0);
    const auto inside = [&](const Eigen::Vector3d& p) {
      return ((p - b.centre).cwiseAbs() - b.half).maxCoeff() <= 1e-9;
    };
    for (const CollisionBox& c : m.collision_boxes)
      for (int s = 0; s < 8; ++s)
        EXPECT_TRUE(inside(
            c.pose * Eigen::Vector3d(s & 1 ? 0.5 : -0.5, s & 2 ? 0.5 : -0.5, s & 4 ? 0.5 : -0.5).cwiseProduct(c.size)));
    for (const WheelSpec& w : m.wheels)
      for (double dx : { -w.radius, w.radius })
        EXPECT_TRUE(inside(w.rest_position + Eigen::Vector3d(dx, 0.5 * w.width, -w.radius)));
    for (const TrackSpec& t : m.tracks)
      for (const RoadWheelSpec& w : t.road_wheels)
        EXPECT_TRUE(inside(w.rest_position + Eigen::Vector3d(w.radius, 0.5 * w.width, -w.radius)));
    EXPECT_GT(b.half.x(), 0.3);  // a real vehicle, not a point (tracer_x is 0.95 m long)
  }
}

TEST(SweptReach, LinearAngularAndAcceleration)
{
  const VehicleBox b = box(0.0, 0.0, 0.0, 2.0, 1.0, 0.0);  // farthest corner sqrt(5) m
  EXPECT_NEAR(sweptReach(b, Eigen::Vector3d(3.0, 4.0, 0.0), Eigen::Vector3d::Zero(), 0.1, 0.0), 0.5, 1e-12);
  EXPECT_NEAR(sweptReach(b, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 0.0, 2.0), 0.1, 0.0),
              2.0 * std::sqrt(5.0) * 0.1, 1e-12);
  EXPECT_NEAR(sweptReach(b, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.02, 200.0), 0.5 * 200.0 * 0.0004,
              1e-12);
  // A point of a box turning at w while moving: after T it is within the reach of where it was.
  const Eigen::Vector3d v(1.5, -0.5, 0.2), w(0.1, -0.2, 0.7);
  const double T = 0.05, reach = sweptReach(b, v, w, T, 0.0);
  for (int s = 0; s < 8; ++s)
  {
    const Eigen::Vector3d p0(s & 1 ? 2.0 : -2.0, s & 2 ? 1.0 : -1.0, 0.0);
    const Eigen::Vector3d p1 = v * T + Eigen::AngleAxisd(w.norm() * T, w.normalized()) * p0;
    EXPECT_LE((p1 - p0).norm(), reach + 1e-12);
  }
}

TEST(ShadowsApart, LevelBoxesSideBySideExactThreshold)
{
  const VehicleBox b = box(0.0, 0.0, 0.5, 2.0, 1.0, 1.0);
  // Side by side across y, 5.5 m apart: a gap of 3.5 m between the 1 m half widths.
  const auto a_pose = pose(0.0, 0.0, 0.0, 0.0), b_pose = pose(0.0, 5.5, 0.0, 0.0);
  EXPECT_TRUE(shadowsApart(a_pose, b, 1.7, b_pose, b, 1.7));
  EXPECT_FALSE(shadowsApart(a_pose, b, 1.8, b_pose, b, 1.8));
  // Nose to tail along x: a gap of 1 m.
  EXPECT_TRUE(shadowsApart(a_pose, b, 0.45, pose(5.0, 0.0, 0.0, 0.0), b, 0.5));
  EXPECT_FALSE(shadowsApart(a_pose, b, 0.5, pose(5.0, 0.0, 0.0, 0.0), b, 0.51));
  // The box's centre is offset from base_link: it counts.
  const VehicleBox ahead = box(1.0, 0.0, 0.5, 2.0, 1.0, 1.0);
  // ahead spans x = -1 .. 3 and, turned round at x = 7.5, 4.5 .. 8.5: a 1.5 m gap.
  EXPECT_FALSE(shadowsApart(a_pose, ahead, 0.0, pose(4.9, 0.0, 0.0, 0.0), b, 0.0));
  EXPECT_TRUE(shadowsApart(a_pose, ahead, 0.7, pose(7.5, 0.0, 0.0, M_PI), ahead, 0.7));
  EXPECT_FALSE(shadowsApart(a_pose, ahead, 0.8, pose(7.5, 0.0, 0.0, M_PI), ahead, 0.8));
}

TEST(ShadowsApart, TurnedBoxesUseTheirOwnAxes)
{
  const VehicleBox b = box(0.0, 0.0, 0.0, 2.0, 0.5, 0.5);
  // Two boxes heading 45 deg, side by side across their heading, 1.5 m between centres: a
  // 0.5 m gap along their y axis, none along the map's x or y.
  const double c = std::cos(M_PI / 4), s = std::sin(M_PI / 4);
  const auto pa = pose(0.0, 0.0, 0.0, M_PI / 4), pb = pose(-1.5 * s, 1.5 * c, 0.0, M_PI / 4);
  EXPECT_TRUE(shadowsApart(pa, b, 0.2, pb, b, 0.2));
  EXPECT_FALSE(shadowsApart(pa, b, 0.3, pb, b, 0.3));
}

TEST(ShadowsApart, TiltCountsTheHeight)
{
  // A tall box (2 m up) pitched 90 deg lies along x: its shadow reaches 2 m further.
  const VehicleBox tall = box(0.0, 0.0, 1.0, 0.5, 0.5, 1.0);
  const VehicleBox small = box(0.0, 0.0, 0.0, 0.5, 0.5, 0.5);
  EXPECT_TRUE(shadowsApart(pose(0.0, 0.0, 0.0, 0.0), tall, 0.0, pose(1.5, 0.0, 0.0, 0.0), small, 0.0));
  EXPECT_FALSE(shadowsApart(pose(0.0, 0.0, 0.0, 0.0, M_PI / 2), tall, 0.0, pose(1.5, 0.0, 0.0, 0.0), small, 0.0));
}

TEST(ShadowsApart, NeverApartWhenSampledPointsAreCloserThanTheGrowth)
{
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0), h(0.2, 2.0), g(0.0, 1.0);
  int apart = 0, close = 0;
  for (int trial = 0; trial < 3000; ++trial)
  {
    const VehicleBox a = box(u(rng), u(rng), u(rng), h(rng), h(rng), h(rng));
    const VehicleBox b = box(u(rng), u(rng), u(rng), h(rng), h(rng), h(rng));
    const auto pa = pose(3 * u(rng), 3 * u(rng), u(rng), 4 * u(rng), 0.6 * u(rng), 0.6 * u(rng));
    const auto pb = pose(3 * u(rng), 3 * u(rng), u(rng), 4 * u(rng), 0.6 * u(rng), 0.6 * u(rng));
    const double ga = g(rng), gb = g(rng);
    // Points all over both boxes (corners, edges, faces, inside), on the map's x-y plane.
    const auto points = [](const Eigen::Isometry3d& p, const VehicleBox& bx) {
      std::vector<Eigen::Vector2d> out;
      for (int i = 0; i <= 6; ++i)
        for (int j = 0; j <= 6; ++j)
          for (int k = 0; k <= 6; ++k)
          {
            const Eigen::Vector3d f(i / 3.0 - 1.0, j / 3.0 - 1.0, k / 3.0 - 1.0);
            const Eigen::Vector3d q = p * (bx.centre + f.cwiseProduct(bx.half));
            out.emplace_back(q.x(), q.y());
          }
      return out;
    };
    const auto qa = points(pa, a), qb = points(pb, b);
    double d = 1e300;
    for (const auto& x : qa)
      for (const auto& y : qb)
        d = std::min(d, (x - y).norm());
    if (shadowsApart(pa, a, ga, pb, b, gb))
    {
      ++apart;
      ASSERT_GT(d, ga + gb) << "trial " << trial;
    }
    else
      ++close;
  }
  // Both answers occur: the test covers both sides.
  EXPECT_GT(apart, 300);
  EXPECT_GT(close, 300);
}
