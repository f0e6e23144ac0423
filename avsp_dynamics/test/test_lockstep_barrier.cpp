// LockstepBarrier: the clock of a partitioned run advances only when every partition has
// reported the current time; its times are exact multiples of the interval.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "avsp_dynamics/lockstep_barrier.hpp"

namespace
{
using avsp::dynamics::LockstepBarrier;
using Report = LockstepBarrier::Report;

TEST(LockstepBarrier, AdvancesOnlyWhenEveryPartitionReportedTheCurrentTime)
{
  LockstepBarrier b({ "p1", "p2" }, 0.01);
  EXPECT_EQ(b.time(), 0.0);
  EXPECT_FALSE(b.complete());
  EXPECT_EQ(b.waitingFor(), (std::vector<std::string>{ "p1", "p2" }));
  EXPECT_THROW(b.advance(), std::logic_error);
  EXPECT_EQ(b.done("p2", 0.0), Report::kAccepted);
  EXPECT_EQ(b.waitingFor(), std::vector<std::string>{ "p1" });
  EXPECT_FALSE(b.complete());
  EXPECT_EQ(b.done("p1", 0.0), Report::kAccepted);
  ASSERT_TRUE(b.complete());
  EXPECT_DOUBLE_EQ(b.advance(), 0.01);
  // A repeated (old) report changes nothing; only the new time counts.
  EXPECT_EQ(b.done("p1", 0.0), Report::kAccepted);
  EXPECT_EQ(b.done("p2", 0.0), Report::kAccepted);
  EXPECT_FALSE(b.complete());
  EXPECT_EQ(b.done("p1", 0.01), Report::kAccepted);
  EXPECT_FALSE(b.complete());
  EXPECT_EQ(b.done("p2", 0.01), Report::kAccepted);
  EXPECT_TRUE(b.complete());
}

TEST(LockstepBarrier, TimesAreExactMultiplesOfTheInterval)
{
  LockstepBarrier b({ "solo" }, 0.01);
  for (int k = 0; k < 100000; ++k)
  {
    ASSERT_EQ(b.done("solo", b.time()), Report::kAccepted);
    b.advance();
  }
  // 100000 additions of 0.01 drift; k × 0.01 does not.
  EXPECT_EQ(b.time(), 100000 * 0.01);
  EXPECT_EQ(b.step(), 100000u);
  // A partition that summed 1 ms steps to the same time (within 1e-9) completes it.
  LockstepBarrier c({ "solo" }, 0.01);
  c.done("solo", 0.0);
  c.advance();
  double summed = 0.0;
  for (int k = 0; k < 10; ++k)
    summed += 0.001;
  EXPECT_NE(summed, 0.01);
  EXPECT_EQ(c.done("solo", summed), Report::kAccepted);
  EXPECT_TRUE(c.complete());
}

TEST(LockstepBarrier, RefusesUnknownAheadAndBadSetups)
{
  LockstepBarrier b({ "p1" }, 0.05);
  EXPECT_EQ(b.done("p9", 0.0), Report::kUnknownPartition);
  EXPECT_EQ(b.done("p1", 0.05), Report::kAhead);  // the clock has not published 0.05
  EXPECT_EQ(b.done("p1", std::nan("")), Report::kNotFinite);
  EXPECT_FALSE(b.complete());
  EXPECT_THROW(LockstepBarrier({}, 0.01), std::invalid_argument);
  EXPECT_THROW(LockstepBarrier({ "a", "a" }, 0.01), std::invalid_argument);
  EXPECT_THROW(LockstepBarrier({ "" }, 0.01), std::invalid_argument);
  EXPECT_THROW(LockstepBarrier({ "a" }, 0.0), std::invalid_argument);
  EXPECT_THROW(LockstepBarrier({ "a" }, std::nan("")), std::invalid_argument);
  try
  {
    LockstepBarrier({ "a", "b", "a" }, 0.01);
    FAIL() << "no error";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("partitions[2]: 'a' is listed twice"), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(LockstepBarrier, LookaheadLetsTheTimeRunThatManyIntervalsAheadOfTheSlowest)
{
  // Lookahead 2: the time may move to k + 1 once every partition has reported k - 1.
  LockstepBarrier b({ "p1", "p2" }, 0.01, 2);
  EXPECT_DOUBLE_EQ(b.needed(), 0.0);
  EXPECT_FALSE(b.complete());  // nobody has reported 0 yet
  b.done("p1", 0.0);
  b.done("p2", 0.0);
  ASSERT_TRUE(b.complete());
  b.advance();  // 0.01
  EXPECT_DOUBLE_EQ(b.needed(), 0.0);
  EXPECT_TRUE(b.complete());  // 0.01 -> 0.02 needs only 0.00
  b.advance();                // 0.02
  EXPECT_DOUBLE_EQ(b.needed(), 0.01);
  EXPECT_FALSE(b.complete());
  EXPECT_EQ(b.waitingFor(), (std::vector<std::string>{ "p1", "p2" }));
  b.done("p1", 0.02);
  EXPECT_EQ(b.waitingFor(), (std::vector<std::string>{ "p2" }));
  b.done("p2", 0.01);
  EXPECT_TRUE(b.complete());
  b.advance();  // 0.03: p2 at 0.01 is two intervals behind, the most lookahead 2 allows
  EXPECT_FALSE(b.complete());
  EXPECT_EQ(b.waitingFor(), (std::vector<std::string>{ "p2" }));
  EXPECT_THROW(b.advance(), std::logic_error);
  EXPECT_EQ(b.done("p1", 0.04), LockstepBarrier::Report::kAhead);
  EXPECT_THROW(LockstepBarrier({ "p1" }, 0.01, 0), std::invalid_argument);
}
