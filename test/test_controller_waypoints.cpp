// rostest of controller_node in waypoint mode (test/controller_waypoints.test): the vehicle is
// driven only by the controller; the run is judged only from the vehicle's odometry against
// the waypoints the controller was given. Time is the odometry's sim time; wall deadlines only
// guard a hang. Bad parameters: the node binary, run to completion, must exit 1 naming them.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <avsp_msgs/DriveCommand.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <std_msgs/Bool.h>
#include <avsp_terrain/ros/spin_until.hpp>

#include <avsp_terrain/ros/run_command.hpp>

#include "avsp/control/path.hpp"

namespace ac = avsp::control;

namespace
{
/// avsp::node::spinUntil, polling every 0.001 s here.
bool spinUntil(const std::function<bool()>& done, double timeout)
{
  return avsp::node::spinUntil(done, timeout, 0.001);
}

struct Sample
{
  double t, x, y, speed;
};

struct Waypoint
{
  double x, y, speed;
};

std::vector<Waypoint> waypointsOf(const std::string& param)
{
  XmlRpc::XmlRpcValue list;
  std::vector<Waypoint> out;
  if (!ros::param::get(param, list) || list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return out;
  auto number = [](XmlRpc::XmlRpcValue& v) {
    return v.getType() == XmlRpc::XmlRpcValue::TypeInt ? static_cast<double>(static_cast<int>(v))
                                                       : static_cast<double>(v);
  };
  for (int k = 0; k < list.size(); ++k)
    out.push_back({ number(list[k]["x"]), number(list[k]["y"]), number(list[k]["speed"]) });
  return out;
}

/// Runs controller_node as `name` with the private parameters already set; exit code and output.
std::pair<int, std::string> runNode(const std::string& name)
{
  return avsp::node::runCommand(std::string(CONTROLLER_NODE_PATH) + " __name:=" + name);
}
}  // namespace

TEST(ControllerWaypoints, ReachesTheGoalHoldingEachSegmentSpeed)
{
  ros::NodeHandle nh;
  const std::vector<Waypoint> waypoints = waypointsOf("/ego/controller/waypoints");
  ASSERT_GE(waypoints.size(), 2u) << "no /ego/controller/waypoints";
  std::vector<Sample> samples;
  bool goal_reached = false;
  nav_msgs::Path path;
  std::size_t commands = 0;
  ros::Subscriber odom_sub =
      nh.subscribe<nav_msgs::Odometry>("/ego/avt_341/odometry", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) {
        samples.push_back(
            { m->header.stamp.toSec(), m->pose.pose.position.x, m->pose.pose.position.y, m->twist.twist.linear.x });
      });
  ros::Subscriber goal_sub = nh.subscribe<std_msgs::Bool>(
      "/ego/controller/goal_reached", 10, [&](const std_msgs::Bool::ConstPtr& m) { goal_reached = m->data; });
  ros::Subscriber path_sub =
      nh.subscribe<nav_msgs::Path>("/ego/controller/path", 1, [&](const nav_msgs::Path::ConstPtr& m) { path = *m; });
  // In lockstep the controller answers each 50 ms instant on cmd_drive, stamped with it.
  std::size_t off_grid = 0;
  ros::Subscriber cmd_sub =
      nh.subscribe<avsp_msgs::DriveCommand>("/ego/cmd_drive", 100, [&](const avsp_msgs::DriveCommand::ConstPtr& m) {
        ++commands;
        const double t = m->header.stamp.toSec();
        if (std::abs(t - 0.05 * std::round(t / 0.05)) > 1e-6)
          ++off_grid;
      });

  auto now = [&] { return samples.empty() ? 0.0 : samples.back().t; };
  // Arrived: the controller says so and the vehicle has stopped (or 150 s of sim time).
  ASSERT_TRUE(spinUntil(
      [&] { return (goal_reached && !samples.empty() && std::abs(samples.back().speed) < 0.02) || now() > 150.0; },
      150.0))
      << "simulation stalled at t = " << now() << " s";
  ASSERT_TRUE(goal_reached) << "goal not reached by t = " << now() << " s";
  // Stays braked at the goal.
  const Sample stopped = samples.back();
  ASSERT_TRUE(spinUntil([&] { return now() > stopped.t + 3.0; }, 30.0));
  EXPECT_LT(std::hypot(samples.back().x - stopped.x, samples.back().y - stopped.y), 0.05);
  EXPECT_GT(commands, 100u);
  EXPECT_EQ(off_grid, 0u) << "commands stamped off the 50 ms lockstep grid";
  ASSERT_EQ(path.poses.size(), waypoints.size()) << "controller/path does not show the waypoints";
  EXPECT_EQ(path.header.frame_id, "map");

