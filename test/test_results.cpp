// The run recorder's core (avsp_results, no ROS) against closed forms: the distance of a known
// polyline, the gap along a straight path and a circular arc, time stuck, max driven slip, rut
// depths from patches, and the output files: summary JSON parsed back (yaml-cpp and Python's
// json), .npy grids read back (header and values), CSV rows.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include "avsp/results/anomaly_monitor.hpp"
#include "avsp/results/gap.hpp"
#include "avsp/results/output.hpp"
#include "avsp/results/rut_map.hpp"
#include "avsp/results/run_watch.hpp"
#include "avsp/results/vehicle_record.hpp"

using namespace avsp::results;
namespace terrain = avsp::terrain;
namespace fs = std::filesystem;

namespace
{
std::string tempDir()
{
  char pattern[] = "/tmp/avsp_test_results_XXXXXX";
  const char* dir = mkdtemp(pattern);
  if (!dir)
    throw std::runtime_error("mkdtemp failed");
  return dir;
}

std::string readFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A level-ish grid: z = slope * x, origin (-10, -10), 0.1 m, 201 x 201 points.
terrain::ElevationGrid plane(double slope = 0.0)
{
  const std::size_t n = 201;
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(slope * (-10.0 + 0.1 * static_cast<double>(i)));
  return terrain::ElevationGrid(-10.0, -10.0, 0.1, 0.1, n, n, h);
}
}  // namespace

