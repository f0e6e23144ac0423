// Magnetometer: the Earth's field in the body frame for known headings, declination and
// inclination (closed forms), noise, determinism, the IGRF dipole's closed forms, bad config.
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

/// Body orientation with yaw psi (rad, from east, counter-clockwise: REP 103 in ENU).
Eigen::Quaterniond yaw(double psi)
{
  return Eigen::Quaterniond(Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()));
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
  EXPECT_NEAR(enu.x(), h * std::sin(dec * kDeg), 1e-18);  // east
  EXPECT_NEAR(enu.y(), h * std::cos(dec * kDeg), 1e-18);  // north
  EXPECT_NEAR(enu.z(), -f * std::sin(inc * kDeg), 1e-18); // up: the field dips down in the north
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
  } cases[] = { { 0.0, { 0.0, h, -v } }, { 90.0, { h, 0.0, -v } }, { 180.0, { 0.0, -h, -v } },
                { 270.0, { -h, 0.0, -v } } };
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
  const Eigen::Quaterniond q =
      yaw((90.0 - dec) * kDeg) * Eigen::Quaterniond(Eigen::AngleAxisd(inc * kDeg, Eigen::Vector3d::UnitY()));
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

TEST(MagneticDipole, PolesAndEquatorHaveTheDipoleClosedForms)
{
  namespace d = igrf13_dipole;
  const Eigen::Vector3d g = Eigen::Vector3d(d::kG11, d::kH11, d::kG10) * 1e-9;
  const double b0 = g.norm();
  EXPECT_NEAR(b0, 29805.9e-9, 0.1e-9);  // sqrt(g10^2 + g11^2 + h11^2)
  const double r = 6371.2e3 + 5000.0;
  const double scale = std::pow(d::kReferenceRadius / r, 3);
  // At the boreal geomagnetic pole (along -g) the field points straight down with 2 B0.
  const Eigen::Vector3d pole = -g.normalized() * r;
  const Eigen::Vector3d bp = dipoleFieldEcef(pole);
  EXPECT_NEAR((bp - 2.0 * b0 * scale * g.normalized()).norm(), 0.0, 1e-15);
  // On the geomagnetic equator it is horizontal, B0, pointing to the boreal pole (along -g).
  const Eigen::Vector3d eq = g.normalized().cross(Eigen::Vector3d::UnitZ()).normalized() * r;
  const Eigen::Vector3d be = dipoleFieldEcef(eq);
  EXPECT_NEAR((be + b0 * scale * g.normalized()).norm(), 0.0, 1e-15);
  // The boreal pole's geocentric position from these coefficients: 80.59 N, 72.68 W.
  EXPECT_NEAR(std::asin(-g.normalized().z()) / kDeg, 80.59, 0.01);
  EXPECT_NEAR(std::atan2(-g.y(), -g.x()) / kDeg, -72.68, 0.01);
}

TEST(MagneticDipole, InclinationFollowsTanIEqualsTwoTanMagneticLatitude)
{
  // At geodetic (0, 0) the ENU up axis is the radial one, so the dipole law holds exactly:
  // tan I = 2 tan(lambda_m), sin(lambda_m) = -g_hat . r_hat, F = B0 (a/r)^3 sqrt(1 + 3 sin^2).
  const EarthField f = dipoleEarthField({ 0.0, 0.0, 0.0 });
  namespace d = igrf13_dipole;
  const Eigen::Vector3d gh = Eigen::Vector3d(d::kG11, d::kH11, d::kG10).normalized();
  const double lm = std::asin(-gh.x());
  EXPECT_NEAR(std::tan(f.inclination_deg * kDeg), 2.0 * std::tan(lm), 1e-9);
  const double b0 = Eigen::Vector3d(d::kG11, d::kH11, d::kG10).norm() * 1e-9;
  const double s = d::kReferenceRadius / 6378137.0;
  EXPECT_NEAR(f.intensity, b0 * s * s * s * std::sqrt(1.0 + 3.0 * std::sin(lm) * std::sin(lm)), 1e-15);
  // Near the boreal pole the field is nearly vertical (ENU up is the ellipsoid normal, which
  // differs from the radial direction by < 0.07 deg there).
  EXPECT_GT(dipoleEarthField({ 80.59, -72.68, 0.0 }).inclination_deg, 89.8);
  // Mid-northern latitudes: the documented default (50 uT, 60 deg) is in the dipole's range.
  const EarthField mid = dipoleEarthField({ 42.3, -83.2, 180.0 });
  EXPECT_GT(mid.inclination_deg, 55.0);
  EXPECT_LT(mid.inclination_deg, 75.0);
  EXPECT_GT(mid.intensity, 45e-6);
  EXPECT_LT(mid.intensity, 60e-6);
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
  EXPECT_THROW(m.measure(0.0, Eigen::Quaterniond(2.0, 0.0, 0.0, 0.0)), std::invalid_argument);
}
