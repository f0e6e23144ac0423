#include "avsp_sensors/geodetic.hpp"

#include <cmath>
#include <sstream>

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;

double primeVerticalRadius(double sin_lat)
{
  return wgs84::kSemiMajorAxis / std::sqrt(1.0 - wgs84::kEccentricitySq * sin_lat * sin_lat);
}
}  // namespace

Eigen::Vector3d geodeticToEcef(const Geodetic& g)
{
  const double lat = g.latitude_deg * kDegToRad;
  const double lon = g.longitude_deg * kDegToRad;
  const double n = primeVerticalRadius(std::sin(lat));
  return { (n + g.altitude) * std::cos(lat) * std::cos(lon), (n + g.altitude) * std::cos(lat) * std::sin(lon),
           (n * (1.0 - wgs84::kEccentricitySq) + g.altitude) * std::sin(lat) };
}

Geodetic ecefToGeodetic(const Eigen::Vector3d& ecef)
{
  const double a = wgs84::kSemiMajorAxis;
  const double e2 = wgs84::kEccentricitySq;
  const double p = std::hypot(ecef.x(), ecef.y());
  const double lon = std::atan2(ecef.y(), ecef.x());
  // Fixed-point iteration on latitude; converges to machine precision within a few steps
  // for any point outside the Earth's core.
  double lat = std::atan2(ecef.z(), p * (1.0 - e2));
  double h = 0.0;
  for (int k = 0; k < 10; ++k)
  {
    const double s = std::sin(lat);
    const double n = a / std::sqrt(1.0 - e2 * s * s);
    // Near the poles p ~ 0: use the z form of the height to stay well conditioned.
    h = (std::abs(std::cos(lat)) > 1e-3) ? p / std::cos(lat) - n : ecef.z() / s - n * (1.0 - e2);
    const double next = std::atan2(ecef.z(), p * (1.0 - e2 * n / (n + h)));
    if (std::abs(next - lat) < 1e-15)
    {
      lat = next;
      break;
    }
    lat = next;
  }
  const double s = std::sin(lat);
  const double n = a / std::sqrt(1.0 - e2 * s * s);
  h = (std::abs(std::cos(lat)) > 1e-3) ? p / std::cos(lat) - n : ecef.z() / s - n * (1.0 - e2);
  return { lat / kDegToRad, lon / kDegToRad, h };
}

EnuFrame::EnuFrame(const Geodetic& origin) : origin_(origin)
{
  if (!std::isfinite(origin.latitude_deg) || !std::isfinite(origin.longitude_deg) ||
      !std::isfinite(origin.altitude) || std::abs(origin.latitude_deg) > 90.0)
  {
    std::ostringstream why;
    why << "geodetic reference (lat " << origin.latitude_deg << " deg, lon " << origin.longitude_deg
        << " deg, alt " << origin.altitude << " m) is not a valid position";
    throw GeodeticError(why.str());
  }
  origin_ecef_ = geodeticToEcef(origin);
  const double lat = origin.latitude_deg * kDegToRad;
  const double lon = origin.longitude_deg * kDegToRad;
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  ecef_to_enu_ << -so, co, 0.0,  // east
      -sl * co, -sl * so, cl,    // north
      cl * co, cl * so, sl;      // up
}

Geodetic EnuFrame::toGeodetic(const Eigen::Vector3d& enu) const
{
  return ecefToGeodetic(origin_ecef_ + ecef_to_enu_.transpose() * enu);
}

Eigen::Vector3d EnuFrame::toEnu(const Geodetic& g) const
{
  return ecef_to_enu_ * (geodeticToEcef(g) - origin_ecef_);
}

}  // namespace sensors
}  // namespace avsp