TEST(VehicleList, ValidatesNamesAndLeaders)
{
  EXPECT_NO_THROW(validateVehicles({ { "a", "" }, { "b", "a" }, { "c", "b" } }));
  auto message = [](const std::vector<VehicleSpec>& v) {
    try
    {
      validateVehicles(v);
    }
    catch (const std::invalid_argument& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message({}), "vehicles must list at least one vehicle");
  EXPECT_EQ(message({ { "a", "" }, { "a", "" } }), "vehicles[1].name 'a' is listed twice");
  EXPECT_EQ(message({ { "a", "" }, { "b", "zed" } }), "vehicles[1].leader 'zed' is not a listed vehicle");
  EXPECT_EQ(message({ { "a", "a" } }), "vehicles[0].leader 'a' is the vehicle itself");
  EXPECT_EQ(message({ { "", "" } }), "vehicles[0].name must not be empty");
}

// A 3-4-5 triangle's legs, then a climb: distance is the sum of the 3-D segment lengths.
TEST(VehicleRecord, DistanceOfAKnownPolylineAndSpeeds)
{
  VehicleRecord r;
  EXPECT_EQ(OdometryAdded::kSample, r.addOdometry(0.0, 0.0, 0.0, 0.0, 0.0));
  EXPECT_EQ(OdometryAdded::kSample, r.addOdometry(1.0, 3.0, 0.0, 0.0, 3.0));
  EXPECT_EQ(OdometryAdded::kSample, r.addOdometry(2.0, 3.0, 4.0, 0.0, 4.0));
  EXPECT_EQ(OdometryAdded::kSample,
            r.addOdometry(3.0, 6.0, 4.0, 4.0, -5.0));  // (3, 0, 4): 5 m; reversing speed counts as 5 m/s
  EXPECT_DOUBLE_EQ(r.distance(), 12.0);
  EXPECT_DOUBLE_EQ(r.maxSpeed(), 5.0);
  EXPECT_DOUBLE_EQ(r.speed(), 5.0);
  ASSERT_TRUE(r.meanSpeed());
  EXPECT_DOUBLE_EQ(*r.meanSpeed(), 4.0);
  // Bad samples leave everything as it was.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(OdometryAdded::kRefused, r.addOdometry(4.0, nan, 0.0, 0.0, 1.0));
  EXPECT_EQ(OdometryAdded::kRefused, r.addOdometry(4.0, 0.0, 0.0, 0.0, std::numeric_limits<double>::infinity()));
  EXPECT_EQ(OdometryAdded::kRefused, r.addOdometry(2.5, 0.0, 0.0, 0.0, 1.0));  // out of order
  // The last instant again, even moved: a repeat, not a sample (the count would depend on how
  // long start-up took).
  EXPECT_EQ(OdometryAdded::kRepeat, r.addOdometry(3.0, 9.0, 4.0, 4.0, 1.0));
  EXPECT_DOUBLE_EQ(r.distance(), 12.0);
  EXPECT_EQ(r.sampleCount(), 4u);
  EXPECT_DOUBLE_EQ(r.last()->x, 6.0);
  EXPECT_DOUBLE_EQ(r.first()->t, 0.0);
  EXPECT_DOUBLE_EQ(r.last()->t, 3.0);
  EXPECT_DOUBLE_EQ(r.last()->distance, 12.0);
  const std::array<double, 4> box{ 0.0, 0.0, 6.0, 4.0 };
  EXPECT_EQ(*r.bounds(), box);

  // A circle of radius 10 m sampled at 1000 points: the chords sum to 2000 R sin(pi / 1000).
  VehicleRecord c;
  for (int k = 0; k <= 1000; ++k)
  {
    const double a = 2.0 * M_PI * k / 1000.0;
    c.addOdometry(0.01 * k, 10.0 * std::cos(a), 10.0 * std::sin(a), 0.0, 1.0);
  }
  EXPECT_NEAR(c.distance(), 2000.0 * 10.0 * std::sin(M_PI / 1000.0), 1e-9);
  EXPECT_NEAR(c.distance(), 2.0 * M_PI * 10.0, 1e-3);
  VehicleRecord empty;
  EXPECT_FALSE(empty.meanSpeed());
  EXPECT_FALSE(empty.first());
  EXPECT_FALSE(empty.bounds());
  EXPECT_EQ(empty.distance(), 0.0);
}

TEST(VehicleRecord, TimeStuckCollisionsAndMaxSlip)
{
  VehicleRecord r;
  EXPECT_FALSE(r.collisions());
  EXPECT_FALSE(r.maxSlip());
  // Stuck from t = 1 to t = 3.5 (the flag holds until the next message clears it), and 9 to 10.
  const bool stuck[] = { false, true, true, true, false, false, true, true };
  const double t[] = { 0.0, 1.0, 2.0, 3.0, 3.5, 9.0, 9.0, 10.0 };
  for (int k = 0; k < 8; ++k)
    EXPECT_TRUE(r.addTelemetry(t[k], 0.1 * k, stuck[k], static_cast<std::uint32_t>(k / 3)));
  EXPECT_DOUBLE_EQ(r.timeStuck(), 2.5 + 1.0);
  ASSERT_TRUE(r.collisions());
  EXPECT_EQ(*r.collisions(), 2u);  // the latest cumulative count
  ASSERT_TRUE(r.maxSlip());
  EXPECT_DOUBLE_EQ(*r.maxSlip(), 0.7);
  EXPECT_FALSE(r.addTelemetry(8.0, 0.99, true, 5));  // out of order: ignored
  EXPECT_DOUBLE_EQ(*r.maxSlip(), 0.7);
  EXPECT_TRUE(r.addTelemetry(11.0, std::nullopt, false, 2));  // no slip this time
  EXPECT_DOUBLE_EQ(r.timeStuck(), 4.5);
  EXPECT_DOUBLE_EQ(*r.maxSlip(), 0.7);
  EXPECT_EQ(r.telemetryCount(), 9u);

  // Slip: driven wheels on the ground only.
  EXPECT_EQ(maxDrivenSlip({ { 0.3, 1000.0, true }, { 0.9, 0.0, true }, { 0.95, 500.0, false }, { -0.2, 10.0, true } }),
            0.3);
  EXPECT_EQ(maxDrivenSlip({ { 0.9, 0.0, true }, { 0.5, 100.0, false } }), std::nullopt);
  EXPECT_EQ(maxDrivenSlip({ { -0.4, 100.0, true }, { -0.1, 100.0, true } }), -0.1);
  EXPECT_EQ(maxDrivenSlip({ { std::nan(""), 100.0, true } }), std::nullopt);
}

std::vector<OdometrySample> samples(const std::vector<std::array<double, 3>>& txy)
{
  VehicleRecord r;
  std::vector<OdometrySample> out;
  for (const auto& p : txy)
    if (r.addOdometry(p[0], p[1], p[2], 0.0, 0.0) == OdometryAdded::kSample)
      out.push_back(*r.last());
  return out;
}

// Straight line: leader at 5 m/s from x = 0, follower 12 m behind at the same speed; the
// follower starts 12 m behind the leader's first point, so the first gaps come from the
// breadcrumb rule (distance to the start); all are 12 m. Then the follower drifts 0.5 m to the
// side: the gap along the path stays 12 m, lateral 0.5 m.
TEST(Gap, StraightLineAndBeforeTheStart)
{
  std::vector<std::array<double, 3>> l, f;
  for (int k = 0; k <= 1000; ++k)
  {
    const double t = 0.01 * k;
    l.push_back({ t, 5.0 * t, 0.0 });
    f.push_back({ t, 5.0 * t - 12.0, t > 5.0 ? 0.5 : 0.0 });
  }
  const auto series = gapSeries(samples(l), samples(f), 0.1);
  ASSERT_EQ(series.size(), 101u);
  for (const GapSample& g : series)
  {
    EXPECT_NEAR(g.gap, 12.0, 1e-9) << "t = " << g.t;
    EXPECT_NEAR(g.lateral, g.t > 5.0 ? 0.5 : 0.0, 1e-9) << "t = " << g.t;
  }
  EXPECT_NEAR(series[37].t, 3.7, 1e-9);
  const auto st = gapStats(series);
  ASSERT_TRUE(st);
  EXPECT_NEAR(st->min, 12.0, 1e-9);
  EXPECT_NEAR(st->mean, 12.0, 1e-9);
  EXPECT_FALSE(gapStats({}));
  EXPECT_TRUE(gapSeries({}, samples(f), 0.1).empty());
  EXPECT_THROW(gapSeries(samples(l), samples(f), 0.0), std::invalid_argument);
}

// Circle of radius R = 20 m: the leader drives it at angular rate w, the follower a lag of
// dtheta behind on the same circle, or on a circle 1 m inside: the gap is R dtheta (the
// leader's path is a polygon of 5 cm chords at 100 Hz: the arc to 1e-5 m).
TEST(Gap, CircularArcIsRTimesTheAngle)
{
  const double R = 20.0, w = 0.25, lag = 0.6;  // rad/s, rad: 12 m behind
  for (const double r_follower : { R, R - 1.0 })
  {
    std::vector<std::array<double, 3>> l, f;
    for (int k = 0; k <= 4000; ++k)
    {
      const double t = 0.01 * k;
      const double a = w * t;
      l.push_back({ t, R * std::cos(a), R * std::sin(a) });
      f.push_back({ t, r_follower * std::cos(a - lag), r_follower * std::sin(a - lag) });
    }
    const auto series = gapSeries(samples(l), samples(f), 0.5);
    ASSERT_EQ(series.size(), 81u);
    // Once the follower is on the leader's path (t >= lag / w = 2.4 s) the gap is the arc R lag,
    // including after a full lap (t > 2 pi / w = 25 s), where the window keeps it on this lap.
    int checked = 0;
    for (const GapSample& g : series)
    {
      if (g.t < lag / w + 0.5)
        continue;
      ++checked;
      EXPECT_NEAR(g.gap, R * lag, 2e-3) << "t = " << g.t << ", follower radius " << r_follower;
      EXPECT_NEAR(g.lateral, R - r_follower, 2e-3) << "t = " << g.t;
    }
    EXPECT_GT(checked, 70);
  }
}

// A leader on a winding path (x = 5 t, y = 8 sin(0.05 x)), the follower 15 m of x behind on the
// same path, 100 Hz each.
std::pair<std::vector<OdometrySample>, std::vector<OdometrySample>> windingConvoy(int steps)
{
  std::vector<std::array<double, 3>> l, f;
  for (int k = 0; k <= steps; ++k)
  {
    const double t = 0.01 * k, xl = 5.0 * t, xf = xl - 15.0;
    l.push_back({ t, xl, 8.0 * std::sin(0.05 * xl) });
    f.push_back({ t, xf, 8.0 * std::sin(0.05 * xf) });
  }
  return { samples(l), samples(f) };
}

// The streaming tracker gives the same series bit for bit however the two topics' messages
// interleave: all the leader's first, all the follower's first, or shuffled with a random lag of
// up to 1 s either way (seeded); min and mean as gapStats of the series.
TEST(Gap, SeriesDoesNotDependOnHowTheTopicsInterleave)
{
  const auto [leader, follower] = windingConvoy(6000);
  const std::vector<GapSample> reference = gapSeries(leader, follower, 0.1);
  ASSERT_EQ(reference.size(), 601u);
  EXPECT_GT(reference[300].gap, 15.0);  // along the winding path: longer than the 15 m of x
  for (int order = 0; order < 4; ++order)
  {
    std::vector<GapSample> got;
    GapTracker tracker(0.1, [&got](const GapSample& g) { got.push_back(g); });
    std::mt19937 rng(static_cast<unsigned>(order));
    std::uniform_int_distribution<int> lag(-100, 100);
    std::size_t i = 0, j = 0;
    int ahead = lag(rng);  // + = the leader's messages ahead
    while (i < leader.size() || j < follower.size())
    {
      const bool leader_next =
          j == follower.size() ||
          (i < leader.size() && (order == 0 || (order != 1 && static_cast<int>(i) < static_cast<int>(j) + ahead)));
      if (leader_next)
        tracker.addLeader(leader[i++]);
      else
        tracker.addFollower(follower[j++]);
      if ((i + j) % 250 == 0)
        ahead = lag(rng);
    }
    ASSERT_EQ(got.size(), reference.size()) << "order " << order;
    for (std::size_t k = 0; k < got.size(); ++k)
    {
      EXPECT_EQ(got[k].t, reference[k].t) << "order " << order << ", sample " << k;
      EXPECT_EQ(got[k].gap, reference[k].gap) << "order " << order << ", sample " << k;
      EXPECT_EQ(got[k].lateral, reference[k].lateral) << "order " << order << ", sample " << k;
    }
    const auto st = tracker.stats(), expected = gapStats(reference);
    ASSERT_TRUE(st && expected);
    EXPECT_EQ(st->min, expected->min);
    EXPECT_NEAR(st->mean, expected->mean, 1e-12);
  }
}

// Memory: a 3 h convoy at 5 m/s, messages interleaved as they come: what the tracker holds after
// 3 h is what it held after 1 h (the leader's samples back to the follower's, the path back to
// kKeepBehind), and a parked leader with the follower still sending holds no more either.
TEST(Gap, TrackerHoldsTheSameAfterOneHourAndThree)
{
  GapTracker tracker(0.1, [](const GapSample&) {});
  std::size_t held_1h = 0;
  for (int k = 0; k <= 3 * 360000; ++k)
  {
    const double t = 0.01 * k, xl = 5.0 * t, xf = xl - 15.0;
    tracker.addLeader({ t, xl, 8.0 * std::sin(0.05 * xl), 0.0, 5.0, 0.0 });
    tracker.addFollower({ t, xf, 8.0 * std::sin(0.05 * xf), 0.0, 5.0, 0.0 });
    if (k == 360000)
      held_1h = tracker.held();
  }
  // 500 m kept behind + the 15 m gap at 5 cm per point, plus a sample or two of each stream.
  EXPECT_LT(held_1h, 12000u);
  EXPECT_GT(held_1h, 9000u);
  EXPECT_LE(tracker.held(), held_1h + 2);
  const std::size_t moving = tracker.held();
  for (int k = 1; k <= 360000; ++k)  // an hour parked
  {
    const double t = 10800.0 + 0.01 * k;
    tracker.addLeader({ t, 54000.0, 8.0 * std::sin(0.05 * 54000.0), 0.0, 0.0, 0.0 });
    tracker.addFollower({ t, 54000.0 - 15.0, 8.0 * std::sin(0.05 * 53985.0), 0.0, 0.0, 0.0 });
  }
  EXPECT_LE(tracker.held(), moving + 2);
  EXPECT_EQ(tracker.dropped(), 0u);
}

// Rut depths: base z = 0.05 x; patches set deformed heights; the latest patch wins; depth =
// base - deformed; a misaligned patch is refused naming the field.
TEST(RutMap, DepthFromPatchesAndCroppedGrid)
{
  const terrain::ElevationGrid base = plane(0.05);
  RutMap map(base);
  EXPECT_EQ(map.pointCount(), 0u);
  EXPECT_FALSE(map.depthGrid(0.001, 1.0, 100));
  // Patch 1: points i = 100..104 (x = 0 .. 0.4), j = 110..111 (y = 1.0, 1.1), 3 cm deep, first
  // row; second row unchanged.
  terrain::HeightPatch p;
  p.origin_x = 0.0;
  p.origin_y = 1.0;
  p.resolution = 0.1;
  p.width = 5;
  p.height = 2;
  for (std::size_t r = 0; r < 2; ++r)
    for (std::size_t c = 0; c < 5; ++c)
      p.heights.push_back(static_cast<float>(0.05 * 0.1 * static_cast<double>(c) - (r == 0 ? 0.03 : 0.0)));
  map.apply(p);
  EXPECT_EQ(map.pointCount(), 10u);
  ASSERT_TRUE(map.depth(102, 110));
  EXPECT_NEAR(*map.depth(102, 110), 0.03, 1e-6);
  EXPECT_NEAR(*map.depth(102, 111), 0.0, 1e-6);
  EXPECT_FALSE(map.depth(102, 112));
  EXPECT_FALSE(map.depth(5000, 0));
  // Patch 2 overlaps: point (104, 110) now 8 cm deep, (105, 110) new, a berm at (106, 110).
  terrain::HeightPatch q = p;
  q.origin_x = 0.4;
  q.width = 3;
  q.height = 1;
  q.heights = { static_cast<float>(0.02 - 0.08), static_cast<float>(0.025 - 0.05), static_cast<float>(0.03 + 0.01) };
  map.apply(q);
  EXPECT_EQ(map.pointCount(), 12u);
  EXPECT_NEAR(*map.depth(104, 110), 0.08, 1e-6);
  EXPECT_NEAR(*map.depth(105, 110), 0.05, 1e-6);
  EXPECT_NEAR(*map.depth(106, 110), -0.01, 1e-6);
  EXPECT_NEAR(map.maxDepth(), 0.08, 1e-6);
  EXPECT_NEAR(map.areaDeeperThan(0.04), 2 * 0.01, 1e-9);  // (104, 110) and (105, 110)
  EXPECT_NEAR(map.areaDeeperThan(0.01), 6 * 0.01, 1e-9);  // 100..105 on row 110

  // Cropped to the points >= 1 cm (i 100..105, j 110) widened by 0.2 m, full resolution.
  auto g = map.depthGrid(0.01, 0.2, 100);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->width, 10u);  // 98..107
  EXPECT_EQ(g->height, 5u);  // 108..112
  EXPECT_NEAR(g->origin_x, -0.2, 1e-9);
  EXPECT_NEAR(g->origin_y, 0.8, 1e-9);
  EXPECT_NEAR(g->values[2 * 10 + 6], 0.08, 1e-6);  // (104, 110)
  EXPECT_TRUE(std::isnan(g->values[0]));           // never patched
  // Max-pooled to at most 4 cells per side: blocks of 3 points, the deepest of each.
  g = map.depthGrid(0.01, 0.2, 4);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->width, 4u);
  EXPECT_EQ(g->height, 2u);
  EXPECT_NEAR(g->resolution, 0.3, 1e-12);
  EXPECT_NEAR(g->origin_x, -0.1, 1e-9);  // centre of points 98..100
  // Block (2, 0) covers i 104..106, j 108..110: deepest 8 cm.
  EXPECT_NEAR(g->values[2], 0.08, 1e-6);

  // Refused: wrong resolution, origin off the grid points, wrong count, NaN.
  terrain::HeightPatch bad = p;
  bad.resolution = 0.2;
  EXPECT_THROW(map.apply(bad), terrain::PatchError);
  bad = p;
  bad.origin_x = 0.05;
  try
  {
    map.apply(bad);
    ADD_FAILURE() << "misaligned patch accepted";
  }
  catch (const terrain::PatchError& e)
  {
    EXPECT_NE(std::string(e.what()).find("origin"), std::string::npos) << e.what();
  }
  bad = p;
  bad.heights.pop_back();
  EXPECT_THROW(map.apply(bad), terrain::PatchError);
  bad = p;
  bad.heights[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(map.apply(bad), terrain::PatchError);
  EXPECT_EQ(map.pointCount(), 12u);
  // Partly off the grid: the rest is applied.
  terrain::HeightPatch edge = p;
  edge.origin_x = 9.8;  // points 198..202: 198..200 are on the grid
  map.apply(edge);
  EXPECT_EQ(map.pointCount(), 12u + 6u);
}

