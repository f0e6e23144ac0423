// Weather reaching the lidar: the extinction laws, the two-way transmission of returned
// signal, the detection range in fog, monotonic loss of range with thickening fog, and false
// near-range returns from falling snow and rain at the rate the model states.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/scene.hpp"
#include "avsp_sensors/weather.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;

namespace
{
constexpr double kDeg = 3.14159265358979323846 / 180.0;

Scene flatGround(double half, double cell)
{
  const auto n = static_cast<std::size_t>(2 * half / cell) + 1;
  return Scene(HeightField(-half, -half, cell, cell, n, n, std::vector<float>(n * n, 0.f)));
}

Primitive wallAt(double x, float reflectivity)
{
  Primitive p;
  p.shape = Shape::kBox;
  p.centre = Vector3d(x + 0.5, 0.0, 5.0);
  p.half_extents = Vector3d(0.5, 20.0, 5.0);
  p.reflectivity = reflectivity;
  return p;
}

/// One horizontal pulse straight ahead: ideal optics, no noise.
LidarConfig onePulse()
{
  LidarConfig c;
  c.name = "one pulse";
  c.channels = { { 0.0, 0.0, 0.0 } };
  c.columns = 1;
  c.sub_rays = 1;
  c.range_noise = 0.0;
  c.max_range = 200.0;
  c.reference_range = 100.0;
  c.reference_reflectivity = 0.8;
  return c;
}

LidarScanRequest from(const Vector3d& p, const Weather& w)
{
  LidarScanRequest r;
  r.motion.pose.translation() = p;
  r.weather = w;
  return r;
}
}  // namespace

TEST(Weather, ExtinctionLaws)
{
  // Koschmieder in fog (Kim's q = 0 below 500 m): 3.912 / V at any wavelength.
  EXPECT_DOUBLE_EQ(fogExtinction(200.0, 905e-9), 3.912 / 200.0);
  EXPECT_DOUBLE_EQ(fogExtinction(200.0, 1550e-9), 3.912 / 200.0);
  // Haze at 2 km: q = 0.16 * 2 + 0.34 = 0.66; at 20 km q = 1.3; at 550 nm the factor is 1.
  EXPECT_NEAR(fogExtinction(2000.0, 905e-9), 3.912 / 2000.0 * std::pow(905.0 / 550.0, -0.66), 1e-15);
  EXPECT_NEAR(fogExtinction(20000.0, 905e-9), 3.912 / 20000.0 * std::pow(905.0 / 550.0, -1.3), 1e-15);
  EXPECT_DOUBLE_EQ(fogExtinction(20000.0, 550e-9), 3.912 / 20000.0);
  EXPECT_EQ(fogExtinction(INFINITY, 905e-9), 0.0);
  // Rain, Carbonneau: 1.076 R^0.67 dB/km; 10 mm/h = 5.03 dB/km = 1.16e-3 / m.
  EXPECT_NEAR(rainExtinction(10.0), 1.076 * std::pow(10.0, 0.67) / (10.0 * std::log10(std::exp(1.0))) / 1000.0, 1e-15);
  EXPECT_NEAR(rainExtinction(10.0), 1.158e-3, 1e-6);
  // Snow at 905 nm: dry a = 5.42e-5 * 905 + 5.4958776 = 5.5449, b = 1.38.
  const double a_dry = 5.42e-5 * 905.0 + 5.4958776, a_wet = 1.023e-4 * 905.0 + 3.7855466;
  EXPECT_NEAR(snowExtinction(2.0, 905e-9, false), dbPerKmToPerMetre(a_dry * std::pow(2.0, 1.38)), 1e-15);
  EXPECT_NEAR(snowExtinction(2.0, 905e-9, true), dbPerKmToPerMetre(a_wet * std::pow(2.0, 0.72)), 1e-15);
  // Sums and the two-way transmission.
  Weather w;
  w.fog_visibility = 400.0;
  w.rain_rate = 4.0;
  w.snow_rate = 1.0;
  EXPECT_DOUBLE_EQ(extinction(w, 905e-9),
                   fogExtinction(400.0, 905e-9) + rainExtinction(4.0) + snowExtinction(1.0, 905e-9, false));
  EXPECT_DOUBLE_EQ(twoWayTransmission(0.01, 50.0), std::exp(-1.0));
  EXPECT_DOUBLE_EQ(clutterRate(w, 905e-9, 1.0), 0.5 * (rainExtinction(4.0) + snowExtinction(1.0, 905e-9, false)));
}

