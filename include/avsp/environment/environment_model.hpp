#pragma once
/**
 * @file environment_model.hpp
 * @brief The simulated world's clock, sky, light and weather (docs/MODELS.md section 6), no ROS:
 *        what environment_node publishes on /environment.
 *
 * World time: utc(t) = anchor_utc + time_acceleration * (t - anchor_t) for sim-clock time t
 * (s); the anchor starts at (0, start_utc) and moves when setTime() jumps the clock.
 */
#include <optional>

#include "avsp/environment/astronomy.hpp"
#include "avsp/environment/weather.hpp"

namespace avsp
{
namespace environment
{
/**
 * @brief Overcast fraction in [0, 1] the weather implies: 1 with any rain, snow or hail,
 *        else 1 - visibility / 10 km for fog thicker than 10 km visibility, else 0.
 */
double overcastFraction(const WeatherState& weather);

/**
 * @brief Horizontal illuminance (lx) from the Sun, the sky, the Moon and the night sky.
 *
 * Day (Sun above the horizon): the IES daylight model, clear sky: direct 127.5 klx
 * exp(-0.21 m) sin h (m: Kasten-Young air mass) plus sky 0.8 klx + 15.5 klx sqrt(sin h);
 * overcast sky: 0.3 klx + 21 klx sin h, no direct light; blended by `overcast`. Twilight:
 * log-linear in elevation through the daylight value at 0 deg, 3.4 lx at -6 deg (end of
 * civil twilight), 0.008 lx at -12 deg (nautical), 6e-4 lx at -18 deg (astronomical), each
 * scaled by the overcast/clear ratio at the horizon, fading out by -21 deg. Moon: its
 * magnitude -12.73 + 0.026 |i| + 4e-9 i^4 (i phase angle in deg, Krisciunas & Schaefer 1991)
 * as illuminance 10^(-0.4 (mag + 13.99)) lx, times sin h_moon and the clear-air
 * transmittance, dimmed 90 % by full overcast. Night sky (stars, airglow): 0.001 lx.
 * @param sun_elevation, moon_elevation rad, apparent
 * @param moon_phase_angle rad (0 full, pi new)
 * @param overcast [0, 1]
 */
double ambientIlluminance(double sun_elevation, double moon_elevation, double moon_phase_angle, double overcast);

/// What the model needs at start-up.
struct EnvironmentConfig
{
  Site site;                        ///< the scenario's geodetic reference
  double start_utc = 0.0;           ///< Unix s, world time at sim time 0
  double time_acceleration = 1.0;   ///< world seconds per sim-clock second, > 0
  double air_temperature = 288.15;  ///< K, > 0
  WeatherTimeline timeline;         ///< weather events over sim time
};

/// Everything /environment carries, at one sim time.
struct EnvironmentState
{
  double utc = 0.0;                ///< Unix s
  double time_acceleration = 1.0;  ///< world s per sim s
  SkyState sky;                    ///< Sun and Moon
  double ambient_light = 0.0;      ///< lx
  WeatherState weather;
  double air_temperature = 0.0;  ///< K
};

class EnvironmentModel
{
public:
  /// @throw std::invalid_argument naming the field (site.latitude_deg, time_acceleration, ...)
  explicit EnvironmentModel(const EnvironmentConfig& config);

  /// The world at sim time t (s).
  EnvironmentState at(double t) const;

  /// World UTC (Unix s) at sim time t.
  double utcAt(double t) const { return anchor_utc_ + acceleration_ * (t - anchor_t_); }
  double timeAcceleration() const { return acceleration_; }

  /**
   * @brief From sim time t on, world time is `utc` and runs at `acceleration`.
   * @throw std::invalid_argument naming utc or time_acceleration; the model is unchanged
   */
  void setTime(double t, double utc, double acceleration);

  /**
   * @brief Replaces the timeline's weather by `weather` (and the air temperature) for the
   *        rest of the run.
   * @throw std::invalid_argument naming the field; the model is unchanged
   */
  void overrideWeather(const WeatherState& weather, double air_temperature);
  bool weatherOverridden() const { return override_.has_value(); }

  /// Station pressure (hPa) at the site's altitude (standard atmosphere), used for refraction.
  double pressureHpa() const { return pressure_hpa_; }

private:
  Site site_;
  double anchor_t_ = 0.0, anchor_utc_ = 0.0, acceleration_ = 1.0;
  double air_temperature_ = 288.15;
  double pressure_hpa_ = 1013.25;
  WeatherTimeline timeline_;
  std::optional<WeatherState> override_;
};

}  // namespace environment
}  // namespace avsp
