#include "avsp_sensors/geodetic.hpp"

#include <cmath>
#include <sstream>
#include <vector>

#include <GeographicLib/Geocentric.hpp>

namespace avsp
{
namespace sensors
{
Eigen::Vector3d geodeticToEcef(const Geodetic& g)
{
  Eigen::Vector3d ecef;
  GeographicLib::Geocentric::WGS84().Forward(g.latitude_deg, g.longitude_deg, g.altitude, ecef.x(), ecef.y(), ecef.z());
  return ecef;
}

Geodetic ecefToGeodetic(const Eigen::Vector3d& ecef)
{
  Geodetic g{};
  GeographicLib::Geocentric::WGS84().Reverse(ecef.x(), ecef.y(), ecef.z(), g.latitude_deg, g.longitude_deg, g.altitude);
  return g;
}

EnuFrame::EnuFrame(const Geodetic& origin) : origin_(origin)
{
  // LocalCartesian takes any input and turns a latitude beyond the poles into NaN: refuse such
  // a reference here, where the caller can still name it.
  if (!std::isfinite(origin.latitude_deg) || !std::isfinite(origin.longitude_deg) || !std::isfinite(origin.altitude) ||
      std::abs(origin.latitude_deg) > 90.0)
  {
    std::ostringstream why;
    why << "geodetic reference (lat " << origin.latitude_deg << " deg, lon " << origin.longitude_deg << " deg, alt "
        << origin.altitude << " m) is not a valid position";
    throw GeodeticError(why.str());
  }
  local_.Reset(origin.latitude_deg, origin.longitude_deg, origin.altitude);
}

Geodetic EnuFrame::toGeodetic(const Eigen::Vector3d& enu) const
{
  Geodetic g{};
  local_.Reverse(enu.x(), enu.y(), enu.z(), g.latitude_deg, g.longitude_deg, g.altitude);
  return g;
}

Geodetic EnuFrame::toGeodetic(const Eigen::Vector3d& enu, Eigen::Matrix3d& local_to_map) const
{
  Geodetic g{};
  std::vector<double> m(9);  // row-major; GeographicLib: v_map = M v_local
  local_.Reverse(enu.x(), enu.y(), enu.z(), g.latitude_deg, g.longitude_deg, g.altitude, m);
  local_to_map = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(m.data());
  return g;
}

Eigen::Vector3d EnuFrame::toEnu(const Geodetic& g) const
{
  Eigen::Vector3d enu;
  local_.Forward(g.latitude_deg, g.longitude_deg, g.altitude, enu.x(), enu.y(), enu.z());
  return enu;
}

}  // namespace sensors
}  // namespace avsp
