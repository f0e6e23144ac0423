// environment_node's class (the node's main is ../environment_node.cpp): the simulated world's
// clock, Sun, Moon, light and weather on /environment (avsp_msgs/Environment) at ~rate on sim
// time, changed at run time through ~set_environment (avsp_msgs/SetEnvironment). On sim time a
// message goes out for every multiple of 1/~rate that /clock reaches, stamped with that
// multiple, in order and none skipped (sensors_node ~environment_period waits for them), so
// what a run's sensors see of the weather does not depend on how fast the clock moves. The model is
// avsp_environment (include/avsp/environment/); this file only converts parameters and messages.
#include "avsp/ros/environment_node.hpp"

#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <avsp_msgs/Environment.h>
#include <avsp_msgs/SetEnvironment.h>
#include <avsp_terrain/geodetic_reference.hpp>
#include <avsp_terrain/ros/node_params.hpp>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include "avsp/environment/environment_model.hpp"

namespace avsp
{
namespace node
{
namespace
{
namespace ae = avsp::environment;

// ros::Time holds 1970-01-01 .. 2106-02-07; the model accepts 1800-2200.
constexpr double kMinUtc = ae::kRosTimeMinUtc;
constexpr double kMaxUtc = ae::kRosTimeMaxUtc;

/// ~weather: a list of {start, end, ramp?, fog_visibility?, rain_rate_mm_h?, ...}, through the
/// reader the scenario loader uses.
ae::WeatherTimeline weatherFromParams(const ros::NodeHandle& pnh)
{
  XmlRpc::XmlRpcValue list;
  if (!avsp::node::structuredParam(pnh, "weather", list))
    return {};
  try
  {
    return ae::WeatherTimeline(ae::parseWeatherEvents(avsp::node::toYaml(list), "~weather"));
  }
  catch (const ae::WeatherError& e)
  {
    throw StartupError(std::string("parameter ") + e.what());
  }
}

geometry_msgs::Vector3 vector3(const std::array<double, 3>& v)
{
  geometry_msgs::Vector3 out;
  out.x = v[0];
  out.y = v[1];
  out.z = v[2];
  return out;
}

}  // namespace

class EnvironmentNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh)
  {
    ae::EnvironmentConfig config;
    double* const site[] = { &config.site.latitude_deg, &config.site.longitude_deg, &config.site.altitude_m };
    for (std::size_t k = 0; k < 3; ++k)
    {
      const avsp::terrain::GeodeticNumber& n = avsp::terrain::geodeticReferenceNumbers()[k];
      if (n.required && !pnh.hasParam(n.key))
      {
        std::ostringstream what;
        what << "parameter ~" << n.key << " (" << n.unit << ", [" << n.min << ", " << n.max << "]) is required";
        throw StartupError(what.str());
      }
      *site[k] = boundedParam(pnh, n.key, n.fallback, n.min, n.max);
    }
    std::string start_utc;
    if (!pnh.getParam("start_utc", start_utc))
      throw StartupError("parameter ~start_utc (string, ISO 8601 UTC such as 2025-06-21T10:30:00Z) is required");
    try
    {
      config.start_utc = ae::parseRunStartUtc(start_utc);  // the rule scenario_launch --check applies
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError("parameter ~start_utc: " + std::string(e.what()));
    }
    config.time_acceleration = avsp::node::runNumberParam(pnh, avsp::terrain::kTimeAcceleration);
    config.air_temperature = boundedParam(pnh, "air_temperature", 288.15, 150.0, 350.0);
    const double rate = boundedParam(pnh, "rate", 1.0, 0.01, 100.0);
    frame_id_ = avsp::node::stringParam(pnh, "frame_id", "map");
    config.timeline = weatherFromParams(pnh);
    try
    {
      model_ = std::make_unique<ae::EnvironmentModel>(config);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError("parameter ~" + std::string(e.what()));
    }

    // On sim time the model's clock is /clock itself; on wall time it starts with the node.
    origin_ = ros::Time::isSimTime() ? 0.0 : ros::Time::now().toSec();
    // Latched: a node that subscribes late still gets the weather now.
    pub_ = nh.advertise<avsp_msgs::Environment>("/environment", 1000, true);
    service_ = pnh.advertiseService("set_environment", &Impl::onSetEnvironment, this);
    period_ = 1.0 / rate;
    if (ros::Time::isSimTime())
      clock_sub_ = nh.subscribe("/clock", 100, &Impl::onClock, this, ros::TransportHints().tcpNoDelay());
    else
      timer_ = nh.createTimer(ros::Duration(period_), &Impl::onTimer, this);
    ROS_INFO(
        "environment_node: site %.6f, %.6f, %.0f m; world time %s at sim 0, x%g; %zu weather events; "
        "/environment at %g Hz",
        config.site.latitude_deg, config.site.longitude_deg, config.site.altitude_m,
        ae::formatUtc(config.start_utc).c_str(), config.time_acceleration, config.timeline.events().size(), rate);
  }

private:
  void onTimer(const ros::TimerEvent&) { publishAt(ros::Time::now()); }