TEST(RutMap, SampledHeightsCoverTheBox)
{
  const terrain::ElevationGrid base = plane(0.05);
  const Grid g = sampleHeights(base, -5.0, -2.0, 5.0, 2.0, 51);
  EXPECT_NEAR(g.resolution, 0.2, 1e-12);
  EXPECT_EQ(g.width, 51u);
  EXPECT_EQ(g.height, 21u);
  EXPECT_NEAR(g.values[10 * 51 + 25], 0.0, 1e-6);  // x = 0
  EXPECT_NEAR(g.values[0 * 51 + 50], 0.25, 1e-6);  // x = 5
  const Grid off = sampleHeights(base, 9.0, 0.0, 11.0, 1.0, 100);
  EXPECT_NEAR(off.resolution, 0.1, 1e-12);
  EXPECT_TRUE(std::isnan(off.values.back()));  // x = 11 is off the terrain
  EXPECT_THROW(sampleHeights(base, 1.0, 0.0, 1.0, 1.0, 10), std::invalid_argument);
}

// The summary document: well formed (yaml-cpp and Python's json parse it), values round-trip,
// NaN becomes null, strings are escaped.
TEST(Output, JsonRoundTrips)
{
  Json doc = Json::object();
  doc.set("scenario", "test \"quoted\"\\path\n");
  doc.set("duration", 10.0);
  doc.set("rtf", std::numeric_limits<double>::quiet_NaN());
  doc.set("none", std::optional<double>());
  doc.set("some", std::optional<double>(0.125));
  doc.set("count", std::uint32_t{ 3 });
  doc.set("ok", true);
  doc.set("empty", Json::array());
  Json vehicles = Json::array();
  for (int k = 0; k < 2; ++k)
  {
    Json v = Json::object();
    v.set("name", "v" + std::to_string(k));
    v.set("distance", 1234.5678901234 * (k + 1));
    vehicles.push(v);
  }
  doc.set("vehicles", vehicles);
  doc.set("duration", 12.5);  // replaces, keeps its place
  const std::string text = doc.dump();
  EXPECT_LT(text.find("\"scenario\""), text.find("\"duration\""));

  const YAML::Node y = YAML::Load(text);
  EXPECT_EQ(y["scenario"].as<std::string>(), "test \"quoted\"\\path\n");
  EXPECT_DOUBLE_EQ(y["duration"].as<double>(), 12.5);
  EXPECT_TRUE(y["rtf"].IsNull());
  EXPECT_TRUE(y["none"].IsNull());
  EXPECT_DOUBLE_EQ(y["some"].as<double>(), 0.125);
  EXPECT_EQ(y["count"].as<int>(), 3);
  EXPECT_TRUE(y["ok"].as<bool>());
  EXPECT_EQ(y["empty"].size(), 0u);
  ASSERT_EQ(y["vehicles"].size(), 2u);
  EXPECT_NEAR(y["vehicles"][1]["distance"].as<double>(), 2469.1357802468, 1e-6);
  EXPECT_THROW(Json().set("a", 1), std::logic_error);
  EXPECT_THROW(Json::object().push(1), std::logic_error);

  // Python's json (strict: no NaN, no trailing commas) reads it and gives the same values.
  const std::string dir = tempDir();
  writeText(dir + "/summary.json", text);
  writeText(dir + "/check.py", R"(import json, sys
d = json.load(open(sys.argv[1]))
assert d['rtf'] is None, d
assert d['vehicles'][1]['distance'] == 2469.13578, d
assert d['scenario'] == 'test "quoted"\\path\n', d
)");
  const std::string cmd = "/usr/bin/python3 " + dir + "/check.py " + dir + "/summary.json";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd << "\n" << text;
  EXPECT_THROW(writeText("/nonexistent_dir_avsp/summary.json", "{}"), std::runtime_error);
  std::system(("rm -rf " + dir).c_str());
}

