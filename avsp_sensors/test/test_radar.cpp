// Radar: the fan covers the configured field of view, Doppler sign and magnitude for
// approaching and receding targets (and the radar's own motion), clusters become targets with
// centroid, range, angles, count and extent, terrain clutter is off by default, bad input.
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/radar.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;

namespace
{
constexpr double kDeg = 3.14159265358979323846 / 180.0;

Scene flatGround(double half = 200.0, double cell = 1.0)
{
  const auto n = static_cast<std::size_t>(2 * half / cell) + 1;
  return Scene(HeightField(-half, -half, cell, cell, n, n, std::vector<float>(n * n, 0.f)));
}

Body car(const Vector3d& centre, const Vector3d& velocity, std::uint32_t id)
{
  Body b;
  b.primitive.shape = Shape::kBox;
  b.primitive.centre = centre;
  b.primitive.half_extents = Vector3d(2.2, 0.9, 0.75);
  b.primitive.id = id;
  b.velocity = velocity;
  return b;
}

RadarScanRequest radarAt(const Vector3d& p)
{
  RadarScanRequest r;
  r.pose.translation() = p;
  return r;
}
}  // namespace

TEST(Radar, DopplerSignAndMagnitudeForApproachingAndRecedingTargets)
{
  Scene scene = flatGround();
  // Straight ahead at 40 m, one approaching at 12 m/s; one 10 deg to the left driving away
  // along the line of sight at 8 m/s (turned to it, so only its rear is in view: a car seen
  // at a slant shows its side as a sparse row that DBSCAN may split off).
  const Vector3d left = 40.0 * Vector3d(std::cos(10 * kDeg), std::sin(10 * kDeg), 0.0);
  Body away = car(Vector3d(left.x(), left.y(), 0.75), 8.0 * left.normalized(), 2);
  away.primitive.rotation = Eigen::AngleAxisd(10 * kDeg, Vector3d::UnitZ()).toRotationMatrix();
  scene.setBodies({ car(Vector3d(40, 0, 0.75), Vector3d(-12, 0, 0), 1), away });
  const Radar radar(RadarConfig(), 1);
  const RadarScan s = radar.scan(scene, radarAt(Vector3d(0, 0, 0.75)));
  ASSERT_EQ(s.targets.size(), 2u);
  for (const RadarTarget& t : s.targets)
  {
    ASSERT_GE(t.point_count, 3u);
    if (std::abs(t.azimuth) < 2 * kDeg)
    {
      // Each detection sees -12 cos(angle off the car's path); all within a few degrees.
      EXPECT_LT(t.range_rate, 0.0);
      EXPECT_NEAR(t.range_rate, -12.0, 12.0 * (1 - std::cos(3 * kDeg)));
      EXPECT_NEAR(t.range, 40.0 - 2.2, 0.3);  // the near face
    }
    else
    {
      EXPECT_NEAR(t.azimuth, 10 * kDeg, 1 * kDeg);
      EXPECT_GT(t.range_rate, 0.0);
      EXPECT_NEAR(t.range_rate, 8.0, 8.0 * (1 - std::cos(3 * kDeg)));
    }
  }
  // Every detection's range rate is exactly (v_hit - v_radar) . unit line of sight.
  for (const RadarDetection& d : s.detections)
  {
    const Vector3d u = d.position.normalized();
    const Vector3d v = d.id == 1 ? Vector3d(-12, 0, 0) : Vector3d(8.0 * left.normalized());
    EXPECT_NEAR(d.range_rate, v.dot(u), 1e-9);
  }
}

TEST(Radar, OwnMotionShowsStaticObjectsClosing)
{
  Scene scene = flatGround();
  Primitive wall;
  wall.shape = Shape::kBox;
  wall.centre = Vector3d(30, 0, 2);
  wall.half_extents = Vector3d(0.5, 3, 2);
  scene.setStaticPrimitives({ wall });
  RadarScanRequest req = radarAt(Vector3d(0, 0, 1.0));
  req.velocity = Vector3d(5, 0, 0);
  const RadarScan s = Radar(RadarConfig(), 1).scan(scene, req);
  ASSERT_EQ(s.targets.size(), 1u);
  EXPECT_NEAR(s.targets[0].range_rate, -5.0, 5.0 * (1 - std::cos(6 * kDeg)));
  EXPECT_LT(s.targets[0].range_rate, -4.9);
}

