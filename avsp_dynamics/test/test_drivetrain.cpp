// The command-to-actuator math against its closed forms: engine torque and power limit
// through the gear ratio, the governor, Ackermann geometry, skid-steer mixing, command ranges.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "avsp_dynamics/drivetrain.hpp"

using namespace avsp::dynamics;

namespace
{
const std::string kConfigDir = AVSP_VEHICLE_CONFIG_DIR;

DrivetrainSpec fedAlphaLike()
{
  DrivetrainSpec d;
  d.engine_max_torque = 700.0;
  d.engine_max_power = 150000.0;
  d.gear_ratio = 20.0;
  d.efficiency = 0.85;
  d.max_speed = 30.0;
  return d;
}
}  // namespace

TEST(EngineTorqueLimit, TorqueBelowCornerSpeedPowerAbove)
{
  const DrivetrainSpec d = fedAlphaLike();
  const double corner = d.engine_max_power / d.engine_max_torque;  // rad/s where T w = P
  EXPECT_DOUBLE_EQ(engineTorqueLimit(d, 0.0), 700.0);
  EXPECT_DOUBLE_EQ(engineTorqueLimit(d, 0.5 * corner), 700.0);
  EXPECT_DOUBLE_EQ(engineTorqueLimit(d, -0.5 * corner), 700.0);
  for (double w : { 1.01 * corner, 2.0 * corner, 500.0 })
  {
    EXPECT_NEAR(engineTorqueLimit(d, w), d.engine_max_power / w, 1e-9);
    EXPECT_NEAR(engineTorqueLimit(d, w) * w, d.engine_max_power, 1e-6);  // never more power than P
  }
}

TEST(WheelTorqueAvailable, GearRatioEfficiencyAndGovernor)
{
  const DrivetrainSpec d = fedAlphaLike();
  const double r = 0.546;
  // At rest: eta G T_max.
  EXPECT_NEAR(wheelTorqueAvailable(d, 0.0, r), 0.85 * 20.0 * 700.0, 1e-9);
  // At 10 m/s the engine turns at G v / r = 366 rad/s, beyond the 214 rad/s corner: power limit.
  const double w = 10.0 / r;
  EXPECT_NEAR(wheelTorqueAvailable(d, w, r), 0.85 * 150000.0 / w, 1e-6);
  // The governor: full torque below 95 % of max_speed, none at max_speed.
  EXPECT_NEAR(wheelTorqueAvailable(d, 0.94 * d.max_speed / r, r), 0.85 * 150000.0 / (0.94 * d.max_speed / r), 1e-6);
  EXPECT_EQ(wheelTorqueAvailable(d, d.max_speed / r, r), 0.0);
  EXPECT_EQ(wheelTorqueAvailable(d, 1.2 * d.max_speed / r, r), 0.0);
  EXPECT_NEAR(governorFactor(0.975, 1.0), 0.5, 1e-12);
}

TEST(AckermannGeometry, WheelsShareOneTurningCentreAndInnerReachesMaxAngle)
{
  const VehicleModel m = loadVehicleModel(kConfigDir + "/fed_alpha.yaml");
  const AckermannGeometry g(m);
  EXPECT_NEAR(g.wheelbase(), 3.3, 1e-9);
  EXPECT_NEAR(g.referenceX(), -1.65, 1e-9);
  const double track = m.trackWidth();
  // Full lock: the inner wheel (left for a left turn, index 0) reaches max_angle.
  EXPECT_NEAR(g.wheelAngle(0, g.maxCentreAngle()), m.steering.max_angle, 1e-12);
  EXPECT_NEAR(g.wheelAngle(1, -g.maxCentreAngle()), -m.steering.max_angle, 1e-12);
  for (double delta : { 0.05, 0.2, g.maxCentreAngle() })
  {
    const double inner = g.wheelAngle(0, delta), outer = g.wheelAngle(1, delta);
    // The Ackermann condition cot(outer) - cot(inner) = track / wheelbase.
    EXPECT_NEAR(1.0 / std::tan(outer) - 1.0 / std::tan(inner), track / g.wheelbase(), 1e-9) << delta;
    // Both point at the centre on the rear-axle line at radius L / tan(delta).
    const double radius = g.wheelbase() / std::tan(delta);
    EXPECT_NEAR(std::tan(inner), g.wheelbase() / (radius - 0.5 * track), 1e-9);
    EXPECT_NEAR(std::tan(outer), g.wheelbase() / (radius + 0.5 * track), 1e-9);
    // Symmetric for right turns; unsteered wheels stay straight.
    EXPECT_NEAR(g.wheelAngle(1, -delta), -inner, 1e-12);
    EXPECT_EQ(g.wheelAngle(2, delta), 0.0);
  }
  EXPECT_EQ(g.wheelAngle(0, 0.0), 0.0);
}

