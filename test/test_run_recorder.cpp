// run_recorder against what the test sees itself (test/run_recorder.test): the test starts
// run_recorder as a child process, drives two vehicles through avt_341/cmd_vel (lead ahead,
// follow behind with more throttle; lead brakes at ~brake_time and follow runs into it), records
// their odometry and telemetry, and when run_recorder has exited checks:
//  - it exited 0 at its ~duration of sim time and printed progress lines;
//  - every file exists; the PNGs are PNGs of a sane size;
//  - summary.json (parsed with yaml-cpp): each distance within 1 % of the distance the test
//    integrates from its own odometry over the same samples' time span, the collision counts
//    as telemetry gave them (at least one: the rear-end), max speed, ruts deeper than 0;
//  - gaps.csv: the follower's gap series over the run, each value the leader's x minus the
//    follower's at that stamp (a straight path along x: the distance along it) within 5 cm.
// Also: a NaN odometry message the test slips in is ignored with a warning naming the topic
// (the distances would be NaN otherwise); bad parameters exit 1 naming the parameter.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <avsp_msgs/VehicleTelemetry.h>
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <yaml-cpp/yaml.h>

#include <avsp_terrain/ros/ros_graph.hpp>
#include <avsp_terrain/ros/run_command.hpp>

namespace
{
struct Sample
{
  double t, x, y, z, speed;
};

/// The limits the recorder is given (fed_alpha's, but the follower "governed" at 1 m/s so that
/// its driving is counted as overspeed above 1.5 m/s).
constexpr double kLeadMaxSpeed = 30.0, kFollowMaxSpeed = 1.0, kWheelRadius = 0.546;

std::string readFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Width and height from a PNG's IHDR; {0, 0} if the file is not a PNG.
std::pair<unsigned, unsigned> pngSize(const std::string& path)
{
  const std::string b = readFile(path);
  if (b.size() < 33 || b.substr(0, 8) != std::string("\x89PNG\r\n\x1a\n", 8) || b.substr(12, 4) != "IHDR")
    return { 0, 0 };
  auto be32 = [&](std::size_t o) {
    return (static_cast<unsigned>(static_cast<unsigned char>(b[o])) << 24) |
           (static_cast<unsigned>(static_cast<unsigned char>(b[o + 1])) << 16) |
           (static_cast<unsigned>(static_cast<unsigned char>(b[o + 2])) << 8) |
           static_cast<unsigned>(static_cast<unsigned char>(b[o + 3]));
  };
  return { be32(16), be32(20) };
}

/// Sets the recorder's parameters under /<name>/ (vehicles lead and follow, follow behind lead).
void setRecorderParams(ros::NodeHandle& nh, const std::string& name, const std::string& output_dir, double duration)
{
  XmlRpc::XmlRpcValue vehicles, lead, follow;
  lead["name"] = std::string("lead");
  lead["leader"] = std::string("");
  lead["max_speed"] = kLeadMaxSpeed;
  lead["rest_height"] = kWheelRadius;
  lead["wheel_radius"] = kWheelRadius;
  follow["name"] = std::string("follow");
  follow["leader"] = std::string("lead");
  follow["max_speed"] = kFollowMaxSpeed;
  follow["rest_height"] = kWheelRadius;
  follow["wheel_radius"] = kWheelRadius;
  vehicles[0] = lead;
  vehicles[1] = follow;
  ros::NodeHandle pnh("~");
  std::string soils;
  pnh.getParam("soils_file", soils);
  const std::string ns = "/" + name + "/";
  nh.setParam(ns + "vehicles", vehicles);
  nh.setParam(ns + "output_dir", output_dir);
  nh.setParam(ns + "scenario_name", std::string("recorder_test"));
  nh.setParam(ns + "duration", duration);
  nh.setParam(ns + "progress_period", 0.5);
  nh.setParam(ns + "soils_file", soils);
  nh.setParam(ns + "flat_soil", std::string("sandy_loam"));
  nh.setParam(ns + "flat_size", 100.0);
}

/// A summary value as text ("null" for null).
std::string show(const YAML::Node& n)
{
  return n.IsNull() ? std::string("null") : n.as<std::string>();
}

/// Runs run_recorder named `name` to completion; {exit code, its output}.
std::pair<int, std::string> runRecorder(const std::string& name)
{
  return avsp::node::runCommand(std::string(RUN_RECORDER_PATH) + " __name:=" + name);
}
}  // namespace

