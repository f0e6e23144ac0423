#pragma once
/**
 * @file geodetic.hpp
 * @brief Conversions between WGS-84 geodetic coordinates, ECEF and the local ENU frame (`map`)
 *        whose origin is the scenario's geodetic reference, by GeographicLib (`Geocentric`,
 *        `LocalCartesian`: exact to round-off, C. F. F. Karney's library, Debian's
 *        libgeographiclib-dev).
 */
#include <stdexcept>

#include <Eigen/Core>
#include <GeographicLib/LocalCartesian.hpp>

namespace avsp
{
namespace sensors
{
/// A point on or above the ellipsoid. Angles in degrees (as NavSatFix), altitude in m.
struct Geodetic
{
  double latitude_deg;   ///< [-90, 90], positive north
  double longitude_deg;  ///< (-180, 180], positive east
  double altitude;       ///< m above the WGS-84 ellipsoid
};

/// Thrown for a geodetic reference that is not a valid position.
class GeodeticError : public std::invalid_argument
{
public:
  using std::invalid_argument::invalid_argument;
};

/// Geodetic -> Earth-centred Earth-fixed (WGS-84), m.
Eigen::Vector3d geodeticToEcef(const Geodetic& g);

/// ECEF (m) -> geodetic (WGS-84), exact to round-off for any point (GeographicLib::Geocentric).
Geodetic ecefToGeodetic(const Eigen::Vector3d& ecef);

/**
 * @brief The local east-north-up frame tangent to the WGS-84 ellipsoid at a reference point.
 */
class EnuFrame
{
public:
  /// @throw GeodeticError if the latitude is outside [-90, 90] or any value is not finite
  explicit EnuFrame(const Geodetic& origin);

  /// ENU position (m, map frame) -> geodetic.
  Geodetic toGeodetic(const Eigen::Vector3d& enu) const;
  /**
   * @brief ENU position (m, map frame) -> geodetic, and the rotation between the axes there and
   *        the map's.
   * @param local_to_map set to R with v_map = R v_local for a vector's components in the east,
   *        north and up axes at the point (v_local) and in the map's axes (v_map); the two sets
   *        of axes differ by the angle between the verticals, about 0.009 deg per km from the
   *        origin
   */
  Geodetic toGeodetic(const Eigen::Vector3d& enu, Eigen::Matrix3d& local_to_map) const;
  /// Geodetic -> ENU position (m, map frame).
  Eigen::Vector3d toEnu(const Geodetic& g) const;

  const Geodetic& origin() const { return origin_; }

private:
  Geodetic origin_;
  GeographicLib::LocalCartesian local_;  ///< WGS-84, origin_
};

}  // namespace sensors
}  // namespace avsp
