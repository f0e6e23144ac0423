#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "avsp_dynamics/ros/conversions.hpp"

using avsp::dynamics::CommandCheck;
using avsp::dynamics::node::driveCommandFromTwist;
using avsp::dynamics::node::sanitizeDriveCommand;

namespace
{
geometry_msgs::Twist twist(double throttle, double brake, double steering)
{
  geometry_msgs::Twist t;
  t.linear.x = throttle;
  t.linear.y = brake;
  t.angular.z = steering;
  return t;
}
}  // namespace

TEST(DriveCommandFromTwist, Avt341NegativeBrakeBecomesPositive)
{
  avsp_msgs::DriveCommand cmd;
  std::string why;
  EXPECT_EQ(driveCommandFromTwist(twist(0.4, -0.7, 0.25), cmd, why), CommandCheck::kAccepted);
  EXPECT_DOUBLE_EQ(cmd.throttle, 0.4);
  EXPECT_DOUBLE_EQ(cmd.brake, 0.7);
  EXPECT_DOUBLE_EQ(cmd.steering, 0.25);
  EXPECT_TRUE(why.empty());
}

TEST(DriveCommandFromTwist, PositiveBrakeMeansTheSame)
{
  avsp_msgs::DriveCommand a, b;
  std::string why;
  driveCommandFromTwist(twist(0.0, -0.3, -1.0), a, why);
  driveCommandFromTwist(twist(0.0, 0.3, -1.0), b, why);
  EXPECT_DOUBLE_EQ(a.brake, b.brake);
  EXPECT_DOUBLE_EQ(b.steering, -1.0);
}

TEST(DriveCommandFromTwist, OutOfRangeIsClampedAndNamed)
{
  avsp_msgs::DriveCommand cmd;
  std::string why;
  EXPECT_EQ(driveCommandFromTwist(twist(1.5, -2.0, -3.0), cmd, why), CommandCheck::kClamped);
  EXPECT_DOUBLE_EQ(cmd.throttle, 1.0);
  EXPECT_DOUBLE_EQ(cmd.brake, 1.0);
  EXPECT_DOUBLE_EQ(cmd.steering, -1.0);
  EXPECT_NE(why.find("throttle"), std::string::npos) << why;
  EXPECT_NE(why.find("brake"), std::string::npos) << why;
  EXPECT_NE(why.find("steering"), std::string::npos) << why;
}

TEST(DriveCommandFromTwist, NegativeThrottleIsClampedToZero)
{
  avsp_msgs::DriveCommand cmd;
  std::string why;
  EXPECT_EQ(driveCommandFromTwist(twist(-0.5, 0.0, 0.0), cmd, why), CommandCheck::kClamped);
  EXPECT_DOUBLE_EQ(cmd.throttle, 0.0);
  EXPECT_NE(why.find("throttle"), std::string::npos);
}

TEST(DriveCommandFromTwist, NonFiniteIsRejectedAndLeavesCommandUntouched)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  avsp_msgs::DriveCommand cmd;
  cmd.throttle = 0.2;
  cmd.brake = 0.1;
  cmd.steering = 0.3;
  std::string why;
  EXPECT_EQ(driveCommandFromTwist(twist(nan, 0.0, 0.0), cmd, why), CommandCheck::kRejected);
  EXPECT_NE(why.find("throttle"), std::string::npos);
  EXPECT_EQ(driveCommandFromTwist(twist(0.0, -inf, 0.0), cmd, why), CommandCheck::kRejected);
  EXPECT_NE(why.find("brake"), std::string::npos);
  EXPECT_EQ(driveCommandFromTwist(twist(0.0, 0.0, inf), cmd, why), CommandCheck::kRejected);
  EXPECT_NE(why.find("steering"), std::string::npos);
  EXPECT_DOUBLE_EQ(cmd.throttle, 0.2);
  EXPECT_DOUBLE_EQ(cmd.brake, 0.1);
  EXPECT_DOUBLE_EQ(cmd.steering, 0.3);
}

TEST(SanitizeDriveCommand, InRangeCommandIsAcceptedUnchanged)
{
  avsp_msgs::DriveCommand cmd;
  cmd.throttle = 1.0;
  cmd.brake = 0.0;
  cmd.steering = -1.0;
  std::string why = "stale";
  EXPECT_EQ(sanitizeDriveCommand(cmd, why), CommandCheck::kAccepted);
  EXPECT_TRUE(why.empty());
  EXPECT_DOUBLE_EQ(cmd.throttle, 1.0);
  EXPECT_DOUBLE_EQ(cmd.steering, -1.0);
}

TEST(SanitizeDriveCommand, ReverseGearIsAcceptedAndUnknownGearRejected)
{
  avsp_msgs::DriveCommand cmd;
  cmd.throttle = 0.5;
  cmd.gear = avsp_msgs::DriveCommand::GEAR_REVERSE;
  std::string why;
  EXPECT_EQ(sanitizeDriveCommand(cmd, why), CommandCheck::kAccepted);
  EXPECT_EQ(cmd.gear, avsp_msgs::DriveCommand::GEAR_REVERSE);

  cmd.gear = 2;
  EXPECT_EQ(sanitizeDriveCommand(cmd, why), CommandCheck::kRejected);
  EXPECT_NE(why.find("gear=2"), std::string::npos) << why;
}
