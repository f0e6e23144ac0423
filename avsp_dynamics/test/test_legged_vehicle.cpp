// The legged vehicle (the quadruped, issue 24's first stage): its legs' kinematics against their
// own forward solution, standing on gravel and asphalt, its feet on dry sand, pushes it takes and
// one that topples it, bad model files.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/leg_kinematics.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"
#include "soil_settling.hpp"

using namespace avsp::dynamics;
namespace terrain = avsp::terrain;

namespace
{
const std::string kConfigDir = AVSP_VEHICLE_CONFIG_DIR;
constexpr double kG = 9.81;

using test::soils;

const VehicleModel& quadruped()
{
  static const VehicleModel m = loadVehicleModel(kConfigDir + "/quadruped.yaml");
  return m;
}

std::unique_ptr<terrain::DeformableTerrain> flat(const terrain::SoilParameters& soil, double size, double res)
{
  const std::size_t n = static_cast<std::size_t>(std::lround(size / res)) + 1;
  terrain::ElevationGrid grid(-0.5 * size, -0.5 * size, res, res, n, n, std::vector<float>(n * n, 0.f));
  return std::make_unique<terrain::DeformableTerrain>(grid, soil, terrain::DeformableTerrain::Options{ true });
}

double horizontal(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::hypot(a.x() - b.x(), a.y() - b.y());
}
}  // namespace

// The model: 12 actuated joints from the URDF, its mass, the joint kinds' limits from the YAML.
TEST(LeggedVehicle, TheQuadrupedLoadsWithTwelveJoints)
{
  const VehicleModel& m = quadruped();
  EXPECT_EQ(m.drive_type, DriveType::kLegged);
  ASSERT_EQ(m.legs.size(), 4u);
  EXPECT_NEAR(m.total_mass, 30.0 + 4 * (1.5 + 2.5 + 0.7 + 0.15), 1e-9);
  EXPECT_EQ(m.legs[0].joints[2], "front_left_knee");
  EXPECT_EQ(m.legs[3].foot_link, "rear_right_foot");
  EXPECT_DOUBLE_EQ(m.legs[0].foot_radius, 0.03);
  EXPECT_DOUBLE_EQ(m.legged.joints[2].max_torque, 80.0);
  EXPECT_DOUBLE_EQ(m.legged.joints[2].upper, -0.1);
  EXPECT_NEAR(m.wheelbase(), 0.56, 1e-12);
  EXPECT_NEAR(m.trackWidth(), 2 * (0.12 + 0.08), 1e-12);
  // Only the trunk's box collides (leg links have none; the feet are running gear).
  ASSERT_EQ(m.collision_boxes.size(), 1u);
  EXPECT_EQ(m.collision_boxes[0].link, "chassis");
}

// Inverse kinematics is forward kinematics' inverse over the leg's workspace, both knee ways;
// the stance puts each foot under its hip flexion joint, the sole stance.height below base_link.
TEST(LeggedVehicle, InverseKinematicsInvertsTheForwardSolution)
{
  const VehicleModel& m = quadruped();
  int solved = 0;
  for (const LegSpec& leg : m.legs)
    for (const bool backward : { true, false })
      for (double dx = -0.2; dx <= 0.2001; dx += 0.1)
        for (double dy = -0.1; dy <= 0.1001; dy += 0.05)
          for (double h = 0.25; h <= 0.4501; h += 0.05)
          {
            const Eigen::Vector3d target = leg.anchors[1] + Eigen::Vector3d(dx, dy, -h);
            const auto q = legInverse(leg, target, backward);
            ASSERT_TRUE(q.has_value()) << leg.name << " " << target.transpose();
            EXPECT_LT((legForward(leg, *q).foot - target).norm(), 1e-9) << leg.name << " " << target.transpose();
            EXPECT_TRUE(backward ? (*q)[2] < 0.0 : (*q)[2] > 0.0);
            ++solved;
          }
  EXPECT_EQ(solved, 4 * 2 * 5 * 5 * 5);
  EXPECT_FALSE(legInverse(m.legs[0], m.legs[0].anchors[1] - Eigen::Vector3d(0, 0, 0.7), true).has_value());
  for (const LegSpec& leg : m.legs)
  {
    const LegAngles q = stanceAngles(m, leg);
    const Eigen::Vector3d foot = legForward(leg, q).foot;
    EXPECT_NEAR(foot.x(), leg.anchors[1].x(), 1e-9);
    EXPECT_NEAR(foot.y(), leg.anchors[1].y(), 1e-9);
    EXPECT_NEAR(foot.z() - leg.foot_radius, -m.legged.stance_height, 1e-9);
    // Knees backward: the knee behind the hip.
    EXPECT_LT((legForward(leg, q).motion[1] * leg.anchors[2]).x(), leg.anchors[1].x());
  }
}