// .npy: NumPy's header (magic, version 1.0, a 64-byte aligned header giving '<f4', C order and
// the shape (height, width)) and the values in row order; NumPy itself reads it back.
TEST(Output, NpyGridAndCsvTables)
{
  const std::string dir = tempDir();
  Grid g;
  g.width = 3;
  g.height = 2;
  g.resolution = 0.5;
  g.values = { 0.f, 1.f, 2.f, 3.f, 4.f, std::numeric_limits<float>::quiet_NaN() };
  writeNpy(dir + "/g.npy", g);
  const std::string bytes = readFile(dir + "/g.npy");
  ASSERT_GE(bytes.size(), 10u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t header_len = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
  EXPECT_EQ((10 + header_len) % 64, 0u);
  const std::string header = bytes.substr(10, header_len);
  EXPECT_NE(header.find("'descr': '<f4'"), std::string::npos);
  EXPECT_NE(header.find("'shape': (2, 3)"), std::string::npos);
  ASSERT_EQ(bytes.size(), 10 + header_len + 6 * 4);
  float v[6];
  std::memcpy(v, bytes.data() + 10 + header_len, sizeof v);
  EXPECT_EQ(v[4], 4.f);
  EXPECT_TRUE(std::isnan(v[5]));
  const std::string check =
      "/usr/bin/python3 -c \"import numpy, sys; a = numpy.load(sys.argv[1]); "
      "assert a.shape == (2, 3) and a[1, 1] == 4 and numpy.isnan(a[1, 2])\" " +
      dir + "/g.npy";
  EXPECT_EQ(std::system(check.c_str()), 0);
  g.values.pop_back();
  EXPECT_THROW(writeNpy(dir + "/bad.npy", g), std::invalid_argument);

  // Trajectories at 10 Hz from 100 Hz samples, plus the last sample; gaps as given.
  {
    VehicleRecord r, b;
    TrajectoryTable table(dir, { "alpha", "bravo" }, 0.1);
    for (int k = 0; k <= 205; ++k)
    {
      r.addOdometry(0.01 * k, 0.01 * k, 0.0, 0.0, 1.0);
      table.add(0, *r.last());
      if (k < 3)  // bravo: three samples, one table row for t = 0 and its last (0.02 s)
      {
        b.addOdometry(0.01 * k, 5.0, 0.0, 0.0, 0.0);
        table.add(1, *b.last());
      }
    }
    EXPECT_TRUE(fs::exists(dir + "/.trajectories.0.part"));
    table.write(dir + "/trajectories.csv");
  }
  EXPECT_FALSE(fs::exists(dir + "/.trajectories.0.part")) << "the spool files go with the table";
  std::ifstream in(dir + "/trajectories.csv");
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line))
    lines.push_back(line);
  ASSERT_EQ(lines.size(), 1u + 21u + 1u + 2u);  // header, alpha t = 0.0 .. 2.0 and 2.05, bravo 0 and 0.02
  EXPECT_EQ(lines[0], "vehicle,t,x,y,z,speed,distance");
  EXPECT_EQ(lines[1], "alpha,0.000,0.000,0.000,0.000,1.000,0.000");
  EXPECT_EQ(lines[4].substr(0, 12), "alpha,0.300,");
  EXPECT_EQ(lines[22], "alpha,2.050,2.050,0.000,0.000,1.000,2.050");
  EXPECT_EQ(lines[23], "bravo,0.000,5.000,0.000,0.000,0.000,0.000");
  EXPECT_EQ(lines[24], "bravo,0.020,5.000,0.000,0.000,0.000,0.000");
  {
    SpooledTable gaps(dir, "gaps", kGapsHeader, 2);
    gaps.add(1, gapRow("charlie", "bravo", { 2.0, 3.25, 0.0 }));
    gaps.add(0, gapRow("bravo", "alpha", { 1.0, 12.5, 0.25 }));
    EXPECT_EQ(gaps.rows(0), 1u);
    gaps.write(dir + "/gaps.csv");
  }
  EXPECT_EQ(readFile(dir + "/gaps.csv"),
            "follower,leader,t,gap,lateral\nbravo,alpha,1.000,12.500,0.250\ncharlie,bravo,2.000,3.250,0.000\n");
  EXPECT_THROW(SpooledTable(dir + "/no/such/folder", "gaps", kGapsHeader, 1), std::runtime_error);
  std::system(("rm -rf " + dir).c_str());
}

