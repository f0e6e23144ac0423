// RealTimeFactorWindow: sim time over wall time on a sliding wall-time window.
#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "avsp_dynamics/real_time_factor.hpp"

using avsp::dynamics::Pacer;
using avsp::dynamics::RealTimeFactorWindow;

TEST(RealTimeFactorWindow, NothingUntilTwoSamplesApartInWallTime)
{
  RealTimeFactorWindow w(5.0);
  EXPECT_FALSE(w.factor());
  w.add(0.0, 10.0);
  EXPECT_FALSE(w.factor());
  w.add(0.01, 10.0);  // same wall instant: no span yet
  EXPECT_FALSE(w.factor());
  EXPECT_EQ(w.span(), 0.0);
  w.add(1.01, 10.5);
  ASSERT_TRUE(w.factor());
  EXPECT_DOUBLE_EQ(*w.factor(), 1.01 / 0.5);
  EXPECT_DOUBLE_EQ(w.span(), 0.5);
}

TEST(RealTimeFactorWindow, ASlowdownShowsOnceTheFastPartLeavesTheWindow)
{
  // 10 s of wall at 2x, then 10 s at 0.5x, sampled every 0.1 s of wall.
  RealTimeFactorWindow w(4.0);
  double sim = 0.0;
  for (int k = 0; k <= 100; ++k)
  {
    w.add(sim, 0.1 * k);
    sim += 0.2;
  }
  sim -= 0.2;
  ASSERT_TRUE(w.factor());
  EXPECT_NEAR(*w.factor(), 2.0, 1e-9);
  EXPECT_NEAR(w.span(), 4.0, 1e-9);
  for (int k = 101; k <= 200; ++k)
  {
    sim += 0.05;
    w.add(sim, 0.1 * k);
    if (k == 120)  // 2 s into the slow part: half the window each
      EXPECT_NEAR(*w.factor(), (2.0 * 2.0 + 2.0 * 0.5) / 4.0, 1e-9);
  }
  EXPECT_NEAR(*w.factor(), 0.5, 1e-9);
  EXPECT_NEAR(w.span(), 4.0, 1e-9);
}

TEST(RealTimeFactorWindow, SparseSamplesKeepTheLastOneBeyondTheWindow)
{
  // A sample every 3 s of wall with a 2 s window: the factor spans the last interval.
  RealTimeFactorWindow w(2.0);
  w.add(0.0, 0.0);
  w.add(6.0, 3.0);
  w.add(9.0, 6.0);
  EXPECT_DOUBLE_EQ(*w.factor(), 1.0);
  EXPECT_DOUBLE_EQ(w.span(), 3.0);
}

TEST(RealTimeFactorWindow, BadInputsAreRefused)
{
  EXPECT_THROW(RealTimeFactorWindow(0.0), std::invalid_argument);
  EXPECT_THROW(RealTimeFactorWindow(-1.0), std::invalid_argument);
  EXPECT_THROW(RealTimeFactorWindow(std::nan("")), std::invalid_argument);
  RealTimeFactorWindow w;
  w.add(1.0, 1.0);
  EXPECT_THROW(w.add(0.5, 2.0), std::invalid_argument);
  EXPECT_THROW(w.add(2.0, 0.5), std::invalid_argument);
  EXPECT_THROW(w.add(std::nan(""), 2.0), std::invalid_argument);
  EXPECT_THROW(w.add(2.0, INFINITY), std::invalid_argument);
  EXPECT_DOUBLE_EQ(w.span(), 0.0);  // the refused samples changed nothing
}

TEST(Pacer, PacesAndRestartsAfterAStallInsteadOfSprinting)
{
  Pacer p(2.0, 0.1);                    // 2x real time
  EXPECT_EQ(p.due(10.0), -INFINITY);    // no pace yet
  EXPECT_EQ(p.wait(10.0, 100.0), 0.0);  // anchors: sim 10 s at wall 100 s
  EXPECT_DOUBLE_EQ(p.due(11.0), 100.5);
  EXPECT_NEAR(p.wait(11.0, 100.1), 0.4, 1e-9);  // sim 11 due at wall 100.5
  EXPECT_DOUBLE_EQ(p.wait(12.0, 101.05), 0.0);  // 0.05 s late: within max_lag, caught up
  EXPECT_EQ(p.restarts(), 0u);
  // A stall: sim 13 (due at 101.5) comes at wall 105: the pace restarts there ...
  EXPECT_EQ(p.wait(13.0, 105.0), 0.0);
  EXPECT_EQ(p.restarts(), 1u);
  EXPECT_NEAR(p.lost(), 3.5, 1e-9);
  // ... and sim 14 is due 0.5 s after it, not at once (the old pace had it at 102.0).
  EXPECT_DOUBLE_EQ(p.due(14.0), 105.5);
  EXPECT_NEAR(p.wait(14.0, 105.0), 0.5, 1e-9);
  EXPECT_NEAR(p.wait(14.5, 105.5), 0.25, 1e-9);
  // A pause of 60 s (wall): after reanchor() the pace starts again where the run resumes.
  p.reanchor();
  EXPECT_EQ(p.due(14.6), -INFINITY);
  EXPECT_EQ(p.wait(14.6, 165.5), 0.0);
  EXPECT_NEAR(p.wait(15.6, 165.5), 0.5, 1e-9);
  EXPECT_EQ(p.restarts(), 1u);
}

TEST(Pacer, BadInputsAreRefused)
{
  EXPECT_THROW(Pacer(0.0), std::invalid_argument);
  EXPECT_THROW(Pacer(-1.0), std::invalid_argument);
  EXPECT_THROW(Pacer(1.0, -0.1), std::invalid_argument);
  EXPECT_THROW(Pacer{ INFINITY }, std::invalid_argument);
  Pacer p(1.0);
  EXPECT_THROW(p.wait(std::nan(""), 0.0), std::invalid_argument);
  EXPECT_THROW(p.wait(0.0, INFINITY), std::invalid_argument);
}
