// WheelOdometry: exact arcs against closed forms; runningGearSpeed on hand-made states; and the
// drift it should have: driving the fed_alpha and the M113 straight, the odometry over-reads
// the distance by at least the running gear's slip, the more the softer the soil.
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"
#include "avsp_dynamics/wheel_odometry.hpp"

using namespace avsp::dynamics;
namespace terrain = avsp::terrain;

namespace
{
VehicleModel vehicle(const std::string& name)
{
  return loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/" + name + ".yaml");
}

std::unique_ptr<terrain::DeformableTerrain> flat(const std::string& soil, double size, double res)
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  const std::size_t n = static_cast<std::size_t>(std::lround(size / res)) + 1;
  return std::make_unique<terrain::DeformableTerrain>(
      terrain::ElevationGrid(-0.5 * size, -0.5 * size, res, res, n, n, std::vector<float>(n * n, 0.0f)), lib.get(soil),
      terrain::DeformableTerrain::Options{ true });
}

struct Drift
{
  double driven = 0.0;    ///< m over the ground (map, plane)
  double measured = 0.0;  ///< m the odometry says
  double slip = 0.0;      ///< mean slip of the driven running gear
};

/// Drives `model` straight at `throttle` for `seconds` after settling, odometry from rest.
Drift driveStraight(const std::string& model, const std::string& soil, double throttle, double seconds)
{
  const VehicleModel m = vehicle(model);
  auto ground = flat(soil, 80.0, 0.1);
  WorldOptions options;
  World world(*ground, options);
  const std::size_t id = world.addVehicle(m, world.restingPose(m, -30.0, 0.0, 0.0, 0.01));
  world.advance(1.0);  // settle (braked: no command yet)
  const Eigen::Vector3d start = world.state(id).pose.translation();
  WheelOdometry odometry(world.state(id).pose);
  DriveCommand c;
  c.throttle = throttle;
  c.brake = 0.0;
  double slip_sum = 0.0;
  int slip_samples = 0;
  const double end = world.time() + seconds;
  while (world.time() < end)
  {
    world.setCommand(id, c);
    world.step();
    const VehicleState& s = world.state(id);
    odometry.step(runningGearSpeed(m, s), bodyYawRate(s), options.step);
    double sum = 0.0;
    int n = 0;
    for (std::size_t w = 0; w < s.wheels.size(); ++w)
      if (m.wheels[w].driven && s.wheels[w].in_contact)
        sum += s.wheels[w].slip, ++n;
    for (const TrackState& t : s.tracks)
      sum += t.slip, ++n;
    if (n > 0 && world.time() > end - 0.5 * seconds)
      slip_sum += sum / n, ++slip_samples;
  }
  const Eigen::Vector3d p = world.state(id).pose.translation();
  Drift d;
  d.driven = std::hypot(p.x() - start.x(), p.y() - start.y());
  d.measured = std::hypot(odometry.x() - start.x(), odometry.y() - start.y());
  d.slip = slip_samples > 0 ? slip_sum / slip_samples : 0.0;
  std::printf("[wheel odometry] %s on %s: driven %.2f m, odometry %.2f m (+%.1f %%), slip %.3f\n", model.c_str(),
              soil.c_str(), d.driven, d.measured, 100.0 * (d.measured / d.driven - 1.0), d.slip);
  return d;
}
}  // namespace

TEST(WheelOdometry, StraightLinesAndArcsAreExact)
{
  WheelOdometry o;  // at the origin facing +x
  o.step(2.0, 0.0, 1.5);
  EXPECT_DOUBLE_EQ(o.x(), 3.0);
  EXPECT_DOUBLE_EQ(o.y(), 0.0);
  // A quarter circle of radius v / w = 4 m to the left: (3 + 4, 4), facing +y.
  const double v = 2.0, w = 0.5;
  for (int k = 0; k < 1000; ++k)
    o.step(v, w, 0.5 * M_PI / w / 1000.0);
  EXPECT_NEAR(o.x(), 7.0, 1e-9);
  EXPECT_NEAR(o.y(), 4.0, 1e-9);
  EXPECT_NEAR(o.yaw(), 0.5 * M_PI, 1e-12);
  EXPECT_NEAR(o.distance(), 3.0 + 4.0 * 0.5 * M_PI, 1e-9);
  EXPECT_NEAR(o.turned(), 0.5 * M_PI, 1e-12);
  // Backwards on the same arc (negative speed, negative rate): back to (3, 0) facing +x.
  for (int k = 0; k < 7; ++k)
    o.step(-v, -w, 0.5 * M_PI / w / 7.0);
  EXPECT_NEAR(o.x(), 3.0, 1e-9);
  EXPECT_NEAR(o.y(), 0.0, 1e-9);
  EXPECT_NEAR(o.yaw(), 0.0, 1e-12);
}

