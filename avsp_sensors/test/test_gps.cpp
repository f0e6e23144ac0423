// GPS model: exact geodesy of the fix, white-noise and Gauss-Markov bias statistics, rate,
// determinism, covariance, bad configuration. (Published geodesy reference points:
// test_geodetic.cpp, "GeodeticPublished".)
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/gps.hpp"

using namespace avsp::sensors;

namespace
{
const Geodetic kOrigin{ 55.0, 5.0, 200.0 };  // EPSG GN 7-2's topocentric origin

GpsConfig noiseFree()
{
  GpsConfig c;
  c.horizontal_noise = c.vertical_noise = 0.0;
  c.horizontal_bias_sigma = c.vertical_bias_sigma = 0.0;
  return c;
}

std::string thrownMessage(const GpsConfig& c)
{
  try
  {
    Gps gps(c, EnuFrame(kOrigin), 1);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Gps, NoiseFreeFixIsTheExactGeodeticPosition)
{
  const EnuFrame frame(kOrigin);
  Gps gps(noiseFree(), frame, 7);
  double t = 0.0;
  for (const Eigen::Vector3d& p : { Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(-189013.869, -128642.040, -4220.171),
                                    Eigen::Vector3d(250.0, -120.0, 3.5) })
  {
    const GpsFix fix = gps.measure(t, p);
    t += 0.1;
    EXPECT_LT((frame.toEnu(fix.position) - p).norm(), 1e-6);
    EXPECT_TRUE(fix.covariance.isZero());
  }
  // The published EPSG point (test_geodetic) through the GPS.
  const GpsFix fix = gps.measure(t, { -189013.869, -128642.040, -4220.171 });
  EXPECT_NEAR(fix.position.latitude_deg, 53.0 + 48.0 / 60 + 33.820 / 3600, 1e-8);
  EXPECT_NEAR(fix.position.longitude_deg, 2.0 + 7.0 / 60 + 46.380 / 3600, 1.5e-8);
  EXPECT_NEAR(fix.position.altitude, 73.0, 1e-3);
}

TEST(Gps, WhiteNoiseHasTheConfiguredMeanAndSpread)
{
  GpsConfig c = noiseFree();
  c.horizontal_noise = 0.7;
  c.vertical_noise = 1.2;
  const EnuFrame frame(kOrigin);
  Gps gps(c, frame, 42);
  const int n = 20000;
  const Eigen::Vector3d p(120.0, 80.0, 10.0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k)
  {
    // The error as seen through the geodesy: reported fix back to ENU minus the truth.
    const Eigen::Vector3d e = frame.toEnu(gps.measure(0.1 * k, p).position) - p;
    sum += e;
    sum2 += e.cwiseAbs2();
  }
  const Eigen::Vector3d mean = sum / n;
  const Eigen::Vector3d sigma(0.7, 0.7, 1.2);
  for (int a = 0; a < 3; ++a)
  {
    const double sd = std::sqrt(sum2[a] / n - mean[a] * mean[a]);
    // Mean within 4 standard errors (sigma / sqrt(n)); spread within 3 % (6 standard errors of
    // a standard deviation, sigma / sqrt(2 n)).
    EXPECT_NEAR(mean[a], 0.0, 4.0 * sigma[a] / std::sqrt(n)) << "axis " << a;
    EXPECT_NEAR(sd / sigma[a], 1.0, 0.03) << "axis " << a;
  }
}

TEST(Gps, BiasIsFirstOrderGaussMarkov)
{
  GpsConfig c = noiseFree();
  c.rate = 1.0;
  c.horizontal_bias_sigma = 2.0;
  c.vertical_bias_sigma = 3.0;
  c.bias_time_constant = 10.0;
  Gps gps(c, EnuFrame(kOrigin), 3);
  const int n = 100000;
  std::vector<double> east(n), up(n);
  for (int k = 0; k < n; ++k)
  {
    const GpsFix fix = gps.measure(static_cast<double>(k), Eigen::Vector3d::Zero());
    east[k] = fix.error.x();
    up[k] = fix.error.z();
  }
  const auto stats = [&](const std::vector<double>& x, int lag) {
    double m = 0.0;
    for (double v : x)
      m += v;
    m /= x.size();
    double var = 0.0, cov = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k)
      var += (x[k] - m) * (x[k] - m);
    for (std::size_t k = 0; k + lag < x.size(); ++k)
      cov += (x[k] - m) * (x[k + lag] - m);
    var /= x.size();
    cov /= (x.size() - lag);
    return std::make_pair(std::sqrt(var), cov / var);
  };
  // Stationary sigma: an AR(1) series with phi = e^(-1/10) has ~n (1 - phi^2) / (1 + phi^2)
  // effective samples (~10,000), so its sample sigma has a standard error of ~0.7 %: 3 % is > 4 se.
  EXPECT_NEAR(stats(east, 0).first / 2.0, 1.0, 0.03);
  EXPECT_NEAR(stats(up, 0).first / 3.0, 1.0, 0.03);
  // Autocorrelation e^(-lag / tau) at lags tau and 2 tau (standard error ~0.01).
  EXPECT_NEAR(stats(east, 10).second, std::exp(-1.0), 0.04);
  EXPECT_NEAR(stats(east, 20).second, std::exp(-2.0), 0.04);
  EXPECT_NEAR(stats(up, 10).second, std::exp(-1.0), 0.04);
  EXPECT_NEAR(stats(east, 1).second, std::exp(-0.1), 0.02);
}

TEST(Gps, CovarianceIsTheStationaryErrorVariance)
{
  Gps gps(GpsConfig(), EnuFrame(kOrigin), 1);
  const GpsFix fix = gps.measure(0.0, Eigen::Vector3d::Zero());
  EXPECT_NEAR(fix.covariance(0, 0), 2.0 * 2.0 + 0.7 * 0.7, 1e-12);
  EXPECT_NEAR(fix.covariance(1, 1), 2.0 * 2.0 + 0.7 * 0.7, 1e-12);
  EXPECT_NEAR(fix.covariance(2, 2), 3.5 * 3.5 + 1.0 * 1.0, 1e-12);
  EXPECT_EQ(fix.covariance(0, 1), 0.0);
  // Defaults: 2.5 m CEP horizontally, i.e. sigma = 2.5 / 1.1774 per axis.
  EXPECT_NEAR(std::sqrt(fix.covariance(0, 0)) * 1.1774, 2.5, 0.01);
}

TEST(Gps, FixesComeAtTheConfiguredRate)
{
  GpsConfig c;
  c.rate = 10.0;
  Gps gps(c, EnuFrame(kOrigin), 1);
  std::vector<double> times;
  for (int k = 0; k <= 1000; ++k)  // polled at 1 kHz for 1 s
  {
    const double t = 0.001 * k;
    if (gps.due(t))
    {
      gps.measure(t, Eigen::Vector3d::Zero());
      times.push_back(t);
    }
  }
  ASSERT_EQ(times.size(), 11u);  // 0, 0.1, ..., 1.0
  for (std::size_t k = 0; k < times.size(); ++k)
    EXPECT_NEAR(times[k], 0.1 * k, 1e-9);
}

TEST(Gps, SameSeedSameFixesOtherSeedOthers)
{
  const EnuFrame frame(kOrigin);
  Gps a(GpsConfig(), frame, 99), b(GpsConfig(), frame, 99), c(GpsConfig(), frame, 100);
  bool differs = false;
  for (int k = 0; k < 50; ++k)
  {
    const Eigen::Vector3d p(k, 2.0 * k, 0.5);
    const GpsFix fa = a.measure(0.1 * k, p), fb = b.measure(0.1 * k, p), fc = c.measure(0.1 * k, p);
    EXPECT_EQ(fa.position.latitude_deg, fb.position.latitude_deg);
    EXPECT_EQ(fa.position.longitude_deg, fb.position.longitude_deg);
    EXPECT_EQ(fa.position.altitude, fb.position.altitude);
    differs = differs || fa.position.latitude_deg != fc.position.latitude_deg;
  }
  EXPECT_TRUE(differs);
}

TEST(Gps, BadConfigNamesTheField)
{
  GpsConfig c;
  c.rate = 0.0;
  EXPECT_NE(thrownMessage(c).find("rate"), std::string::npos);
  c = GpsConfig();
  c.horizontal_noise = -1.0;
  EXPECT_NE(thrownMessage(c).find("horizontal_noise"), std::string::npos);
  c = GpsConfig();
  c.vertical_bias_sigma = std::nan("");
  EXPECT_NE(thrownMessage(c).find("vertical_bias_sigma"), std::string::npos);
  c = GpsConfig();
  c.bias_time_constant = 0.0;
  EXPECT_NE(thrownMessage(c).find("bias_time_constant"), std::string::npos);
  c.bias_time_constant = std::numeric_limits<double>::infinity();  // a constant bias is allowed
  EXPECT_EQ(thrownMessage(c), "");
}

TEST(Gps, BadInputIsRejected)
{
  Gps gps(GpsConfig(), EnuFrame(kOrigin), 1);
  gps.measure(1.0, Eigen::Vector3d::Zero());
  EXPECT_THROW(gps.measure(0.5, Eigen::Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(gps.measure(2.0, Eigen::Vector3d(std::nan(""), 0, 0)), std::invalid_argument);
  EXPECT_THROW(Gps(GpsConfig(), EnuFrame({ 95.0, 0.0, 0.0 }), 1), GeodeticError);
}
