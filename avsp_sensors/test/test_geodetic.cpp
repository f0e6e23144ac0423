#include <cmath>

#include <gtest/gtest.h>

#include "avsp_sensors/geodetic.hpp"

using avsp::sensors::EnuFrame;
using avsp::sensors::Geodetic;
using avsp::sensors::GeodeticError;
namespace wgs84 = avsp::sensors::wgs84;

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
  const double m = wgs84::kSemiMajorAxis * (1 - wgs84::kEccentricitySq) /
                   std::pow(1 - wgs84::kEccentricitySq * s * s, 1.5);
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
