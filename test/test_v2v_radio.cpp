// gtest of the V2V radio core (avsp_v2v): range cut, loss rate, latency, terrain line of
// sight, determinism per seed, bad options.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp/v2v/radio.hpp"

namespace av = avsp::v2v;

namespace
{
/// A 30 m Gaussian hill (sigma 20 m) centred at (100, 0) on flat ground at z = 0, over
/// [-50, 400] x [-200, 200]; no terrain outside.
bool hill(double x, double y, double& h)
{
  if (x < -50.0 || x > 400.0 || std::abs(y) > 200.0)
    return false;
  h = 30.0 * std::exp(-((x - 100.0) * (x - 100.0) + y * y) / (2.0 * 20.0 * 20.0));
  return true;
}

bool flat(double, double, double& h)
{
  h = 0.0;
  return true;
}
}  // namespace

TEST(V2vRadio, RangeCutIsExact)
{
  av::RadioOptions options;
  options.range = 300.0;
  av::Radio radio({ "a", "b", "c" }, options);
  radio.transmit(1, { 300.0, 0.0, 0.0 }, 0, 0.0, 100);    // b exactly at the range
  radio.transmit(2, { 0.0, 300.001, 0.0 }, 0, 0.0, 101);  // c 1 mm beyond it
  const std::vector<av::Delivery> d = radio.transmit(0, { 0.0, 0.0, 0.0 }, 0, 1.0, 7);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].receiver, 1u);
  EXPECT_EQ(d[0].message, 7u);
  EXPECT_EQ(radio.link(0, 1), av::Link::Up);
  EXPECT_EQ(radio.link(0, 2), av::Link::OutOfRange);
  // 3-D distance: raising b by 1 m puts it out of range.
  radio.transmit(1, { 300.0, 0.0, 1.0 }, 1, 1.1, 102);
  EXPECT_EQ(radio.link(0, 1), av::Link::OutOfRange);
  EXPECT_TRUE(radio.transmit(0, { 0.0, 0.0, 0.0 }, 1, 1.2, 8).empty());
  // Pairs beyond range: c->b, a->c, b->a and b->c (b raised), a->b and a->c.
  EXPECT_EQ(radio.stats().out_of_range, 6u);
}

TEST(V2vRadio, NoDeliveryToAVehicleThatNeverBroadcast)
{
  av::Radio radio({ "a", "b" }, av::RadioOptions{});
  EXPECT_TRUE(radio.transmit(0, { 0.0, 0.0, 0.0 }, 0, 0.0, 1).empty());
  EXPECT_EQ(radio.link(0, 1), av::Link::Unknown);
  EXPECT_EQ(radio.stats().unknown, 1u);
  radio.transmit(1, { 10.0, 0.0, 0.0 }, 0, 0.1, 2);  // b is heard by a from now on
  EXPECT_EQ(radio.transmit(0, { 0.0, 0.0, 0.0 }, 1, 0.2, 3).size(), 1u);
}

TEST(V2vRadio, LatencyIsExactInSimTime)
{
  av::RadioOptions options;
  options.latency = 0.25;
  av::Radio radio({ "a", "b" }, options);
  radio.transmit(1, { 5.0, 0.0, 0.0 }, 0, 9.0, 1);  // a unknown: nothing queued
  EXPECT_EQ(radio.pending(), 0u);
  radio.transmit(0, { 0.0, 0.0, 0.0 }, 0, 10.0, 2);
  radio.transmit(0, { 0.0, 0.0, 0.0 }, 1, 10.1, 3);
  EXPECT_EQ(radio.pending(), 2u);
  EXPECT_TRUE(radio.due(10.0).empty());
  EXPECT_TRUE(radio.due(10.2499).empty());
  std::vector<av::Delivery> out = radio.due(10.25);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].message, 2u);
  EXPECT_DOUBLE_EQ(out[0].due, 10.25);
  EXPECT_TRUE(radio.due(10.3).empty());
  out = radio.due(10.35);  // 10.1 + 0.25 rounds to 10.35 within 1 ns
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].message, 3u);
  EXPECT_NEAR(out[0].due, 10.35, 1e-12);
  EXPECT_EQ(radio.pending(), 0u);

  // Zero latency: due at the stamp itself.
  av::Radio instant({ "a", "b" }, av::RadioOptions{});
  instant.transmit(1, { 5.0, 0.0, 0.0 }, 0, 0.0, 1);
  instant.transmit(0, { 0.0, 0.0, 0.0 }, 0, 3.0, 2);
  EXPECT_TRUE(instant.due(2.999).empty());
  EXPECT_EQ(instant.due(3.0).size(), 1u);
}