TEST(RunRecorder, WritesTheResultsOfARunAtItsDuration)
{
  ros::NodeHandle nh, pnh("~");
  double duration = 0.0, brake_time = 0.0;
  ASSERT_TRUE(pnh.getParam("duration", duration) && pnh.getParam("brake_time", brake_time));
  char pattern[] = "/tmp/avsp_run_recorder_XXXXXX";
  ASSERT_NE(mkdtemp(pattern), nullptr);
  const std::string dir = std::string(pattern) + "/results/recorder_test";  // created by the node
  setRecorderParams(nh, "recorder", dir, duration);

  std::map<std::string, std::vector<Sample>> odom;
  std::map<std::string, std::uint32_t> collisions;
  std::vector<ros::Subscriber> subs;
  std::map<std::string, ros::Publisher> cmd;
  for (const std::string v : { "lead", "follow" })
  {
    subs.push_back(nh.subscribe<nav_msgs::Odometry>(
        "/" + v + "/avt_341/odometry", 5000, [&odom, v](const nav_msgs::Odometry::ConstPtr& m) {
          const auto& p = m->pose.pose.position;
          const auto& l = m->twist.twist.linear;
          // Not the test's own NaN or copy (below).
          if (std::isfinite(p.x) && (odom[v].empty() || m->header.stamp.toSec() > odom[v].back().t))
            odom[v].push_back({ m->header.stamp.toSec(), p.x, p.y, p.z, std::sqrt(l.x * l.x + l.y * l.y + l.z * l.z) });
        }));
    subs.push_back(nh.subscribe<avsp_msgs::VehicleTelemetry>(
        "/" + v + "/telemetry", 5000, [&collisions, v, duration](const avsp_msgs::VehicleTelemetry::ConstPtr& m) {
          if (m->header.stamp.toSec() <= duration)
            collisions[v] = m->collisions;
        }));
    cmd[v] = nh.advertise<geometry_msgs::Twist>("/" + v + "/avt_341/cmd_vel", 1, true);
  }

  // A bad odometry message among dynamics_node's: run_recorder must ignore it, naming the topic;
  // and a copy of one of dynamics_node's, which is not a new sample.
  ros::Publisher bad_odom = nh.advertise<nav_msgs::Odometry>("/lead/avt_341/odometry", 1);

  // run_recorder in the background; the test drives once it is up.
  int code = -1;
  std::string output;
  std::atomic<bool> done{ false };
  std::thread recorder([&] {
    std::tie(code, output) = runRecorder("recorder");
    done = true;
  });
  // Up when the master lists it among the telemetry's subscribers (it loaded the terrain first).
  const std::string self = ros::this_node::getName();
  auto subscribed = [] {
    avsp::node::RosGraph graph;
    return avsp::node::readRosGraph(graph) && graph.subscribes("/recorder", "/follow/telemetry");
  };
  const ros::WallTime start = ros::WallTime::now();
  while (!done && !subscribed() && (ros::WallTime::now() - start).toSec() < 30.0)
    ros::WallDuration(0.05).sleep();
  ASSERT_FALSE(done) << "run_recorder exited at start-up";
  ASSERT_TRUE(subscribed()) << "run_recorder did not subscribe within 30 s";
  // Nothing moves before the commands (wait_for_command): once run_recorder and this test are
  // connected to every publisher of what they read (the clock, odometry, telemetry; the bad
  // topic's two publishers), no message of the run can be lost.
  auto connected = [&] {
    return avsp::node::subscriptionsConnected("/recorder") && avsp::node::subscriptionsConnected(self) &&
           bad_odom.getNumSubscribers() >= 2;
  };
  while (!done && !connected() && (ros::WallTime::now() - start).toSec() < 30.0)
    ros::WallDuration(0.01).sleep();
  ASSERT_TRUE(connected()) << "run_recorder or the test not connected to its publishers within 30 s";

  geometry_msgs::Twist go_lead, go_follow, brake;
  go_lead.linear.x = 0.35;
  go_follow.linear.x = 0.6;
  brake.linear.y = -1.0;  // avt_341: linear.y = -brake
  cmd["lead"].publish(go_lead);
  cmd["follow"].publish(go_follow);
  bool bad_sent = false;
  bool braked = false;
  double clock_at_exit = 0.0;
  while (!done && (ros::WallTime::now() - start).toSec() < 75.0)
  {
    ros::spinOnce();
    if (!bad_sent && ros::Time::now().toSec() >= 3.0 && !odom["lead"].empty())
    {
      nav_msgs::Odometry nan_odom;
      nan_odom.header.stamp = ros::Time::now();
      nan_odom.header.frame_id = "odom";
      nan_odom.pose.pose.position.x = std::nan("");
      nan_odom.pose.pose.orientation.w = 1.0;
      bad_odom.publish(nan_odom);
      // A copy of the first message, which run_recorder has had since the start: arriving now it
      // is out of order (or a repeat), never a new sample. (A copy of the latest one raced the
      // original: on a loaded machine run_recorder, two messages behind, took the copy as the
      // sample and then refused the older original, one sample short.)
      const Sample& first = odom["lead"].front();
      nav_msgs::Odometry copy;
      copy.header.stamp = ros::Time(first.t);
      copy.header.frame_id = "odom";
      copy.pose.pose.position.x = first.x;
      copy.pose.pose.position.y = first.y;
      copy.pose.pose.position.z = first.z;
      copy.pose.pose.orientation.w = 1.0;
      bad_odom.publish(copy);
      bad_sent = true;
    }
    if (!braked && ros::Time::now().toSec() >= brake_time)
    {
      cmd["lead"].publish(brake);
      braked = true;
    }
    ros::WallDuration(0.002).sleep();
  }
  clock_at_exit = ros::Time::now().toSec();
  recorder.join();
  ros::spinOnce();
  std::printf("[ run_recorder ] exited %d after %.1f s wall at sim time %.2f s\n%s\n", code,
              (ros::WallTime::now() - start).toSec(), clock_at_exit, output.c_str());
  ASSERT_EQ(code, 0) << output;
  EXPECT_GE(clock_at_exit, duration);
  EXPECT_NE(output.find("[run_recorder] sim "), std::string::npos) << "no progress line";
  EXPECT_TRUE(bad_sent);
  EXPECT_NE(output.find("/lead/avt_341/odometry: odometry at"), std::string::npos) << "NaN odometry not reported";

  for (const char* f : { "summary.json", "grids.json", "trajectories.csv", "gaps.csv", "objects.csv",
                         "terrain_heights.npy", "rut_depth.npy", "trajectories.png", "ruts.png", "gaps.png" })
    EXPECT_TRUE(std::ifstream(dir + "/" + f).good()) << f << " missing";
  for (const char* f : { "trajectories.png", "ruts.png", "gaps.png" })
  {
    const auto [w, h] = pngSize(dir + "/" + f);
    std::printf("[ run_recorder ] %s: %u x %u px\n", f, w, h);
    EXPECT_GE(w, 400u) << f;
    EXPECT_GE(h, 300u) << f;
    EXPECT_LE(w, 4000u) << f;
    EXPECT_LE(h, 4000u) << f;
  }

  const YAML::Node summary = YAML::LoadFile(dir + "/summary.json");
  EXPECT_EQ(summary["scenario"].as<std::string>(), "recorder_test");
  ASSERT_TRUE(summary["aborted"].IsDefined());
  EXPECT_TRUE(summary["aborted"].IsNull()) << "a complete run is not aborted";
  const double end = summary["sim_time_end"].as<double>();
  EXPECT_GE(end, duration);
  EXPECT_LE(end, duration + 0.5);  // stopped at the duration, not later
  EXPECT_GT(summary["real_time_factor"].as<double>(), 0.0);
  ASSERT_EQ(summary["vehicles"].size(), 2u);
  for (const YAML::Node& v : summary["vehicles"])
  {
    const std::string name = v["name"].as<std::string>();
    const double t0 = v["t_first"].as<double>(), t1 = v["t_last"].as<double>();
    EXPECT_LE(t1, duration);
    EXPECT_GE(t1, duration - 0.05);
    // The distance the test integrates from its own odometry over the recorder's time span.
    double own = 0.0, max_gap_dt = 0.0;
    const Sample* previous = nullptr;
    for (const Sample& s : odom[name])
    {
      if (s.t < t0 - 1e-9 || s.t > t1 + 1e-9)
        continue;
      if (previous)
      {
        own +=
            std::sqrt(std::pow(s.x - previous->x, 2) + std::pow(s.y - previous->y, 2) + std::pow(s.z - previous->z, 2));
        max_gap_dt = std::max(max_gap_dt, s.t - previous->t);
      }
      previous = &s;
    }
    const double distance = v["distance"].as<double>();
    std::printf(
        "[ run_recorder ] %s: summary %.3f m, own odometry %.3f m (%.2f-%.2f s), max slip %s, collisions %s, "
        "gap min %s mean %s\n",
        name.c_str(), distance, own, t0, t1, show(v["max_slip"]).c_str(), show(v["collisions"]).c_str(),
        show(v["gap_min"]).c_str(), show(v["gap_mean"]).c_str());
    EXPECT_GT(own, 10.0) << name << " hardly moved";
    const std::size_t own_samples = std::count_if(
        odom[name].begin(), odom[name].end(), [&](const Sample& s) { return s.t >= t0 - 1e-9 && s.t <= t1 + 1e-9; });
    EXPECT_EQ(v["odometry_samples"].as<std::size_t>(), own_samples) << name;
    EXPECT_NEAR(distance, own, 0.01 * own) << name;
    EXPECT_NEAR(v["mean_speed"].as<double>(), distance / (t1 - t0), 1e-6 * distance);
    EXPECT_GT(v["max_slip"].as<double>(), 0.0) << name << ": driving on sandy loam slips";
    EXPECT_LE(v["max_slip"].as<double>(), 1.0) << name;  // 1: a wheel spinning on the spot
    EXPECT_EQ(v["collisions"].as<unsigned>(), collisions[name]) << name;
    EXPECT_GE(v["collisions"].as<unsigned>(), 1u) << name << ": the rear-end";
    EXPECT_DOUBLE_EQ(v["time_stuck"].as<double>(), 0.0) << name;
    // Anomalies: exactly the samples of the test's own odometry beyond 1.5 x the given governed
    // speed; on flat ground nobody leaves it; the lead's one non-finite sample is the test's NaN.
    std::size_t fast = 0;
    const double governed = name == "lead" ? kLeadMaxSpeed : kFollowMaxSpeed;
    for (const Sample& s : odom[name])
      if (s.t >= t0 - 1e-9 && s.t <= t1 + 1e-9 && s.speed > 1.5 * governed)
        ++fast;
    EXPECT_EQ(v["anomalies"]["overspeed"].as<std::size_t>(), fast) << name;
    EXPECT_EQ(v["anomalies"]["airborne"].as<std::size_t>(), 0u) << name;
    EXPECT_EQ(v["anomalies"]["non_finite"].as<std::size_t>(), name == "lead" ? 1u : 0u) << name;
    if (name == "follow")
      EXPECT_GT(fast, 100u) << "the follower drives above 1.5 m/s for a while";
    else
      EXPECT_EQ(fast, 0u);
  }
  EXPECT_EQ(summary["anomalies"].as<std::size_t>(),
            summary["vehicles"][1]["anomalies"]["overspeed"].as<std::size_t>() + 1u);
  EXPECT_NE(output.find("anomaly: follow: "), std::string::npos) << "the first overspeed is reported";
  EXPECT_TRUE(summary["vehicles"][0]["gap_min"].IsNull());
  EXPECT_TRUE(summary["vehicles"][0]["leader"].IsNull());
  EXPECT_EQ(summary["vehicles"][1]["leader"].as<std::string>(), "lead");
  EXPECT_GT(summary["ruts"]["max_depth"].as<double>(), 0.002);

  // gaps.csv: the follower's series, every 0.1 s over the run; on this straight path the gap is
  // the leader's x minus the follower's at the same stamp.
  std::map<long long, double> lead_x, follow_x;
  for (const Sample& s : odom["lead"])
    lead_x[std::llround(s.t * 1000.0)] = s.x;
  for (const Sample& s : odom["follow"])
    follow_x[std::llround(s.t * 1000.0)] = s.x;
  std::ifstream gaps(dir + "/gaps.csv");
  std::string line;
  std::getline(gaps, line);
  EXPECT_EQ(line, "follower,leader,t,gap,lateral");
  int rows = 0, compared = 0;
  double worst = 0.0, gap_min = 1e9;
  while (std::getline(gaps, line))
  {
    ++rows;
    double t = 0.0, gap = 0.0, lateral = 0.0;
    ASSERT_EQ(line.rfind("follow,lead,", 0), 0u) << line;
    ASSERT_EQ(std::sscanf(line.c_str() + 12, "%lf,%lf,%lf", &t, &gap, &lateral), 3) << line;
    gap_min = std::min(gap_min, gap);
    const long long key = std::llround(t * 1000.0);
    if (lead_x.count(key) && follow_x.count(key))
    {
      ++compared;
      worst = std::max(worst, std::abs(gap - (lead_x[key] - follow_x[key])));
    }
  }
  std::printf("[ run_recorder ] gaps.csv: %d rows, %d compared, worst |gap - (x_lead - x_follow)| %.4f m\n", rows,
              compared, worst);
  EXPECT_GE(rows, static_cast<int>(0.9 * duration / 0.1));
  EXPECT_GE(compared, rows - 2);
  EXPECT_LT(worst, 0.05);
  EXPECT_NEAR(summary["vehicles"][1]["gap_min"].as<double>(), gap_min, 1e-3);
  bool keep = false;
  pnh.param("keep_results", keep, false);
  if (keep)
    std::printf("[ run_recorder ] results kept in %s\n", dir.c_str());
  else
    std::system(("rm -rf " + std::string(pattern)).c_str());
}