// Set down in its stance, the robot's joints read the stance's angles and its feet stand where
// the kinematics puts them; standing 60 s on gravel and on asphalt it keeps its place within
// 1 cm, its height within 2 cm, its feet carry its weight and none of its joints leaves its range.
TEST(LeggedVehicle, StandsStillForSixtySecondsOnGravelAndAsphalt)
{
  const VehicleModel& m = quadruped();
  for (const char* soil : { "gravel", "asphalt" })
  {
    auto ground = flat(soils().get(soil), 6.0, 0.02);
    World world(*ground);
    const Eigen::Isometry3d pose = world.restingPose(m, 0.0, 0.0, 0.3);
    const std::size_t id = world.addVehicle(m, pose);
    const VehicleState& s0 = world.state(id);
    ASSERT_EQ(s0.joints.size(), 12u);
    for (std::size_t l = 0; l < m.legs.size(); ++l)
    {
      const LegAngles q = stanceAngles(m, m.legs[l]);
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(s0.joints[3 * l + k].position, q[k], 1e-12) << s0.joints[3 * l + k].name;
      EXPECT_LT((s0.feet[l].position - pose * legForward(m.legs[l], q).foot).norm(), 1e-9);
    }
    world.advance(2.0);
    const Eigen::Vector3d start = world.state(id).pose.translation();
    double worst_drift = 0.0, worst_height = 0.0, load = 0.0;
    int samples = 0;
    while (world.time() < 62.0)
    {
      world.step();
      const VehicleState& s = world.state(id);
      worst_drift = std::max(worst_drift, horizontal(s.pose.translation(), start));
      worst_height = std::max(worst_height, std::abs(s.pose.translation().z() - start.z()));
      for (std::size_t k = 0; k < s.joints.size(); ++k)
      {
        const LegJointSpec& j = m.legged.joints[k % 3];
        ASSERT_GE(s.joints[k].position, j.lower - 0.01) << s.joints[k].name;
        ASSERT_LE(s.joints[k].position, j.upper + 0.01) << s.joints[k].name;
      }
      if (world.stepCount() % 100 == 0)
      {
        for (const FootState& f : s.feet)
          load += f.normal_force;
        ++samples;
      }
      ASSERT_FALSE(s.fallen) << soil << " at " << world.time();
    }
    load /= samples;
    std::printf("quadruped standing 60 s on %s: drift %.2f mm, height within %.2f mm, feet carry %.1f N of %.1f N\n",
                soil, 1e3 * worst_drift, 1e3 * worst_height, load, m.total_mass * kG);
    EXPECT_LT(worst_drift, 0.01) << soil;
    EXPECT_LT(worst_height, 0.02) << soil;
    EXPECT_NEAR(load, m.total_mass * kG, 0.02 * m.total_mass * kG) << soil;
    // The stance height: base_link stance.height above the soles (less the soil's give).
    const VehicleState& s = world.state(id);
    EXPECT_NEAR(s.pose.translation().z(), m.legged.stance_height, 0.02) << soil;
    EXPECT_GT(s.pose.linear()(2, 2), std::cos(2.0 * M_PI / 180.0)) << soil;
  }
}

