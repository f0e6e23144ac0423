#include "avsp_sensors/weather.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace sensors
{
void validateWeather(const Weather& w)
{
  if (!(w.fog_visibility > 0.0))
    throw std::invalid_argument("Weather: fog_visibility must be > 0 m (+inf for no fog), got " +
                                std::to_string(w.fog_visibility));
  if (!(w.rain_rate >= 0.0) || !std::isfinite(w.rain_rate))
    throw std::invalid_argument("Weather: rain_rate must be finite and >= 0 mm/h, got " + std::to_string(w.rain_rate));
  if (!(w.snow_rate >= 0.0) || !std::isfinite(w.snow_rate))
    throw std::invalid_argument("Weather: snow_rate must be finite and >= 0 mm/h, got " + std::to_string(w.snow_rate));
}

double fogExtinction(double visibility_m, double wavelength_m)
{
  if (!(visibility_m > 0.0))
    throw std::invalid_argument("fogExtinction: visibility must be > 0 m");
  if (!(wavelength_m > 0.0))
    throw std::invalid_argument("fogExtinction: wavelength must be > 0 m");
  if (std::isinf(visibility_m))
    return 0.0;
  // Kim, McArthur and Korevaar (2001): the size-distribution exponent q from visibility (km).
  const double v_km = visibility_m / 1000.0;
  double q;
  if (v_km > 50.0)
    q = 1.6;
  else if (v_km > 6.0)
    q = 1.3;
  else if (v_km > 1.0)
    q = 0.16 * v_km + 0.34;
  else if (v_km > 0.5)
    q = v_km - 0.5;
  else
    q = 0.0;
  // Koschmieder: visibility is where a black object's contrast falls to 2 %, ln(50) = 3.912.
  return 3.912 / visibility_m * std::pow(wavelength_m / 550e-9, -q);
}

double rainExtinction(double rate_mm_h)
{
  if (!(rate_mm_h >= 0.0))
    throw std::invalid_argument("rainExtinction: rate must be >= 0 mm/h");
  return rate_mm_h == 0.0 ? 0.0 : dbPerKmToPerMetre(1.076 * std::pow(rate_mm_h, 0.67));
}

double snowExtinction(double rate_mm_h, double wavelength_m, bool wet)
{
  if (!(rate_mm_h >= 0.0))
    throw std::invalid_argument("snowExtinction: rate must be >= 0 mm/h");
  if (rate_mm_h == 0.0)
    return 0.0;
  const double nm = wavelength_m * 1e9;
  const double a = wet ? 1.023e-4 * nm + 3.7855466 : 5.42e-5 * nm + 5.4958776;
  const double b = wet ? 0.72 : 1.38;
  return dbPerKmToPerMetre(a * std::pow(rate_mm_h, b));
}

double precipitationExtinction(const Weather& w, double wavelength_m)
{
  return rainExtinction(w.rain_rate) + snowExtinction(w.snow_rate, wavelength_m, w.wet_snow);
}

double extinction(const Weather& w, double wavelength_m)
{
  return fogExtinction(w.fog_visibility, wavelength_m) + precipitationExtinction(w, wavelength_m);
}

double twoWayTransmission(double alpha_per_m, double range_m)
{
  return std::exp(-2.0 * alpha_per_m * range_m);
}

double clutterRate(const Weather& w, double wavelength_m, double efficiency)
{
  return efficiency * 0.5 * precipitationExtinction(w, wavelength_m);
}

}  // namespace sensors
}  // namespace avsp