TEST(RunRecorderStartup, BadParametersExitNamingTheParameter)
{
  ros::NodeHandle nh;
  auto bad = [&](const std::string& name, const std::function<void(const std::string&)>& spoil) {
    setRecorderParams(nh, name, "/tmp/avsp_run_recorder_bad_" + std::to_string(getpid()), 10.0);
    spoil("/" + name + "/");
    return runRecorder(name);
  };
  auto [code, out] = bad("bad_leader", [&](const std::string& ns) {
    XmlRpc::XmlRpcValue list, a, b;
    a["name"] = std::string("lead");
    b["name"] = std::string("follow");
    b["leader"] = std::string("ghost");
    list[0] = a;
    list[1] = b;
    nh.setParam(ns + "vehicles", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~vehicles[1].leader 'ghost' is not a listed vehicle"), std::string::npos) << out;

  std::tie(code, out) = bad("twice", [&](const std::string& ns) {
    XmlRpc::XmlRpcValue list, a;
    a["name"] = std::string("lead");
    list[0] = a;
    list[1] = a;
    nh.setParam(ns + "vehicles", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~vehicles[1].name 'lead' is listed twice"), std::string::npos) << out;

  std::tie(code, out) = bad("half_limits", [&](const std::string& ns) {
    XmlRpc::XmlRpcValue list, a;
    a["name"] = std::string("lead");
    a["max_speed"] = 2.0;
    list[0] = a;
    nh.setParam(ns + "vehicles", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~vehicles[0]: max_speed, rest_height and wheel_radius go together"), std::string::npos) << out;

  std::tie(code, out) = bad("relative_watch", [&](const std::string& ns) {
    XmlRpc::XmlRpcValue list;
    list[0] = std::string("/terrain");
    list[1] = std::string("sensors");
    nh.setParam(ns + "watch", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~watch[1] 'sensors' must be a resolved node name"), std::string::npos) << out;

  std::tie(code, out) = bad("no_dir", [&](const std::string& ns) { nh.deleteParam(ns + "output_dir"); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~output_dir is required"), std::string::npos) << out;

  std::tie(code, out) = bad(
      "unwritable", [&](const std::string& ns) { nh.setParam(ns + "output_dir", std::string("/proc/avsp_results")); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~output_dir '/proc/avsp_results'"), std::string::npos) << out;

  std::tie(code, out) = bad("zero_duration", [&](const std::string& ns) { nh.setParam(ns + "duration", 0.0); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~duration"), std::string::npos) << out;

  std::tie(code, out) = bad("typo", [&](const std::string& ns) {
    XmlRpc::XmlRpcValue list, a;
    a["name"] = std::string("lead");
    a["leeder"] = std::string("x");
    list[0] = a;
    nh.setParam(ns + "vehicles", list);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~vehicles[0].leeder: unknown key"), std::string::npos) << out;
  std::system(("rm -rf /tmp/avsp_run_recorder_bad_" + std::to_string(getpid())).c_str());
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_run_recorder");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
