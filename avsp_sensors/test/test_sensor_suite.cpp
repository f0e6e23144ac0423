// A vehicle's sensor suite driven by states in sim time (sensor_suite.hpp): sampling grids and
// counts, the lidar sweep's motion between two states, IMU from successive velocities (+g at
// rest, a known yaw rate and centripetal force), radar Doppler of another vehicle's body, own
// body hidden, GPS through the reference, the occupancy map and its grid window, the merge of
// vehicle streams (same batches for any interleaving, timeouts), rut patches, determinism.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/sensor_suite.hpp"
#include "avsp_sensors/terrain_patch.hpp"

using namespace avsp::sensors;

namespace
{
constexpr double kPi = 3.14159265358979323846;

/// A flat square of side 2 * half at height z, 0.5 m cells, centred on the origin.
HeightField flat(double half = 100.0, float z = 0.f)
{
  const double cell = 0.5;
  const std::size_t n = static_cast<std::size_t>(2 * half / cell) + 1;
  return HeightField(-half, -half, cell, cell, n, n, std::vector<float>(n * n, z));
}

Eigen::Isometry3d mountAt(double x, double y, double z)
{
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.translation() = Eigen::Vector3d(x, y, z);
  return m;
}

VehicleState at(double t, double x, double y, double yaw, double speed = 0.0, double yaw_rate = 0.0)
{
  VehicleState s;
  s.time = t;
  s.pose.translation() = Eigen::Vector3d(x, y, 0.5);
  s.pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  s.linear_velocity = s.pose.linear() * Eigen::Vector3d(speed, 0, 0);
  s.angular_velocity = Eigen::Vector3d(0, 0, yaw_rate);
  return s;
}

ImuConfig quietImu()
{
  ImuConfig c;
  c.gyro_noise_density = c.gyro_random_walk = c.accel_noise_density = c.accel_random_walk = 0.0;
  c.orientation_noise = 0.0;
  return c;
}

/// A car-sized box, base_link at the bottom of its wheels' axle height.
std::vector<BodyBox> carBoxes()
{
  BodyBox b;
  b.pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);
  b.size = Eigen::Vector3d(4.0, 2.0, 1.5);
  return { b };
}

/// 100 Hz states of a vehicle standing at (x, y) from t0 for `seconds`.
std::vector<VehicleState> standing(double x, double y, double seconds, double t0 = 0.0)
{
  std::vector<VehicleState> out;
  for (int k = 0; k <= static_cast<int>(std::lround(seconds * 100)); ++k)
    out.push_back(at(t0 + 0.01 * k, x, y, 0.0));
  return out;
}