TEST(RunWatch, ProcessNamesMapToNodes)
{
  EXPECT_EQ(nodeOfProcess("sensors-4"), "/sensors");
  EXPECT_EQ(nodeOfProcess("m113/controller-10"), "/m113/controller");
  EXPECT_EQ(nodeOfProcess("dynamics_part-a-3"), "/dynamics_part-a");
  EXPECT_EQ(nodeOfProcess("no_counter"), "/no_counter");
  EXPECT_EQ(nodeOfProcess("/already"), "/already");
}

TEST(RunWatch, AWatchedNodeExitingFailsTheRunWithItsLastError)
{
  RunWatch w({ "/terrain", "/sensors" });
  w.noteError("/sensors", "lidar: ray budget exceeded", false, 3.0);
  EXPECT_FALSE(w.abort());  // an ERROR alone does not stop a run
  w.noteProcessDied("start_gate-21", 0, 0.0, 100.0);
  EXPECT_FALSE(w.abort()) << "a helper finishing its job is not a failure";
  w.noteProcessDied("sensors-4", -9, 20.5, 120.0);
  ASSERT_TRUE(w.abort());
  EXPECT_EQ(w.abort()->node, "/sensors");
  EXPECT_DOUBLE_EQ(w.abort()->sim_time, 20.5);
  EXPECT_NE(w.abort()->reason.find("killed by signal 9"), std::string::npos) << w.abort()->reason;
  EXPECT_NE(w.abort()->reason.find("lidar: ray budget exceeded"), std::string::npos) << w.abort()->reason;
  // Later deaths are the first one's echoes: the first is kept.
  w.noteProcessDied("terrain-2", 1, 21.0, 121.0);
  EXPECT_EQ(w.abort()->node, "/sensors");
}