TEST(Weather, BadWeatherThrowsNamingTheField)
{
  Weather w;
  w.fog_visibility = 0.0;
  try
  {
    validateWeather(w);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("fog_visibility"), std::string::npos);
  }
  w = Weather();
  w.snow_rate = std::nan("");
  try
  {
    validateWeather(w);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("snow_rate"), std::string::npos);
  }
  w = Weather();
  w.rain_rate = INFINITY;
  EXPECT_THROW(validateWeather(w), std::invalid_argument);
}

TEST(Weather, ReturnedSignalFractionIsTheTwoWayTransmission)
{
  // A wall 40 m away at normal incidence: in fog of visibility V the returned signal is
  // exp(-2 (3.912 / V) R) of the clear-air signal.
  Scene scene = flatGround(100.0, 1.0);
  scene.setStaticPrimitives({ wallAt(40.0, 0.8f) });
  LidarConfig c = onePulse();
  c.reference_range = 1e4;  // detect everything: this test is about the signal
  const Lidar lidar(c, 1);
  Weather clear, fog;
  fog.fog_visibility = 300.0;
  const LidarScan a = lidar.scan(scene, from(Vector3d(0, 0, 2), clear));
  const LidarScan b = lidar.scan(scene, from(Vector3d(0, 0, 2), fog));
  ASSERT_EQ(a.points.size(), 1u);
  ASSERT_EQ(b.points.size(), 1u);
  EXPECT_NEAR(a.points[0].intensity, 80.0f, 1e-4);
  const double expect = std::exp(-2.0 * 3.912 / 300.0 * 40.0);  // 0.352
  EXPECT_NEAR(b.points[0].intensity / a.points[0].intensity, expect, 1e-6);
  EXPECT_EQ(a.points[0].x, b.points[0].x);  // the range is unchanged, only the signal
}

TEST(Weather, FogDetectionRangeMatchesTheFormula)
{
  // Detected while rho T^2(R) / R^2 >= rho_ref / R_ref^2: with rho = rho_ref = 0.8,
  // R_ref = 100 m and V = 100 m, R* solves exp(-2 alpha R) = (R / 100)^2.
  const double alpha = 3.912 / 100.0;
  double lo = 1.0, hi = 100.0;
  for (int k = 0; k < 100; ++k)
  {
    const double mid = 0.5 * (lo + hi);
    (std::exp(-2 * alpha * mid) >= (mid / 100.0) * (mid / 100.0) ? lo : hi) = mid;
  }
  const double r_star = lo;  // 30.4 m
  EXPECT_GT(r_star, 25.0);
  EXPECT_LT(r_star, 35.0);
  Weather fog;
  fog.fog_visibility = 100.0;
  for (double f : { 0.97, 1.03 })
  {
    Scene scene = flatGround(150.0, 1.0);
    scene.setStaticPrimitives({ wallAt(f * r_star, 0.8f) });
    const LidarScan s = Lidar(onePulse(), 1).scan(scene, from(Vector3d(0, 0, 2), fog));
    EXPECT_EQ(s.points.size(), f < 1 ? 1u : 0u) << "wall at " << f * r_star << " m, R* = " << r_star;
    // In clear air the same wall is detected either way (out to 100 m).
    const LidarScan clear = Lidar(onePulse(), 1).scan(scene, from(Vector3d(0, 0, 2), Weather()));
    EXPECT_EQ(clear.points.size(), 1u);
  }
}

TEST(Weather, ThickerFogMonotonicallyShortensTheMaxReturnRange)
{
  // Ground all round and walls at 30, 60 and 90 m in three directions.
  Scene scene = flatGround(150.0, 0.5);
  std::vector<Primitive> walls;
  for (int k = 0; k < 3; ++k)
  {
    const double r = 30.0 * (k + 1), az = 2.0 * k;
    Primitive p = wallAt(0.0, 0.5f);
    p.centre = Vector3d(r * std::cos(az), r * std::sin(az), 5.0);
    p.rotation = Eigen::AngleAxisd(az, Vector3d::UnitZ()).toRotationMatrix();
    p.id = static_cast<std::uint32_t>(k);
    walls.push_back(p);
  }
  scene.setStaticPrimitives(walls);
  LidarConfig c = lidarPreset("HDL-64E");
  c.columns = 360;  // a coarse sweep keeps the test quick; noise and divergence stay on
  const Lidar lidar(c, 5);
  double previous_max = INFINITY;
  std::size_t previous_count = SIZE_MAX;
  std::vector<double> maxima;
  for (double v : { double(INFINITY), 5000.0, 1000.0, 500.0, 200.0, 100.0, 50.0, 20.0 })
  {
    Weather w;
    w.fog_visibility = v;
    const LidarScan s = lidar.scan(scene, from(Vector3d(0, 0, 2.0), w));
    double max_range = 0.0;
    for (const LidarPoint& p : s.points)
      max_range = std::max(max_range, std::sqrt(double(p.x) * p.x + double(p.y) * p.y + (p.z - 2.0) * (p.z - 2.0)));
    EXPECT_LE(max_range, previous_max) << "V = " << v;
    EXPECT_LE(s.points.size(), previous_count) << "V = " << v;
    previous_max = max_range;
    previous_count = s.points.size();
    maxima.push_back(max_range);
  }
  EXPECT_GT(maxima.front(), 89.0);  // the far wall, in clear air
  EXPECT_LT(maxima.back(), 0.5 * maxima.front());
  EXPECT_LT(maxima[6], maxima[3]);  // 50 m visibility sees less far than 500 m
}