// Where users put it: at 0.5, 1 and 2 ms physics steps, set down 5 cm above gravel (a drop), and
// standing across and along a 10 degree gravel slope: it lands and stands parallel to the ground,
// base_link its stance height from it (5 mm), within 1 cm of where it settled over 10 s.
TEST(LeggedVehicle, StandsAtSeveralStepsAfterADropAndOnASlope)
{
  const VehicleModel& m = quadruped();
  struct Case
  {
    double step, clearance, slope, yaw;
  };
  const double slope = std::tan(10.0 * M_PI / 180.0);
  for (const Case& c : { Case{ 0.0005, 0.0, 0.0, 0.0 }, Case{ 0.002, 0.0, 0.0, 0.0 }, Case{ 0.001, 0.05, 0.0, 0.0 },
                         Case{ 0.001, 0.0, slope, 0.0 }, Case{ 0.001, 0.0, slope, M_PI / 2.0 } })
  {
    const std::size_t n = 301;
    const double res = 0.02;
    std::vector<float> h(n * n);
    for (std::size_t j = 0; j < n; ++j)
      for (std::size_t i = 0; i < n; ++i)
        h[j * n + i] = static_cast<float>(c.slope * (-3.0 + i * res));
    terrain::DeformableTerrain ground(terrain::ElevationGrid(-3.0, -3.0, res, res, n, n, h), soils().get("gravel"),
                                      terrain::DeformableTerrain::Options{ true });
    WorldOptions options;
    options.step = c.step;
    World world(ground, options);
    const std::size_t id = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, c.yaw, c.clearance));
    world.advance(2.0);
    const Eigen::Vector3d settled = world.state(id).pose.translation();
    world.advance(10.0);
    const VehicleState& s = world.state(id);
    const Eigen::Vector3d at = s.pose.translation();
    const double above = at.z() - *ground.height(at.x(), at.y());
    std::printf("step %.1f ms, dropped %.2f m, slope %.0f deg (yaw %.2f): height %.4f m, moved %.2f mm in 10 s\n",
                1e3 * c.step, c.clearance, std::atan(c.slope) * 180.0 / M_PI, c.yaw, above,
                1e3 * (at - settled).norm());
    EXPECT_FALSE(s.fallen);
    // Parallel to the ground: stance.height along the slope's normal, 1 / cos of it vertically.
    EXPECT_NEAR(above, m.legged.stance_height * std::sqrt(1.0 + c.slope * c.slope), 0.005);
    EXPECT_LT((at - settled).norm(), 0.01);
  }
}

// On dry sand (Bekker) each foot's pad sinks as Bekker's flat plate of its side b at its own soil
// pressure, z = (p / (k_c / b + k_phi))^(1 / n), within 15 % (issue 24); the feet carry the robot's
// weight (what ODE applies, within 2 %) and the more heavily loaded rear feet (the legs' mass hangs
// behind the hips) sink deeper than the front ones. The soil is softened from 20x stiff over 4 s
// (as the M113's test does) so the feet arrive without the drop's overshoot.
TEST(LeggedVehicle, OnDrySandEachFootSinksAsBekkersPlate)
{
  const VehicleModel& m = quadruped();
  const terrain::SoilParameters sand = soils().get("dry_sand");
  ASSERT_EQ(sand.model, terrain::SinkageModel::kBekker);
  auto ground = flat(sand, 4.0, 0.01);
  World world(*ground);
  const std::size_t id = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0));
  test::settleOnSoftening(world, *ground, sand, 4.0, 6.0);
  const double b = m.legged.pad_size, modulus = sand.k_c / b + sand.k_phi;
  std::vector<double> sinkage(4, 0.0), force(4, 0.0), applied(4, 0.0);
  const int samples = 200;
  for (int k = 0; k < samples; ++k)
  {
    world.step();
    for (std::size_t f = 0; f < 4; ++f)
    {
      sinkage[f] += world.state(id).feet[f].sinkage / samples;
      force[f] += world.state(id).feet[f].normal_force / samples;
      applied[f] += world.state(id).feet[f].applied_normal_force / samples;
    }
  }
  double total = 0.0;
  for (std::size_t f = 0; f < 4; ++f)
  {
    const double p = force[f] / (b * b);
    const double z = std::pow(p / modulus, 1.0 / sand.n);
    std::printf(
        "dry sand, foot %s: applied %.1f N, soil %.1f N, p %.0f Pa, sinkage %.2f mm, plate law %.2f mm "
        "(%+.1f %%)\n",
        m.legs[f].name.c_str(), applied[f], force[f], p, 1e3 * sinkage[f], 1e3 * z, 100.0 * (sinkage[f] / z - 1.0));
    EXPECT_NEAR(sinkage[f], z, 0.15 * z) << m.legs[f].name;
    total += applied[f];
  }
  EXPECT_NEAR(total, m.total_mass * kG, 0.02 * m.total_mass * kG);
  // Left and right alike; rear (legs 2, 3) more loaded and deeper than front (0, 1).
  EXPECT_NEAR(sinkage[0], sinkage[1], 1e-6);
  EXPECT_NEAR(sinkage[2], sinkage[3], 1e-6);
  EXPECT_GT(applied[2], applied[0] + 5.0);
  EXPECT_GT(sinkage[2], sinkage[0] + 0.002);
  EXPECT_FALSE(world.state(id).fallen);
}

