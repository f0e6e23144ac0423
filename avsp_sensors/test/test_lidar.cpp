// Lidar: presets, flat-ground ranges per ring, point counts, registered vs unregistered clouds,
// motion skew during a sweep, beam divergence (mixed pixels, strongest vs last), intensity,
// max range, dropout, determinism across threads, and bad input.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/scene.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;

namespace
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

/// Flat ground at z = 0 over [-half, half]^2 on `cell` m cells.
Scene flatGround(double half = 130.0, double cell = 0.5)
{
  const auto n = static_cast<std::size_t>(2 * half / cell) + 1;
  return Scene(HeightField(-half, -half, cell, cell, n, n, std::vector<float>(n * n, 0.f)));
}

/// A config with ideal optics: one ray per pulse, no noise, everything in range detectable.
LidarConfig ideal(LidarConfig c)
{
  c.sub_rays = 1;
  c.range_noise = 0.0;
  c.reference_range = 1e4;
  return c;
}

Primitive wall(double x0, double x1, double half_y, double height, float reflectivity, std::uint32_t id = 1)
{
  Primitive p;
  p.shape = Shape::kBox;
  p.centre = Vector3d(0.5 * (x0 + x1), 0.0, 0.5 * height);
  p.half_extents = Vector3d(0.5 * (x1 - x0), half_y, 0.5 * height);
  p.reflectivity = reflectivity;
  p.id = id;
  return p;
}

LidarScanRequest at(const Vector3d& position, double yaw = 0.0)
{
  LidarScanRequest r;
  r.motion.pose = Eigen::Isometry3d::Identity();
  r.motion.pose.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  r.motion.pose.translation() = position;
  return r;
}

bool sameBits(const LidarCloud& a, const LidarCloud& b)
{
  if (a.size() != b.size())
    return false;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (a[k].x != b[k].x || a[k].y != b[k].y || a[k].z != b[k].z || a[k].intensity != b[k].intensity ||
        a[k].ring != b[k].ring || a[k].time != b[k].time)
      return false;
  return true;
}
}  // namespace

TEST(LidarPresets, PublishedChannelAnglesAndRates)
{
  const std::vector<std::string> names = lidarPresetNames();
  ASSERT_EQ(names.size(), 4u);
  for (const std::string& n : names)
    EXPECT_NO_THROW(validateLidarConfig(lidarPreset(n))) << n;
  auto sortedDeg = [](const LidarConfig& c) {
    std::vector<double> e;
    for (const auto& ch : c.channels)
      e.push_back(ch.elevation / kDeg);
    std::sort(e.begin(), e.end());
    return e;
  };
  // VLP-16: -15 .. +15 deg, 2 deg apart; ~289,000 points/s (data sheet: 289,344).
  const LidarConfig vlp = lidarPreset("VLP-16");
  const auto ev = sortedDeg(vlp);
  ASSERT_EQ(ev.size(), 16u);
  for (std::size_t k = 0; k < 16; ++k)
    EXPECT_NEAR(ev[k], -15.0 + 2.0 * k, 1e-9);
  EXPECT_NEAR(vlp.channels.size() * vlp.columns * vlp.rotation_rate, 289344.0, 0.001 * 289344.0);
  EXPECT_NEAR(vlp.channels[15].time_offset, 15 * 2.304e-6, 1e-15);
  // HDL-32E: -30.67 .. +10.67 deg, 1.33 deg apart; ~694,000 points/s.
  const LidarConfig h32 = lidarPreset("HDL-32E");
  const auto e32 = sortedDeg(h32);
  ASSERT_EQ(e32.size(), 32u);
  for (std::size_t k = 0; k < 32; ++k)
    EXPECT_NEAR(e32[k], -30.67 + 4.0 / 3.0 * k, 0.01);
  EXPECT_NEAR(h32.channels.size() * h32.columns * h32.rotation_rate, 694000.0, 0.001 * 694000.0);
  // HDL-64E: +2 .. -24.9 deg field of view (a calibrated unit: +1.96 .. -24.56), 1.333 M points/s.
  const LidarConfig h64 = lidarPreset("HDL-64E");
  const auto e64 = sortedDeg(h64);
  ASSERT_EQ(e64.size(), 64u);
  EXPECT_NEAR(e64.back(), 1.96, 0.01);
  EXPECT_NEAR(e64.front(), -24.56, 0.01);
  EXPECT_NEAR(h64.channels.size() * h64.columns * h64.rotation_rate, 1.333e6, 0.001 * 1.333e6);
  // OS1-64: +-16.611 deg, 64 beams, 1024 x 10 Hz.
  const LidarConfig os1 = lidarPreset("OS1-64");
  const auto eo = sortedDeg(os1);
  ASSERT_EQ(eo.size(), 64u);
  EXPECT_NEAR(eo.front(), -16.611, 1e-9);
  EXPECT_NEAR(eo.back(), 16.611, 1e-9);
  EXPECT_NEAR(os1.channels[0].azimuth_offset, -3.164 * kDeg, 1e-12);
  EXPECT_EQ(os1.columns * os1.rotation_rate, 10240.0);
  // Sub-rays from docs/MODELS.md 4: N = ceil(2 (r + R tan(theta/2)) / x).
  EXPECT_EQ(subRayCount(vlp), 4u);  // 2 (0.005 + 100 tan 1.5 mrad) / 0.1 = 3.1
  EXPECT_EQ(subRayCount(os1), 3u);  // 2 (0.005 + 120 tan 0.065 deg) / 0.1 = 2.8
}