TEST(RunWatch, ExitCodesFatalsAndPings)
{
  {
    RunWatch w({ "/terrain" });
    w.noteProcessDied("terrain-2", 0, 5.0, 0.0);  // a watched node may not end before the run, even cleanly
    ASSERT_TRUE(w.abort());
    EXPECT_NE(w.abort()->reason.find("exited with code 0"), std::string::npos);
    EXPECT_NE(w.abort()->reason.find("logged no error"), std::string::npos);
  }
  {
    RunWatch w({ "/terrain" });
    w.noteProcessDied("start_gate-9", 1, 0.0, 0.0);  // any non-zero exit, watched or not
    ASSERT_TRUE(w.abort());
    EXPECT_EQ(w.abort()->node, "/start_gate");
  }
  {
    // Exit code unknown (roslaunch's case): a helper gone while the clock has not started fails
    // the run after kStartGrace without a tick, not before ...
    RunWatch w({ "/terrain" });
    w.noteError("/start_gate", "timed out after 300 s waiting for /sensors", false, 0.0);
    w.noteProcessDied("start_gate-9", std::nullopt, 0.0, 50.0);
    w.noteTime(0.0, 50.0 + 0.9 * RunWatch::kStartGrace);
    EXPECT_FALSE(w.abort());
    w.noteTime(0.0, 50.0 + RunWatch::kStartGrace);
    ASSERT_TRUE(w.abort());
    EXPECT_EQ(w.abort()->node, "/start_gate");
    EXPECT_EQ(w.abort()->reason,
              "exited before the run started; its last error: timed out after 300 s waiting for /sensors");
  }
  {
    // ... and not at all when the clock starts within it (start_gate's normal exit), or when
    // it exits once the run is under way.
    RunWatch w({ "/terrain" });
    w.noteProcessDied("start_gate-9", std::nullopt, 0.0, 50.0);
    w.noteTime(0.01, 50.5);
    w.noteTime(0.0, 60.0);
    w.noteProcessDied("rviz-30", std::nullopt, 12.0, 70.0);
    w.noteTime(12.0, 80.0);
    EXPECT_FALSE(w.abort());
    w.noteProcessDied("terrain-2", std::nullopt, 13.0, 81.0);  // a watched node: at once
    ASSERT_TRUE(w.abort());
    EXPECT_EQ(w.abort()->reason, "exited before the run ended (it logged no error)");
  }
  {
    RunWatch w({ "/environment" });
    w.noteError("/rviz", "GL context lost", true, 1.0);
    EXPECT_FALSE(w.abort()) << "a FATAL of an unwatched node";
    w.noteError("/environment", "parameter ~start_utc: year 2200 out of range", true, 0.0);
    ASSERT_TRUE(w.abort());
    EXPECT_EQ(w.abort()->reason, "FATAL: parameter ~start_utc: year 2200 out of range");
  }
  {
    RunWatch w({ "/far/dynamics" });
    w.notePing("/far/dynamics", false, "not registered", 0.0);
    w.notePing("/far/dynamics", false, "not registered", 0.0);
    EXPECT_FALSE(w.abort()) << "never seen alive: still starting";
    w.notePing("/far/dynamics", true, "", 1.0);
    w.notePing("/far/dynamics", false, "connection refused", 2.0);
    EXPECT_FALSE(w.abort()) << "one failed ping may be a timeout";
    w.notePing("/far/dynamics", true, "", 2.5);
    w.notePing("/far/dynamics", false, "connection refused", 3.0);
    EXPECT_FALSE(w.abort()) << "a good ping resets the count";
    w.notePing("/far/dynamics", false, "connection refused", 3.5);
    ASSERT_TRUE(w.abort());
    EXPECT_NE(w.abort()->reason.find("stopped answering (connection refused)"), std::string::npos);
    EXPECT_DOUBLE_EQ(w.abort()->sim_time, 3.5);
  }
}

