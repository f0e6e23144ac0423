#include "avsp/environment/weather.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace avsp
{
namespace environment
{
namespace
{
std::string number(double v)
{
  std::ostringstream s;
  s << v;
  return s.str();
}

void checkEvent(const std::string& where, const WeatherEvent& e)
{
  if (!std::isfinite(e.start) || e.start < 0.0)
    throw WeatherError(where + ".start = " + number(e.start) + " must be finite and >= 0 (s, sim clock)");
  if (!std::isfinite(e.end) || e.end <= e.start)
    throw WeatherError(where + ".end = " + number(e.end) + " must be finite and > start (" + number(e.start) + ")");
  if (!std::isfinite(e.ramp) || e.ramp < 0.0 || 2.0 * e.ramp > e.end - e.start)
    throw WeatherError(where + ".ramp = " + number(e.ramp) + " must be >= 0 and at most half of end - start (" +
                       number(e.end - e.start) + " s)");
  if (std::isnan(e.fog_visibility) || e.fog_visibility <= 0.0)
    throw WeatherError(where + ".fog_visibility = " + number(e.fog_visibility) + " must be > 0 (m; .inf = no fog)");
  const std::pair<const char*, double> rates[] = { { "rain_rate_mm_h", e.rain_rate_mm_h },
                                                   { "snow_rate_mm_h", e.snow_rate_mm_h },
                                                   { "hail_rate_mm_h", e.hail_rate_mm_h } };
  for (const auto& [key, value] : rates)
    if (!std::isfinite(value) || value < 0.0)
      throw WeatherError(where + "." + key + " = " + number(value) + " must be finite and >= 0 (mm/h)");
  const std::pair<const char*, double> wind[] = { { "wind_x", e.wind_x },
                                                  { "wind_y", e.wind_y },
                                                  { "wind_z", e.wind_z } };
  for (const auto& [key, value] : wind)
    if (!std::isfinite(value))
      throw WeatherError(where + "." + key + " = " + number(value) + " must be finite (m/s)");
}
}  // namespace

WeatherEvent makeWeatherEvent(const std::string& where, const std::map<std::string, double>& numbers,
                              const std::vector<std::string>& other_keys)
{
  static const std::set<std::string> kWeatherKeys = { "fog_visibility", "rain_rate_mm_h", "snow_rate_mm_h",
                                                      "hail_rate_mm_h", "wind_x",         "wind_y",
                                                      "wind_z" };
  static const std::set<std::string> kTimeKeys = { "start", "end", "ramp" };
  for (const std::string& key : other_keys)
  {
    if (kWeatherKeys.count(key) == 0 && kTimeKeys.count(key) == 0)
      throw WeatherError(where + "." + key +
                         ": unknown key (known: start, end, ramp, fog_visibility, "
                         "rain_rate_mm_h, snow_rate_mm_h, hail_rate_mm_h, wind_x, wind_y, wind_z)");
    throw WeatherError(where + "." + key + " must be a number");
  }
  bool has_weather = false;
  for (const auto& [key, value] : numbers)
  {
    (void)value;
    if (kWeatherKeys.count(key) > 0)
      has_weather = true;
    else if (kTimeKeys.count(key) == 0)
      throw WeatherError(where + "." + key +
                         ": unknown key (known: start, end, ramp, fog_visibility, "
                         "rain_rate_mm_h, snow_rate_mm_h, hail_rate_mm_h, wind_x, wind_y, wind_z)");
  }
  for (const char* required : { "start", "end" })
    if (numbers.count(required) == 0)
      throw WeatherError(where + "." + required + " is missing (s, sim clock)");
  if (!has_weather)
    throw WeatherError(where +
                       " sets no weather: give at least one of fog_visibility, rain_rate_mm_h, "
                       "snow_rate_mm_h, hail_rate_mm_h, wind_x, wind_y, wind_z");
  auto get = [&](const char* key, double fallback) {
    const auto it = numbers.find(key);
    return it == numbers.end() ? fallback : it->second;
  };
  WeatherEvent e;
  e.start = get("start", 0.0);
  e.end = get("end", 0.0);
  e.ramp = get("ramp", 0.0);
  e.fog_visibility = get("fog_visibility", std::numeric_limits<double>::infinity());
  e.rain_rate_mm_h = get("rain_rate_mm_h", 0.0);
  e.snow_rate_mm_h = get("snow_rate_mm_h", 0.0);
  e.hail_rate_mm_h = get("hail_rate_mm_h", 0.0);
  e.wind_x = get("wind_x", 0.0);
  e.wind_y = get("wind_y", 0.0);
  e.wind_z = get("wind_z", 0.0);
  checkEvent(where, e);
  return e;
}

std::vector<WeatherEvent> parseWeatherEvents(const YAML::Node& list, const std::string& list_key)
{
  if (!list.IsSequence())
    throw WeatherError(list_key + " must be a list of events {start, end, ...}");
  std::vector<WeatherEvent> events;
  for (std::size_t k = 0; k < list.size(); ++k)
  {
    const std::string where = list_key + "[" + std::to_string(k) + "]";
    const YAML::Node entry = list[k];
    if (!entry.IsMap())
      throw WeatherError(where + " must be a map {start, end, ...}");
    std::map<std::string, double> numbers;
    std::vector<std::string> others;
    std::set<std::string> seen;
    for (const auto& kv : entry)
    {
      if (!kv.first.IsScalar())
        throw WeatherError(where + ": a key is not a plain string");
      const std::string key = kv.first.Scalar();
      if (!seen.insert(key).second)
        throw WeatherError(where + "." + key + ": duplicate key");
      double v = 0.0;
      bool is_number = kv.second.IsScalar() && kv.second.Tag() != "!";
      if (is_number)
      {
        try
        {
          v = kv.second.as<double>();
        }
        catch (const YAML::Exception&)
        {
          is_number = false;
        }
      }
      if (is_number)
        numbers[key] = v;
      else
        others.push_back(key);
    }
    events.push_back(makeWeatherEvent(where, numbers, others));
  }
  return events;
}

WeatherTimeline::WeatherTimeline(std::vector<WeatherEvent> events) : events_(std::move(events))
{
  for (std::size_t k = 0; k < events_.size(); ++k)
    checkEvent("weather[" + std::to_string(k) + "]", events_[k]);
}

double WeatherTimeline::strength(const WeatherEvent& e, double t)
{
  if (t < e.start || t >= e.end)
    return 0.0;
  if (e.ramp <= 0.0)
    return 1.0;
  return std::min({ 1.0, (t - e.start) / e.ramp, (e.end - t) / e.ramp });
}

WeatherState WeatherTimeline::at(double t) const
{
  WeatherState w;
  double extinction = 0.0;  // 1/m
  for (const WeatherEvent& e : events_)
  {
    const double s = strength(e, t);
    if (s <= 0.0)
      continue;
    extinction += s * kKoschmieder / e.fog_visibility;  // 0 for .inf
    w.rain_rate_mm_h += s * e.rain_rate_mm_h;
    w.snow_rate_mm_h += s * e.snow_rate_mm_h;
    w.hail_rate_mm_h += s * e.hail_rate_mm_h;
    w.wind_x += s * e.wind_x;
    w.wind_y += s * e.wind_y;
    w.wind_z += s * e.wind_z;
  }
  w.fog_visibility = extinction > 0.0 ? kKoschmieder / extinction : std::numeric_limits<double>::infinity();
  return w;
}

}  // namespace environment
}  // namespace avsp
