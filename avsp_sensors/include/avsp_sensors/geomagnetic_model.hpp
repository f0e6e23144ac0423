#pragma once
/**
 * @file geomagnetic_model.hpp
 * @brief The Earth's main magnetic field from a spherical-harmonic model read by
 *        GeographicLib::MagneticModel (the World Magnetic Model WMM2025 ships in
 *        avsp_sensors/data/magnetic/), and that field over the map on one date (what the
 *        magnetometer reads). Units: T, metres, degrees, decimal years.
 */
#include <memory>
#include <stdexcept>
#include <string>

#include <Eigen/Core>

#include "avsp_sensors/geodetic.hpp"

namespace GeographicLib
{
class MagneticModel;
}

namespace avsp
{
namespace sensors
{
/// Thrown for a model file that cannot be used, a date or a height outside a model's validity.
class GeomagneticModelError : public std::invalid_argument
{
public:
  using std::invalid_argument::invalid_argument;
};

/**
 * @brief The decimal year of a date, the WMM's time scale: year + (day of the year - 1) / (days in
 *        the year), e.g. "2025-10-15" -> 2025 + 287 / 365 = 2025.7863.
 * @param date "YYYY-MM-DD", or a decimal year such as "2027.5"
 * @throw GeomagneticModelError "date '<text>': ..." for anything else (GeographicLib's "now" too:
 *        a run's field must not depend on when it runs)
 */
double decimalYear(const std::string& date);

/**
 * @brief A geomagnetic model file in GeographicLib's format: `<name>.wmm` (metadata: validity in
 *        time and height, reference radius, normalisation) and `<name>.wmm.cof` (coefficients).
 *        Copies share the loaded coefficients; evaluation is const and thread-safe.
 */
class GeomagneticModel
{
public:
  /**
   * @param wmm_file path of the metadata file, e.g. ".../data/magnetic/wmm2025.wmm"; the
   *        coefficients are read from `wmm_file` + ".cof"
   * @throw GeomagneticModelError "magnetic model file <path>: <reason>" when a file is missing,
   *        unreadable or corrupt (GeographicLib's reason: no WMMF signature, ID mismatch, short or
   *        extra data, ...) or its validity range is not finite
   */
  explicit GeomagneticModel(const std::string& wmm_file);

  const std::string& file() const { return file_; }
  std::string name() const;         ///< the metadata's Name, e.g. "wmm2025"
  std::string description() const;  ///< e.g. "World Magnetic Model 2025"
  double minYear() const;           ///< decimal year, start of validity
  double maxYear() const;           ///< decimal year, end of validity
  double minHeight() const;         ///< m above the ellipsoid
  double maxHeight() const;         ///< m above the ellipsoid

  /**
   * @brief The main field at a point and time.
   * @param point WGS-84 latitude, longitude (deg) and height above the ellipsoid (m)
   * @param year decimal year in [minYear(), maxYear()]
   * @return T, components along east, north and up at the point
   * @throw GeomagneticModelError naming the year or the height outside the model's validity, or
   *        a point that is not finite or has |latitude| > 90 deg
   */
  Eigen::Vector3d fieldEnu(const Geodetic& point, double year) const;

  /// @throw GeomagneticModelError "<name> (<file>) is valid for decimal years A to B: <what> is
  ///        <year>" when the year is outside the validity
  void checkYear(double year, const std::string& what) const;

private:
  std::string file_;
  std::shared_ptr<const GeographicLib::MagneticModel> model_;
};

/**
 * @brief A geomagnetic model on one date over the map: the field at a map position, in the map's
 *        (ENU) axes. The position goes to geodetic through the map's EnuFrame, the model gives the
 *        field in the east-north-up axes there, and the rotation between those axes and the map's
 *        brings it into the map.
 */
class MapMagneticField
{
public:
  /**
   * @param year decimal year of the run (decimalYear())
   * @throw GeomagneticModelError for a year outside the model's validity or a map origin whose
   *        height is outside it
   */
  MapMagneticField(GeomagneticModel model, const EnuFrame& map, double year);

  /**
   * @param map_position m, map (ENU)
   * @return T, map axes
   * @throw GeomagneticModelError for a position whose height is outside the model's validity
   */
  Eigen::Vector3d at(const Eigen::Vector3d& map_position) const;

  const GeomagneticModel& model() const { return model_; }
  const EnuFrame& map() const { return map_; }
  double year() const { return year_; }

private:
  GeomagneticModel model_;
  EnuFrame map_;
  double year_;
};

}  // namespace sensors
}  // namespace avsp
