// Proxies (World::addProxy): another process's vehicle as a kinematic body updated at every
// exchange. Two worlds, each simulating one fed_alpha and seeing the other as a proxy updated
// every 10 ms (as two dynamics partitions do), drive the vehicles head-on into each other: they
// collide and never pass through or sink into each other; without proxies they pass through. A
// proxy far away leaves a vehicle's trajectory bit-identical; bad proxy input is refused.
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

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp::dynamics;
namespace terrain = avsp::terrain;

namespace
{
const terrain::SoilLibrary& soils()
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  return lib;
}

VehicleModel fedAlpha()
{
  return loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/fed_alpha.yaml");
}

/// Level gravel, 60 m x 20 m from (-30, -10), 0.1 m cells.
std::unique_ptr<terrain::DeformableTerrain> flatGravel()
{
  const std::size_t nx = 601, ny = 201;
  return std::make_unique<terrain::DeformableTerrain>(
      terrain::ElevationGrid(-30.0, -10.0, 0.1, 0.1, nx, ny, std::vector<float>(nx * ny, 0.f)), soils().get("gravel"),
      terrain::DeformableTerrain::Options{ true });
}

/// Corners of the chassis boxes and the rims of the wheels (every 10 deg), in map.
std::vector<Eigen::Vector3d> vehiclePoints(const VehicleModel& m, const Eigen::Isometry3d& pose)
{
  std::vector<Eigen::Vector3d> out;
  for (const CollisionBox& b : m.collision_boxes)
    for (int k = 0; k < 8; ++k)
    {
      const Eigen::Vector3d local(k & 1 ? 0.5 : -0.5, k & 2 ? 0.5 : -0.5, k & 4 ? 0.5 : -0.5);
      out.push_back(pose * (b.pose * local.cwiseProduct(b.size)));
    }
  for (const WheelSpec& w : m.wheels)
    for (int k = 0; k < 36; ++k)
    {
      const double a = k * M_PI / 18.0;
      out.push_back(pose * (w.rest_position + Eigen::Vector3d(w.radius * std::cos(a), 0.0, w.radius * std::sin(a))));
    }
  return out;
}

/// m: how deep any of `a`'s points lies inside `b`'s chassis boxes (negative: outside all).
double depthInto(const VehicleModel& m, const Eigen::Isometry3d& a, const Eigen::Isometry3d& b)
{
  double deepest = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : vehiclePoints(m, a))
    for (const CollisionBox& box : m.collision_boxes)
    {
      const Eigen::Vector3d local = (b * box.pose).inverse() * p;
      deepest = std::max(deepest, (0.5 * box.size - local.cwiseAbs()).minCoeff());
    }
  return deepest;
}

struct HeadOn
{
  double deepest = -1.0;                     ///< m, worst overlap of the true vehicles over the run
  double closest = 1e9;                      ///< m, least distance between the base_links
  int contacts_east = 0, contacts_west = 0;  ///< steps with rigid contacts
  VehicleState east, west;
};

