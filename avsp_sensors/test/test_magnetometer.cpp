// Magnetometer: the Earth's field in the body frame for known headings, declination and
// inclination (closed forms), noise, determinism, bad config; on the World Magnetic Model, NOAA's
// test values through the sensor and the field at the sensor's position.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "avsp_sensors/magnetometer.hpp"

using namespace avsp::sensors;

namespace
{
constexpr double kDeg = M_PI / 180.0;

MagnetometerConfig noiseFree(double intensity, double inclination_deg, double declination_deg)
{
  MagnetometerConfig c;
  c.noise = 0.0;
  c.field.intensity = intensity;
  c.field.inclination_deg = inclination_deg;
  c.field.declination_deg = declination_deg;
  return c;
}

/// Body pose at the map origin with yaw psi (rad, from east, counter-clockwise: REP 103 in ENU).
Eigen::Isometry3d yaw(double psi)
{
  return Eigen::Isometry3d(Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()));
}

std::string thrownMessage(const MagnetometerConfig& c)
{
  try
  {
    Magnetometer m(c, 1);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Magnetometer, FieldComponentsFromIntensityInclinationDeclination)
{
  const double f = 50e-6, inc = 60.0, dec = 10.0;
  const Eigen::Vector3d enu = earthFieldEnu({ f, inc, dec });
  const double h = f * std::cos(inc * kDeg);
  EXPECT_NEAR(enu.x(), h * std::sin(dec * kDeg), 1e-18);   // east
  EXPECT_NEAR(enu.y(), h * std::cos(dec * kDeg), 1e-18);   // north
  EXPECT_NEAR(enu.z(), -f * std::sin(inc * kDeg), 1e-18);  // up: the field dips down in the north
  EXPECT_NEAR(enu.norm(), f, 1e-18);
}

TEST(Magnetometer, CardinalHeadingsWithoutDeclination)
{
  const double f = 50e-6, inc = 60.0;
  const double h = f * std::cos(inc * kDeg), v = f * std::sin(inc * kDeg);
  Magnetometer mag(noiseFree(f, inc, 0.0), 1);
  // Facing east (yaw 0): north is to the left (+y). North (90): ahead. West: right. South: behind.
  const struct
  {
    double yaw_deg;
    Eigen::Vector3d body;
  } cases[] = {
    { 0.0, { 0.0, h, -v } }, { 90.0, { h, 0.0, -v } }, { 180.0, { 0.0, -h, -v } }, { 270.0, { -h, 0.0, -v } }
  };
  double t = 0.0;
  for (const auto& c : cases)
  {
    const MagSample s = mag.measure(t += 0.1, yaw(c.yaw_deg * kDeg));
    EXPECT_NEAR((s.field - c.body).norm(), 0.0, 1e-18) << "yaw " << c.yaw_deg;
  }
}

TEST(Magnetometer, DeclinationShiftsTheCompassHeading)
{
  // With declination D (east), magnetic north lies at azimuth 90 - D deg from east; a body at yaw
  // psi sees the horizontal field at angle (90 - D - psi) from its x axis.
  const double f = 48e-6, inc = 65.0, dec = 12.5;
  const double h = f * std::cos(inc * kDeg);
  Magnetometer mag(noiseFree(f, inc, dec), 1);
  double t = 0.0;
  for (double psi_deg = -180.0; psi_deg < 180.0; psi_deg += 22.5)
  {
    const MagSample s = mag.measure(t += 0.1, yaw(psi_deg * kDeg));
    const double angle = (90.0 - dec - psi_deg) * kDeg;
    EXPECT_NEAR(s.field.x(), h * std::cos(angle), 1e-18) << psi_deg;
    EXPECT_NEAR(s.field.y(), h * std::sin(angle), 1e-18) << psi_deg;
    // The compass heading (clockwise from magnetic north) a driver would compute.
    const double true_heading = 90.0 - psi_deg;  // clockwise from true north
    const double compass = std::atan2(s.field.y(), s.field.x()) / kDeg;
    EXPECT_NEAR(std::remainder(compass - (true_heading - dec), 360.0), 0.0, 1e-9) << psi_deg;
  }
  // Facing true north the field leans west of ahead by D: y = -H sin D.
  const MagSample north = mag.measure(t += 0.1, yaw(90.0 * kDeg));
  EXPECT_NEAR(north.field.y(), -h * std::sin(dec * kDeg), 1e-18);
}

TEST(Magnetometer, NoseDownByTheInclinationAlongMagneticNorthReadsTheWholeField)
{
  const double f = 52e-6, inc = 67.0, dec = -7.0;
  Magnetometer mag(noiseFree(f, inc, dec), 1);
  // Yaw to magnetic north, then pitch the nose down (positive rotation about body y) by I.
  const Eigen::Isometry3d q =
      yaw((90.0 - dec) * kDeg) * Eigen::Isometry3d(Eigen::AngleAxisd(inc * kDeg, Eigen::Vector3d::UnitY()));
  const MagSample s = mag.measure(0.0, q);
  EXPECT_NEAR((s.field - Eigen::Vector3d(f, 0.0, 0.0)).norm(), 0.0, 1e-17);
  // Level, the vertical part is -F sin I on z and atan2(-z, |horizontal|) is the inclination.
  const MagSample level = mag.measure(0.1, yaw(0.3));
  EXPECT_NEAR(std::atan2(-level.field.z(), level.field.head<2>().norm()) / kDeg, inc, 1e-9);
}

TEST(Magnetometer, MountOffsetAndNoise)
{
  MagnetometerConfig c = noiseFree(50e-6, 60.0, 0.0);
  c.offset = Eigen::Vector3d(1e-6, -2e-6, 0.5e-6);
  c.mount.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();  // mounted backwards
  Magnetometer mag(c, 1);
  const double h = 50e-6 * std::cos(60 * kDeg), v = 50e-6 * std::sin(60 * kDeg);
  const MagSample s = mag.measure(0.0, yaw(M_PI / 2));  // body faces north, the sensor south
  EXPECT_NEAR((s.field - (Eigen::Vector3d(-h, 0.0, -v) + c.offset)).norm(), 0.0, 1e-18);

  MagnetometerConfig n = noiseFree(50e-6, 60.0, 0.0);
  n.noise = 0.2e-6;
  Magnetometer noisy(n, 11);
  const Eigen::Vector3d truth(0.0, h, -v);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  const int count = 20000;
  MagSample last;
  for (int k = 0; k < count; ++k)
  {
    last = noisy.measure(0.01 * k, yaw(0.0));
    sum += last.field - truth;
    sum2 += (last.field - truth).cwiseAbs2();
  }
  for (int a = 0; a < 3; ++a)
  {
    EXPECT_NEAR(sum[a] / count, 0.0, 4.0 * 0.2e-6 / std::sqrt(count));
    EXPECT_NEAR(std::sqrt(sum2[a] / count) / 0.2e-6, 1.0, 0.03);
  }
  EXPECT_NEAR(last.covariance(1, 1), 0.04e-12, 1e-24);
}

TEST(Magnetometer, SameSeedSameSamples)
{
  MagnetometerConfig c;
  Magnetometer a(c, 4), b(c, 4);
  for (int k = 0; k < 20; ++k)
    EXPECT_EQ(a.measure(0.1 * k, yaw(0.2 * k)).field, b.measure(0.1 * k, yaw(0.2 * k)).field);
}

TEST(Magnetometer, BadConfigNamesTheField)
{
  MagnetometerConfig c;
  c.rate = 0.0;
  EXPECT_NE(thrownMessage(c).find("rate"), std::string::npos);
  c = MagnetometerConfig();
  c.field.inclination_deg = 95.0;
  EXPECT_NE(thrownMessage(c).find("field.inclination_deg"), std::string::npos);
  c = MagnetometerConfig();
  c.field.declination_deg = std::nan("");
  EXPECT_NE(thrownMessage(c).find("field.declination_deg"), std::string::npos);
  c = MagnetometerConfig();
  c.noise = -1.0;
  EXPECT_NE(thrownMessage(c).find("noise"), std::string::npos);
  c = MagnetometerConfig();
  c.field.intensity = -1e-6;
  EXPECT_NE(thrownMessage(c).find("field.intensity"), std::string::npos);
  Magnetometer m(MagnetometerConfig(), 1);
  Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
  scaled.linear() *= 2.0;
  EXPECT_THROW(m.measure(0.0, scaled), std::invalid_argument);
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation().x() = std::nan("");
  EXPECT_THROW(m.measure(0.1, far), std::invalid_argument);
}

TEST(Magnetometer, FieldElementsRoundTrip)
{
  const EarthField f = earthFieldFromEnu(earthFieldEnu({ 51e-6, 65.9, -7.7 }));
  EXPECT_NEAR(f.intensity, 51e-6, 1e-18);
  EXPECT_NEAR(f.inclination_deg, 65.9, 1e-12);
  EXPECT_NEAR(f.declination_deg, -7.7, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// On the World Magnetic Model 2025 (data/magnetic/wmm2025.wmm).
namespace
{
const std::string kWmm2025 = std::string(AVSP_SENSORS_DATA_DIR) + "/magnetic/wmm2025.wmm";
}

TEST(MagnetometerOnWmm, ReadsNoaasTestValueAndGivesTheTrueHeading)
{
  // NOAA NCEI, WMM2025_TestValues.txt (WMM2025COF.zip), row 4: 2025.5, 6 km, 36 S, 137 W:
  // D 20.28 deg, I -52.11 deg, X 23781.930678, Y 8786.698927, Z -32577.518648 nT.
  const double x = 23781.930678e-9, y = 8786.698927e-9, z = -32577.518648e-9, d = 20.28;
  MagnetometerConfig c = noiseFree(50e-6, 60.0, 0.0);  // the fixed field is not used with a model
  c.model.emplace(GeomagneticModel(kWmm2025), EnuFrame({ -36.0, -137.0, 6000.0 }), 2025.5);
  Magnetometer mag(c, 1);
  // Level, facing true north (yaw 90 deg): x forward = north, y left = west, z up.
  const MagSample north = mag.measure(0.0, yaw(90.0 * kDeg));
  EXPECT_NEAR(north.field.x(), x, 0.01e-9);
  EXPECT_NEAR(north.field.y(), -y, 0.01e-9);
  EXPECT_NEAR(north.field.z(), -z, 0.01e-9);
  // A compass heading (clockwise from magnetic north) plus the declination is the true heading,
  // within 0.01 deg (NOAA prints D to 0.01 deg).
  double t = 0.0;
  for (double psi_deg = -180.0; psi_deg < 180.0; psi_deg += 30.0)
  {
    const MagSample s = mag.measure(t += 0.1, yaw(psi_deg * kDeg));
    const double compass = std::atan2(s.field.y(), s.field.x()) / kDeg;  // as DeclinationShifts... above
    const double true_heading = 90.0 - psi_deg;
    EXPECT_NEAR(std::remainder(compass + d - true_heading, 360.0), 0.0, 0.01) << psi_deg;
  }
}

TEST(MagnetometerOnWmm, ReadsTheFieldAtTheSensorsPosition)
{
  MagnetometerConfig c = noiseFree(50e-6, 60.0, 0.0);
  c.mount.translation() = Eigen::Vector3d(0.5, 0.0, 1.2);
  c.mount.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  c.model.emplace(GeomagneticModel(kWmm2025), EnuFrame({ 39.7425, -105.1786, 1829.0 }), 2025.0 + 287.0 / 365.0);
  Magnetometer mag(c, 1);
  Eigen::Isometry3d body(Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitZ()));
  body.translation() = Eigen::Vector3d(20e3, -35e3, 150.0);  // far enough for the field to differ
  const MagSample s = mag.measure(0.0, body);
  const Eigen::Isometry3d sensor = body * c.mount;
  const Eigen::Vector3d expected = sensor.linear().transpose() * c.model->at(sensor.translation());
  EXPECT_LT((s.field - expected).norm(), 1e-15);
  const Eigen::Vector3d at_origin = sensor.linear().transpose() * c.model->at(Eigen::Vector3d::Zero());
  EXPECT_GT((s.field - at_origin).norm(), 50e-9);
  // The default site on 2025-10-15: D 7.67 deg east, the compass error the model removes (the
  // MagneticField tool of GeographicLib on these files: D 7.66796, I 65.86412, F 51056.148 nT).
  const EarthField site = earthFieldFromEnu(c.model->at(Eigen::Vector3d::Zero()));
  EXPECT_NEAR(site.declination_deg, 7.66796, 1e-4);
  EXPECT_NEAR(site.inclination_deg, 65.86412, 1e-4);
  EXPECT_NEAR(site.intensity, 51056.148e-9, 0.01e-9);
}
