#include <cmath>

#include <gtest/gtest.h>

#include "avsp_sensors/geodetic.hpp"

using avsp::sensors::EnuFrame;
using avsp::sensors::Geodetic;
using avsp::sensors::GeodeticError;

namespace
{
// WGS 84's defining parameters (NIMA TR8350.2, "Department of Defense World Geodetic System
// 1984", table 3.1), typed in here so that the closed forms below do not use the library's own.
namespace wgs84
{
constexpr double kSemiMajorAxis = 6378137.0;                           // a, m
constexpr double kFlattening = 1.0 / 298.257223563;                    // f
constexpr double kEccentricitySq = kFlattening * (2.0 - kFlattening);  // e^2
}  // namespace wgs84
}  // namespace

TEST(Geodetic, EquatorEastOffsetHasClosedForm)
{
  // At (0 N, 0 E, 0 m) the ENU frame's east axis is ECEF +y and up is ECEF +x. A point
  // 1000 m east lies at ECEF (a, 1000, 0): longitude atan(1000 / a), latitude 0,
  // altitude sqrt(a^2 + 1000^2) - a (the tangent plane rises above the sphere of the equator).
  const EnuFrame frame({ 0.0, 0.0, 0.0 });
  const Geodetic g = frame.toGeodetic({ 1000.0, 0.0, 0.0 });
  const double a = wgs84::kSemiMajorAxis;
  EXPECT_NEAR(g.latitude_deg, 0.0, 1e-12);
  EXPECT_NEAR(g.longitude_deg, std::atan(1000.0 / a) * 180.0 / M_PI, 1e-12);
  EXPECT_NEAR(g.altitude, std::sqrt(a * a + 1e6) - a, 1e-6);
}