  // Acceptance: within 3 m of the last waypoint.
  const Waypoint& goal = waypoints.back();
  const double final_distance = std::hypot(samples.back().x - goal.x, samples.back().y - goal.y);
  EXPECT_LT(final_distance, 3.0);
  RecordProperty("final_distance_m", std::to_string(final_distance));
  std::printf("[ controller_waypoints ] arrived at t = %.1f s, %.2f m from the last waypoint\n", stopped.t,
              final_distance);

  // Acceptance: each segment's speed within 10 % in the middle half of the segment
  // (base_link's projection on the waypoint polyline), every odometry sample.
  std::vector<ac::Vec2> pts;
  for (const Waypoint& w : waypoints)
    pts.push_back({ w.x, w.y });
  const ac::Path route(pts);
  double s_previous = 0.0;
  for (std::size_t seg = 0; seg + 1 < waypoints.size(); ++seg)
  {
    const double s0 = route.sAt(seg), s1 = route.sAt(seg + 1);
    const double lo = s0 + 0.25 * (s1 - s0), hi = s0 + 0.75 * (s1 - s0);
    double sum = 0.0, worst = 0.0, worst_lateral = 0.0;
    int n = 0;
    s_previous = 0.0;
    for (const Sample& p : samples)
    {
      const ac::PathProjection proj = route.project({ p.x, p.y }, s_previous - 5.0, s_previous + 20.0);
      s_previous = proj.s;
      if (proj.s < lo || proj.s > hi)
        continue;
      sum += p.speed;
      ++n;
      worst = std::max(worst, std::abs(p.speed - waypoints[seg].speed));
      worst_lateral = std::max(worst_lateral, proj.distance);
    }
    ASSERT_GT(n, 100) << "segment " << seg << " barely sampled";
    const double mean = sum / n;
    EXPECT_LT(worst, 0.1 * waypoints[seg].speed) << "segment " << seg << " at " << waypoints[seg].speed << " m/s";
    EXPECT_LT(worst_lateral, 1.0) << "segment " << seg << ": off the route";
    RecordProperty("segment" + std::to_string(seg) + "_mean_speed", std::to_string(mean));
    std::printf(
        "[ controller_waypoints ] segment %zu: %.1f m/s prescribed, mean %.3f m/s (%+.2f %%), worst %.3f m/s "
        "(%.2f %%), worst lateral %.2f m\n",
        seg, waypoints[seg].speed, mean, 100.0 * (mean / waypoints[seg].speed - 1.0), worst,
        100.0 * worst / waypoints[seg].speed, worst_lateral);
  }
}

