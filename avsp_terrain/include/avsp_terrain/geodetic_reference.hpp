#pragma once
/**
 * @file geodetic_reference.hpp
 * @brief The map origin's WGS-84 position as every part of a run reads it: the scenario's
 *        `geodetic_reference.<key>`, and the `~latitude`, `~longitude`, `~altitude` of
 *        environment_node and sensors_node. One table of keys, defaults and ranges, so a site the
 *        scenario check accepts is one every node accepts.
 */
#include <array>

namespace avsp
{
namespace terrain
{
/// One coordinate of the geodetic reference as a parameter.
struct GeodeticNumber
{
  const char* key;  ///< latitude, longitude, altitude
  bool required;    ///< no default (latitude, longitude)
  double fallback;  ///< when not required and not given
  double min, max;  ///< inclusive
  const char* unit;
};

/// latitude (deg, [-90, 90]), longitude (deg east, [-180, 360]), altitude (m above the
/// ellipsoid, [-500, 9000], default 0).
inline const std::array<GeodeticNumber, 3>& geodeticReferenceNumbers()
{
  static const std::array<GeodeticNumber, 3> numbers{ { { "latitude", true, 0.0, -90.0, 90.0, "deg" },
                                                        { "longitude", true, 0.0, -180.0, 360.0, "deg east" },
                                                        { "altitude", false, 0.0, -500.0, 9000.0, "m" } } };
  return numbers;
}

}  // namespace terrain
}  // namespace avsp
