#pragma once
/**
 * @file magnetometer.hpp
 * @brief Three-axis magnetometer (docs/MODELS.md section 4: the direction of magnetic north relative
 *        to the vehicle): the Earth's field rotated from the map (ENU) into the sensor frame
 *        (REP 103: x forward, y left, z up), plus white noise and a constant offset. The field is
 *        a geomagnetic model's (the World Magnetic Model, geomagnetic_model.hpp) at the sensor's
 *        position on the run's date, or a fixed one given by total intensity, inclination and
 *        declination. Defaults and sources: README.md, "Magnetometer".
 */
#include <cstdint>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/geomagnetic_model.hpp"
#include "avsp_sensors/noise.hpp"

namespace avsp
{
namespace sensors
{
/**
 * @brief The geomagnetic field at the site by its elements. Declination D: angle from true north
 *        to the field's horizontal component, positive east. Inclination I: angle below the
 *        horizontal, positive down (northern hemisphere). North, east, down components:
 *        H = F cos I, B_N = H cos D, B_E = H sin D, B_D = F sin I.
 *
 * Defaults: F = 50 uT, I = 60 deg, D = 0 deg, a generic mid-northern-latitude field (the WMM2025
 * gives F = 51.06 uT, I = 65.86 deg, D = 7.67 deg at the default site, 39.7425 N 105.1786 W
 * 1829 m, on 2025-10-15).
 */
struct EarthField
{
  double intensity = 50e-6;       ///< T, total intensity F, >= 0
  double inclination_deg = 60.0;  ///< deg, dip below horizontal, [-90, 90]
  double declination_deg = 0.0;   ///< deg, east of true north, [-180, 180]
};

/// The field in the map frame (ENU), T: (B_E, B_N, -B_D).
Eigen::Vector3d earthFieldEnu(const EarthField& field);

/// The elements of a field given by its east, north, up components (T): the inverse of
/// earthFieldEnu() (declination 0 for a vertical field).
EarthField earthFieldFromEnu(const Eigen::Vector3d& enu);

/**
 * @brief Magnetometer parameters.
 *
 * Noise default: 0.2 uT, the 2 milligauss noise floor of the Honeywell HMC5883L data sheet;
 * rate 15 Hz, that sheet's default data output rate.
 */
struct MagnetometerConfig
{
  double rate = 15.0;  ///< Hz, > 0
  EarthField field;    ///< the site's field when `model` is not set
  /// The geomagnetic model on the run's date over the map: when set, the sensor reads the model's
  /// field at its position (`field` is not used).
  std::optional<MapMagneticField> model;
  double noise = 0.2e-6;                             ///< T, white noise per axis (1 sigma), >= 0
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< T, constant hard-iron offset, sensor frame, finite
  /// Pose of the sensor in the body frame (sensor frame -> body frame).
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
};

/// @throw std::invalid_argument naming the field ("MagnetometerConfig: field.inclination_deg ...")
void validateMagnetometerConfig(const MagnetometerConfig& config);

/// One sample, what sensor_msgs/MagneticField carries.
struct MagSample
{
  double time = 0.0;                                     ///< s
  Eigen::Vector3d field = Eigen::Vector3d::Zero();       ///< T, sensor frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< T^2, diag(noise^2)
};

/**
 * @brief A magnetometer: m = R^T B_enu(p) + offset + noise n, R the sensor's orientation
 *        (R_body R_mount) in the map, p its position (the model's field there, or the fixed field
 *        everywhere).
 */
class Magnetometer
{
public:
  /// @throw std::invalid_argument (validateMagnetometerConfig)
  Magnetometer(MagnetometerConfig config, std::uint64_t seed);

  const MagnetometerConfig& config() const { return config_; }

  bool due(double t) const { return clock_.due(t); }

  /**
   * @brief One sample at time t (s) with the body's pose (body frame -> map, m).
   * @throw std::invalid_argument for a non-finite time or position, a rotation that is not
   *        orthonormal, or a time earlier than the last sample; GeomagneticModelError (an
   *        std::invalid_argument) for a position whose height is outside the model's validity
   */
  MagSample measure(double t, const Eigen::Isometry3d& body_pose);

private:
  MagnetometerConfig config_;
  Eigen::Vector3d fixed_field_enu_;  ///< T, earthFieldEnu(config_.field)
  NormalSource normal_;
  SampleClock clock_;
  bool started_ = false;
  double last_time_ = 0.0;
};

}  // namespace sensors
}  // namespace avsp
