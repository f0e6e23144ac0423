// ClockFollowers: the clock may publish T only once every follower reported T - lag.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "avsp_dynamics/clock_followers.hpp"

namespace
{
using avsp::dynamics::ClockFollowers;
using Report = ClockFollowers::Report;

TEST(ClockFollowers, HoldsTheClockUntilEveryFollowerIsWithinTheLag)
{
  ClockFollowers f({ "sensors", "environment" }, 0.05);
  // Before any report nothing may be published, not even a time within the lag of 0.
  EXPECT_FALSE(f.allows(0.0));
  EXPECT_EQ(f.holding(0.0), (std::vector<std::string>{ "sensors", "environment" }));
  EXPECT_EQ(f.done("sensors", 0.0), Report::kAccepted);
  EXPECT_EQ(f.holding(0.02), std::vector<std::string>{ "environment" });
  EXPECT_EQ(f.done("environment", 0.0), Report::kAccepted);
  EXPECT_TRUE(f.allows(0.05));    // exactly the lag ahead
  EXPECT_FALSE(f.allows(0.051));  // more than the lag ahead
  EXPECT_EQ(f.holding(0.051), (std::vector<std::string>{ "sensors", "environment" }));
  EXPECT_EQ(f.done("sensors", 0.03), Report::kAccepted);
  EXPECT_EQ(f.holding(0.06), std::vector<std::string>{ "environment" });
  // An older report (a repeat) changes nothing.
  EXPECT_EQ(f.done("sensors", 0.01), Report::kAccepted);
  EXPECT_DOUBLE_EQ(f.reached("sensors"), 0.03);
  EXPECT_EQ(f.done("environment", 0.03), Report::kAccepted);
  EXPECT_TRUE(f.allows(0.08));
  EXPECT_FALSE(f.allows(0.0801));
}

TEST(ClockFollowers, ZeroLagIsStrictLockstepToTheStampResolution)
{
  ClockFollowers f({ "sensors" }, 0.0);
  f.done("sensors", 0.3);
  EXPECT_TRUE(f.allows(0.3));
  EXPECT_TRUE(f.allows(0.1 + 0.2));  // 0.30000000000000004: the same ROS stamp
  EXPECT_FALSE(f.allows(0.300001));
}

TEST(ClockFollowers, RefusesUnknownNamesAndNonFiniteTimesWithoutChange)
{
  ClockFollowers f({ "sensors" }, 0.05);
  EXPECT_EQ(f.done("dynamics", 1.0), Report::kUnknown);
  EXPECT_EQ(f.done("sensors", std::numeric_limits<double>::quiet_NaN()), Report::kNotFinite);
  EXPECT_EQ(f.done("sensors", std::numeric_limits<double>::infinity()), Report::kNotFinite);
  EXPECT_TRUE(std::isinf(f.reached("sensors")));
  EXPECT_FALSE(f.allows(0.0));
  EXPECT_THROW(f.reached("dynamics"), std::out_of_range);
}

TEST(ClockFollowers, BadConstructionIsRefusedByName)
{
  EXPECT_THROW(ClockFollowers({}, 0.05), std::invalid_argument);
  EXPECT_THROW(ClockFollowers({ "a", "a" }, 0.05), std::invalid_argument);
  EXPECT_THROW(ClockFollowers({ "" }, 0.05), std::invalid_argument);
  EXPECT_THROW(ClockFollowers({ "a" }, -0.01), std::invalid_argument);
  EXPECT_THROW(ClockFollowers({ "a" }, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  try
  {
    ClockFollowers({ "sensors", "sensors" }, 0.05);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("'sensors' is listed twice"), std::string::npos);
  }
}
}  // namespace