TEST(LidarPresets, UnknownNamesAndEmptyConfigsThrow)
{
  try
  {
    lidarPreset("VLP-17");
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    const std::string w = e.what();
    EXPECT_NE(w.find("VLP-17"), std::string::npos) << w;
    EXPECT_NE(w.find("OS1-64"), std::string::npos) << w;
  }
  EXPECT_THROW(lidarPreset(""), std::invalid_argument);
  LidarConfig empty;
  try
  {
    Lidar(empty, 1);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("channels"), std::string::npos) << e.what();
  }
  LidarConfig c = lidarPreset("VLP-16");
  c.min_range = -1.0;
  try
  {
    Lidar(c, 1);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("min_range"), std::string::npos) << e.what();
  }
  c = lidarPreset("VLP-16");
  c.max_range = std::nan("");
  EXPECT_THROW(Lidar(c, 1), std::invalid_argument);
  c = lidarPreset("VLP-16");
  c.channels[3].elevation = std::nan("");
  try
  {
    Lidar(c, 1);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("channels[3].elevation"), std::string::npos) << e.what();
  }
}

TEST(Lidar, FlatGroundRingsHitAtHeightOverSineOfTheirAngle)
{
  const Scene scene = flatGround();
  const double h = 2.0;
  const Lidar lidar(ideal(lidarPreset("VLP-16")), 1);
  LidarScanRequest req = at(Vector3d(3.0, -4.0, h), 0.4);
  req.registered = false;
  const LidarScan scan = lidar.scan(scene, req);
  // Downward channels whose ground range is within 100 m: -15 .. -3 deg (7 of them); -1 deg
  // reaches the ground at 114.6 m, beyond the range gate; upward ones see sky.
  std::size_t expect_per_column = 0;
  std::vector<double> expect_range(16, -1.0);
  for (std::size_t k = 0; k < 16; ++k)
  {
    const double el = lidar.config().channels[k].elevation;
    if (el < 0 && h / std::sin(-el) <= 100.0)
    {
      expect_range[lidar.ring(k)] = h / std::sin(-el);
      ++expect_per_column;
    }
  }
  EXPECT_EQ(expect_per_column, 7u);
  EXPECT_EQ(scan.pulses, 16u * 1808u);
  ASSERT_EQ(scan.points.size(), scan.pulses - (16 - expect_per_column) * 1808);  // channels x steps - misses
  for (const LidarPoint& p : scan.points)
  {
    ASSERT_GE(expect_range[p.ring], 0.0);
    const double r = std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
    ASSERT_NEAR(r, expect_range[p.ring], 1e-3) << "ring " << p.ring;
    // Lambertian intensity: 100 rho cos(incidence), incidence from the vertical.
    const double sin_el = h / expect_range[p.ring];
    ASSERT_NEAR(p.intensity, 100.0 * scene.reflectivities().terrain * sin_el, 1e-3);
  }
}