TEST(V2vRadio, LossRateWithinTwoPercentOver2000Messages)
{
  for (double p : { 0.05, 0.2, 0.5 })
  {
    av::RadioOptions options;
    options.loss_probability = p;
    options.seed = 1;
    av::Radio radio({ "leader", "follower" }, options);
    radio.transmit(1, { 20.0, 0.0, 0.0 }, 0, 0.0, 0);
    int delivered = 0;
    for (std::uint32_t seq = 0; seq < 2000; ++seq)
      delivered += static_cast<int>(radio.transmit(0, { 0.0, 0.0, 0.0 }, seq, 0.1 * seq, seq).size());
    const double loss = 1.0 - delivered / 2000.0;
    EXPECT_NEAR(loss, p, 0.02) << "configured " << p;
    EXPECT_EQ(radio.stats().lost + radio.stats().delivered, 2000u + 0u);
  }
  // Over many seeds the mean converges (a biased draw would show here): 20 x 2000 messages.
  double lost = 0.0;
  for (std::uint64_t seed = 0; seed < 20; ++seed)
    for (std::uint32_t seq = 0; seq < 2000; ++seq)
      lost += av::Radio::lossDraw(seed, "leader", "follower", seq) < 0.3 ? 1.0 : 0.0;
  EXPECT_NEAR(lost / 40000.0, 0.3, 0.005);
  // Loss 0 loses nothing, loss 1 everything (the draw is in [0, 1): never below 0, always below 1).
  for (double p : { 0.0, 1.0 })
  {
    av::RadioOptions options;
    options.loss_probability = p;
    options.seed = 3;
    av::Radio radio({ "leader", "follower" }, options);
    radio.transmit(1, { 20.0, 0.0, 0.0 }, 0, 0.0, 0);
    std::size_t delivered = 0;
    for (std::uint32_t seq = 0; seq < 500; ++seq)
      delivered += radio.transmit(0, { 0.0, 0.0, 0.0 }, seq, 0.1 * seq, seq).size();
    EXPECT_EQ(delivered, p == 0.0 ? 500u : 0u) << "loss " << p;
    EXPECT_EQ(radio.stats().lost, p == 0.0 ? 0u : 500u) << "loss " << p;
  }
}

TEST(V2vRadio, LinksLoseIndependently)
{
  // Two receivers of the same broadcasts: their losses must not coincide (shared draws would).
  av::RadioOptions options;
  options.loss_probability = 0.5;
  options.seed = 11;
  av::Radio radio({ "s", "r1", "r2" }, options);
  radio.transmit(1, { 10.0, 0.0, 0.0 }, 0, 0.0, 0);
  radio.transmit(2, { -10.0, 0.0, 0.0 }, 0, 0.0, 0);
  int both = 0, r1 = 0, r2 = 0;
  for (std::uint32_t seq = 0; seq < 2000; ++seq)
  {
    bool got1 = false, got2 = false;
    for (const av::Delivery& d : radio.transmit(0, { 0.0, 0.0, 0.0 }, seq, seq * 0.1, seq))
      (d.receiver == 1 ? got1 : got2) = true;
    r1 += got1;
    r2 += got2;
    both += got1 && got2;
  }
  EXPECT_NEAR(r1 / 2000.0, 0.5, 0.02);
  EXPECT_NEAR(r2 / 2000.0, 0.5, 0.02);
  EXPECT_NEAR(both / 2000.0, 0.25, 0.02);  // independent: 0.5 * 0.5
}