TEST(AnomalyMonitor, CountsOverspeedAirborneAndNonFiniteSamplesAndReportsEachKindOnce)
{
  AnomalyMonitor m;
  // tracer_x-like: governed 2 m/s, base_link 0.30 m above the ground at rest, wheels r 0.15 m.
  m.addVehicle("tracer_x", VehicleLimits{ 2.0, 0.30, 0.15 });
  EXPECT_THROW(m.addVehicle("bad", VehicleLimits{ 0.0, 0.3, 0.1 }), std::invalid_argument);
  EXPECT_THROW(m.addVehicle("bad", VehicleLimits{ 2.0, std::nan(""), 0.1 }), std::invalid_argument);
  const double ground = 10.0;
  // At rest, and driving at the governed speed, on the ground: nothing.
  EXPECT_EQ(m.sample("tracer_x", 0.0, 0, 0, ground + 0.30, 0.0, ground), "");
  EXPECT_EQ(m.sample("tracer_x", 1.0, 2, 0, ground + 0.30 + 0.149, 2.0 * kOverspeedFactor, ground), "")
      << "exactly 1.5 x, and just under one wheel radius up, are still plausible";
  // The CI scenario's old launch: 12.3 m/s, 4.8 m up. Both kinds, reported once.
  const std::string first = m.sample("tracer_x", 2.0, 4, 0, ground + 5.1, 12.3, ground);
  EXPECT_NE(first.find("12.30 m/s at 2.000 s, above 1.5 x its governed 2.00 m/s"), std::string::npos) << first;
  EXPECT_NE(first.find("base_link 4.80 m above its rest height at 2.000 s"), std::string::npos) << first;
  EXPECT_EQ(m.sample("tracer_x", 2.1, 4, 0, ground + 5.0, 12.0, ground), "") << "the second of a kind is only counted";
  EXPECT_EQ(m.counts("tracer_x").overspeed, 2u);
  EXPECT_EQ(m.counts("tracer_x").airborne, 2u);
  // Off the terrain there is no ground to judge height by.
  EXPECT_EQ(m.sample("tracer_x", 3.0, 900, 0, ground + 50.0, 1.0, std::nullopt), "");
  EXPECT_EQ(m.counts("tracer_x").airborne, 2u);
  const std::string nan = m.sample("tracer_x", 4.0, std::nan(""), 0, ground, 1.0, ground);
  EXPECT_NE(nan.find("non-finite state at 4.000 s"), std::string::npos) << nan;
  EXPECT_EQ(m.sample("tracer_x", 4.1, 0, 0, INFINITY, 1.0, ground), "");
  EXPECT_EQ(m.counts("tracer_x").non_finite, 2u);
  EXPECT_EQ(m.total(), 6u);
  EXPECT_EQ(m.sample("unknown", 0.0, 0, 0, 1e9, 1e9, 0.0), "") << "vehicles without limits are not judged";
}
