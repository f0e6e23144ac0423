#pragma once
/**
 * @file weather.hpp
 * @brief What fog, rain and snow do to a near-infrared lidar: extinction coefficients from
 *        visibility and precipitation rate (published empirical laws), the two-way
 *        Beer-Lambert transmission, and the rate of false near-range returns from falling
 *        drops and flakes. Formulas and sources: README.md, "Weather".
 */
#include <limits>

namespace avsp
{
namespace sensors
{
/// The weather a sensor sees (the fields of avsp_msgs/Environment it uses).
struct Weather
{
  double fog_visibility = std::numeric_limits<double>::infinity();  ///< m, meteorological visibility; +inf = no fog
  double rain_rate = 0.0;                                           ///< mm/h
  double snow_rate = 0.0;                                           ///< mm/h, snowfall rate
  bool wet_snow = false;  ///< wet (melting) snow instead of dry: different law
};

/**
 * @brief Checks the fields.
 * @throw std::invalid_argument naming the field: fog_visibility not > 0 (NaN), rain_rate or
 *        snow_rate negative, NaN or infinite
 */
void validateWeather(const Weather& weather);

/**
 * @brief Fog (and haze) extinction coefficient, 1/m: Koschmieder's 3.912 / V at 550 nm with
 *        Kim's wavelength exponent, alpha = (3.912 / V) (lambda / 550 nm)^-q, q = 1.6 (V > 50 km),
 *        1.3 (6-50 km), 0.16 V + 0.34 (1-6 km), V - 0.5 (0.5-1 km), 0 (V < 0.5 km, V in km).
 *        In fog (V < 500 m) this is exactly 3.912 / V at every wavelength.
 * @param visibility_m m (> 0; +inf gives 0)
 * @param wavelength_m m (> 0)
 */
double fogExtinction(double visibility_m, double wavelength_m);

/// Rain extinction, 1/m, from Carbonneau's law 1.076 R^0.67 dB/km (R in mm/h).
double rainExtinction(double rate_mm_h);

/**
 * @brief Snow extinction, 1/m, from a S^b dB/km (S in mm/h) with, for lambda in nm,
 *        dry snow a = 5.42e-5 lambda + 5.4958776, b = 1.38;
 *        wet snow a = 1.023e-4 lambda + 3.7855466, b = 0.72.
 */
double snowExtinction(double rate_mm_h, double wavelength_m, bool wet);

/// Total extinction of the weather at a wavelength, 1/m (fog + rain + snow).
double extinction(const Weather& weather, double wavelength_m);

/// Precipitation-only extinction (rain + snow), 1/m: what causes false returns.
double precipitationExtinction(const Weather& weather, double wavelength_m);

/// Two-way Beer-Lambert transmission to range r and back: exp(-2 alpha r).
double twoWayTransmission(double alpha_per_m, double range_m);

/**
 * @brief Rate (1/m along the beam) at which the beam meets a falling particle large enough to
 *        send back a detectable echo: kappa = efficiency * alpha_precip / 2. Large particles
 *        extinguish twice their geometric cross-section (extinction efficiency -> 2), so
 *        alpha / 2 is the geometric cross-section per volume, i.e. interceptions per metre.
 */
double clutterRate(const Weather& weather, double wavelength_m, double efficiency);

/// dB/km -> 1/m: gamma [dB/km] = 10 log10(e) * 1000 * alpha [1/m].
inline double dbPerKmToPerMetre(double db_per_km)
{
  return db_per_km * 0.23025850929940458 / 1000.0;  // ln(10) / 10
}

}  // namespace sensors
}  // namespace avsp
