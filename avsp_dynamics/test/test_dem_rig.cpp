// The single-wheel rig: an ODE wheel coupled to a DEM bed. Sinkage against load and width,
// drawbar pull against slip, determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "avsp_dynamics/dem/wheel_rig.hpp"
#include "dem_test_beds.hpp"

namespace dem = avsp::dynamics::dem;

namespace
{
/// A fresh bed `blocks` template lengths long, walled at both ends, settled.
std::unique_ptr<dem::DemWorld> freshBed(int blocks)
{
  const auto& bed = dem_test::smallTemplate();
  auto world = std::make_unique<dem::DemWorld>(bed.parameters(), dem_test::domainFor(bed, blocks), bed);
  world->addBed(
      0.0, blocks * bed.length(), [&](double, double) { return bed.depth(); }, true, true);
  world->setBedEnds(0.0, blocks * bed.length());
  world->settle(0.2);
  return world;
}

/// Static sinkage (m): the wheel set down mid-bed, held on its spot (carriage and spin at 0),
/// free vertically for 0.2 s; the mean over the last 0.05 s.
double staticSinkage(double load, double width)
{
  auto world = freshBed(3);
  dem::WheelRigSpec spec;
  spec.load = load;
  spec.width = width;
  dem::SingleWheelRig rig(*world, spec, 1.5 * dem_test::smallTemplate().length());
  rig.setCarriageSpeed(0.0);
  rig.setSpinRate(0.0);
  double sum = 0.0;
  for (int k = 0; k < 200; ++k)
  {
    rig.step();
    if (k >= 150)
      sum += rig.state().sinkage;
  }
  return sum / 50;
}

/// The three static cases, each run once: 200 N on 0.08 m, 400 N on 0.08 m, 200 N on 0.16 m.
struct StaticCases
{
  double base = staticSinkage(200.0, 0.08);
  double heavy = staticSinkage(400.0, 0.08);
  double wide = staticSinkage(200.0, 0.16);
};
const StaticCases& staticCases()
{
  static const StaticCases cases;
  return cases;
}

/// Mean drawbar pull (N, the soil's net force along travel) of a lugged wheel (12 grousers,
/// 15 mm) driven at 0.5 m/s rim speed with the carriage holding (1 - slip) of it, over 0.1 s
/// after 0.1 s of travel.
double drawbarPull(double slip)
{
  auto world = freshBed(4);
  dem::WheelRigSpec spec;
  spec.load = 200.0;
  spec.grousers = 12;
  spec.grouser_height = 0.015;
  dem::SingleWheelRig rig(*world, spec, 0.17);
  const double rim_speed = 0.5;
  rig.setSpinRate(rim_speed / spec.radius);
  rig.setCarriageSpeed((1.0 - slip) * rim_speed);
  double sum = 0.0;
  for (int k = 0; k < 200; ++k)
  {
    rig.step();
    if (k >= 100)
      sum += rig.state().soil.force.x();
  }
  EXPECT_NEAR(rig.state().slip, slip, 1e-6);
  return sum / 100;
}
}  // namespace

TEST(DemRig, SinkageGrowsWithLoad)
{
  const auto& c = staticCases();
  std::cout << "sinkage, b = 0.08 m: at 200 N " << c.base << " m, at 400 N " << c.heavy << " m\n";
  EXPECT_GT(c.base, 0.0);
  // Bekker's closed form (T13) gives z ~ W^(2 / (2n + 1)): 2^(2/3) = 1.59 for n = 1, 2^(2/5)
  // = 1.32 for n = 2; any pressure-sinkage law that stiffens with depth stays above 1.
  EXPECT_GT(c.heavy, 1.15 * c.base);
}

TEST(DemRig, SinkageFallsWithWidth)
{
  const auto& c = staticCases();
  std::cout << "sinkage at 200 N: b = 0.08 m " << c.base << " m, b = 0.16 m " << c.wide << " m\n";
  EXPECT_GT(c.wide, 0.0);
  // The same load on twice the width: half the pressure (T13: z ~ (k_c + b k_phi)^(-2/(2n+1))).
  EXPECT_LT(c.wide, 0.85 * c.base);
}

TEST(DemRig, DrawbarPullRisesWithSlip)
{
  const double dp10 = drawbarPull(0.1), dp30 = drawbarPull(0.3), dp60 = drawbarPull(0.6);
  std::cout << "drawbar pull at slip 0.1 " << dp10 << " N, 0.3 " << dp30 << " N, 0.6 " << dp60 << " N\n";
  // Janosi-Hanamoto (T7, T11): thrust (A c + W tan phi)(1 - K / (s l) (1 - e^(-s l / K))) rises
  // with slip towards the soil's strength; the resistance does not depend on slip at first
  // order, so the drawbar pull does the same. (It saturates once s l is several K; on this
  // bed the contact is 4 to 5 particles long and K, of the order of a few particle sizes, is
  // not yet reached at s = 0.6: the pull still rises there; docs/MODELS.md, "DEM soil".)
  EXPECT_GT(dp30, dp10);
  EXPECT_GT(dp60, dp30);
  // Bounded by the Mohr-Coulomb strength of a cohesionless soil under the load: W tan(phi)
  // with phi < 45 deg for granular beds.
  EXPECT_LT(dp60, 200.0);
}

TEST(DemRig, ARunRepeatsBitForBit)
{
  auto run = [] {
    auto world = freshBed(3);
    dem::SingleWheelRig rig(*world, dem::WheelRigSpec{}, 1.5 * dem_test::smallTemplate().length());
    rig.setSpinRate(2.0);
    for (int k = 0; k < 30; ++k)
      rig.step();
    return rig.state();
  };
  const auto a = run(), b = run();
  EXPECT_EQ(a.centre, b.centre);
  EXPECT_EQ(a.soil.force, b.soil.force);
  EXPECT_EQ(a.soil.torque, b.soil.torque);
}

TEST(DemRig, BadSpecIsNamed)
{
  const auto& bed = dem_test::smallTemplate();
  dem::DemWorld world(bed.parameters(), dem_test::domainFor(bed, 3), bed);
  dem::WheelRigSpec spec;
  spec.width = 0.0;
  try
  {
    dem::SingleWheelRig rig(world, spec, 0.2);
    FAIL() << "no error";
  }
  catch (const dem::DemParameterError& e)
  {
    EXPECT_NE(std::string(e.what()).find("dem.rig.width"), std::string::npos) << e.what();
  }
}
