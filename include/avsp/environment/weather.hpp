#pragma once
/**
 * @file weather.hpp
 * @brief Weather from a timeline of events (fog, rain, snow, hail, wind), no ROS.
 *
 * An event holds its values from `start` to `end` (sim-clock seconds), ramping linearly
 * from nothing over the first and last `ramp` seconds. Overlapping events add their rain,
 * snow and hail rates, wind vectors and fog extinction coefficients. Fog is interpolated
 * through its extinction coefficient sigma = 3.912 / visibility (Koschmieder), so half-way
 * through a ramp towards 200 m fog the visibility is 400 m, and two 400 m fogs make 200 m.
 */
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace avsp
{
namespace environment
{
/// Koschmieder's constant: visibility (m) = kKoschmieder / extinction coefficient (1/m).
constexpr double kKoschmieder = 3.912;

/// Weather at one instant.
struct WeatherState
{
  double fog_visibility = std::numeric_limits<double>::infinity();  ///< m; +inf = no fog
  double rain_rate_mm_h = 0.0;                                      ///< mm/h
  double snow_rate_mm_h = 0.0;                                      ///< mm/h, liquid-water equivalent
  double hail_rate_mm_h = 0.0;                                      ///< mm/h, liquid-water equivalent
  double wind_x = 0.0, wind_y = 0.0, wind_z = 0.0;                  ///< m/s, air velocity in map (ENU)
};

/// One timeline entry.
struct WeatherEvent
{
  double start = 0.0;  ///< s, sim clock
  double end = 0.0;    ///< s, sim clock, > start
  double ramp = 0.0;   ///< s, linear fade in after start and out before end; 2 ramp <= end - start
  double fog_visibility = std::numeric_limits<double>::infinity();          ///< m at full strength; +inf = no fog
  double rain_rate_mm_h = 0.0, snow_rate_mm_h = 0.0, hail_rate_mm_h = 0.0;  ///< at full strength
  double wind_x = 0.0, wind_y = 0.0, wind_z = 0.0;                          ///< m/s at full strength
};

/// A bad timeline entry: the message names the entry ("weather[2]") and the key.
struct WeatherError : std::invalid_argument
{
  using std::invalid_argument::invalid_argument;
};

/**
 * @brief Builds an event from the keys of one timeline entry (as read from YAML/XML-RPC).
 *
 * Keys: start, end (s, required), ramp (s, default 0), fog_visibility (m, > 0),
 * rain_rate_mm_h, snow_rate_mm_h, hail_rate_mm_h (mm/h, >= 0), wind_x, wind_y, wind_z (m/s);
 * at least one weather key. Every value must be finite (fog_visibility may be .inf).
 * @param where the entry's name in messages, e.g. "~weather[2]"
 * @param numbers the entry's numeric keys
 * @param other_keys keys present with a value that is not a number (each is an error)
 * @throw WeatherError naming `where` and the key: missing, unknown, not a number, out of range
 */
WeatherEvent makeWeatherEvent(const std::string& where, const std::map<std::string, double>& numbers,
                              const std::vector<std::string>& other_keys = {});

/**
 * @brief The one reader of a weather list: the scenario's `weather` (its YAML) and
 *        environment_node's `~weather` (its XML-RPC value as YAML) alike. Each entry a map whose
 *        plain numeric scalars go to makeWeatherEvent() (a quoted scalar is not a number).
 * @param list_key names the list in messages ("weather", "~weather")
 * @throw WeatherError "<list_key> must be a list ...", "<list_key>[k] must be a map ...", a key
 *        given twice, or what makeWeatherEvent() refuses
 */
std::vector<WeatherEvent> parseWeatherEvents(const YAML::Node& list, const std::string& list_key);

/// The events' weather over sim time.
class WeatherTimeline
{
public:
  WeatherTimeline() = default;
  /// @throw WeatherError naming the event ("weather[k]") if one is inconsistent
  explicit WeatherTimeline(std::vector<WeatherEvent> events);

  /// Weather at sim time t (s): the sum of the events active at t (clear sky when none).
  WeatherState at(double t) const;

  /// Strength in [0, 1] of event `e` at time t (the ramp profile).
  static double strength(const WeatherEvent& e, double t);

  const std::vector<WeatherEvent>& events() const { return events_; }

private:
  std::vector<WeatherEvent> events_;
};

}  // namespace environment
}  // namespace avsp