TEST(Lidar, RangeNoiseHasTheConfiguredSpread)
{
  const Scene scene = flatGround();
  LidarConfig c = ideal(lidarPreset("VLP-16"));
  c.range_noise = 0.03;
  const Lidar lidar(c, 7);
  LidarScanRequest req = at(Vector3d(0, 0, 2.0));
  req.registered = false;
  const LidarScan scan = lidar.scan(scene, req);
  double sum = 0, sum2 = 0;
  for (const LidarPoint& p : scan.points)
  {
    const double r = std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
    const double dir_z = p.z / r;  // sin(elevation) of the beam
    const double err = r - 2.0 / (-dir_z);
    ASSERT_LT(std::abs(err), 5 * 0.03 + 1e-3);
    sum += err;
    sum2 += err * err;
  }
  const double n = static_cast<double>(scan.points.size());
  ASSERT_GT(n, 10000);
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 5 * 0.03 / std::sqrt(n));
  EXPECT_NEAR(sd, 0.03, 0.03 * 0.05);
}

TEST(Lidar, RegisteredAndUnregisteredCloudsDifferByExactlyThePose)
{
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(15.0, 16.0, 40.0, 6.0, 0.5f) });
  LidarConfig c = lidarPreset("HDL-32E");
  c.dropout = 0.05;  // noise, divergence and dropout on: the two clouds share every draw
  const Lidar lidar(c, 3);
  LidarScanRequest req = at(Vector3d(1.0, 2.0, 1.8), 0.3);
  req.motion.linear_velocity = Vector3d(6.0, -1.0, 0.2);
  req.motion.angular_velocity = Vector3d(0.05, 0.0, 0.8);
  req.registered = false;
  const LidarScan local = lidar.scan(scene, req);
  req.registered = true;
  const LidarScan map = lidar.scan(scene, req);
  ASSERT_EQ(local.points.size(), map.points.size());
  ASSERT_GT(local.points.size(), 20000u);
  for (std::size_t k = 0; k < local.points.size(); ++k)
  {
    const LidarPoint& a = local.points[k];
    const LidarPoint& b = map.points[k];
    ASSERT_EQ(a.ring, b.ring);
    ASSERT_EQ(a.time, b.time);
    ASSERT_EQ(a.intensity, b.intensity);
    const Vector3d expect = req.motion.at(a.time) * Vector3d(a.x, a.y, a.z);
    // float storage of map coordinates ~20 m from the origin: a few micrometres
    ASSERT_NEAR(b.x, expect.x(), 2e-5 * (1 + std::abs(expect.x())));
    ASSERT_NEAR(b.y, expect.y(), 2e-5 * (1 + std::abs(expect.y())));
    ASSERT_NEAR(b.z, expect.z(), 2e-5 * (1 + std::abs(expect.z())));
  }
}