  /// Every multiple of the period the clock has reached, in order. A clock that went back (a
  /// new run on the same master) starts the sequence again from there.
  void onClock(const rosgraph_msgs::Clock::ConstPtr& c)
  {
    const double t = c->clock.toSec();
    if (next_ > 0 && t < static_cast<double>(next_ - 1) * period_ - 1e-9)
      next_ = static_cast<std::uint64_t>(std::ceil(t / period_ - 1e-9));
    while (ros::ok() && static_cast<double>(next_) * period_ <= t + 1e-9)
      publishAt(ros::Time(static_cast<double>(next_++) * period_));
  }

  void publishAt(const ros::Time& now)
  {
    const ae::EnvironmentState s = model_->at(now.toSec() - origin_);
    avsp_msgs::Environment msg;
    msg.header.stamp = now;
    msg.header.frame_id = frame_id_;
    msg.utc = ros::Time(std::min(kMaxUtc, std::max(kMinUtc, s.utc)));
    msg.time_acceleration = s.time_acceleration;
    msg.sun_direction = vector3(s.sky.sun.direction);
    msg.sun_elevation = s.sky.sun.elevation;
    msg.sun_azimuth = s.sky.sun.azimuth;
    msg.moon_direction = vector3(s.sky.moon.direction);
    msg.moon_elevation = s.sky.moon.elevation;
    msg.moon_azimuth = s.sky.moon.azimuth;
    msg.moon_illumination = s.sky.moon_illumination;
    msg.ambient_light = s.ambient_light;
    msg.fog_visibility = s.weather.fog_visibility;
    msg.rain_rate_mm_h = s.weather.rain_rate_mm_h;
    msg.snow_rate_mm_h = s.weather.snow_rate_mm_h;
    msg.hail_rate_mm_h = s.weather.hail_rate_mm_h;
    msg.wind.x = s.weather.wind_x;
    msg.wind.y = s.weather.wind_y;
    msg.wind.z = s.weather.wind_z;
    msg.air_temperature = s.air_temperature;
    pub_.publish(msg);
  }

  bool onSetEnvironment(avsp_msgs::SetEnvironment::Request& req, avsp_msgs::SetEnvironment::Response& res)
  {
    if (!req.set_time && !req.set_weather)
    {
      res.success = false;
      res.message = "nothing to change: set_time and set_weather are both false";
      return true;
    }
    const double now = ros::Time::now().toSec() - origin_;
    ae::EnvironmentModel changed = *model_;  // all or nothing: apply to a copy first
    std::string what;
    try
    {
      if (req.set_time)
      {
        const double utc = req.utc.toSec();
        if (utc <= kMinUtc)
          throw std::invalid_argument("utc must be set (after 1970-01-01)");
        changed.setTime(now, utc, req.time_acceleration);
        what += "world time " + ae::formatUtc(utc) + " at sim " + std::to_string(now) + " s, x" +
                std::to_string(req.time_acceleration) + "; ";
      }
      if (req.set_weather)
      {
        ae::WeatherState w;
        w.fog_visibility = req.fog_visibility;
        w.rain_rate_mm_h = req.rain_rate_mm_h;
        w.snow_rate_mm_h = req.snow_rate_mm_h;
        w.hail_rate_mm_h = req.hail_rate_mm_h;
        w.wind_x = req.wind.x;
        w.wind_y = req.wind.y;
        w.wind_z = req.wind.z;
        changed.overrideWeather(w, req.air_temperature);
        what += "weather overridden for the rest of the run (timeline no longer used)";
      }
    }
    catch (const std::invalid_argument& e)
    {
      res.success = false;
      res.message = std::string("refused, nothing changed: ") + e.what();
      ROS_WARN("environment_node: ~set_environment %s", res.message.c_str());
      return true;
    }
    *model_ = changed;
    res.success = true;
    res.message = what;
    ROS_INFO("environment_node: %s", what.c_str());
    return true;
  }

  std::unique_ptr<ae::EnvironmentModel> model_;
  double origin_ = 0.0;  ///< ROS time (s) that is the model's time 0
  std::string frame_id_;
  ros::Publisher pub_;
  ros::ServiceServer service_;
  ros::Timer timer_;           ///< wall time: at ~rate
  ros::Subscriber clock_sub_;  ///< sim time: every multiple of the period /clock reaches
  double period_ = 1.0;        ///< s, 1 / ~rate
  std::uint64_t next_ = 0;     ///< the next multiple of the period to publish
};

EnvironmentNode::EnvironmentNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

EnvironmentNode::~EnvironmentNode() = default;

int EnvironmentNode::spin()
{
  ros::spin();
  return 0;
}

}  // namespace node
}  // namespace avsp