TEST(WheelOdometry, StartsAtTheGivenPoseAndHeading)
{
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  start.translation() = Eigen::Vector3d(10.0, -5.0, 1.2);
  // Heading 30 deg, pitched 10 deg: only the heading is kept.
  start.linear() =
      (Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  WheelOdometry o(start);
  EXPECT_NEAR(o.yaw(), M_PI / 6, 1e-12);
  o.step(1.0, 0.0, 2.0);
  EXPECT_NEAR(o.x(), 10.0 + 2.0 * std::cos(M_PI / 6), 1e-12);
  EXPECT_NEAR(o.y(), -5.0 + 2.0 * std::sin(M_PI / 6), 1e-12);
  EXPECT_EQ(o.z(), 1.2);
  EXPECT_TRUE(o.pose().linear().isApprox(Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix()));
}

TEST(WheelOdometry, RunningGearSpeedIsTheMeanRimOrBeltSpeed)
{
  const VehicleModel car = vehicle("fed_alpha");
  VehicleState s;
  s.wheels.resize(car.wheels.size());
  double expected = 0.0;
  for (std::size_t w = 0; w < s.wheels.size(); ++w)
  {
    s.wheels[w].spin_rate = 5.0 + w;
    expected += (5.0 + w) * car.wheels[w].radius;
  }
  EXPECT_NEAR(runningGearSpeed(car, s), expected / s.wheels.size(), 1e-12);
  const VehicleModel tank = vehicle("m113");
  VehicleState t;
  t.tracks.resize(2);
  t.tracks[0].track_speed = 2.0;
  t.tracks[1].track_speed = 3.0;
  EXPECT_DOUBLE_EQ(runningGearSpeed(tank, t), 2.5);
  // Yaw rate of a body-fixed gyro: a vehicle rolled 90 deg reads the map's yaw rate on its y axis.
  VehicleState r;
  r.angular_velocity = Eigen::Vector3d(0.0, 0.0, 0.4);
  EXPECT_DOUBLE_EQ(bodyYawRate(r), 0.4);
  r.pose.linear() = Eigen::AngleAxisd(0.5 * M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_NEAR(bodyYawRate(r), 0.0, 1e-12);
}

TEST(WheelOdometry, BadInputsAreRefused)
{
  WheelOdometry o;
  EXPECT_THROW(o.step(std::nan(""), 0.0, 0.01), std::invalid_argument);
  EXPECT_THROW(o.step(1.0, INFINITY, 0.01), std::invalid_argument);
  EXPECT_THROW(o.step(1.0, 0.0, -0.01), std::invalid_argument);
  EXPECT_EQ(o.x(), 0.0);
  const VehicleModel car = vehicle("fed_alpha");
  VehicleState s;
  s.wheels.resize(2);
  EXPECT_THROW(runningGearSpeed(car, s), std::invalid_argument);
}

TEST(WheelOdometry, DriftGrowsWithTheSlipOfTheSoil)
{
  // Full throttle, straight, 8 s: the fed_alpha on gravel, sandy loam and clay (its mean driven
  // slip about 0.04, 0.08, 0.7 here), the M113 on gravel and snow (0.001, 0.08). Wheel speed =
  // ground speed / (1 - slip): the odometry reads long by at least the slip, and the more the
  // soil makes the running gear slip, the further it drifts.
  const std::vector<std::pair<std::string, std::vector<std::string>>> runs = {
    { "fed_alpha", { "gravel", "sandy_loam", "clay" } }, { "m113", { "gravel", "snow" } }
  };
  for (const auto& [model, soils] : runs)
  {
    double last_over = -1.0, last_slip = -1.0;
    for (const std::string& soil : soils)
    {
      const Drift d = driveStraight(model, soil, 1.0, 8.0);
      ASSERT_GT(d.driven, 5.0) << model << " on " << soil << " did not get going";
      const double over = d.measured / d.driven - 1.0;
      EXPECT_GT(over, d.slip) << model << " on " << soil;
      EXPECT_GT(d.slip, last_slip) << model << " on " << soil << " (soils ordered by slip)";
      EXPECT_GT(over, last_over) << model << " on " << soil << ": more slip, more drift";
      last_over = over;
      last_slip = d.slip;
    }
  }
}