/// "east" (world A, from x = -8 heading +x) and "west" (world B, from x = 8 heading -x) at full
/// throttle for 8 s; with `proxies`, each world sees the other's vehicle as a proxy updated
/// every `every` steps from the other world's state, and the worlds swap their ruts.
HeadOn headOn(bool proxies, int every = 10)
{
  const VehicleModel m = fedAlpha();
  auto ground_a = flatGravel(), ground_b = flatGravel();
  World a(*ground_a), b(*ground_b);
  const std::size_t east = a.addVehicle(m, a.restingPose(m, -8.0, 0.0, 0.0, 0.01), "east");
  const std::size_t west = b.addVehicle(m, b.restingPose(m, 8.0, 0.0, M_PI, 0.01), "west");
  if (proxies)
  {
    EXPECT_EQ(a.addProxy(m, "west"), 0u);
    EXPECT_EQ(b.addProxy(m, "east"), 0u);
    ground_a->setChangeTracking(true);
    ground_b->setChangeTracking(true);
  }
  auto exchange = [&] {
    const VehicleState& se = a.state(east);
    const VehicleState& sw = b.state(west);
    a.setProxyState(0, sw.pose, sw.linear_velocity, sw.angular_velocity);
    b.setProxyState(0, se.pose, se.linear_velocity, se.angular_velocity);
    const auto from_a = ground_a->takeChanges(), from_b = ground_b->takeChanges();
    ground_b->applyChanges(from_a);
    ground_a->applyChanges(from_b);
  };
  if (proxies)
    exchange();
  a.setCommand(east, { 1.0, 0.0, 0.0 });
  b.setCommand(west, { 1.0, 0.0, 0.0 });
  HeadOn r;
  for (int k = 1; k <= 8000; ++k)
  {
    a.step();
    b.step();
    if (proxies && k % every == 0)
      exchange();
    const Eigen::Isometry3d& pe = a.state(east).pose;
    const Eigen::Isometry3d& pw = b.state(west).pose;
    r.deepest = std::max({ r.deepest, depthInto(m, pe, pw), depthInto(m, pw, pe) });
    r.closest = std::min(r.closest, (pe.translation() - pw.translation()).head<2>().norm());
    r.contacts_east += a.state(east).obstacle_rigid_contacts > 0;
    r.contacts_west += b.state(west).obstacle_rigid_contacts > 0;
  }
  r.east = a.state(east);
  r.west = b.state(west);
  return r;
}
}  // namespace

TEST(Proxies, VehiclesInTwoWorldsCollideHeadOnWithoutPassingThrough)
{
  const VehicleModel m = fedAlpha();
  double half_length = 0.0;  // m, the chassis' reach ahead of base_link
  for (const CollisionBox& b : m.collision_boxes)
    half_length = std::max(half_length, b.pose.translation().x() + 0.5 * b.size.x());

  const HeadOn apart = headOn(false);
  // The control: without proxies the two run through each other and on.
  EXPECT_GT(apart.deepest, 0.1);
  EXPECT_LT(apart.closest, 0.5);
  EXPECT_GT(apart.east.pose.translation().x(), 8.0);

  const HeadOn met = headOn(true);
  // Each met the other (contacts on both sides), neither got through: base_links never closer
  // than the two chassis' reach (less the allowed 5 cm overlap), the true bodies never more than
  // 5 cm into each other (one 10 ms interval at the closing speed, plus the contact layer).
  EXPECT_GT(met.contacts_east, 0);
  EXPECT_GT(met.contacts_west, 0);
  EXPECT_GT(met.closest, 2.0 * half_length - 0.05);
  EXPECT_LT(met.deepest, 0.05);
  EXPECT_LT(met.east.pose.translation().x(), met.west.pose.translation().x());
  std::printf(
      "[proxies] head-on: closest base_links %.3f m (chassis reach 2 x %.3f m), deepest overlap %.1f mm, "
      "contact steps %d / %d; without proxies overlap %.2f m\n",
      met.closest, half_length, 1e3 * met.deepest, met.contacts_east, met.contacts_west, apart.deepest);

  // The same head-on run in one world (both vehicles, no proxies): the layouts differ by the
  // 10 ms delay only (proxies carry the peer's mass). Both stop nose to nose; the difference
  // in where each ends is what README.md documents (3-4 mm).
  auto ground = flatGravel();
  World one(*ground);
  const std::size_t east = one.addVehicle(m, one.restingPose(m, -8.0, 0.0, 0.0, 0.01), "east");
  const std::size_t west = one.addVehicle(m, one.restingPose(m, 8.0, 0.0, M_PI, 0.01), "west");
  one.setCommand(east, { 1.0, 0.0, 0.0 });
  one.setCommand(west, { 1.0, 0.0, 0.0 });
  one.advance(8.0);
  const double de = met.east.pose.translation().x() - one.state(east).pose.translation().x();
  const double dw = met.west.pose.translation().x() - one.state(west).pose.translation().x();
  EXPECT_LT(std::fabs(de), 0.02);
  EXPECT_LT(std::fabs(dw), 0.02);
  std::printf(
      "[proxies] one world: east ends at x %.3f m, west at %.3f m; two worlds with proxies: %.3f / %.3f m "
      "(differences %.3f / %.3f m)\n",
      one.state(east).pose.translation().x(), one.state(west).pose.translation().x(), met.east.pose.translation().x(),
      met.west.pose.translation().x(), de, dw);
}