TEST(Weather, SnowMakesNearRangeFalseReturnsAtTheStatedRate)
{
  // Channels pointing up into open sky: every return is a falling flake. The model: flakes are
  // met along the beam as a Poisson process of rate kappa = alpha_snow / 2 from min_range on, and
  // echo when nearer than clutter_max_range: P(return) = 1 - exp(-kappa (R_c - R_min)).
  const Scene scene = flatGround(50.0, 1.0);
  LidarConfig c;
  c.name = "sky";
  for (int k = 0; k < 8; ++k)
    c.channels.push_back({ (10.0 + 5.0 * k) * kDeg, 0.0, 0.0 });
  c.columns = 4000;
  c.sub_rays = 1;
  c.range_noise = 0.0;
  c.min_range = 0.5;
  c.clutter_max_range = 10.0;
  const Lidar lidar(c, 21);
  for (const bool rain : { false, true })
  {
    Weather w;
    (rain ? w.rain_rate : w.snow_rate) = rain ? 50.0 : 8.0;
    const LidarScan s = lidar.scan(scene, from(Vector3d(0, 0, 2.0), w));
    const double kappa = 0.5 * (rain ? rainExtinction(50.0) : snowExtinction(8.0, c.wavelength, false));
    const double L = c.clutter_max_range - c.min_range;
    const double p = 1.0 - std::exp(-kappa * L);
    const double n = static_cast<double>(s.pulses);
    EXPECT_EQ(s.clutter, s.points.size());
    EXPECT_NEAR(s.points.size() / n, p, 5.0 * std::sqrt(p * (1 - p) / n)) << (rain ? "rain" : "snow") << " p = " << p;
    // Ranges: a truncated exponential on [R_min, R_c].
    double sum = 0.0;
    for (const LidarPoint& q : s.points)
    {
      const double r = std::sqrt(double(q.x) * q.x + double(q.y) * q.y + (q.z - 2.0) * (q.z - 2.0));
      ASSERT_GE(r, c.min_range - 1e-4);
      ASSERT_LE(r, c.clutter_max_range + 1e-4);
      sum += r - c.min_range;
    }
    const double mean = sum / s.points.size();
    const double expect_mean = 1.0 / kappa - L * std::exp(-kappa * L) / (1.0 - std::exp(-kappa * L));
    EXPECT_NEAR(mean, expect_mean, 5.0 * (L / std::sqrt(12.0)) / std::sqrt(double(s.points.size())));
    if (!rain)
    {
      EXPECT_GT(p, 0.1);  // 8 mm/h of dry snow: a false return on more than one pulse in ten
    }
  }
}

TEST(Weather, LastReturnSeesThroughSnowStrongestDoesNot)
{
  Scene scene = flatGround(100.0, 1.0);
  scene.setStaticPrimitives({ wallAt(20.0, 0.5f) });
  LidarConfig c;
  c.name = "ahead";
  c.channels = { { 0.0, 0.0, 0.0 } };
  c.columns = 2000;
  c.start_azimuth = 0.0;
  c.sub_rays = 1;
  c.range_noise = 0.0;
  Weather w;
  w.snow_rate = 8.0;
  LidarScanRequest req = from(Vector3d(0, 0, 2.0), w);
  c.return_mode = ReturnMode::kStrongest;
  const LidarScan strongest = Lidar(c, 4).scan(scene, req);
  c.return_mode = ReturnMode::kLast;
  const LidarScan last = Lidar(c, 4).scan(scene, req);
  auto nearCount = [](const LidarScan& s) {
    std::size_t n = 0;
    for (const LidarPoint& p : s.points)
      n += std::hypot(p.x, p.y) < 15.0;
    return n;
  };
  EXPECT_GT(strongest.clutter, 20u);
  EXPECT_EQ(nearCount(strongest), strongest.clutter);
  // Where the wall is in view, the last return is the wall; flakes show only against the sky.
  for (const LidarPoint& p : last.points)
    if (std::abs(std::atan2(p.y, p.x)) < 0.5)
    {
      ASSERT_NEAR(p.x, 20.0, 1e-3);
    }
}