TEST(Lidar, MovingAtTenMetresPerSecondSkewsOneSweep)
{
  // One horizontal channel, 10 Hz, facing a wall 20 m ahead while driving at it at 10 m/s.
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(20.0, 21.0, 60.0, 10.0, 0.5f) });
  LidarConfig c;
  c.name = "test";
  c.channels = { { 0.0, 0.0, 0.0 } };
  c.columns = 3600;
  c.rotation_rate = 10.0;
  c = ideal(c);
  const Lidar lidar(c, 1);
  LidarScanRequest req = at(Vector3d(0, 0, 1.0));
  req.motion.linear_velocity = Vector3d(10.0, 0, 0);
  req.registered = false;
  const LidarScan local = lidar.scan(scene, req);
  req.registered = true;
  const LidarScan map = lidar.scan(scene, req);
  ASSERT_EQ(local.points.size(), map.points.size());
  std::size_t on_wall = 0;
  float first_x = 0, last_x = 0, first_t = 0, last_t = 0;
  for (std::size_t k = 0; k < local.points.size(); ++k)
  {
    const LidarPoint& p = local.points[k];
    if (std::abs(map.points[k].x - 20.0f) > 0.01f)
      continue;  // the ground or elsewhere
    ++on_wall;
    // In the sensor frame at firing time the wall is 20 - v t away: the skew grows with time.
    ASSERT_NEAR(p.x, 20.0 - 10.0 * p.time, 1e-4) << "t = " << p.time;
    if (on_wall == 1)
    {
      first_x = p.x;
      first_t = p.time;
    }
    last_x = p.x;
    last_t = p.time;
  }
  ASSERT_GT(on_wall, 1000u);
  // The sweep starts facing the wall and ends facing it again 0.1 s later: 1 m closer.
  EXPECT_NEAR(first_t, 0.0, 1e-6);
  EXPECT_NEAR(last_t, 0.1, 0.001);
  EXPECT_NEAR(first_x - last_x, 10.0 * 0.1, 0.011);
  // Registered, every wall point is where the wall is.
  for (const LidarPoint& p : map.points)
    if (std::abs(p.x - 20.0f) < 0.01f)
    {
      ASSERT_NEAR(p.x, 20.0, 1e-4);
    }
}

TEST(Lidar, PointTimesFollowTheFiringSchedule)
{
  const Scene scene = flatGround();
  const LidarConfig c = ideal(lidarPreset("VLP-16"));
  const Lidar lidar(c, 1);
  LidarScanRequest req = at(Vector3d(0, 0, 2.0));
  const LidarScan scan = lidar.scan(scene, req);
  const double column_period = 1.0 / (10.0 * 1808);
  float previous = -1.0f;
  for (std::size_t k = 0; k < scan.points.size(); ++k)
  {
    const LidarPoint& p = scan.points[k];
    ASSERT_GE(p.time, previous);
    previous = p.time;
    // time = column * period + laser id * 2.304 us; the ground point's azimuth tells the column.
    const double az = std::atan2(p.y, p.x);
    const double t_from_az = std::fmod(2 * kPi - az, 2 * kPi) / (2 * kPi * 10.0);  // clockwise spin
    double diff = p.time - t_from_az;
    diff -= 0.1 * std::round(diff / 0.1);  // the seam at azimuth 0: 0 and 0.1 s are the same place
    ASSERT_NEAR(diff, 0.0, 2 * column_period);
  }
  EXPECT_NEAR(scan.duration, 0.1, 1e-12);
}

TEST(Lidar, BeamDivergenceSeesAThinPoleTheAxisMisses)
{
  Scene scene = flatGround();
  // A pole 0.1 m thick, 20 m ahead, its surface 2 cm beside the horizontal channel's axis.
  Primitive pole;
  pole.shape = Shape::kCylinder;
  pole.centre = Vector3d(20.0, 0.07, 3.0);
  pole.half_extents = Vector3d(0.05, 0.05, 3.0);
  pole.reflectivity = 0.5f;
  scene.setStaticPrimitives({ pole });
  LidarConfig c;
  c.name = "test";
  c.channels = { { 0.0, 0.0, 0.0 } };
  c.columns = 1;  // one pulse, straight ahead
  c.range_noise = 0.0;
  c.reference_range = 1e4;
  c.divergence_horizontal = c.divergence_vertical = 3e-3;  // footprint radius at 20 m: 0.035 m
  c.sub_rays = 16;
  LidarScanRequest req = at(Vector3d(0, 0, 1.0));
  const LidarScan wide = Lidar(c, 1).scan(scene, req);
  ASSERT_EQ(wide.points.size(), 1u);
  EXPECT_NEAR(wide.points[0].x, 20.0 - 0.04, 0.02);  // the pole's near side, along the axis
  EXPECT_NEAR(wide.points[0].y, 0.0, 1e-9);
  // Only part of the footprint is on the pole: less than a full hit's 100 rho.
  EXPECT_GT(wide.points[0].intensity, 0.0f);
  EXPECT_LT(wide.points[0].intensity, 0.5f * 50.0f);
  EXPECT_EQ(wide.rays, 16u);
  c.sub_rays = 1;
  EXPECT_TRUE(Lidar(c, 1).scan(scene, req).points.empty());
}