TEST(Proxies, AProxyFarAwayChangesNothing)
{
  auto run = [](bool with_proxy) {
    const VehicleModel m = fedAlpha();
    auto ground = flatGravel();
    World w(*ground);
    const std::size_t car = w.addVehicle(m, w.restingPose(m, -10.0, 0.0, 0.0, 0.01), "car");
    if (with_proxy)
    {
      w.addProxy(m, "far");
      w.setProxyState(0, w.restingPose(m, 20.0, 5.0, 1.0), Eigen::Vector3d(0.0, 1.0, 0.0), Eigen::Vector3d::Zero());
    }
    w.setCommand(car, { 0.7, 0.0, 0.2 });
    w.advance(3.0);
    const VehicleState& s = w.state(car);
    std::vector<double> out(s.pose.data(), s.pose.data() + 16);
    out.insert(out.end(), s.linear_velocity.data(), s.linear_velocity.data() + 3);
    out.insert(out.end(), s.angular_velocity.data(), s.angular_velocity.data() + 3);
    return out;
  };
  const std::vector<double> with = run(true), without = run(false);
  ASSERT_EQ(with.size(), without.size());
  EXPECT_EQ(std::memcmp(with.data(), without.data(), with.size() * sizeof(double)), 0);
}

TEST(Proxies, ProxyMovesOnAtItsVelocities)
{
  auto ground = flatGravel();
  World w(*ground);
  const VehicleModel m = fedAlpha();
  w.addProxy(m, "p");
  const Eigen::Isometry3d start = w.restingPose(m, 0.0, 0.0, 0.0);
  const Eigen::Vector3d v(2.0, 0.0, 0.0), omega(0.0, 0.0, 0.5);
  w.setProxyState(0, start, v, omega);
  w.advance(1.0);
  const Eigen::Isometry3d p = w.proxyPose(0);
  // A free body: its centre of mass flies on at its velocity, the body turning about it (at a
  // constant omega but for the torque-free precession of an axis that is not quite principal:
  // 0.1 mm over this second; exchanges come every few ms).
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  for (const Body& b : m.bodies)
  {
    mass += b.mass;
    com += b.mass * b.com;
  }
  com /= mass;
  const Eigen::Vector3d arm = start.linear() * com;
  const Eigen::Vector3d centre = start.translation() + arm + (v + omega.cross(arm)) * 1.0;
  const Eigen::Matrix3d turned = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix() * start.linear();
  const Eigen::Vector3d expected = centre - turned * com;
  EXPECT_LT((p.translation() - expected).norm(), 1e-3) << p.translation().transpose() << " vs " << expected.transpose();
  EXPECT_NEAR(Eigen::AngleAxisd(p.linear() * start.linear().transpose()).angle(), 0.5, 1e-4);
  // Without turning, the centre of mass flies exactly.
  w.setProxyState(0, start, v, Eigen::Vector3d::Zero());
  w.advance(1.0);
  EXPECT_LT((w.proxyPose(0).translation() - (start.translation() + v)).norm(), 1e-9);
}

TEST(Proxies, BadProxyInputIsRefused)
{
  auto ground = flatGravel();
  World w(*ground);
  const VehicleModel m = fedAlpha();
  EXPECT_THROW(w.setProxyState(0, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()),
               std::out_of_range);
  w.addProxy(m, "p");
  try
  {
    w.setProxyState(0, Eigen::Isometry3d::Identity(), Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d::Zero());
    FAIL() << "a NaN velocity was taken";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("'p'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(w.proxyPose(1), std::out_of_range);
}