// dynamics_node sends the odometry of time 0 again until every lockstep controller has
// answered it: the first answer can go out before dynamics_node's cmd_drive subscription has
// connected. A repeated instant must be answered again with the same command (or the run stalls
// at t = 0); an instant on the grid after it gets its own answer, an older one none.
TEST(ControllerLockstep, TheSameInstantAgainIsAnsweredAgainWithTheSameCommand)
{
  ros::NodeHandle nh;
  std::vector<avsp_msgs::DriveCommand> answers;
  ros::Subscriber sub = nh.subscribe<avsp_msgs::DriveCommand>(
      "/echo/cmd_drive", 10, [&](const avsp_msgs::DriveCommand::ConstPtr& c) { answers.push_back(*c); });
  ros::Publisher pub = nh.advertise<nav_msgs::Odometry>("/echo/avt_341/odometry", 10);
  ASSERT_TRUE(spinUntil([&] { return pub.getNumSubscribers() > 0 && sub.getNumPublishers() > 0; }, 60.0));
  auto odometryAt = [](double t) {
    nav_msgs::Odometry o;
    o.header.stamp = ros::Time(t);
    o.header.frame_id = "odom";
    o.pose.pose.position.y = 5.0;  // 5 m left of the path: it steers right
    o.pose.pose.orientation.w = 1.0;
    return o;
  };
  // Until the first answer comes we may not be connected both ways yet: send until one does.
  ASSERT_TRUE(spinUntil(
      [&] {
        if (answers.empty())
          pub.publish(odometryAt(0.0));
        ros::WallDuration(0.05).sleep();
        ros::spinOnce();
        return !answers.empty();
      },
      30.0));
  // Then time 0 once more, the next instant, an older one, the one after. One connection keeps
  // the order, so every answer before 0.05's is one to time 0.
  pub.publish(odometryAt(0.0));
  pub.publish(odometryAt(0.05));
  pub.publish(odometryAt(0.0));
  pub.publish(odometryAt(0.1));
  ASSERT_TRUE(spinUntil([&] { return answers.back().header.stamp == ros::Time(0.1); }, 30.0));
  const std::size_t n = answers.size();
  ASSERT_GE(n, 4u);
  EXPECT_EQ(answers[n - 1].header.stamp, ros::Time(0.1));
  EXPECT_EQ(answers[n - 2].header.stamp, ros::Time(0.05));  // the older instant: no answer
  const avsp_msgs::DriveCommand& first = answers.front();
  EXPECT_LT(first.steering, 0.0);  // a command of its own, not a default
  for (std::size_t k = 0; k + 2 < n; ++k)
  {
    EXPECT_EQ(answers[k].header.stamp, ros::Time(0.0)) << k;
    EXPECT_EQ(answers[k].throttle, first.throttle) << k;
    EXPECT_EQ(answers[k].brake, first.brake) << k;
    EXPECT_EQ(answers[k].steering, first.steering) << k;
  }
}

TEST(ControllerNodeStartup, BadParametersExitNamingTheKey)
{
  ros::NodeHandle nh;
  std::string config_dir;
  ASSERT_TRUE(ros::NodeHandle("~").getParam("config_dir", config_dir));
  auto setUp = [&](const std::string& name, const std::string& mode) {
    const std::string ns = "/" + name + "/";
    nh.setParam(ns + "config_dir", config_dir);
    nh.setParam(ns + "model", "fed_alpha");
    if (!mode.empty())
      nh.setParam(ns + "mode", mode);
    XmlRpc::XmlRpcValue w;
    w.setSize(2);
    for (int k = 0; k < 2; ++k)
    {
      w[k]["x"] = 10.0 * k;
      w[k]["y"] = 0.0;
      w[k]["speed"] = 2.0;
    }
    nh.setParam(ns + "waypoints", w);
    return ns;
  };
  // No ~mode.
  setUp("bad_mode", "");
  auto [code, out] = runNode("bad_mode");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~mode"), std::string::npos) << out;
  // Unknown model.
  std::string ns = setUp("bad_model", "waypoints");
  nh.setParam(ns + "model", "rover7");
  std::tie(code, out) = runNode("bad_model");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("rover7"), std::string::npos) << out;
  // A negative speed names the entry and key.
  ns = setUp("bad_speed", "waypoints");
  {
    XmlRpc::XmlRpcValue w;
    nh.getParam(ns + "waypoints", w);
    w[1]["speed"] = -2.0;
    nh.setParam(ns + "waypoints", w);
  }
  std::tie(code, out) = runNode("bad_speed");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~waypoints[1].speed"), std::string::npos) << out;
  // An unknown key in a waypoint.
  ns = setUp("bad_key", "waypoints");
  {
    XmlRpc::XmlRpcValue w;
    nh.getParam(ns + "waypoints", w);
    w[0]["z"] = 1.0;
    nh.setParam(ns + "waypoints", w);
  }
  std::tie(code, out) = runNode("bad_key");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~waypoints[0].z"), std::string::npos) << out;
  // Lookahead bounds inverted.
  ns = setUp("bad_lookahead", "waypoints");
  nh.setParam(ns + "lookahead_min", 10.0);
  nh.setParam(ns + "lookahead_max", 5.0);
  std::tie(code, out) = runNode("bad_lookahead");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~lookahead_max"), std::string::npos) << out;
  // Leader-follower without a leader, and with a negative gap.
  setUp("bad_leader", "leader_follower");
  std::tie(code, out) = runNode("bad_leader");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~leader"), std::string::npos) << out;
  ns = setUp("bad_gap", "leader_follower");
  nh.setParam(ns + "leader", "alpha");
  nh.setParam(ns + "gap", -1.0);
  std::tie(code, out) = runNode("bad_gap");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~gap"), std::string::npos) << out;
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_controller_waypoints");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