TEST(AckermannGeometry, SkidSteerModelHasNoSteeredAxle)
{
  const VehicleModel m = loadVehicleModel(kConfigDir + "/tracer_x.yaml");
  try
  {
    AckermannGeometry g(m);
    FAIL() << "expected ConfigError";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("tracer_x.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("wheels"), std::string::npos) << e.what();
  }
}

TEST(SkidSteerSides, OuterAtThrottleInnerFromThrottleToReverse)
{
  EXPECT_EQ(skidSteerSides(0.6, 0.0), std::make_pair(0.6, 0.6));
  EXPECT_EQ(skidSteerSides(0.6, 1.0), std::make_pair(-0.6, 0.6));   // turn in place, left
  EXPECT_EQ(skidSteerSides(0.6, -1.0), std::make_pair(0.6, -0.6));  // turn in place, right
  const auto pivot = skidSteerSides(0.6, 0.5);                      // pivot about the left side
  EXPECT_NEAR(pivot.first, 0.0, 1e-15);
  EXPECT_EQ(pivot.second, 0.6);
  EXPECT_EQ(skidSteerSides(0.0, 1.0), std::make_pair(0.0, 0.0));
}

// Tracks: as skid-steer while the throttle is above pivot |steering|; below it steering alone
// still turns (in place at full steering, about the inner track at half), continuously.
TEST(TrackedSides, SkidSteerAboveThePivotSpeedTurnsInPlaceWithoutThrottle)
{
  const double p = 0.05;
  EXPECT_EQ(trackedSides(0.6, 0.3, p), skidSteerSides(0.6, 0.3));
  EXPECT_EQ(trackedSides(0.6, -1.0, p), skidSteerSides(0.6, -1.0));
  EXPECT_EQ(trackedSides(0.0, 0.0, p), std::make_pair(0.0, 0.0));
  EXPECT_EQ(trackedSides(0.0, 1.0, p), std::make_pair(-p, p));   // in place, left
  EXPECT_EQ(trackedSides(0.0, -1.0, p), std::make_pair(p, -p));  // in place, right
  const auto half = trackedSides(0.0, 0.5, p);                   // about the left track
  EXPECT_NEAR(half.first, 0.0, 1e-15);
  EXPECT_EQ(half.second, 0.5 * p);
  // Continuous where the throttle takes over at t = p |s|.
  const auto below = trackedSides(0.04 - 1e-9, 0.8, p), above = trackedSides(0.04 + 1e-9, 0.8, p);
  EXPECT_NEAR(below.first, above.first, 1e-8);
  EXPECT_NEAR(below.second, above.second, 1e-8);
}

TEST(ClampedCommand, ClampsFiniteRejectsNonFiniteNamingTheField)
{
  const DriveCommand c = clampedCommand(DriveCommand{ 1.5, -0.2, -3.0 });
  EXPECT_EQ(c.throttle, 1.0);
  EXPECT_EQ(c.brake, 0.0);
  EXPECT_EQ(c.steering, -1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const struct
  {
    DriveCommand command;
    const char* field;
  } bad[] = { { { nan, 0, 0 }, "throttle" }, { { 0, inf, 0 }, "brake" }, { { 0, 0, -inf }, "steering" } };
  for (const auto& b : bad)
  {
    try
    {
      clampedCommand(b.command);
      FAIL() << "expected CommandError for " << b.field;
    }
    catch (const CommandError& e)
    {
      EXPECT_NE(std::string(e.what()).find(std::string("DriveCommand.") + b.field), std::string::npos) << e.what();
    }
  }
}
