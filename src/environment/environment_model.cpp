#include "avsp/environment/environment_model.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace avsp
{
namespace environment
{
namespace
{
std::string number(double v)
{
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

/// Kasten & Young (1989) relative air mass at apparent elevation h (deg), for h > 0.
double airMass(double h_deg)
{
  return 1.0 / (std::sin(h_deg * kDegToRad) + 0.50572 * std::pow(h_deg + 6.07995, -1.6364));
}

/// Clear (c = 0) to overcast (c = 1) daylight at elevation h (deg, >= 0), lx.
double daylight(double h_deg, double c)
{
  const double s = std::sin(std::max(0.0, h_deg) * kDegToRad);
  const double direct = h_deg > 0.0 ? 127500.0 * std::exp(-0.21 * airMass(h_deg)) * s : 0.0;
  const double clear = direct + 800.0 + 15500.0 * std::sqrt(s);
  const double overcast = 300.0 + 21000.0 * s;
  return (1.0 - c) * clear + c * overcast;
}

void checkWeather(const WeatherState& w, double air_temperature)
{
  if (std::isnan(w.fog_visibility) || w.fog_visibility <= 0.0)
    throw std::invalid_argument("fog_visibility = " + number(w.fog_visibility) + " must be > 0 (m; inf = no fog)");
  const std::pair<const char*, double> rates[] = { { "rain_rate_mm_h", w.rain_rate_mm_h },
                                                   { "snow_rate_mm_h", w.snow_rate_mm_h },
                                                   { "hail_rate_mm_h", w.hail_rate_mm_h } };
  for (const auto& [key, value] : rates)
    if (!std::isfinite(value) || value < 0.0)
      throw std::invalid_argument(std::string(key) + " = " + number(value) + " must be finite and >= 0 (mm/h)");
  if (!std::isfinite(w.wind_x) || !std::isfinite(w.wind_y) || !std::isfinite(w.wind_z))
    throw std::invalid_argument("wind must be finite (m/s)");
  // Earth's air: 184 K (Vostok) to 330 K (Death Valley) measured; refraction divides by it, so
  // a denormal temperature once made the Sun's elevation NaN.
  if (!std::isfinite(air_temperature) || air_temperature < 150.0 || air_temperature > 350.0)
    throw std::invalid_argument("air_temperature = " + number(air_temperature) + " must be in [150, 350] K");
}
}  // namespace

double overcastFraction(const WeatherState& weather)
{
  if (weather.rain_rate_mm_h > 0.0 || weather.snow_rate_mm_h > 0.0 || weather.hail_rate_mm_h > 0.0)
    return 1.0;
  if (weather.fog_visibility < 10000.0)
    return 1.0 - weather.fog_visibility / 10000.0;
  return 0.0;
}

double ambientIlluminance(double sun_elevation, double moon_elevation, double moon_phase_angle, double overcast)
{
  const double c = std::clamp(overcast, 0.0, 1.0);
  const double h = sun_elevation * kRadToDeg;
  double sun = 0.0;
  if (h >= 0.0)
  {
    sun = daylight(h, c);
  }
  else if (h > -21.0)
  {
    // log10 lx at 0, -6, -12, -18 deg; the twilight anchors are for a clear sky.
    const double ratio = daylight(0.0, c) / daylight(0.0, 0.0);
    const double anchors[4] = { std::log10(daylight(0.0, c)), std::log10(3.4 * ratio), std::log10(0.008 * ratio),
                                std::log10(6e-4 * ratio) };
    if (h > -18.0)
    {
      const double x = -h / 6.0;  // (0, 3)
      const int k = std::min(2, static_cast<int>(x));
      const double u = x - k;
      sun = std::pow(10.0, anchors[k] + u * (anchors[k + 1] - anchors[k]));
    }
    else
    {
      sun = std::pow(10.0, anchors[3]) * (h + 21.0) / 3.0;
    }
  }
  double moon = 0.0;
  const double hm = moon_elevation * kRadToDeg;
  if (hm > 0.0)
  {
    const double i = std::abs(moon_phase_angle) * kRadToDeg;
    const double magnitude = -12.73 + 0.026 * i + 4e-9 * std::pow(i, 4);
    moon = std::pow(10.0, -0.4 * (magnitude + 13.99)) * std::sin(moon_elevation) * std::exp(-0.21 * airMass(hm)) *
           (1.0 - 0.9 * c);
  }
  return sun + moon + 0.001;
}

EnvironmentModel::EnvironmentModel(const EnvironmentConfig& config)
  : site_(config.site),
    anchor_t_(0.0),
    anchor_utc_(config.start_utc),
    acceleration_(config.time_acceleration),
    air_temperature_(config.air_temperature),
    timeline_(config.timeline)
{
  if (!std::isfinite(site_.latitude_deg) || std::abs(site_.latitude_deg) > 90.0)
    throw std::invalid_argument("latitude = " + number(site_.latitude_deg) + " must be in [-90, 90] deg");
  if (!std::isfinite(site_.longitude_deg) || site_.longitude_deg < -180.0 || site_.longitude_deg > 360.0)
    throw std::invalid_argument("longitude = " + number(site_.longitude_deg) + " must be in [-180, 360] deg");
  if (!std::isfinite(site_.altitude_m) || site_.altitude_m < -500.0 || site_.altitude_m > 9000.0)
    throw std::invalid_argument("altitude = " + number(site_.altitude_m) + " must be in [-500, 9000] m");
  setTime(0.0, config.start_utc, config.time_acceleration);
  checkWeather(WeatherState{}, air_temperature_);
  pressure_hpa_ = 1013.25 * std::pow(1.0 - 2.25577e-5 * site_.altitude_m, 5.25588);
}

void EnvironmentModel::setTime(double t, double utc, double acceleration)
{
  // Years 1800-2200: the series' stated range; further out the Moon drifts.
  if (!std::isfinite(utc) || utc < -5364662400.0 || utc > 7258118400.0)
    throw std::invalid_argument("utc = " + number(utc) + " s must be a time between 1800 and 2200");
  if (!std::isfinite(acceleration) || acceleration <= 0.0 || acceleration > 1e6)
    throw std::invalid_argument("time_acceleration = " + number(acceleration) + " must be in (0, 1e6]");
  if (!std::isfinite(t))
    throw std::invalid_argument("sim time must be finite");
  anchor_t_ = t;
  anchor_utc_ = utc;
  acceleration_ = acceleration;
}

void EnvironmentModel::overrideWeather(const WeatherState& weather, double air_temperature)
{
  checkWeather(weather, air_temperature);
  override_ = weather;
  air_temperature_ = air_temperature;
}

EnvironmentState EnvironmentModel::at(double t) const
{
  EnvironmentState s;
  s.utc = utcAt(t);
  s.time_acceleration = acceleration_;
  s.air_temperature = air_temperature_;
  s.weather = override_ ? *override_ : timeline_.at(t);
  s.sky = skyAt(s.utc, site_, Atmosphere{ pressure_hpa_, air_temperature_ });
  s.ambient_light = ambientIlluminance(s.sky.sun.elevation, s.sky.moon.elevation, s.sky.moon_phase_angle,
                                       overcastFraction(s.weather));
  return s;
}

}  // namespace environment
}  // namespace avsp