TEST(Lidar, StrongestAndLastReturnsPickDifferentEchoes)
{
  Scene scene = flatGround();
  // A pole's edge at 10 m covering part of the footprint, a wall behind at 30 m.
  Primitive pole;
  pole.shape = Shape::kCylinder;
  pole.centre = Vector3d(10.0, 0.1, 3.0);
  pole.half_extents = Vector3d(0.1, 0.1, 3.0);
  pole.reflectivity = 0.5f;
  scene.setStaticPrimitives({ pole, wall(30.0, 31.0, 20.0, 5.0, 0.3f, 2) });
  LidarConfig c;
  c.name = "test";
  c.channels = { { 0.0, 0.0, 0.0 } };
  c.columns = 1;
  c.range_noise = 0.0;
  c.reference_range = 1e4;
  c.divergence_horizontal = c.divergence_vertical = 0.02;  // 0.1 m footprint radius at 10 m
  c.sub_rays = 64;
  LidarScanRequest req = at(Vector3d(0, 0, 1.0));
  c.return_mode = ReturnMode::kStrongest;
  const LidarScan strongest = Lidar(c, 1).scan(scene, req);
  c.return_mode = ReturnMode::kLast;
  const LidarScan last = Lidar(c, 1).scan(scene, req);
  ASSERT_EQ(strongest.points.size(), 1u);
  ASSERT_EQ(last.points.size(), 1u);
  EXPECT_NEAR(strongest.points[0].x, 10.0, 0.1);  // the near pole: 1/R^2 favours it
  EXPECT_NEAR(last.points[0].x, 30.0, 0.1);       // the wall behind
  // The two echoes share the footprint: their intensities add up to at most a full hit.
  EXPECT_LT(strongest.points[0].intensity + last.points[0].intensity, 100.0f * 0.5f);
}

TEST(Lidar, MaxRangeGatesReturns)
{
  for (double x : { 99.0, 101.0 })
  {
    Scene scene = flatGround(150.0, 1.0);
    scene.setStaticPrimitives({ wall(x, x + 1.0, 5.0, 10.0, 0.8f) });
    LidarConfig c;
    c.name = "test";
    c.channels = { { 0.0, 0.0, 0.0 } };
    c.columns = 1;
    c.max_range = 100.0;
    c = ideal(c);
    const LidarScan scan = Lidar(c, 1).scan(scene, at(Vector3d(0, 0, 2.0)));
    EXPECT_EQ(scan.points.size(), x < 100.0 ? 1u : 0u) << x;
  }
}

TEST(Lidar, DropoutLosesTheConfiguredShareOfPulses)
{
  const Scene scene = flatGround();
  LidarConfig c = ideal(lidarPreset("VLP-16"));
  c.dropout = 0.3;
  const LidarScan scan = Lidar(c, 11).scan(scene, at(Vector3d(0, 0, 2.0)));
  const double returning = 7.0 * 1808.0;  // pulses that would return without dropout
  const double share = static_cast<double>(scan.dropped) / returning;
  EXPECT_NEAR(share, 0.3, 5 * std::sqrt(0.3 * 0.7 / returning));
  EXPECT_EQ(scan.points.size() + scan.dropped, static_cast<std::size_t>(returning));
}

