// Partitions (issue 7), behind lockstep_clock:
// - Same answer, any layout: the same four vehicles in one dynamics_node (partition "one") and
//   split over two (partitions "p1" and "p2"), all on one lockstep clock, driven by this node
//   as their lockstep controller with the same open-loop commands: every odometry message of
//   every vehicle is bit-identical between the layouts.
// - A partition killed mid-run stops the clock within its timeout, naming the partition.
// - Two vehicles in two partitions driven head-on collide through their proxies: neither
//   passes through the other. While they are apart the partitions step ahead of each other's
//   exchanges and hold their soil changes back, and the odometry equals, bit for bit, a strict
//   pair's (~step_ahead_intervals 0) run alongside on the same clock.
// - A malformed exchange from a peer stops the partition with exit 1 naming the topic.
// - Vehicles join and leave a partitioned run through any partition's ~spawn_vehicle and
//   ~remove_vehicle (forwarded to the partition that runs them).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <avsp_msgs/DriveCommand.h>
#include <avsp_msgs/PartitionExchange.h>
#include <avsp_msgs/RemoveVehicle.h>
#include <avsp_msgs/SpawnVehicle.h>
#include <avsp_msgs/StepDone.h>
#include <avsp_msgs/VehicleTelemetry.h>
#include <avsp_dynamics/vehicle_model.hpp>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <xmlrpcpp/XmlRpcClient.h>
#include <avsp_terrain/ros/ros_graph.hpp>
#include <avsp_terrain/ros/spin_until.hpp>

namespace
{
/// avsp::node::spinUntil, polling every 0.0005 s here.
bool spinUntil(const std::function<bool()>& done, double timeout)
{
  return avsp::node::spinUntil(done, timeout, 0.0005);
}

/// Open-loop command of vehicle k at sim time t: throttle ramps, steering weaves (k < 0:
/// straight on), a brake pulse.
avsp_msgs::DriveCommand command(int k, const ros::Time& stamp)
{
  const double t = stamp.toSec();
  avsp_msgs::DriveCommand c;
  c.header.stamp = stamp;
  c.throttle = std::min(1.0, 0.2 + 0.1 * t) * (t > 6.0 && t < 7.0 ? 0.0 : 1.0);
  c.brake = t > 6.0 && t < 7.0 ? 0.5 : 0.0;
  c.steering = k < 0 ? 0.0 : 0.3 * std::sin(0.7 * t + static_cast<double>(k));
  return c;
}

/// How many of the first n messages of two odometry streams differ in pose or twist, bit for
/// bit; a stamp mismatch fails the test and counts as all n.
std::size_t differingMessages(const std::vector<nav_msgs::Odometry>& a, const std::vector<nav_msgs::Odometry>& b,
                              std::size_t n, const std::string& what)
{
  std::size_t differ = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (a[i].header.stamp != b[i].header.stamp)
    {
      ADD_FAILURE() << what << " message " << i << ": stamps " << a[i].header.stamp << " and " << b[i].header.stamp;
      return n;
    }
    const auto &p = a[i].pose.pose, &q = b[i].pose.pose;
    const auto &u = a[i].twist.twist, &w = b[i].twist.twist;
    if (p.position.x != q.position.x || p.position.y != q.position.y || p.position.z != q.position.z ||
        p.orientation.x != q.orientation.x || p.orientation.y != q.orientation.y ||
        p.orientation.z != q.orientation.z || p.orientation.w != q.orientation.w || u.linear.x != w.linear.x ||
        u.linear.y != w.linear.y || u.angular.z != w.angular.z)
      ++differ;
  }
  return differ;
}