std::string thrown(const std::function<void()>& f)
{
  try
  {
    f();
  }
  catch (const std::exception& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(GridClock, SamplesOnTheAbsoluteGridAtTheFirstStateAtOrAfterEachGridTime)
{
  // 10 Hz over 100 Hz states from t = 0.03: the first sample waits for 0.1, then every 0.1 s.
  GridClock clock(10.0);
  std::vector<double> taken;
  for (int k = 3; k <= 103; ++k)
  {
    const double t = 0.01 * k;
    if (clock.due(t))
    {
      clock.taken(t);
      taken.push_back(t);
    }
  }
  ASSERT_EQ(taken.size(), 10u);
  for (std::size_t k = 0; k < taken.size(); ++k)
    EXPECT_NEAR(taken[k], 0.1 * (k + 1), 1e-9);

  // 15 Hz over 100 Hz states: 75 samples in 5 s, each at the first state at or after k / 15.
  GridClock mag(15.0);
  int count = 0;
  for (int k = 0; k < 500; ++k)
  {
    const double t = 0.01 * k;
    if (mag.due(t))
    {
      const double grid = std::ceil(t * 15.0 - 1e-6) / 15.0;
      EXPECT_LT(t - grid, 0.01 + 1e-9) << t;
      mag.taken(t);
      ++count;
    }
  }
  EXPECT_EQ(count, 75);
  EXPECT_EQ(GridClock(10.0).index(2.3), 23u);
}

TEST(VehicleSensors, EverySensorSamplesAtItsRateOverFiveSeconds)
{
  Scene scene(flat());
  SuiteConfig c;
  c.lidar.emplace();
  c.lidar->config = lidarPreset("VLP-16");
  c.lidar->config.sub_rays = 1;
  c.lidar->mount = mountAt(1.0, 0.0, 1.4);
  c.radar.emplace();
  c.radar->rate = 20.0;
  c.gps.emplace();
  c.gps->config.rate = 5.0;
  c.imu = ImuConfig();
  c.magnetometer = MagnetometerConfig();
  UltrasonicSetup u;
  u.name = "front";
  c.ultrasonics.push_back(u);
  c.occupancy.emplace();
  c.occupancy->publish_rate = 2.0;
  VehicleSensors s(c, EnuFrame({ 42.3, -83.2, 180.0 }), 0);
  std::map<std::string, int> counts;
  for (const VehicleState& st : standing(0.0, 0.0, 5.0))
  {
    const SuiteOutput o = s.update(st, scene, Weather(), 2);
    // Count samples whose time lies in [0, 5).
    if (st.time > 5.0 - 1e-9)
      break;
    counts["lidar"] += o.lidar ? 1 : 0;
    counts["radar"] += o.radar ? 1 : 0;
    counts["gps"] += o.gps ? 1 : 0;
    counts["imu"] += o.imu ? 1 : 0;
    counts["mag"] += o.magnetometer ? 1 : 0;
    counts["ultrasonic"] += static_cast<int>(o.ultrasonics.size());
    counts["occupancy"] += o.occupancy_due ? 1 : 0;
  }
  EXPECT_EQ(counts["lidar"], 49);  // sweeps [0, 0.1) ... [4.8, 4.9) end before 5 s
  EXPECT_EQ(counts["radar"], 100);
  EXPECT_EQ(counts["gps"], 25);
  EXPECT_EQ(counts["imu"], 500);
  EXPECT_EQ(counts["mag"], 75);
  EXPECT_EQ(counts["ultrasonic"], 50);
  EXPECT_EQ(counts["occupancy"], 10);
}

TEST(VehicleSensors, ImuAtRestReadsPlusGAndTurningReadsTheYawRateAndCentripetalForce)
{
  Scene scene(flat());
  SuiteConfig c;
  c.imu = quietImu();
  VehicleSensors rest(c, std::nullopt, 0);
  for (const VehicleState& st : standing(3.0, 4.0, 0.5))
  {
    const SuiteOutput o = rest.update(st, scene, Weather(), 1);
    ASSERT_TRUE(o.imu);
    EXPECT_NEAR((o.imu->linear_acceleration - Eigen::Vector3d(0, 0, 9.81)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(o.imu->angular_velocity.norm(), 0.0, 1e-15);
  }

  // Circling at v = 5 m/s, w = 0.5 rad/s (radius 10 m), states every 10 ms: the IMU reads the
  // yaw rate, and from the velocities' backward difference the centripetal force
  // (v / dt) sin(w dt) to the left (+y) (and (v / dt)(1 - cos(w dt)) on x, the difference
  // quotient's half-step lag), gravity on z.
  VehicleSensors turning(c, std::nullopt, 0);
  const double v = 5.0, w = 0.5, dt = 0.01;
  for (int k = 0; k <= 100; ++k)
  {
    const double t = k * dt, yaw = w * t;
    const VehicleState st = at(t, 10.0 * std::sin(yaw), 10.0 - 10.0 * std::cos(yaw), yaw, v, w);
    const SuiteOutput o = turning.update(st, scene, Weather(), 1);
    ASSERT_TRUE(o.imu);
    EXPECT_NEAR(o.imu->angular_velocity.z(), w, 1e-12);
    if (k > 0)
    {
      EXPECT_NEAR(o.imu->linear_acceleration.y(), v / dt * std::sin(w * dt), 1e-9) << k;
      EXPECT_NEAR(o.imu->linear_acceleration.x(), v / dt * (1.0 - std::cos(w * dt)), 1e-9) << k;
      EXPECT_NEAR(o.imu->linear_acceleration.z(), 9.81, 1e-12);
    }
  }
}

TEST(VehicleSensors, LidarSweepRunsBetweenTwoStatesWithTheTwistJoiningThem)
{
  Scene scene(flat());
  SuiteConfig c;
  c.lidar.emplace();
  c.lidar->config = lidarPreset("VLP-16");
  c.lidar->config.sub_rays = 1;
  c.lidar->config.range_noise = 0.0;
  c.lidar->mount = mountAt(1.0, 0.0, 1.4);
  VehicleSensors s(c, std::nullopt, 0);
  // Driving at 10 m/s along +x while yawing at 0.2 rad/s.
  std::vector<LidarSweep> sweeps;
  for (int k = 0; k <= 30; ++k)
  {
    const double t = 0.01 * k;
    VehicleState st = at(t, 10.0 * t, 0.0, 0.2 * t, 0.0, 0.2);
    st.linear_velocity = Eigen::Vector3d(10.0, 0.0, 0.0);
    SuiteOutput o = s.update(st, scene, Weather(), 2);
    if (o.lidar)
      sweeps.push_back(std::move(*o.lidar));
  }
  ASSERT_EQ(sweeps.size(), 3u);
  for (std::size_t k = 0; k < sweeps.size(); ++k)
  {
    const LidarSweep& w = sweeps[k];
    EXPECT_NEAR(w.start, 0.1 * k, 1e-12);
    const VehicleState s0 = at(w.start, 10.0 * w.start, 0.0, 0.2 * w.start);
    const VehicleState s1 = at(w.start + 0.1, 10.0 * (w.start + 0.1), 0.0, 0.2 * (w.start + 0.1));
    const Eigen::Isometry3d q0 = s0.pose * c.lidar->mount, q1 = s1.pose * c.lidar->mount;
    EXPECT_LT((w.motion.pose.matrix() - q0.matrix()).cwiseAbs().maxCoeff(), 1e-12);
    // The twist carries the sensor exactly to its pose at the end of the sweep.
    EXPECT_LT((w.motion.at(0.1).matrix() - q1.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_NEAR(w.motion.angular_velocity.z(), 0.2, 1e-9);
    // Registered points over flat ground at z = 0, within float rounding (the rings that meet
    // the soil at grazing incidence beyond ~30 m fall below the detection threshold).
    ASSERT_GT(w.scan.points.size(), 5000u);
    for (const LidarPoint& p : w.scan.points)
      ASSERT_NEAR(p.z, 0.0, 2e-3);
  }
}

TEST(VehicleSensors, OwnBodyIsHiddenOtherVehiclesAreSeenWithTheirDoppler)
{
  Scene scene(flat());
  const std::vector<BodyBox> boxes = carBoxes();
  // Vehicle 0 at the origin facing +x; vehicle 1 20 m ahead driving away at 3 m/s.
  const VehicleState a = at(0.0, 0.0, 0.0, 0.0);
  const VehicleState b = at(0.0, 20.0, 0.0, 0.0, 3.0);
  std::vector<Body> bodies = vehicleBodies(boxes, a, 0, 0.5f);
  const std::vector<Body> bb = vehicleBodies(boxes, b, 1, 0.5f);
  bodies.insert(bodies.end(), bb.begin(), bb.end());
  scene.setBodies(bodies);
  EXPECT_NEAR((bb[0].primitive.centre - Eigen::Vector3d(20.0, 0.0, 1.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((bb[0].velocity - Eigen::Vector3d(3.0, 0.0, 0.0)).norm(), 0.0, 1e-12);

  SuiteConfig c;
  c.lidar.emplace();
  c.lidar->config = lidarPreset("VLP-16");
  c.lidar->config.sub_rays = 1;
  c.lidar->mount = mountAt(0.5, 0.0, 1.0);  // inside the own box: it must see out of it
  c.radar.emplace();
  c.radar->mount = mountAt(2.1, 0.0, 0.6);
  VehicleSensors s(c, std::nullopt, 0);
  s.update(a, scene, Weather(), 2);
  VehicleState a1 = a;
  a1.time = 0.1;
  const SuiteOutput o = s.update(a1, scene, Weather(), 2);
  ASSERT_TRUE(o.lidar);
  std::size_t on_b = 0;
  for (const LidarPoint& p : o.lidar->scan.points)
  {
    const Eigen::Vector3d q(p.x, p.y, p.z);
    EXPECT_FALSE(std::abs(q.x()) < 2.0 && std::abs(q.y()) < 1.0 && q.z() > 0.25 && q.z() < 1.75)
        << "a point on the own body at " << q.transpose();
    if (std::abs(q.x() - 20.0) < 2.01 && std::abs(q.y()) < 1.01 && q.z() > 0.2)
      ++on_b;
  }
  EXPECT_GT(on_b, 20u);
  ASSERT_TRUE(o.radar);
  bool seen = false;
  for (const RadarTarget& t : o.radar->scan.targets)
    if (std::abs(t.centroid.x() - (18.0 - 2.1)) < 0.5)
    {
      seen = true;
      EXPECT_NEAR(t.range_rate, 3.0, 0.05);  // receding: + (the radar stands still)
      EXPECT_NEAR(t.azimuth, 0.0, 0.05);
    }
  EXPECT_TRUE(seen) << o.radar->scan.targets.size() << " targets";
}

TEST(VehicleSensors, GpsFixIsTheMountThroughTheReferenceAndMagnetometerTurnsWithTheBody)
{
  Scene scene(flat());
  SuiteConfig c;
  c.gps.emplace();
  c.gps->config.horizontal_noise = c.gps->config.vertical_noise = 0.0;
  c.gps->config.horizontal_bias_sigma = c.gps->config.vertical_bias_sigma = 0.0;
  c.gps->mount = mountAt(-0.5, 0.0, 1.25);
  c.magnetometer = MagnetometerConfig();
  c.magnetometer->noise = 0.0;
  const EnuFrame origin({ 42.3, -83.2, 180.0 });
  VehicleSensors s(c, origin, 0);
  const VehicleState st = at(0.0, 30.0, -40.0, kPi / 2);  // facing north
  const SuiteOutput o = s.update(st, scene, Weather(), 1);
  ASSERT_TRUE(o.gps);
  const Geodetic expected = origin.toGeodetic(Eigen::Vector3d(30.0, -40.5, 1.75));
  EXPECT_NEAR(o.gps->position.latitude_deg, expected.latitude_deg, 1e-11);
  EXPECT_NEAR(o.gps->position.longitude_deg, expected.longitude_deg, 1e-11);
  EXPECT_NEAR(o.gps->position.altitude, expected.altitude, 1e-6);
  // Facing north with declination 0: the horizontal field along the body's x axis.
  ASSERT_TRUE(o.magnetometer);
  const EarthField f = c.magnetometer->field;
  const double kDeg = kPi / 180;
  EXPECT_NEAR(o.magnetometer->field.x(), f.intensity * std::cos(f.inclination_deg * kDeg), 1e-12);
  EXPECT_NEAR(o.magnetometer->field.y(), 0.0, 1e-12);
  EXPECT_NEAR(o.magnetometer->field.z(), -f.intensity * std::sin(f.inclination_deg * kDeg), 1e-12);
}

TEST(VehicleSensors, OccupancyMapMarksAWallAheadAndItsGridFollowsTheVehicleOnWholeCells)
{
  Scene scene(flat());
  Primitive wall;
  wall.shape = Shape::kBox;
  wall.centre = Eigen::Vector3d(12.0, 0.0, 1.5);
  wall.half_extents = Eigen::Vector3d(0.2, 3.0, 1.5);
  scene.setStaticPrimitives({ wall });
  SuiteConfig c;
  c.lidar.emplace();
  c.lidar->config = lidarPreset("VLP-16");
  c.lidar->config.sub_rays = 1;
  c.lidar->mount = mountAt(0.0, 0.0, 1.5);
  c.occupancy.emplace();
  c.occupancy->grid_size = 40.0;
  VehicleSensors s(c, std::nullopt, 0);
  for (const VehicleState& st : standing(0.03, 0.01, 0.2))
    s.update(st, scene, Weather(), 2);
  ASSERT_NE(s.occupancy(), nullptr);
  const OccupancyGrid2D g = s.occupancyGrid(0.03, 0.01, scene.terrain());
  EXPECT_EQ(g.width, 200u);
  EXPECT_NEAR(std::remainder(g.origin_x, 0.2), 0.0, 1e-9);
  EXPECT_NEAR(std::remainder(g.origin_y, 0.2), 0.0, 1e-9);
  EXPECT_EQ(g.atPoint(11.9, 0.1), OccupancyGrid2D::kOccupied);
  EXPECT_EQ(g.atPoint(6.0, 0.1), OccupancyGrid2D::kFree);
  EXPECT_EQ(g.atPoint(16.0, 0.1), OccupancyGrid2D::kUnknown);  // the wall's shadow
}

TEST(VehicleSensors, SameStatesSameOutputsOnAnyThreadCount)
{
  Scene scene(flat());
  SuiteConfig c;
  c.lidar.emplace();
  c.lidar->config = lidarPreset("VLP-16");
  c.lidar->config.dropout = 0.05;
  c.lidar->mount = mountAt(1.0, 0.0, 1.4);
  c.radar.emplace();
  c.radar->config.range_noise = 0.1;
  c.imu = ImuConfig();
  c.gps.emplace();
  c.seed = 99;
  const EnuFrame origin({ 10.0, 20.0, 0.0 });
  VehicleSensors one(c, origin, 0), three(c, origin, 0);
  for (int k = 0; k <= 20; ++k)
  {
    const VehicleState st = at(0.01 * k, 0.3 * k, 0.0, 0.01 * k, 30.0, 1.0);
    const SuiteOutput a = one.update(st, scene, Weather(), 1), b = three.update(st, scene, Weather(), 3);
    ASSERT_EQ(a.lidar.has_value(), b.lidar.has_value());
    if (a.lidar)
    {
      ASSERT_EQ(a.lidar->scan.points.size(), b.lidar->scan.points.size());
      for (std::size_t i = 0; i < a.lidar->scan.points.size(); ++i)
        ASSERT_EQ(a.lidar->scan.points[i].x, b.lidar->scan.points[i].x);
    }
    ASSERT_EQ(a.imu->linear_acceleration, b.imu->linear_acceleration);
    ASSERT_EQ(a.radar.has_value(), b.radar.has_value());
    if (a.gps)
    {
      ASSERT_EQ(a.gps->position.latitude_deg, b.gps->position.latitude_deg);
    }
  }
  // Another seed: other noise.
  c.seed = 100;
  VehicleSensors other(c, origin, 0);
  VehicleSensors again(SuiteConfig(one.config()), origin, 0);
  const SuiteOutput x = other.update(at(0.0, 0.0, 0.0, 0.0), scene, Weather(), 1);
  const SuiteOutput y = again.update(at(0.0, 0.0, 0.0, 0.0), scene, Weather(), 1);
  EXPECT_NE(x.imu->linear_acceleration, y.imu->linear_acceleration);
}

TEST(VehicleSensors, BadConfigurationsAndStatesNameTheField)
{
  SuiteConfig c;
  c.occupancy.emplace();
  EXPECT_NE(thrown([&] { VehicleSensors s(c, std::nullopt, 0); }).find("occupancy: needs a lidar"), std::string::npos);
  c = SuiteConfig();
  c.gps.emplace();
  EXPECT_NE(thrown([&] { VehicleSensors s(c, std::nullopt, 0); }).find("gps: needs"), std::string::npos);
  c = SuiteConfig();
  c.radar.emplace();
  c.radar->rate = 0.0;
  EXPECT_NE(thrown([&] { VehicleSensors s(c, std::nullopt, 0); }).find("rate"), std::string::npos);
  c = SuiteConfig();
  UltrasonicSetup u;
  u.name = "a";
  c.ultrasonics = { u, u };
  EXPECT_NE(thrown([&] { VehicleSensors s(c, std::nullopt, 0); }).find("'a': name is used twice"), std::string::npos);
  c = SuiteConfig();
  c.lidar.emplace();
  c.lidar->config = lidarPreset("VLP-16");
  c.lidar->config.max_range = -1.0;
  EXPECT_NE(thrown([&] { VehicleSensors s(c, std::nullopt, 0); }).find("max_range"), std::string::npos);

  Scene scene(flat());
  c = SuiteConfig();
  c.imu = ImuConfig();
  VehicleSensors s(c, std::nullopt, 0);
  VehicleState st = at(1.0, 0, 0, 0);
  st.linear_velocity.x() = std::nan("");
  EXPECT_NE(thrown([&] { s.update(st, scene, Weather(), 1); }).find("linear_velocity"), std::string::npos);
  s.update(at(1.0, 0, 0, 0), scene, Weather(), 1);
  EXPECT_NE(thrown([&] { s.update(at(0.5, 0, 0, 0), scene, Weather(), 1); }).find("earlier"), std::string::npos);
}

TEST(StateSynchronizer, AnyInterleavingOfTheStreamsGivesTheSameBatches)
{
  // Three vehicles at 100 Hz (the third at 50 Hz), pushed in 20 random interleavings.
  std::vector<std::vector<VehicleState>> streams(3);
  for (int k = 0; k < 100; ++k)
  {
    streams[0].push_back(at(0.01 * k, 0, 0, 0));
    streams[1].push_back(at(0.01 * k, 5, 0, 0));
    if (k % 2 == 0)
      streams[2].push_back(at(0.01 * k, 9, 0, 0));
  }
  std::vector<std::pair<double, std::vector<std::size_t>>> reference;
  for (int run = 0; run < 20; ++run)
  {
    std::mt19937 rng(run);
    StateSynchronizer sync(3, 10.0);
    std::vector<std::size_t> next(3, 0);
    std::vector<std::pair<double, std::vector<std::size_t>>> batches;
    while (next[0] < streams[0].size() || next[1] < streams[1].size() || next[2] < streams[2].size())
    {
      const std::size_t v = rng() % 3;
      if (next[v] >= streams[v].size())
        continue;
      ASSERT_EQ(sync.push(v, streams[v][next[v]++]), StateSynchronizer::Push::kQueued);
      while (auto b = sync.next())  // the streams span < 10 s: nobody is waited out
        batches.emplace_back(b->time, b->vehicles);
    }
    if (run == 0)
      reference = batches;
    ASSERT_EQ(batches, reference) << "run " << run;
  }
  // Released in time order; the last time waits for the third vehicle that ended at 0.98.
  ASSERT_EQ(reference.size(), 99u);
  EXPECT_EQ(reference[0].second, (std::vector<std::size_t>{ 0, 1, 2 }));
  EXPECT_EQ(reference[1].second, (std::vector<std::size_t>{ 0, 1 }));
}

TEST(StateSynchronizer, SilentVehicleIsWaitedOutOnceTheOthersRunAheadAndLateOrRepeatedStatesAreRefused)
{
  StateSynchronizer sync(2, 0.5);
  ASSERT_EQ(sync.push(0, at(1.0, 0, 0, 0)), StateSynchronizer::Push::kQueued);
  ASSERT_EQ(sync.push(0, at(1.5, 0, 0, 0)), StateSynchronizer::Push::kQueued);
  EXPECT_FALSE(sync.next());  // vehicle 0 is only 0.5 s ahead: vehicle 1 may still deliver 1.0
  EXPECT_TRUE(sync.waitedOut().empty());
  ASSERT_EQ(sync.push(0, at(1.51, 0, 0, 0)), StateSynchronizer::Push::kQueued);
  const auto b = sync.next();
  ASSERT_TRUE(b);
  EXPECT_EQ(b->time, 1.0);
  EXPECT_EQ(b->vehicles, std::vector<std::size_t>{ 0 });
  EXPECT_EQ(sync.waitedOut(), std::vector<std::size_t>{ 1 });
  EXPECT_FALSE(sync.next());  // 1.5: vehicle 0 is only 0.01 s beyond it
  EXPECT_EQ(sync.push(1, at(0.9, 0, 0, 0)), StateSynchronizer::Push::kLate);
  EXPECT_EQ(sync.push(0, at(1.0, 0, 0, 0)), StateSynchronizer::Push::kNotAfterLast);
  EXPECT_EQ(sync.push(1, at(1.5, 0, 0, 0)), StateSynchronizer::Push::kQueued);  // back again
  const auto c = sync.next();
  ASSERT_TRUE(c);
  EXPECT_EQ(c->time, 1.5);
  EXPECT_EQ(c->vehicles, (std::vector<std::size_t>{ 0, 1 }));
  ASSERT_TRUE(sync.latest(1));
  EXPECT_EQ(sync.latest(1)->time, 1.5);
  // A node that lags (every queue full) never waits anybody out.
  StateSynchronizer lagging(2, 0.1);
  for (int k = 0; k < 100; ++k)
    lagging.push(0, at(0.01 * k, 0, 0, 0));
  for (int k = 0; k < 100; ++k)
    lagging.push(1, at(0.01 * k, 0, 0, 0));
  int batches = 0;
  while (auto d = lagging.next())
  {
    EXPECT_EQ(d->vehicles.size(), 2u);
    ++batches;
  }
  EXPECT_EQ(batches, 100);
}

// A vehicle spawned into a run with a long timeout (the lockstep's: the others never run far
// ahead): the times pending before its first state are released without it, from then on each
// waits for it; a removed vehicle's states up to its last are still released, later times go
// on without it (no wait), its later states are refused and its latest state is dropped.
TEST(StateSynchronizer, SpawnedVehicleIsWaitedForFromItsFirstStateAndARemovedOneUpToItsLast)
{
  StateSynchronizer sync(1, 1e9);
  for (int k = 1; k <= 3; ++k)
    ASSERT_EQ(sync.push(0, at(0.01 * k, 0, 0, 0)), StateSynchronizer::Push::kQueued);
  auto b = sync.next();
  ASSERT_TRUE(b);
  EXPECT_EQ(b->time, 0.01);
  EXPECT_THROW(sync.addVehicle(0.01), std::invalid_argument);  // already released
  const std::size_t spawned = sync.addVehicle(0.03);
  EXPECT_EQ(spawned, 1u);
  b = sync.next();  // 0.02: before the spawned vehicle's first state, not waited for
  ASSERT_TRUE(b);
  EXPECT_EQ(b->time, 0.02);
  EXPECT_EQ(b->vehicles, std::vector<std::size_t>{ 0 });
  EXPECT_FALSE(sync.next()) << "0.03 must wait for the spawned vehicle";
  ASSERT_EQ(sync.push(spawned, at(0.03, 9, 0, 0)), StateSynchronizer::Push::kQueued);
  b = sync.next();
  ASSERT_TRUE(b);
  EXPECT_EQ(b->time, 0.03);
  EXPECT_EQ(b->vehicles, (std::vector<std::size_t>{ 0, 1 }));
  ASSERT_TRUE(sync.latest(spawned));

  // Removed after its state at 0.05 (queued already, as its 0.06 was).
  for (int k = 4; k <= 6; ++k)
  {
    ASSERT_EQ(sync.push(0, at(0.01 * k, 0, 0, 0)), StateSynchronizer::Push::kQueued);
    ASSERT_EQ(sync.push(spawned, at(0.01 * k, 9, 0, 0)), StateSynchronizer::Push::kQueued);
  }
  sync.removeVehicle(spawned, 0.05);
  EXPECT_THROW(sync.removeVehicle(7, 0.05), std::out_of_range);
  EXPECT_EQ(sync.push(spawned, at(0.07, 9, 0, 0)), StateSynchronizer::Push::kNotAfterLast);
  for (double t : { 0.04, 0.05 })
  {
    b = sync.next();
    ASSERT_TRUE(b);
    EXPECT_EQ(b->time, t);
    EXPECT_EQ(b->vehicles, (std::vector<std::size_t>{ 0, 1 })) << t;
    EXPECT_FALSE(sync.gone(spawned));
  }
  b = sync.next();  // 0.06: its queued 0.06 was dropped by the removal; not waited for
  ASSERT_TRUE(b);
  EXPECT_EQ(b->time, 0.06);
  EXPECT_EQ(b->vehicles, std::vector<std::size_t>{ 0 });
  EXPECT_TRUE(sync.waitedOut().empty());
  EXPECT_FALSE(sync.latest(spawned)) << "a removed vehicle stays in the scene";
  EXPECT_TRUE(sync.gone(spawned));
  EXPECT_EQ(sync.addVehicle(0.07), 2u) << "indices are not reused";
}

TEST(TerrainPatch, AppliedPatchMatchesARebuildAndIsClippedToTheGrid)
{
  HeightField field = flat(10.0);
  avsp::terrain::HeightPatch p;
  p.resolution = 0.5;
  p.origin_x = 8.0;  // 6 x 3 points from (8, -1): the last column (x = 10.5) lies outside the grid
  p.origin_y = -1.0;
  p.width = 6;
  p.height = 3;
  for (std::size_t k = 0; k < p.width * p.height; ++k)
    p.heights.push_back(-0.1f * static_cast<float>(k % 5));
  const auto range = applyHeightPatch(field, p);
  ASSERT_TRUE(range);
  EXPECT_EQ(range->i0, 36u);
  EXPECT_EQ(range->i1, 40u);
  EXPECT_EQ(range->j0, 18u);
  EXPECT_EQ(range->j1, 20u);
  EXPECT_FLOAT_EQ(static_cast<float>(field.pointHeight(37, 19)), p.heights[1 * 6 + 1]);
  // Mips as a full rebuild from the same heights.
  std::vector<float> heights(field.columns() * field.rows());
  for (std::size_t j = 0; j < field.rows(); ++j)
    for (std::size_t i = 0; i < field.columns(); ++i)
      heights[j * field.columns() + i] = static_cast<float>(field.pointHeight(i, j));
  const HeightField rebuilt(field.originX(), field.originY(), 0.5, 0.5, field.columns(), field.rows(), heights);
  for (std::size_t level = 1; level <= field.mipLevels(); ++level)
    for (std::size_t bj = 0; bj < field.mipRows(level); ++bj)
      for (std::size_t bi = 0; bi < field.mipColumns(level); ++bi)
        ASSERT_EQ(field.mipMax(level, bi, bj), rebuilt.mipMax(level, bi, bj));

  p.origin_x = 100.0;
  EXPECT_FALSE(applyHeightPatch(field, p));  // wholly outside: nothing changes
  p.origin_x = 8.25;
  EXPECT_NE(thrown([&] { applyHeightPatch(field, p); }).find("not on a grid point"), std::string::npos);
  p.origin_x = 8.0;
  p.resolution = 0.25;
  EXPECT_NE(thrown([&] { applyHeightPatch(field, p); }).find("resolution"), std::string::npos);
  p.resolution = 0.5;
  p.width = 5;
  EXPECT_NE(thrown([&] { applyHeightPatch(field, p); }).find("does not match"), std::string::npos);
  p.width = 6;
  p.heights[3] = std::nanf("");
  EXPECT_NE(thrown([&] { applyHeightPatch(field, p); }).find("non-finite"), std::string::npos);
}