// A 100 N lateral push for 0.2 s (World::push) at the trunk's centre of mass: the standing robot sways and
// stays up; 2 000 N for 0.2 s topples it, `fallen` is reported, and nothing is NaN.
TEST(LeggedVehicle, APushOfOneHundredNewtonsIsTakenTwoThousandTopplesIt)
{
  const VehicleModel& m = quadruped();
  for (const double push : { 100.0, 2000.0 })
  {
    auto ground = flat(soils().get("gravel"), 10.0, 0.02);
    World world(*ground);
    const std::size_t id = world.addVehicle(m, world.restingPose(m, 0.0, 0.0, 0.0));
    world.advance(1.0);
    const double before = world.state(id).pose.translation().y();
    world.push(id, Eigen::Vector3d(0.0, push, 0.0), 0.2);
    bool fallen = false;
    while (world.time() < 4.0)
    {
      world.step();
      const VehicleState& s = world.state(id);
      ASSERT_TRUE(s.pose.matrix().allFinite());
      for (const LegJointState& j : s.joints)
        ASSERT_TRUE(std::isfinite(j.position) && std::isfinite(j.effort));
      fallen = fallen || s.fallen;
    }
    std::printf("push %.0f N for 0.2 s: moved %.3f m sideways, fallen %d\n", push,
                world.state(id).pose.translation().y() - before, fallen ? 1 : 0);
    EXPECT_EQ(fallen, push > 1000.0) << push;
  }
}

// Bad legged models: a negative or missing torque limit, a range outside the URDF's, a stance
// out of reach, a missing foot, each refused naming the file and the key.
TEST(LeggedVehicle, BadLeggedModelsNameTheFileAndKey)
{
  std::ifstream in(kConfigDir + "/quadruped.yaml");
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string good = buf.str();
  char dir_template[] = "/tmp/avsp_legged_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  const std::string path = dir + "/quadruped.yaml";
  auto refused = [&](const std::string& text, const std::string& key) {
    std::ofstream(path) << std::regex_replace(text, std::regex("\\.\\./\\.\\./urdf/"), kConfigDir + "/../../urdf/");
    try
    {
      loadVehicleModel(path);
      ADD_FAILURE() << "accepted; expected an error naming " << key;
    }
    catch (const ConfigError& e)
    {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find(key), std::string::npos) << what;
    }
  };
  auto replaced = [&](const std::string& from, const std::string& to) {
    const std::size_t at = good.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    std::string out = good;
    return out.replace(at, from.size(), to);
  };
  // The good file itself loads from there.
  std::ofstream(path) << std::regex_replace(good, std::regex("\\.\\./\\.\\./urdf/"), kConfigDir + "/../../urdf/");
  EXPECT_NO_THROW(loadVehicleModel(path));
  refused(replaced("knee:      {lower: -2.7, upper: -0.1, max_torque: 80.0",
                   "knee:      {lower: -2.7, upper: -0.1, max_torque: -80.0"),
          "joints.knee.max_torque");
  refused(replaced("max_torque: 80.0, max_speed: 8.0, stiffness: 300.0, damping: 8.0}\n  flexion",
                   "max_speed: 8.0, stiffness: 300.0, damping: 8.0}\n  flexion"),
          "joints.abduction.max_torque");
  refused(replaced("flexion:   {lower: -1.6", "flexion:   {lower: -1.9"), "flexion_joint");
  refused(replaced("upper: -0.1,", "upper: -2.8,"), "joints.knee.upper");
  refused(replaced("height: 0.45", "height: 0.95"), "stance.height");
  refused(replaced("foot_link: front_left_foot", "foot_link: front_left_shank"), "legs[0].foot_link");
  refused(replaced("knees: backward", "knees: sideways"), "stance.knees");
  refused(replaced("pad_size: 0.06", "pad_size: 0.0"), "feet.pad_size");
  std::remove(path.c_str());
  rmdir(dir.c_str());
}
