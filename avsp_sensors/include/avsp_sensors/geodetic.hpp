#pragma once
/**
 * @file geodetic.hpp
 * @brief Exact conversions between WGS-84 geodetic coordinates, ECEF and the local ENU
 *        frame (`map`) whose origin is the scenario's geodetic reference.
 */
#include <stdexcept>

#include <Eigen/Core>

namespace avsp
{
namespace sensors
{
/// WGS-84 ellipsoid constants.
namespace wgs84
{
constexpr double kSemiMajorAxis = 6378137.0;             ///< a, m
constexpr double kFlattening = 1.0 / 298.257223563;      ///< f
constexpr double kEccentricitySq = kFlattening * (2.0 - kFlattening);  ///< e^2
}  // namespace wgs84

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

/// Geodetic -> Earth-centred Earth-fixed, m.
Eigen::Vector3d geodeticToEcef(const Geodetic& g);

/// ECEF (m) -> geodetic, exact to < 1e-9 m (iterative Bowring, converged).
Geodetic ecefToGeodetic(const Eigen::Vector3d& ecef);

/**
 * @brief The local east-north-up frame tangent to the ellipsoid at a reference point.
 */
class EnuFrame
{
public:
  /// @throw GeodeticError if the latitude is outside [-90, 90] or any value is not finite
  explicit EnuFrame(const Geodetic& origin);

  /// ENU position (m, map frame) -> geodetic.
  Geodetic toGeodetic(const Eigen::Vector3d& enu) const;
  /// Geodetic -> ENU position (m, map frame).
  Eigen::Vector3d toEnu(const Geodetic& g) const;

  const Geodetic& origin() const { return origin_; }

private:
  Geodetic origin_;
  Eigen::Vector3d origin_ecef_;
  Eigen::Matrix3d ecef_to_enu_;  ///< rows: east, north, up unit vectors in ECEF
};

}  // namespace sensors
}  // namespace avsp
