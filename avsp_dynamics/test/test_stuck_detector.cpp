// StuckDetector and meanDrivenSlip on hand-made states: wheels and tracks, contact, throttle
// and the 2 s hold.
#include <string>

#include <gtest/gtest.h>

#include "avsp_dynamics/stuck_detector.hpp"

using namespace avsp::dynamics;

namespace
{
VehicleModel fourWheels(bool rear_driven_only)
{
  VehicleModel m;
  for (const char* name : { "front_left", "front_right", "rear_left", "rear_right" })
  {
    WheelSpec w{};
    w.name = name;
    w.driven = !rear_driven_only || std::string(name).rfind("rear", 0) == 0;
    m.wheels.push_back(w);
  }
  return m;
}

VehicleState wheelState(double front_slip, double rear_slip, bool rear_in_contact, double throttle)
{
  VehicleState s;
  for (int k = 0; k < 4; ++k)
  {
    WheelState w;
    w.in_contact = k < 2 || rear_in_contact;
    w.slip = k < 2 ? front_slip : rear_slip;
    s.wheels.push_back(w);
  }
  s.command.throttle = throttle;
  return s;
}

VehicleState trackState(double left_slip, double right_slip, bool right_touching, double throttle)
{
  VehicleState s;
  for (int side = 0; side < 2; ++side)
  {
    TrackState t;
    t.slip = side == 0 ? left_slip : right_slip;
    t.segments.resize(5);
    t.segments[3].in_contact = side == 0 || right_touching;  // one touching segment is enough
    s.tracks.push_back(t);
  }
  s.command.throttle = throttle;
  return s;
}
}  // namespace

TEST(MeanDrivenSlip, DrivenWheelsInContactOnly)
{
  double slip = -1.0;
  EXPECT_TRUE(meanDrivenSlip(fourWheels(false), wheelState(0.2, 0.6, true, 1.0), slip));
  EXPECT_DOUBLE_EQ(slip, 0.4);
  EXPECT_TRUE(meanDrivenSlip(fourWheels(true), wheelState(0.2, 0.6, true, 1.0), slip));
  EXPECT_DOUBLE_EQ(slip, 0.6);  // undriven front wheels do not count
  EXPECT_TRUE(meanDrivenSlip(fourWheels(false), wheelState(0.2, 0.6, false, 1.0), slip));
  EXPECT_DOUBLE_EQ(slip, 0.2);  // airborne rear wheels do not count
  EXPECT_FALSE(meanDrivenSlip(fourWheels(true), wheelState(0.2, 0.6, false, 1.0), slip));
}

TEST(MeanDrivenSlip, TracksWithASegmentOnTheGround)
{
  const VehicleModel tracked{};  // the tracks' state carries everything the rule needs
  double slip = -1.0;
  EXPECT_TRUE(meanDrivenSlip(tracked, trackState(1.0, 0.9, true, 1.0), slip));
  EXPECT_DOUBLE_EQ(slip, 0.95);
  EXPECT_TRUE(meanDrivenSlip(tracked, trackState(1.0, 0.0, false, 1.0), slip));
  EXPECT_DOUBLE_EQ(slip, 1.0);
}

TEST(StuckDetector, StuckAfterTwoSecondsOfFullSlipUnderThrottle)
{
  const VehicleModel m = fourWheels(false);
  StuckDetector d;
  const VehicleState spinning = wheelState(0.97, 0.99, true, 0.8);
  for (int k = 0; k <= 1999; ++k)
    EXPECT_FALSE(d.update(m, spinning, 10.0 + 0.001 * k)) << k;
  EXPECT_TRUE(d.update(m, spinning, 12.0));
  EXPECT_NEAR(d.heldFor(12.0), 2.0, 1e-12);
  // Throttle off: not stuck at once, and the 2 s start again.
  EXPECT_FALSE(d.update(m, wheelState(0.97, 0.99, true, 0.0), 12.001));
  EXPECT_FALSE(d.update(m, spinning, 12.002));
  EXPECT_FALSE(d.update(m, spinning, 14.0));
  EXPECT_TRUE(d.update(m, spinning, 14.002));
  // Slip below the threshold for one step resets it too.
  EXPECT_FALSE(d.update(m, wheelState(0.9, 0.9, true, 0.8), 14.003));
  EXPECT_FALSE(d.stuck());
  // A tracked vehicle by the same rule.
  StuckDetector t;
  EXPECT_FALSE(t.update(VehicleModel(), trackState(1.0, 1.0, true, 1.0), 0.0));
  EXPECT_TRUE(t.update(VehicleModel(), trackState(1.0, 1.0, true, 1.0), 2.0));
  EXPECT_THROW(StuckDetector(0.0, 2.0), std::invalid_argument);
  EXPECT_THROW(StuckDetector(0.95, 0.0), std::invalid_argument);
}