TEST(Geodetic, LocalAxesAtAnEastOffsetAreTheMapAxesTurnedAboutNorth)
{
  // From (0 N, 0 E) a point at longitude t on the equator has its up axis turned by t about the
  // map's north axis (ECEF z): local east = (cos t, 0, -sin t), north = (0, 1, 0),
  // up = (sin t, 0, cos t) in map (east, north, up) components.
  const EnuFrame frame({ 0.0, 0.0, 0.0 });
  Eigen::Matrix3d local_to_map;
  const Geodetic g = frame.toGeodetic({ 50000.0, 0.0, 0.0 }, local_to_map);
  const double t = std::atan(50000.0 / wgs84::kSemiMajorAxis);
  EXPECT_NEAR(g.longitude_deg, t * 180.0 / M_PI, 1e-12);
  Eigen::Matrix3d expected;
  expected.col(0) << std::cos(t), 0.0, -std::sin(t);
  expected.col(1) << 0.0, 1.0, 0.0;
  expected.col(2) << std::sin(t), 0.0, std::cos(t);
  EXPECT_LT((local_to_map - expected).cwiseAbs().maxCoeff(), 1e-12) << local_to_map;
  // At the origin the axes are the map's.
  frame.toGeodetic(Eigen::Vector3d::Zero(), local_to_map);
  EXPECT_LT((local_to_map - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(Geodetic, PoleIsAtSemiMinorAxis)
{
  const Eigen::Vector3d ecef = avsp::sensors::geodeticToEcef({ 90.0, 0.0, 0.0 });
  const double b = wgs84::kSemiMajorAxis * (1.0 - wgs84::kFlattening);
  EXPECT_NEAR(ecef.z(), b, 1e-6);
  EXPECT_NEAR(std::hypot(ecef.x(), ecef.y()), 0.0, 1e-6);
  const Geodetic back = avsp::sensors::ecefToGeodetic(ecef + Eigen::Vector3d(0, 0, 25.0));
  EXPECT_NEAR(back.latitude_deg, 90.0, 1e-9);
  EXPECT_NEAR(back.altitude, 25.0, 1e-6);
}

TEST(Geodetic, NorthOffsetMatchesMeridianRadius)
{
  // 10 m north at 45 N and 300 m altitude: latitude change = 10 / (M + h) with the meridian
  // radius of curvature M = a (1 - e^2) / (1 - e^2 sin^2 lat)^1.5.
  const double lat = 45.0;
  const EnuFrame frame({ lat, 7.0, 300.0 });
  const Geodetic g = frame.toGeodetic({ 0.0, 10.0, 0.0 });
  const double s = std::sin(lat * M_PI / 180.0);
  const double m =
      wgs84::kSemiMajorAxis * (1 - wgs84::kEccentricitySq) / std::pow(1 - wgs84::kEccentricitySq * s * s, 1.5);
  EXPECT_NEAR((g.latitude_deg - lat) * M_PI / 180.0, 10.0 / (m + 300.0), 1e-12);
  EXPECT_NEAR(g.longitude_deg, 7.0, 1e-12);
}

class GeodeticRoundTrip : public ::testing::TestWithParam<double>
{
};

TEST_P(GeodeticRoundTrip, EnuToGeodeticAndBackIsExact)
{
  const EnuFrame frame({ GetParam(), -83.2, 180.0 });
  for (const Eigen::Vector3d& p : { Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(600, 400, 20),
                                    Eigen::Vector3d(-1200, 1900, -35), Eigen::Vector3d(5000, -3000, 100) })
  {
    const Eigen::Vector3d back = frame.toEnu(frame.toGeodetic(p));
    EXPECT_NEAR((back - p).norm(), 0.0, 1e-6) << "lat " << GetParam() << " p " << p.transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(Latitudes, GeodeticRoundTrip, ::testing::Values(-89.9, -45.0, 0.0, 42.3, 89.9));

TEST(Geodetic, RejectsInvalidReference)
{
  EXPECT_THROW(EnuFrame({ 91.0, 0.0, 0.0 }), GeodeticError);
  EXPECT_THROW(EnuFrame({ 0.0, std::nan(""), 0.0 }), GeodeticError);
}

// ---------------------------------------------------------------------------------------------
// Published reference points, typed in from named geodesy sources.
//
// IOGP (EPSG) Geomatics Guidance Note 7-2, "Coordinate Conversions and Transformations including
// Formulas" (IOGP Publication 373-7-2): the worked examples of the geographic/geocentric
// conversion (EPSG method 9602) and of the geocentric/topocentric and geographic/topocentric
// conversions (methods 9836, 9837), all on WGS 84:
//   point:  53 deg 48' 33.820" N, 2 deg 07' 46.380" E, h = 73.0 m
//           -> X = 3771793.968 m, Y = 140253.342 m, Z = 5124304.349 m
//   topocentric origin: 55 deg 00' 00" N, 5 deg 00' 00" E, h = 200 m
//           -> X0 = 3652755.3058 m, Y0 = 319574.6799 m, Z0 = 5201547.3536 m
//   point in the origin's east-north-up frame: U = -189013.869 m, V = -128642.040 m, W = -4220.171 m
// GeographicLib's CartConvert(1) manual page (C. F. F. Karney), EXAMPLES:
//   33.3 N, 44.4 E, 6000 m -> 3816209.60 3737108.55 3485109.57 (m, to the cm)
namespace
{
double dms(double d, double m, double s)
{
  return d + m / 60.0 + s / 3600.0;
}
const Geodetic kEpsgPoint{ dms(53, 48, 33.820), dms(2, 7, 46.380), 73.0 };
const Eigen::Vector3d kEpsgPointEcef(3771793.968, 140253.342, 5124304.349);
const Geodetic kEpsgOrigin{ 55.0, 5.0, 200.0 };
const Eigen::Vector3d kEpsgOriginEcef(3652755.3058, 319574.6799, 5201547.3536);
const Eigen::Vector3d kEpsgPointEnu(-189013.869, -128642.040, -4220.171);
}  // namespace

TEST(GeodeticPublished, Epsg9602GeographicToGeocentric)
{
  // Published to the mm (0.1 mm for the origin): within 1 mm (0.1 mm).
  EXPECT_LT((avsp::sensors::geodeticToEcef(kEpsgPoint) - kEpsgPointEcef).norm(), 1e-3);
  EXPECT_LT((avsp::sensors::geodeticToEcef(kEpsgOrigin) - kEpsgOriginEcef).norm(), 1e-4);
}

TEST(GeodeticPublished, Epsg9602GeocentricToGeographic)
{
  const Geodetic g = avsp::sensors::ecefToGeodetic(kEpsgPointEcef);
  // The published X, Y, Z are rounded to the mm, so the way back can differ by that much:
  // 1 mm is 9e-9 deg of latitude and 1.5e-8 deg of longitude at 53.8 N.
  EXPECT_NEAR(g.latitude_deg, kEpsgPoint.latitude_deg, 9e-9);
  EXPECT_NEAR(g.longitude_deg, kEpsgPoint.longitude_deg, 1.5e-8);
  EXPECT_NEAR(g.altitude, 73.0, 1e-3);
  // The same check as a distance on the ground.
  EXPECT_LT((avsp::sensors::geodeticToEcef(g) - avsp::sensors::geodeticToEcef(kEpsgPoint)).norm(), 1e-3);
}

TEST(GeodeticPublished, Epsg9837GeographicToTopocentric)
{
  const EnuFrame frame(kEpsgOrigin);
  EXPECT_LT((frame.toEnu(kEpsgPoint) - kEpsgPointEnu).norm(), 1e-3) << frame.toEnu(kEpsgPoint).transpose();
  // And back: the published topocentric point is the published geographic point (to 1 mm).
  const Geodetic g = frame.toGeodetic(kEpsgPointEnu);
  EXPECT_LT((avsp::sensors::geodeticToEcef(g) - avsp::sensors::geodeticToEcef(kEpsgPoint)).norm(), 1e-3);
  EXPECT_NEAR(g.altitude, 73.0, 1e-3);
}

TEST(GeodeticPublished, GeographicLibCartConvertExample)
{
  const Eigen::Vector3d ecef = avsp::sensors::geodeticToEcef({ 33.3, 44.4, 6000.0 });
  const Eigen::Vector3d published(3816209.60, 3737108.55, 3485109.57);
  // Published to the cm: within half a cm per axis.
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(ecef[k], published[k], 0.005) << "axis " << k;
}
