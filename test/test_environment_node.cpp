// rostest of environment_node (test/environment_node.test). This node owns /clock and
// advances it in 10 ms steps (lockstep), so every check is on sim time; wall deadlines only
// guard against a hang.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <avsp_msgs/Environment.h>
#include <avsp_msgs/SetEnvironment.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <avsp_terrain/ros/run_command.hpp>
#include <avsp_terrain/ros/test_clock.hpp>

#include "avsp/environment/environment_model.hpp"

namespace ae = avsp::environment;

namespace
{
constexpr double kStep = 0.01;  // s of sim time per /clock message

/// The test's world: the /clock it drives and the /environment messages it received.
struct World
{
  ros::NodeHandle nh;
  avsp::node::TestClock clock{ kStep };
  avsp::node::TopicRecorder<avsp_msgs::Environment> environment{ "/environment" };
  const std::vector<avsp_msgs::Environment>& received = environment.messages();

  double now() const { return clock.now(); }
  /// Steps the clock to sim time `t`, giving the node 1 ms of wall time per step.
  void advanceTo(double t) { clock.advanceTo(t, 0.001); }
  /// Keeps the clock where it is and spins until `done` or `timeout` wall seconds.
  bool waitFor(const std::function<bool()>& done, double timeout = 10.0) { return clock.waitFor(done, timeout, 0.005); }