TEST(V2vRadio, TerrainHillBlocksLineOfSight)
{
  av::RadioOptions options;
  options.line_of_sight = true;
  options.antenna_height = 1.5;
  options.los_step = 0.5;
  av::Radio radio({ "west", "east", "north", "top" }, options, hill);
  radio.transmit(0, { 0.0, 0.0, 0.0 }, 0, 0.0, 1);
  radio.transmit(1, { 200.0, 0.0, 0.0 }, 0, 0.0, 2);   // the hill's top is between west and east
  radio.transmit(2, { 0.0, 150.0, 0.0 }, 0, 0.0, 3);   // west-north: the ray passes 100 m from the hill's centre
  radio.transmit(3, { 100.0, 0.0, 30.0 }, 0, 0.0, 4);  // on the summit
  EXPECT_EQ(radio.link(0, 1), av::Link::Blocked);
  EXPECT_EQ(radio.link(1, 0), av::Link::Blocked);
  EXPECT_EQ(radio.link(0, 2), av::Link::Up);
  EXPECT_EQ(radio.link(0, 3), av::Link::Up);  // sees the summit (convex slope)
  EXPECT_EQ(radio.link(1, 3), av::Link::Up);
  // A broadcast from west reaches north and the summit, not east.
  std::vector<std::size_t> receivers;
  for (const av::Delivery& d : radio.transmit(0, { 0.0, 0.0, 0.0 }, 1, 1.0, 5))
    receivers.push_back(d.receiver);
  EXPECT_EQ(receivers, (std::vector<std::size_t>{ 2, 3 }));
  EXPECT_EQ(radio.stats().blocked, 1u + 1u);  // east's first broadcast to west, west's second to east

  // The same geometry without the line-of-sight check: everyone hears everyone.
  av::Radio open({ "west", "east" }, av::RadioOptions{});
  open.transmit(0, { 0.0, 0.0, 0.0 }, 0, 0.0, 1);
  open.transmit(1, { 200.0, 0.0, 0.0 }, 0, 0.0, 2);
  EXPECT_EQ(open.link(0, 1), av::Link::Up);

  // Antennas on masts above the hill clear it: 2 x 31 m masts, ray at 31 m over a 30 m top.
  options.antenna_height = 31.0;
  av::Radio masts({ "west", "east" }, options, hill);
  masts.transmit(0, { 0.0, 0.0, 0.0 }, 0, 0.0, 1);
  masts.transmit(1, { 200.0, 0.0, 0.0 }, 0, 0.0, 2);
  EXPECT_EQ(masts.link(0, 1), av::Link::Up);

  // Flat ground never blocks; neither does a ray over ground the terrain does not cover.
  av::Radio plain({ "a", "b" }, options, flat);
  EXPECT_TRUE(plain.lineOfSight({ 0, 0, 1.5 }, { 250, 0, 1.5 }));
  av::Radio edge({ "a", "b" }, options, hill);
  EXPECT_TRUE(edge.lineOfSight({ 500, 0, 0.5 }, { 700, 0, 0.5 }));
}

TEST(V2vRadio, SameSeedSameDeliveriesOtherSeedOthers)
{
  auto run = [](std::uint64_t seed) {
    av::RadioOptions options;
    options.loss_probability = 0.3;
    options.latency = 0.05;
    options.seed = seed;
    av::Radio radio({ "m113", "mrzr", "tracer_x", "fed_alpha" }, options);
    std::vector<std::tuple<double, std::size_t, std::uint64_t>> log;
    std::uint64_t id = 0;
    for (std::uint32_t seq = 0; seq < 200; ++seq)
      for (std::size_t v = 0; v < 4; ++v)
      {
        radio.transmit(v, { 10.0 * v + 0.5 * seq, 3.0 * v, 0.0 }, seq, 0.1 * seq, id++);
        for (const av::Delivery& d : radio.due(0.1 * seq))
          log.emplace_back(d.due, d.receiver, d.message);
      }
    return log;
  };
  const auto a = run(42), b = run(42), c = run(43);
  ASSERT_GT(a.size(), 1000u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

TEST(V2vRadio, BadOptionsNameTheOption)
{
  auto expectRefused = [](const std::vector<std::string>& vehicles, const av::RadioOptions& o, const std::string& name,
                          av::HeightFunction terrain = {}) {
    try
    {
      av::Radio radio(vehicles, o, terrain);
      ADD_FAILURE() << "accepted, expected an error naming " << name;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  av::RadioOptions o;
  o.range = 0.0;
  expectRefused({ "a", "b" }, o, "range");
  o = av::RadioOptions{};
  o.loss_probability = 1.5;
  expectRefused({ "a", "b" }, o, "loss_probability");
  o = av::RadioOptions{};
  o.latency = -0.1;
  expectRefused({ "a", "b" }, o, "latency");
  o = av::RadioOptions{};
  o.los_step = 0.0;
  expectRefused({ "a", "b" }, o, "los_step");
  o = av::RadioOptions{};
  o.line_of_sight = true;
  expectRefused({ "a", "b" }, o, "line_of_sight");
  expectRefused({ "a", "a" }, av::RadioOptions{}, "'a' is listed twice");
  expectRefused({}, av::RadioOptions{}, "empty");
  av::Radio radio({ "a" }, av::RadioOptions{});
  EXPECT_THROW(radio.transmit(1, {}, 0, 0.0, 0), std::out_of_range);
}