TEST(Radar, TargetsCarryCentroidAnglesCountAndExtent)
{
  Scene scene = flatGround();
  scene.setBodies({ car(Vector3d(25, -5, 0.75), Vector3d::Zero(), 3) });
  RadarConfig c;
  c.horizontal_fov = 40 * kDeg;
  c.cluster_eps = 2.0;  // the side, seen at a slant, has hits ~1.1 m apart: keep them with the front
  const RadarScan s = Radar(c, 1).scan(scene, radarAt(Vector3d(0, 0, 0.75)));
  ASSERT_EQ(s.targets.size(), 1u);
  const RadarTarget& t = s.targets[0];
  Vector3d sum = Vector3d::Zero(), lo = Vector3d::Constant(1e9), hi = -lo;
  for (const RadarDetection& d : s.detections)
  {
    sum += d.position;
    lo = lo.cwiseMin(d.position);
    hi = hi.cwiseMax(d.position);
  }
  EXPECT_EQ(t.point_count, s.detections.size());
  EXPECT_TRUE(t.centroid.isApprox(sum / s.detections.size(), 1e-12));
  EXPECT_NEAR(t.range, t.centroid.norm(), 1e-12);
  EXPECT_NEAR(t.azimuth, std::atan2(t.centroid.y(), t.centroid.x()), 1e-12);
  EXPECT_LT(t.azimuth, 0.0);  // to the right
  EXPECT_TRUE(t.extent.isApprox(hi - lo, 1e-12));
  EXPECT_GT(t.extent.y(), 1.0);  // the car's side and front are both in view
}

TEST(Radar, FieldOfViewAndTerrainClutter)
{
  Scene scene = flatGround();
  // Bodies just inside and just outside the 30 deg HFOV at 20 m.
  const auto at = [](double az_deg) {
    return Vector3d(20 * std::cos(az_deg * kDeg), 20 * std::sin(az_deg * kDeg), 1.0);
  };
  Body in = car(at(13.0), Vector3d::Zero(), 1), out = car(at(22.0), Vector3d::Zero(), 2);
  in.primitive.half_extents = out.primitive.half_extents = Vector3d(0.3, 0.3, 1.0);
  scene.setBodies({ in, out });
  RadarConfig c;
  c.cluster_min_points = 1;
  const RadarScan s = Radar(c, 1).scan(scene, radarAt(Vector3d(0, 0, 1.0)));
  for (const RadarDetection& d : s.detections)
  {
    EXPECT_EQ(d.id, 1u);
    EXPECT_LE(std::abs(d.azimuth), 15 * kDeg + 1e-12);
    EXPECT_LE(std::abs(d.elevation), 2.2 * kDeg + 1e-12);
  }
  EXPECT_FALSE(s.detections.empty());
  // The ground: the lowest rows meet it (from 1 m, -2.2 deg reaches it at 26 m) but are dropped
  // unless terrain_returns is on.
  scene.setBodies({});
  EXPECT_TRUE(Radar(c, 1).scan(scene, radarAt(Vector3d(0, 0, 1.0))).detections.empty());
  c.terrain_returns = true;
  const RadarScan ground = Radar(c, 1).scan(scene, radarAt(Vector3d(0, 0, 1.0)));
  ASSERT_FALSE(ground.detections.empty());
  for (const RadarDetection& d : ground.detections)
    EXPECT_EQ(d.kind, HitKind::kTerrain);
}

TEST(Radar, SameSeedSameScanOnAnyThreadCount)
{
  Scene scene = flatGround();
  scene.setBodies({ car(Vector3d(30, 2, 0.75), Vector3d(-3, 1, 0), 1) });
  RadarConfig c;
  c.range_noise = 0.1;
  c.range_rate_noise = 0.2;
  const Radar radar(c, 5);
  RadarScanRequest req = radarAt(Vector3d(0, 0, 0.75));
  req.threads = 1;
  const RadarScan a = radar.scan(scene, req);
  req.threads = 3;
  const RadarScan b = radar.scan(scene, req);
  ASSERT_EQ(a.detections.size(), b.detections.size());
  for (std::size_t k = 0; k < a.detections.size(); ++k)
  {
    EXPECT_EQ(a.detections[k].range, b.detections[k].range);
    EXPECT_EQ(a.detections[k].range_rate, b.detections[k].range_rate);
  }
  EXPECT_EQ(a.clusters.labels, b.clusters.labels);
}

TEST(Radar, BadInputThrowsNamingTheField)
{
  RadarConfig c;
  c.max_range = -5.0;
  try
  {
    Radar(c, 1);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("max_range"), std::string::npos);
  }
  c = RadarConfig();
  c.horizontal_fov = std::nan("");
  EXPECT_THROW(Radar(c, 1), std::invalid_argument);
  const Scene scene = flatGround(10.0);
  RadarScanRequest req;
  req.pose.translation().z() = std::nan("");
  try
  {
    Radar(RadarConfig(), 1).scan(scene, req);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("pose"), std::string::npos);
  }
  req = RadarScanRequest();
  req.velocity.x() = INFINITY;
  EXPECT_THROW(Radar(RadarConfig(), 1).scan(scene, req), std::invalid_argument);
}