TEST(Lidar, SameSeedSameCloudBitForBitOnAnyThreadCount)
{
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(12.0, 13.0, 30.0, 4.0, 0.4f) });
  LidarConfig c = lidarPreset("VLP-16");
  c.dropout = 0.02;
  const Lidar lidar(c, 99);
  LidarScanRequest req = at(Vector3d(0.5, 0.5, 1.9), 0.2);
  req.weather.snow_rate = 3.0;
  req.weather.fog_visibility = 300.0;
  req.motion.linear_velocity = Vector3d(3, 0, 0);
  req.threads = 1;
  const LidarScan one = lidar.scan(scene, req);
  req.threads = 2;
  const LidarScan two = lidar.scan(scene, req);
  req.threads = 3;
  const LidarScan three = lidar.scan(scene, req);
  EXPECT_TRUE(sameBits(one.points, two.points));
  EXPECT_TRUE(sameBits(one.points, three.points));
  EXPECT_GT(one.clutter, 0u);
  // Another seed or another sweep draws other noise.
  const LidarScan other = Lidar(c, 100).scan(scene, req);
  EXPECT_FALSE(sameBits(one.points, other.points));
  req.sweep = 1;
  EXPECT_FALSE(sameBits(one.points, lidar.scan(scene, req).points));
}

TEST(Lidar, ParticleEchoesAreFlaggedPointForPoint)
{
  Scene scene = flatGround();
  const LidarConfig c = lidarPreset("VLP-16");
  const Lidar lidar(c, 7);
  LidarScanRequest req = at(Vector3d(0.5, 0.5, 1.9));
  req.weather.snow_rate = 3.0;
  const LidarScan snow = lidar.scan(scene, req);
  ASSERT_EQ(snow.particle_echo.size(), snow.points.size());
  ASSERT_GT(snow.clutter, 20u);
  std::size_t flagged = 0;
  for (std::size_t k = 0; k < snow.points.size(); ++k)
  {
    if (!snow.particle_echo[k])
      continue;
    ++flagged;
    // A particle echoes from within clutter_max_range of the sensor (range noise aside).
    const LidarPoint& p = snow.points[k];
    const double range = (Vector3d(p.x, p.y, p.z) - Vector3d(0.5, 0.5, 1.9)).norm();
    EXPECT_LE(range, c.clutter_max_range + 5.0 * c.range_noise) << k;
  }
  EXPECT_EQ(flagged, snow.clutter);
  req.weather = Weather();
  const LidarScan clear = lidar.scan(scene, req);
  ASSERT_EQ(clear.particle_echo.size(), clear.points.size());
  EXPECT_EQ(std::count(clear.particle_echo.begin(), clear.particle_echo.end(), true), 0);
}

TEST(Lidar, BadMotionAndWeatherThrowNamingTheField)
{
  const Scene scene = flatGround(20.0);
  const Lidar lidar(lidarPreset("VLP-16"), 1);
  LidarScanRequest req = at(Vector3d(0, 0, 2));
  req.motion.pose.translation().x() = std::nan("");
  try
  {
    lidar.scan(scene, req);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("pose"), std::string::npos) << e.what();
  }
  req = at(Vector3d(0, 0, 2));
  req.motion.angular_velocity.z() = INFINITY;
  EXPECT_THROW(lidar.scan(scene, req), std::invalid_argument);
  req = at(Vector3d(0, 0, 2));
  req.weather.fog_visibility = std::nan("");
  try
  {
    lidar.scan(scene, req);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("fog_visibility"), std::string::npos) << e.what();
  }
  req = at(Vector3d(0, 0, 2));
  req.weather.rain_rate = -1.0;
  EXPECT_THROW(lidar.scan(scene, req), std::invalid_argument);
}
