#pragma once
/**
 * @file magnetometer.hpp
 * @brief Three-axis magnetometer (docs/MODELS.md section 4: the direction of magnetic north relative
 *        to the vehicle): the Earth's field, given by total intensity, inclination and
 *        declination, rotated from the map (ENU) into the sensor frame (REP 103: x forward,
 *        y left, z up), plus white noise and a constant offset. A centred-dipole field from the
 *        IGRF-13 degree-1 coefficients gives location-consistent values for any geodetic
 *        reference. Defaults and sources: README.md, "Magnetometer".
 */
#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/geodetic.hpp"
#include "avsp_sensors/noise.hpp"

namespace avsp
{
namespace sensors
{
/**
 * @brief The geomagnetic field at the site. Declination D: angle from true north to the field's
 *        horizontal component, positive east. Inclination I: angle below the horizontal,
 *        positive down (northern hemisphere). North, east, down components:
 *        H = F cos I, B_N = H cos D, B_E = H sin D, B_D = F sin I.
 *
 * Defaults: F = 50 uT, I = 60 deg, D = 0 deg, a generic mid-northern-latitude field (the dipole
 * of dipoleEarthField() gives 46-52 uT and 62-71 deg between 35 and 55 deg N in North America
 * and Europe); set the site's values (e.g. from a World Magnetic Model calculator), or
 * dipoleEarthField(origin) for intensity and inclination (its declination can be 10-20 deg off).
 */
struct EarthField
{
  double intensity = 50e-6;       ///< T, total intensity F, >= 0
  double inclination_deg = 60.0;  ///< deg, dip below horizontal, [-90, 90]
  double declination_deg = 0.0;   ///< deg, east of true north, [-180, 180]
};

/// The field in the map frame (ENU), T: (B_E, B_N, -B_D).
Eigen::Vector3d earthFieldEnu(const EarthField& field);

/// IGRF-13 (epoch 2020.0) degree-1 Gauss coefficients, nT, and the reference radius, m
/// (Alken et al., "International Geomagnetic Reference Field: the thirteenth generation",
/// Earth, Planets and Space 73:49, 2021).
namespace igrf13_dipole
{
constexpr double kG10 = -29404.8;           ///< nT
constexpr double kG11 = -1450.9;            ///< nT
constexpr double kH11 = 4652.5;             ///< nT
constexpr double kReferenceRadius = 6371200.0;  ///< m
}  // namespace igrf13_dipole

/**
 * @brief Centred tilted dipole field at an ECEF position, T:
 *        B = (a/r)^3 [3 (g . r_hat) r_hat - g], g = (g11, h11, g10) (the degree-1 potential
 *        V = a^3 (g . r) / r^3, B = -grad V). The dipole alone misses the non-dipole field:
 *        against the full model, intensity and inclination are off by up to ~10 % and a few
 *        degrees at mid-latitudes, the declination by 10-20 degrees in places.
 * @throw std::invalid_argument for a position at the Earth's centre or not finite
 */
Eigen::Vector3d dipoleFieldEcef(const Eigen::Vector3d& ecef);

/// dipoleFieldEcef() at a geodetic point, as intensity, inclination and declination (to the
/// geodetic ENU axes at the point).
EarthField dipoleEarthField(const Geodetic& point);

/**
 * @brief Magnetometer parameters.
 *
 * Noise default: 0.2 uT, the 2 milligauss noise floor of the Honeywell HMC5883L data sheet;
 * rate 15 Hz, that sheet's default data output rate.
 */
struct MagnetometerConfig
{
  double rate = 15.0;            ///< Hz, > 0
  EarthField field;              ///< the site's field
  double noise = 0.2e-6;         ///< T, white noise per axis (1 sigma), >= 0
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< T, constant hard-iron offset, sensor frame, finite
  /// Pose of the sensor in the body frame (sensor frame -> body frame).
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
};

/// @throw std::invalid_argument naming the field ("MagnetometerConfig: field.inclination_deg ...")
void validateMagnetometerConfig(const MagnetometerConfig& config);

/// One sample, what sensor_msgs/MagneticField carries.
struct MagSample
{
  double time = 0.0;                                        ///< s
  Eigen::Vector3d field = Eigen::Vector3d::Zero();          ///< T, sensor frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();     ///< T^2, diag(noise^2)
};

/**
 * @brief A magnetometer: m = R^T B_enu + offset + noise n, R the sensor's orientation
 *        (R_body R_mount) in the map.
 */
class Magnetometer
{
public:
  /// @throw std::invalid_argument (validateMagnetometerConfig)
  Magnetometer(MagnetometerConfig config, std::uint64_t seed);

  const MagnetometerConfig& config() const { return config_; }
  /// The configured field in the map frame (ENU), T.
  const Eigen::Vector3d& fieldEnu() const { return field_enu_; }

  bool due(double t) const { return clock_.due(t); }

  /**
   * @brief One sample at time t (s) with the body's orientation (body frame -> map).
   * @throw std::invalid_argument for a non-finite time, a rotation that is not orthonormal, or a
   *        time earlier than the last sample
   */
  MagSample measure(double t, const Eigen::Quaterniond& body_orientation);

private:
  MagnetometerConfig config_;
  Eigen::Vector3d field_enu_;
  NormalSource normal_;
  SampleClock clock_;
  bool started_ = false;
  double last_time_ = 0.0;
};

}  // namespace sensors
}  // namespace avsp