  /// The first message stamped at or after sim time t (nullptr if none).
  const avsp_msgs::Environment* at(double t) const
  {
    for (const auto& m : received)
      if (m.header.stamp.toSec() >= t - 1e-9)
        return &m;
    return nullptr;
  }
};

World* world = nullptr;

ae::EnvironmentModel referenceModel()
{
  ae::EnvironmentConfig config;
  config.site = { 39.742476, -105.1786, 1830.14 };
  config.start_utc = ae::parseUtc("2003-10-17T19:30:30Z");
  config.time_acceleration = 60.0;
  return ae::EnvironmentModel(config);
}

TEST(EnvironmentNode, RateAndContentOnSimTime)
{
  World& w = *world;
  ASSERT_TRUE(w.waitFor([&] { return w.clock.subscribers() > 0 && w.environment.connected(); }))
      << "environment_node did not connect";
  w.advanceTo(45.0);
  ASSERT_TRUE(w.waitFor([&] { return !w.received.empty() && w.received.back().header.stamp.toSec() >= 44.9; }))
      << "no /environment message up to sim time 45 s";

  // Rate: one message per multiple of 0.5 s the clock reached (2 Hz on sim time), stamped with
  // it: exactly 80 over [5, 45) s, none skipped, none twice.
  std::vector<double> stamps;
  for (const auto& m : w.received)
    if (m.header.stamp.toSec() >= 5.0 && m.header.stamp.toSec() < 45.0)
      stamps.push_back(m.header.stamp.toSec());
  ASSERT_EQ(stamps.size(), 80u) << "messages in 40 s of sim time at 2 Hz";
  for (std::size_t k = 0; k < stamps.size(); ++k)
    EXPECT_NEAR(stamps[k], 5.0 + 0.5 * static_cast<double>(k), 1e-9) << "message " << k;

  // Content: world time is start + 60 x sim time; Sun and Moon as the core computes them.
  const ae::EnvironmentModel model = referenceModel();
  const double start = ae::parseUtc("2003-10-17T19:30:30Z");
  for (const auto& m : w.received)
  {
    const double t = m.header.stamp.toSec();
    ASSERT_NEAR(m.utc.toSec(), start + 60.0 * t, 1e-3) << "at sim " << t;
    EXPECT_EQ(m.header.frame_id, "map");
    EXPECT_EQ(m.time_acceleration, 60.0);
    const ae::EnvironmentState s = model.at(t);
    EXPECT_NEAR(m.sun_elevation, s.sky.sun.elevation, 1e-6) << "at sim " << t;
    EXPECT_NEAR(m.sun_azimuth, s.sky.sun.azimuth, 1e-6) << "at sim " << t;
    EXPECT_NEAR(m.moon_elevation, s.sky.moon.elevation, 1e-6) << "at sim " << t;
    EXPECT_NEAR(m.moon_illumination, s.sky.moon_illumination, 1e-9);
    EXPECT_NEAR(std::hypot(std::hypot(m.sun_direction.x, m.sun_direction.y), m.sun_direction.z), 1.0, 1e-9);
    EXPECT_NEAR(std::asin(m.sun_direction.z), m.sun_elevation, 1e-9);
    EXPECT_GT(m.ambient_light, 1000.0);  // mid-afternoon in Colorado
  }
  // The first message (sim 0.5 s = 30 world s after the NREL SPA instant): the Sun is near
  // the SPA example's azimuth 194.34 deg and zenith 50.11 deg.
  const avsp_msgs::Environment* first = w.at(0.0);
  ASSERT_NE(first, nullptr);
  EXPECT_NEAR(first->sun_azimuth * ae::kRadToDeg, 194.34, 0.5);
  EXPECT_NEAR(90.0 - first->sun_elevation * ae::kRadToDeg, 50.11, 0.5);

  // Weather timeline: rain ramps 5-7 s up, 13-15 s down; fog 150 m over [10, 40).
  const avsp_msgs::Environment* dry = w.at(3.0);
  const avsp_msgs::Environment* ramp = w.at(6.0);
  const avsp_msgs::Environment* wet = w.at(10.0);
  const avsp_msgs::Environment* fog = w.at(20.0);
  const avsp_msgs::Environment* clear = w.at(41.0);
  ASSERT_TRUE(dry && ramp && wet && fog && clear);
  EXPECT_EQ(dry->rain_rate_mm_h, 0.0);
  EXPECT_TRUE(std::isinf(dry->fog_visibility));
  EXPECT_NEAR(ramp->rain_rate_mm_h, 12.0 * (ramp->header.stamp.toSec() - 5.0) / 2.0, 1e-6);
  EXPECT_NEAR(wet->rain_rate_mm_h, 12.0, 1e-9);
  EXPECT_NEAR(wet->fog_visibility, 150.0, 1e-9);
  EXPECT_NEAR(wet->wind.x, 3.0, 1e-12);
  EXPECT_EQ(fog->rain_rate_mm_h, 0.0);
  EXPECT_NEAR(fog->fog_visibility, 150.0, 1e-9);
  EXPECT_LT(wet->ambient_light, dry->ambient_light * 0.5);  // overcast under rain
  EXPECT_TRUE(std::isinf(clear->fog_visibility));
  EXPECT_EQ(clear->wind.x, 0.0);
}

TEST(EnvironmentNode, SetEnvironmentJumpsTimeAndOverridesWeather)
{
  World& w = *world;
  ASSERT_TRUE(ros::service::waitForService("/environment/set_environment", 10000));
  ros::ServiceClient client = w.nh.serviceClient<avsp_msgs::SetEnvironment>("/environment/set_environment");

  // Refused requests change nothing and say why.
  avsp_msgs::SetEnvironment bad;
  bad.request.set_time = true;
  bad.request.utc = ros::Time(ae::parseUtc("2003-10-18T07:00:00Z"));
  bad.request.time_acceleration = -1.0;
  ASSERT_TRUE(client.call(bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("time_acceleration"), std::string::npos) << bad.response.message;
  avsp_msgs::SetEnvironment bad_weather;
  bad_weather.request.set_weather = true;
  bad_weather.request.fog_visibility = 100.0;
  bad_weather.request.rain_rate_mm_h = -3.0;
  bad_weather.request.air_temperature = 280.0;
  ASSERT_TRUE(client.call(bad_weather));
  EXPECT_FALSE(bad_weather.response.success);
  EXPECT_NE(bad_weather.response.message.find("rain_rate_mm_h"), std::string::npos) << bad_weather.response.message;
  avsp_msgs::SetEnvironment nothing;
  ASSERT_TRUE(client.call(nothing));
  EXPECT_FALSE(nothing.response.success);

  const double before = w.now();
  w.advanceTo(before + 2.0);
  const avsp_msgs::Environment* unchanged = w.at(before + 0.5);
  ASSERT_NE(unchanged, nullptr);
  EXPECT_NEAR(unchanged->utc.toSec(), ae::parseUtc("2003-10-17T19:30:30Z") + 60.0 * unchanged->header.stamp.toSec(),
              1e-3);

  // Jump to local midnight (00:00 MST), real-time pace; snow and fog for the rest of the run.
  const double midnight = ae::parseUtc("2003-10-18T07:00:00Z");
  avsp_msgs::SetEnvironment jump;
  jump.request.set_time = true;
  jump.request.utc = ros::Time(midnight);
  jump.request.time_acceleration = 1.0;
  jump.request.set_weather = true;
  jump.request.fog_visibility = 80.0;
  jump.request.snow_rate_mm_h = 4.0;
  jump.request.wind.y = -2.0;
  jump.request.air_temperature = 268.15;
  const double jump_at = w.now();
  ASSERT_TRUE(client.call(jump));
  EXPECT_TRUE(jump.response.success) << jump.response.message;
  w.advanceTo(jump_at + 3.0);
  ASSERT_TRUE(w.waitFor([&] { return w.received.back().header.stamp.toSec() >= jump_at + 2.4; }));
  const avsp_msgs::Environment* night = w.at(jump_at + 0.5);
  ASSERT_NE(night, nullptr);
  EXPECT_NEAR(night->utc.toSec(), midnight + (night->header.stamp.toSec() - jump_at), 1e-3);
  EXPECT_EQ(night->time_acceleration, 1.0);
  EXPECT_LT(night->sun_elevation, -0.5);  // ~ -58 deg at lower culmination
  EXPECT_LT(night->ambient_light, 0.5);
  EXPECT_EQ(night->snow_rate_mm_h, 4.0);
  EXPECT_EQ(night->rain_rate_mm_h, 0.0);
  EXPECT_EQ(night->fog_visibility, 80.0);
  EXPECT_EQ(night->wind.y, -2.0);
  EXPECT_EQ(night->air_temperature, 268.15);
}

/// Runs environment_node under a fresh name with the given private parameters (set on the
/// master, as lists cannot be given on the command line): returns its exit code and output.
std::pair<int, std::string> runBadNode(const std::function<void(const std::string&)>& set_params)
{
  static int run = 0;
  const std::string name = "bad_environment_" + std::to_string(getpid()) + "_" + std::to_string(run++);
  ros::NodeHandle nh;
  nh.setParam("/" + name + "/latitude", 45.0);
  nh.setParam("/" + name + "/longitude", 7.0);
  nh.setParam("/" + name + "/start_utc", std::string("2025-06-21T10:00:00Z"));
  set_params("/" + name + "/");
  return avsp::node::runCommand(std::string(ENVIRONMENT_NODE_PATH) + " __name:=" + name);
}

TEST(EnvironmentNodeStartup, BadParametersExitNamingTheKey)
{
  ros::NodeHandle nh;
  auto [code, out] = runBadNode([&](const std::string& ns) {
    XmlRpc::XmlRpcValue list, ok, bad;
    ok["start"] = 0.0;
    ok["end"] = 10.0;
    ok["fog_visibility"] = 300.0;
    bad["start"] = 20.0;
    bad["end"] = 30.0;
    bad["rain_rate_mm_h"] = -5.0;
    list[0] = ok;
    list[1] = bad;
    nh.setParam(ns + "weather", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~weather[1].rain_rate_mm_h"), std::string::npos) << out;

  std::tie(code, out) = runBadNode([&](const std::string& ns) {
    XmlRpc::XmlRpcValue list, typo;
    typo["start"] = 0.0;
    typo["end"] = 10.0;
    typo["snow_rate"] = 2.0;
    list[0] = typo;
    nh.setParam(ns + "weather", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~weather[0].snow_rate: unknown key"), std::string::npos) << out;

  std::tie(code, out) = runBadNode([&](const std::string& ns) { nh.deleteParam(ns + "latitude"); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~latitude"), std::string::npos) << out;

  std::tie(code, out) = runBadNode([&](const std::string& ns) { nh.setParam(ns + "start_utc", std::string("noon")); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~start_utc"), std::string::npos) << out;

  std::tie(code, out) = runBadNode([&](const std::string& ns) { nh.setParam(ns + "time_acceleration", 0.0); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~time_acceleration"), std::string::npos) << out;

  std::tie(code, out) = runBadNode([&](const std::string& ns) { nh.setParam(ns + "latitude", 95.0); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~latitude"), std::string::npos) << out;
}
}  // namespace

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_environment_node");
  World w;
  world = &w;
  return RUN_ALL_TESTS();
}