TEST(Partitions, OneAndTwoPartitionsGiveIdenticalOdometry)
{
  ros::NodeHandle nh, pnh("~");
  std::vector<std::string> vehicles;
  ASSERT_TRUE(pnh.getParam("vehicles", vehicles));
  double until = 10.0;
  pnh.param("until", until, 10.0);
  // ~crossing drives straight on across ~crossed's path after it: over its rut, made in the
  // other partition in the two-partition layout.
  std::string crossing, crossed;
  pnh.param<std::string>("crossing", crossing, "");
  pnh.param<std::string>("crossed", crossed, "");
  const std::vector<std::string> layouts{ "one", "two" };
  std::map<std::string, std::vector<nav_msgs::Odometry>> streams;  // "<layout>/<vehicle>"
  std::vector<ros::Subscriber> subs;
  std::map<std::string, ros::Publisher> commands;
  bool stop = false;  // past `until`: no more answers, the run halts at the barrier
  for (const std::string& layout : layouts)
    for (std::size_t k = 0; k < vehicles.size(); ++k)
    {
      const std::string key = layout + "/" + vehicles[k];
      const int k_command = vehicles[k] == crossing ? -1 : static_cast<int>(k);
      commands[key] = nh.advertise<avsp_msgs::DriveCommand>("/" + key + "/cmd_drive", 10);
      subs.push_back(nh.subscribe<nav_msgs::Odometry>(
          "/" + key + "/avt_341/odometry", 1000,
          [&, key, k = k_command](const nav_msgs::Odometry::ConstPtr& m) {
            std::vector<nav_msgs::Odometry>& s = streams[key];
            const double t = m->header.stamp.toSec();
            if (!s.empty() && m->header.stamp <= s.back().header.stamp)
            {
              // The t = 0 odometry re-sent until every controller answered: answer it again.
              if (m->header.stamp.isZero())
                commands[key].publish(command(k, m->header.stamp));
              return;
            }
            s.push_back(*m);
            if (!stop && std::abs(t - 0.05 * std::round(t / 0.05)) < 1e-6)
              commands[key].publish(command(k, m->header.stamp));
          },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    }
  auto reached = [&] {
    for (const auto& layout : layouts)
      for (const auto& v : vehicles)
      {
        const auto& s = streams[layout + "/" + v];
        if (s.empty() || s.back().header.stamp.toSec() < until)
          return false;
      }
    return true;
  };
  const ros::WallTime start = ros::WallTime::now();
  ASSERT_TRUE(spinUntil(reached, 150.0)) << "the partitioned run did not reach t = " << until << " s";
  stop = true;
  std::printf("[ partitions ] %.1f s of sim time, 2 layouts x %zu vehicles, in %.1f s wall\n", until, vehicles.size(),
              (ros::WallTime::now() - start).toSec());
  for (const std::string& v : vehicles)
  {
    const auto& a = streams["one/" + v];
    const auto& b = streams["two/" + v];
    const std::size_t n = std::min(a.size(), b.size());
    ASSERT_GE(n, static_cast<std::size_t>(100.0 * until)) << v;
    const std::size_t differ = differingMessages(a, b, n, v);
    EXPECT_EQ(differ, 0u) << v << ": " << differ << " of " << n << " odometry messages differ between the layouts";
    // Not trivially equal: it drove and turned.
    const double dist = std::hypot(a[n - 1].pose.pose.position.x - a[0].pose.pose.position.x,
                                   a[n - 1].pose.pose.position.y - a[0].pose.pose.position.y);
    EXPECT_GT(dist, 5.0) << v;
    std::printf("[ partitions ] %s: %zu messages, %zu differ, %.1f m driven\n", v.c_str(), n, differ, dist);
  }
  if (crossing.empty())
    return;
  // The crossing vehicle did drive where the crossed one had been at least 1 s before it (so
  // over its rut, and the two never touched).
  const auto& a = streams["one/" + crossing];
  const auto& b = streams["one/" + crossed];
  double closest = 1e9, when = 0.0;
  for (const auto& m : a)
    for (const auto& o : b)
    {
      if (o.header.stamp.toSec() > m.header.stamp.toSec() - 1.0)
        break;
      const double d =
          std::hypot(m.pose.pose.position.x - o.pose.pose.position.x, m.pose.pose.position.y - o.pose.pose.position.y);
      if (d < closest)
      {
        closest = d;
        when = m.header.stamp.toSec() - o.header.stamp.toSec();
      }
    }
  EXPECT_LT(closest, 0.5) << crossing << " did not cross " << crossed << "'s path";
  std::printf("[ partitions ] %s crossed %s's path %.2f m from where it had been %.1f s before\n", crossing.c_str(),
              crossed.c_str(), closest, when);
}

TEST(PartitionCollide, VehiclesOfTwoPartitionsCollideHeadOn)
{
  ros::NodeHandle nh, pnh("~");
  std::string yaml;
  ASSERT_TRUE(pnh.getParam("model_yaml", yaml));
  double until = 8.0;
  pnh.param("until", until, 8.0);
  const avsp::dynamics::VehicleModel model = avsp::dynamics::loadVehicleModel(yaml);
  double reach = 0.0;  // m, how far the chassis reaches ahead of base_link
  for (const avsp::dynamics::CollisionBox& b : model.collision_boxes)
    reach = std::max(reach, b.pose.translation().x() + 0.5 * b.size.x());
  // The pair under test at the root, and the strict pair in ~strict_ns (empty: none).
  std::string strict_ns;
  pnh.param<std::string>("strict_ns", strict_ns, "");
  std::vector<std::string> names{ "east", "west" };
  if (!strict_ns.empty())
    names.insert(names.end(), { strict_ns + "/east", strict_ns + "/west" });
  std::map<std::string, std::vector<nav_msgs::Odometry>> streams;
  std::map<std::string, std::uint32_t> collisions;
  std::map<std::string, ros::Publisher> commands;
  std::vector<ros::Subscriber> subs;
  // Partition pe's exchanges: when it stepped ahead of pw's (stamp - peers_applied, s), and
  // how many soil points it sent (it holds them back while pw's vehicle is far).
  std::map<double, double> lag;
  std::map<double, std::size_t> soil_sent;
  subs.push_back(nh.subscribe<avsp_msgs::PartitionExchange>(
      "/lockstep/exchange/pe", 1000, [&](const avsp_msgs::PartitionExchange::ConstPtr& m) {
        lag[m->header.stamp.toSec()] = (m->header.stamp - m->peers_applied).toSec();
        soil_sent[m->header.stamp.toSec()] = m->soil_points.size();
      }));
  for (const std::string& v : names)
  {
    commands[v] = nh.advertise<avsp_msgs::DriveCommand>("/" + v + "/cmd_drive", 10);
    subs.push_back(nh.subscribe<avsp_msgs::VehicleTelemetry>(
        "/" + v + "/telemetry", 100,
        [&, v](const avsp_msgs::VehicleTelemetry::ConstPtr& m) { collisions[v] = m->collisions; }));
    subs.push_back(nh.subscribe<nav_msgs::Odometry>(
        "/" + v + "/avt_341/odometry", 1000,
        [&, v](const nav_msgs::Odometry::ConstPtr& m) {
          std::vector<nav_msgs::Odometry>& s = streams[v];
          const double t = m->header.stamp.toSec();
          const bool repeat = !s.empty() && m->header.stamp <= s.back().header.stamp;
          if (!repeat)
            s.push_back(*m);
          if ((repeat && m->header.stamp.isZero()) ||
              (!repeat && t <= until && std::abs(t - 0.05 * std::round(t / 0.05)) < 1e-6))
          {
            avsp_msgs::DriveCommand c;  // full throttle straight ahead
            c.header.stamp = m->header.stamp;
            c.throttle = 1.0;
            commands[v].publish(c);
          }
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
  }
  auto reached = [&] {
    return std::all_of(names.begin(), names.end(), [&](const std::string& v) {
      return !streams[v].empty() && streams[v].back().header.stamp.toSec() >= until;
    });
  };
  ASSERT_TRUE(spinUntil(reached, 100.0)) << "the run did not reach t = " << until << " s";
  const auto& e = streams["east"];
  const auto& w = streams["west"];
  const std::size_t n = std::min(e.size(), w.size());
  ASSERT_GE(n, static_cast<std::size_t>(100.0 * until));
  double closest = 1e9;
  for (std::size_t i = 0; i < n; ++i)
  {
    ASSERT_EQ(e[i].header.stamp, w[i].header.stamp);
    closest = std::min(closest, std::hypot(e[i].pose.pose.position.x - w[i].pose.pose.position.x,
                                           e[i].pose.pose.position.y - w[i].pose.pose.position.y));
  }
  // They met (each counted a collision), and the base_links never came closer than the two
  // chassis' reach less 5 cm: one interval (10 ms) at the closing speed plus the contact layer.
  EXPECT_GE(collisions["east"], 1u);
  EXPECT_GE(collisions["west"], 1u);
  EXPECT_GT(closest, 2.0 * reach - 0.05);
  EXPECT_LT(e[n - 1].pose.pose.position.x, w[n - 1].pose.pose.position.x);
  // Without the other, each would have driven well past the meeting point (x = 0) by now.
  EXPECT_LT(e[n - 1].pose.pose.position.x, 0.0);
  EXPECT_GT(w[n - 1].pose.pose.position.x, 0.0);
  std::printf(
      "[ partitions ] head-on across partitions: closest base_links %.3f m (chassis reach 2 x %.3f m), "
      "collisions %u / %u, final x %.2f / %.2f m\n",
      closest, reach, collisions["east"], collisions["west"], e[n - 1].pose.pose.position.x,
      w[n - 1].pose.pose.position.x);
  if (strict_ns.empty())
    return;
  // Stepping ahead: while apart, pe stepped before pw's latest exchanges (peers_applied up to
  // ~step_ahead_intervals + 1 intervals behind), never when the chassis were within 0.3 m; and
  // the answer is the strict lockstep's.
  int step_ahead = 4;
  pnh.param("step_ahead_intervals", step_ahead, 4);
  std::map<long, double> lag_cs;  // by stamp in centiseconds
  for (const auto& [t, l] : lag)
    lag_cs[std::lround(100.0 * t)] = l;
  std::map<long, std::size_t> soil_cs;
  for (const auto& [t, points] : soil_sent)
    soil_cs[std::lround(100.0 * t)] = points;
  std::size_t ahead = 0, near = 0, ahead_near = 0, missing = 0;
  std::size_t soil_held = 0, soil_held_near = 0, near_1m = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    const long cs = std::lround(100.0 * e[i].header.stamp.toSec());
    if (std::abs(e[i].header.stamp.toSec() - 0.01 * cs) > 1e-6 || cs == 0)
      continue;  // the exchanges are at the intervals' ends
    if (!lag_cs.count(cs))
    {
      ++missing;  // the subscription may have connected late, or the last ones still be under way
      continue;
    }
    const double l = lag_cs.at(cs);
    const long behind = std::lround(l / 0.01);  // intervals
    EXPECT_NEAR(l, 0.01 * behind, 1e-6) << "t = " << 0.01 * cs << " s";
    EXPECT_TRUE(behind >= 1 && behind <= step_ahead + 1) << "t = " << 0.01 * cs << " s: lag " << l;
    const bool stepped_ahead = behind > 1;
    ahead += stepped_ahead;
    const double gap = std::hypot(e[i].pose.pose.position.x - w[i].pose.pose.position.x,
                                  e[i].pose.pose.position.y - w[i].pose.pose.position.y) -
                       2.0 * reach;
    if (gap < 0.3)
    {
      ++near;
      ahead_near += stepped_ahead;
    }
    // Both drive at full throttle all along (slip: the soil under them changes in every step),
    // so an exchange without soil points held them back.
    const bool held = soil_cs.count(cs) && soil_cs.at(cs) == 0;
    soil_held += held;
    if (gap < 1.0)
    {
      ++near_1m;
      soil_held_near += held;
    }
  }
  EXPECT_GT(soil_held, 100u) << "pe never held its soil changes back while apart";
  EXPECT_GT(near_1m, 3u);
  EXPECT_EQ(soil_held_near, 0u) << "pe held its soil changes back with the chassis within 1 m";
  EXPECT_GT(ahead, 100u) << "pe never stepped ahead of pw's exchange while they were apart";
  EXPECT_GT(near, 3u);
  EXPECT_LT(missing, 20u) << "exchanges from pe not heard";
  EXPECT_EQ(ahead_near, 0u) << "pe stepped ahead of pw's exchange with the chassis within 0.3 m";
  for (const std::string v : { "east", "west" })
  {
    const auto& a = streams[v];
    const auto& b = streams[strict_ns + "/" + v];
    const std::size_t m = std::min(a.size(), b.size());
    ASSERT_GE(m, static_cast<std::size_t>(100.0 * until)) << v;
    const std::size_t differ = differingMessages(a, b, m, v);
    EXPECT_EQ(differ, 0u) << v << ": " << differ << " of " << m << " odometry messages differ from the strict pair's";
    std::printf(
        "[ partitions ] %s: %zu messages, %zu differ from the strict lockstep; pe stepped ahead in %zu "
        "intervals, in %zu of the %zu with the chassis within 0.3 m; held its soil back in %zu, in %zu of "
        "the %zu within 1 m\n",
        v.c_str(), m, differ, ahead, ahead_near, near, soil_held, soil_held_near, near_1m);
  }
}

/// pid of a running node, from its own XML-RPC getPid.
int nodePid(const std::string& node)
{
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, false))
    return -1;
  std::string host;
  std::uint32_t port = 0;
  if (!ros::network::splitURI(static_cast<std::string>(payload), host, port))
    return -1;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue pid_args, pid_result;
  pid_args[0] = ros::this_node::getName();
  if (!client.execute("getPid", pid_args, pid_result) || pid_result.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return -1;
  return static_cast<int>(pid_result[2]);
}

TEST(PartitionKill, AKilledPartitionStopsTheClockNamingIt)
{
  ros::NodeHandle nh, pnh("~");
  const std::string clock_path = LOCKSTEP_CLOCK_PATH;
  double last_clock = 0.0;
  ros::Subscriber clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 100, [&](const rosgraph_msgs::Clock::ConstPtr& c) { last_clock = c->clock.toSec(); });
  // The clock runs as a child of this test, so its exit status and message can be read.
  XmlRpc::XmlRpcValue partitions;
  partitions[0] = std::string("p1");
  partitions[1] = std::string("p2");
  nh.setParam("/kill_clock/partitions", partitions);
  nh.setParam("/kill_clock/timeout", 2.0);
  const std::string log = "/tmp/avsp_kill_clock_" + std::to_string(getpid()) + ".log";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0)
  {
    const std::string cmd = clock_path + " __name:=kill_clock > " + log + " 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  const bool running = spinUntil([&] { return last_clock >= 1.0; }, 60.0);
  const int victim = nodePid("/p2");
  bool killed = false;
  if (running && victim > 0)
    killed = kill(victim, SIGKILL) == 0;
  const ros::WallTime killed_at = ros::WallTime::now();
  int status = 0;
  pid_t done = 0;
  while ((done = waitpid(child, &status, WNOHANG)) == 0 && (ros::WallTime::now() - killed_at).toSec() < 30.0)
    ros::WallDuration(0.05).sleep();
  if (done == 0)
  {
    kill(child, SIGKILL);
    waitpid(child, &status, 0);
  }
  const double stopped_after = (ros::WallTime::now() - killed_at).toSec();
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  std::remove(log.c_str());
  ASSERT_TRUE(running) << "the clock did not reach 1 s: " << text.str();
  ASSERT_GT(victim, 0) << "no pid for /p2";
  ASSERT_TRUE(killed);
  ASSERT_NE(done, 0) << "the clock still ran 30 s after p2 was killed: " << text.str();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << text.str();
  EXPECT_NE(text.str().find("partition(s) p2 did not report"), std::string::npos) << text.str();
  EXPECT_EQ(text.str().find("partition(s) p1"), std::string::npos) << text.str();
  std::printf("[ partitions ] p2 killed at t = %.2f s; the clock stopped %.2f s (wall) later\n", last_clock,
              stopped_after);
}
TEST(PartitionBadExchange, AMalformedExchangeStopsThePartitionNamingTheTopic)
{
  // This node is the clock and a fake peer "p2" of a real partition "p1" (run as a child so
  // its exit status and message can be read).
  ros::NodeHandle nh, pnh("~");
  std::string config_dir, soils_file;
  ASSERT_TRUE(pnh.getParam("config_dir", config_dir));
  ASSERT_TRUE(pnh.getParam("soils_file", soils_file));
  XmlRpc::XmlRpcValue vehicles, v, peers;
  v["name"] = std::string("solo");
  v["model"] = std::string("fed_alpha");
  v["x"] = 0.0;
  v["y"] = 0.0;
  v["yaw"] = 0.0;
  vehicles[0] = v;
  peers[0] = std::string("p2");
  const std::string ns = "/bad_p1";
  nh.setParam(ns + "/vehicles", vehicles);
  nh.setParam(ns + "/peers", peers);
  nh.setParam(ns + "/partition", std::string("p1"));
  nh.setParam(ns + "/publish_clock", false);
  nh.setParam(ns + "/config_dir", config_dir);
  nh.setParam(ns + "/soils_file", soils_file);
  nh.setParam(ns + "/flat_soil", std::string("gravel"));
  nh.setParam(ns + "/flat_size", 30.0);
  nh.setParam(ns + "/lockstep_timeout", 20.0);
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  ros::Publisher exchange = nh.advertise<avsp_msgs::PartitionExchange>("/lockstep/exchange/p2", 10);
  bool done0 = false;
  std::size_t exchanges = 0;
  ros::Subscriber done_sub = nh.subscribe<avsp_msgs::StepDone>(
      "/lockstep/done", 10, [&](const avsp_msgs::StepDone::ConstPtr& m) { done0 |= m->header.stamp.isZero(); });
  ros::Subscriber exchange_sub = nh.subscribe<avsp_msgs::PartitionExchange>(
      "/lockstep/exchange/p1", 10, [&](const avsp_msgs::PartitionExchange::ConstPtr&) { ++exchanges; });
  const std::string log = "/tmp/avsp_bad_exchange_" + std::to_string(getpid()) + ".log";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0)
  {
    const std::string cmd = std::string(DYNAMICS_NODE_PATH) + " __name:=bad_p1 > " + log + " 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Tick 0 until p1 reports it (it waits for this node to subscribe to its exchange first).
  ros::WallTime tick = ros::WallTime::now();
  const bool started = spinUntil(
      [&] {
        if (ros::WallTime::now() > tick)
        {
          rosgraph_msgs::Clock c;
          clock.publish(c);
          tick = ros::WallTime::now() + ros::WallDuration(0.1);
        }
        return done0 && exchanges > 0 && exchange.getNumSubscribers() > 0;
      },
      60.0);
  // The fake peer's exchange of t = 0 with 2 soil points but 3 values before (6 needed).
  avsp_msgs::PartitionExchange bad;
  bad.partition = "p2";
  bad.soil_points = { 0, 1 };
  bad.soil_before = { 0.f, 0.f, 0.f };
  bad.soil_after = { 0.f, 0.f, 0.f, 0.f, 0.f, 0.f };
  exchange.publish(bad);
  rosgraph_msgs::Clock c;
  c.clock = ros::Time(0.01);
  clock.publish(c);
  int status = 0;
  pid_t finished = 0;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while ((finished = waitpid(child, &status, WNOHANG)) == 0 && ros::WallTime::now() < deadline)
  {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  if (finished == 0)
  {
    kill(child, SIGKILL);
    waitpid(child, &status, 0);
  }
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  std::remove(log.c_str());
  ASSERT_TRUE(started) << "p1 did not report t = 0: " << text.str();
  ASSERT_NE(finished, 0) << "p1 still ran 30 s after the bad exchange: " << text.str();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << text.str();
  EXPECT_NE(text.str().find("bad exchange on /lockstep/exchange/p2: soil_before and soil_after must hold 3 values "
                            "per soil_points entry"),
            std::string::npos)
      << text.str();
}
}  // namespace

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_partitions");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}

namespace
{
/// Who publishes `topic` (full node names).
std::set<std::string> publishersOf(const std::string& topic)
{
  avsp::node::RosGraph graph;
  if (!avsp::node::readRosGraph(graph) || graph.publishers.count(topic) == 0)
    return {};
  return graph.publishers.at(topic);
}
}  // namespace

TEST(PartitionSpawn, AVehicleJoinsThePartitionNamedAndLeavesThroughAnyPartition)
{
  ros::NodeHandle nh;
  double clock = 0.0;
  ros::Subscriber clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 10, [&](const rosgraph_msgs::Clock::ConstPtr& m) { clock = m->clock.toSec(); });
  std::vector<double> c_stamps;
  ros::Subscriber c_sub = nh.subscribe<nav_msgs::Odometry>(
      "/c/avt_341/odometry", 1000,
      [&](const nav_msgs::Odometry::ConstPtr& m) { c_stamps.push_back(m->header.stamp.toSec()); });
  ASSERT_TRUE(ros::service::waitForService("/p1/spawn_vehicle", 30000));
  ASSERT_TRUE(ros::service::waitForService("/p2/spawn_vehicle", 30000));
  ASSERT_TRUE(spinUntil([&] { return clock > 0.5; }, 60.0)) << "the clock did not start";

  avsp_msgs::SpawnVehicle spawn;
  spawn.request.name = "c";
  spawn.request.model = "mrzr";
  spawn.request.x = 10.0;
  spawn.request.y = 0.0;
  spawn.request.partition = "p9";
  ASSERT_TRUE(ros::service::call("/p1/spawn_vehicle", spawn));
  EXPECT_FALSE(spawn.response.success);
  EXPECT_NE(spawn.response.message.find("no partition 'p9' in this run (partitions: p1, p2)"), std::string::npos)
      << spawn.response.message;

  // Asked of p1, run by p2.
  spawn.request.partition = "p2";
  ASSERT_TRUE(ros::service::call("/p1/spawn_vehicle", spawn));
  ASSERT_TRUE(spawn.response.success) << spawn.response.message;
  EXPECT_EQ(spawn.response.message.rfind("partition 'p2': 'c' (mrzr) set down at (10, 0)", 0), 0u)
      << spawn.response.message;
  const double spawned = clock;
  ASSERT_TRUE(spinUntil([&] { return !c_stamps.empty() && clock > spawned + 0.2; }, 30.0)) << "no odometry of c";
  EXPECT_EQ(publishersOf("/c/avt_341/odometry"), std::set<std::string>{ "/p2" });
  // p1 has applied p2's exchanges well past the spawn: it knows c as p2's.
  avsp_msgs::SpawnVehicle again = spawn;
  again.request.partition = "";
  ASSERT_TRUE(ros::service::call("/p1/spawn_vehicle", again));
  EXPECT_FALSE(again.response.success);
  EXPECT_NE(again.response.message.find("there is already a vehicle 'c' (partition 'p2')"), std::string::npos)
      << again.response.message;

  // Removed through p1, by p2.
  avsp_msgs::RemoveVehicle remove;
  remove.request.name = "c";
  ASSERT_TRUE(ros::service::call("/p1/remove_vehicle", remove));
  ASSERT_TRUE(remove.response.success) << remove.response.message;
  EXPECT_EQ(remove.response.message.rfind("partition 'p2': 'c' removed at t = ", 0), 0u) << remove.response.message;
  const double removed = clock;
  ASSERT_TRUE(spinUntil([&] { return clock > removed + 0.2; }, 30.0));
  EXPECT_TRUE(publishersOf("/c/avt_341/odometry").empty());
  const double last = c_stamps.back();
  EXPECT_LE(last, removed + 0.05) << "c's odometry went on after its removal";
  // p1 has dropped its proxy: the name is free, and c joins p1 this time.
  ASSERT_TRUE(ros::service::call("/p1/spawn_vehicle", again));
  ASSERT_TRUE(again.response.success) << again.response.message;
  ASSERT_TRUE(spinUntil([&] { return !c_stamps.empty() && c_stamps.back() > last + 0.1; }, 30.0));
  EXPECT_EQ(publishersOf("/c/avt_341/odometry"), std::set<std::string>{ "/p1" });
  ASSERT_TRUE(ros::service::call("/p2/remove_vehicle", remove));  // and leaves through p2
  EXPECT_TRUE(remove.response.success) << remove.response.message;
  EXPECT_EQ(remove.response.message.rfind("partition 'p1': ", 0), 0u) << remove.response.message;
}
