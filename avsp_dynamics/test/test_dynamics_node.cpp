// rostest of dynamics_node (test/dynamics_node.test): the vehicle is driven only through
// avt_341/cmd_vel and judged only by what the node publishes (odometry, /terrain/ruts,
// /rosout). Time is the node's sim time (odometry stamps); wall deadlines only guard a hang.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <avsp_msgs/DriveCommand.h>
#include <avsp_msgs/RemoveVehicle.h>
#include <avsp_msgs/SpawnVehicle.h>
#include <avsp_msgs/SetVehiclePose.h>
#include <avsp_msgs/StepPhysics.h>
#include <avsp_msgs/TerrainPatch.h>
#include <avsp_msgs/VehicleTelemetry.h>
#include <geometry_msgs/Twist.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <tf2_msgs/TFMessage.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/JointState.h>
#include <std_srvs/Trigger.h>

#include <Eigen/Core>
#include <avsp_terrain/ros/run_command.hpp>
#include <avsp_terrain/ros/spin_until.hpp>

#include "avsp_dynamics/vehicle_model.hpp"

namespace
{
/// Spins until `done` holds or `timeout` (wall s) passes.
/// avsp::node::spinUntil, polling every 0.001 s here.
bool spinUntil(const std::function<bool()>& done, double timeout = 60.0)
{
  return avsp::node::spinUntil(done, timeout, 0.001);
}

geometry_msgs::Twist twist(double throttle, double brake_y, double steering)
{
  geometry_msgs::Twist t;
  t.linear.x = throttle;
  t.linear.y = brake_y;  // avt_341 sends the brake as [-1, 0]
  t.angular.z = steering;
  return t;
}

double yawOf(const nav_msgs::Odometry& o)
{
  const auto& q = o.pose.pose.orientation;
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

double speedOf(const nav_msgs::Odometry& o)
{
  return std::hypot(o.twist.twist.linear.x, o.twist.twist.linear.y);
}

struct Ego
{
  ros::NodeHandle nh;
  std::vector<nav_msgs::Odometry> odom;
  std::vector<avsp_msgs::TerrainPatch> ruts;
  std::vector<std::string> warnings;
  avsp_msgs::VehicleTelemetry telemetry;                                           ///< the latest
  std::vector<diagnostic_msgs::DiagnosticStatus> ego_reports, simulation_reports;  ///< node "dynamics"
  std::size_t nan_sent = 0;  ///< NaN commands published on cmd_vel
  std::vector<nav_msgs::Odometry> wheel_odom, truth;
  ros::Subscriber odom_sub, ruts_sub, log_sub, telemetry_sub, diagnostics_sub, wheel_sub, truth_sub;
  ros::Publisher cmd_pub, drive_pub;

  Ego()
  {
    odom_sub = nh.subscribe<nav_msgs::Odometry>("/ego/avt_341/odometry", 1000,
                                                [this](const nav_msgs::Odometry::ConstPtr& m) { odom.push_back(*m); });
    // Only the ego's node: the determinism nodes (det_a_sim, det_b_sim) publish ruts too.
    using RutsEvent = ros::MessageEvent<avsp_msgs::TerrainPatch const>;
    const boost::function<void(const RutsEvent&)> on_ruts = [this](const RutsEvent& e) {
      if (e.getPublisherName() == "/dynamics")
        ruts.push_back(*e.getMessage());
    };
    ruts_sub = nh.subscribe<avsp_msgs::TerrainPatch, const RutsEvent&>("/terrain/ruts", 100, on_ruts);
    log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 100, [this](const rosgraph_msgs::Log::ConstPtr& m) {
      if (m->level >= rosgraph_msgs::Log::WARN)
        warnings.push_back(m->msg);
    });
    telemetry_sub = nh.subscribe<avsp_msgs::VehicleTelemetry>(
        "/ego/telemetry", 100, [this](const avsp_msgs::VehicleTelemetry::ConstPtr& m) { telemetry = *m; });
    diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 100, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
          for (const auto& s : m->status)
            if (s.name == "dynamics: ego")
              ego_reports.push_back(s);
            else if (s.name == "dynamics: simulation")
              simulation_reports.push_back(s);
        });
    wheel_sub = nh.subscribe<nav_msgs::Odometry>(
        "/ego/wheel_odometry", 1000, [this](const nav_msgs::Odometry::ConstPtr& m) { wheel_odom.push_back(*m); });
    truth_sub = nh.subscribe<nav_msgs::Odometry>(
        "/ego/ground_truth/odometry", 1000, [this](const nav_msgs::Odometry::ConstPtr& m) { truth.push_back(*m); });
    cmd_pub = nh.advertise<geometry_msgs::Twist>("/ego/avt_341/cmd_vel", 10);
    drive_pub = nh.advertise<avsp_msgs::DriveCommand>("/ego/cmd_drive", 10);
  }

  double now() const { return odom.empty() ? 0.0 : odom.back().header.stamp.toSec(); }

  /// Sends `cmd` on every new odometry message (100 Hz sim) until sim time `until`.
  bool drive(const geometry_msgs::Twist& cmd, double until, const geometry_msgs::Twist* every_other = nullptr)
  {
    std::size_t seen = odom.size();
    std::size_t sent = 0;
    return spinUntil([&] {
      if (odom.size() > seen)
      {
        seen = odom.size();
        const bool other = every_other && sent % 2 == 1;
        cmd_pub.publish(other ? *every_other : cmd);
        nan_sent += other && std::isnan(every_other->linear.x);
        ++sent;
      }
      return now() >= until;
    });
  }

  /// Sends `cmd` on /ego/cmd_drive on every new odometry message until sim time `until`.
  bool driveCommand(const avsp_msgs::DriveCommand& cmd, double until)
  {
    std::size_t seen = odom.size();
    return spinUntil([&] {
      if (odom.size() > seen)
      {
        seen = odom.size();
        drive_pub.publish(cmd);
      }
      return now() >= until;
    });
  }

  /// Sends nothing until sim time `until`.
  bool idle(double until)
  {
    return spinUntil([&] { return now() >= until; });
  }
};

TEST(DynamicsNode, DrivesThroughCmdVel)
{
  Ego ego;
  ASSERT_TRUE(spinUntil([&] { return ego.now() >= 1.0; })) << "no odometry from /ego/avt_341/odometry";
  const nav_msgs::Odometry first = ego.odom.front();
  EXPECT_EQ(first.header.frame_id, "odom");
  EXPECT_EQ(first.child_frame_id, "ego/base_link");
  EXPECT_NEAR(first.pose.pose.position.x, -30.0, 0.05);
  // Stamps are the node's fixed-step sim time: 100 Hz, 0.01 s apart.
  ASSERT_GE(ego.odom.size(), 3u);
  EXPECT_NEAR((ego.odom[2].header.stamp - ego.odom[1].header.stamp).toSec(), 0.01, 1e-6);

  // No command yet: the node brakes, so after landing the vehicle stays put.
  const nav_msgs::Odometry settled = ego.odom.back();
  ASSERT_TRUE(ego.idle(2.0));
  EXPECT_LT(std::abs(ego.odom.back().pose.pose.position.x - settled.pose.pose.position.x), 0.01);
  EXPECT_LT(speedOf(ego.odom.back()), 0.02);
  // Telemetry at rest: braked (no command), the soil carries the vehicle's weight.
  {
    std::string config_dir;
    ASSERT_TRUE(ros::NodeHandle("~").getParam("config_dir", config_dir));
    const avsp::dynamics::VehicleModel model = avsp::dynamics::loadVehicleModel(config_dir + "/fed_alpha.yaml");
    const avsp_msgs::VehicleTelemetry tm = ego.telemetry;
    EXPECT_EQ(tm.vehicle_id, "ego");
    EXPECT_EQ(tm.command.throttle, 0.0);
    EXPECT_EQ(tm.command.brake, 1.0);
    EXPECT_FALSE(tm.stuck);
    EXPECT_EQ(tm.collisions, 0u);  // nothing to hit on the open square
    ASSERT_EQ(tm.contacts.size(), model.wheels.size());
    double load = 0.0;
    for (std::size_t w = 0; w < tm.contacts.size(); ++w)
    {
      EXPECT_EQ(tm.contacts[w].name, model.wheels[w].link);
      EXPECT_EQ(tm.contacts[w].driven, model.wheels[w].driven) << tm.contacts[w].name;
      EXPECT_EQ(tm.contacts[w].soil, "gravel");
      load += tm.contacts[w].normal_force;
    }
    EXPECT_NEAR(load, model.total_mass * 9.81, 0.02 * model.total_mass * 9.81);
  }

  // Throttle step (NaN commands interleaved: rejected, the last good one stays in force).
  ASSERT_TRUE(ego.cmd_pub.getNumSubscribers() > 0 || spinUntil([&] { return ego.cmd_pub.getNumSubscribers() > 0; }));
  const geometry_msgs::Twist nan_cmd = twist(std::nan(""), 0.0, 0.0);
  ASSERT_TRUE(ego.drive(twist(0.4, 0.0, 0.0), 3.5, &nan_cmd));
  const double v_mid = speedOf(ego.odom.back());
  ASSERT_TRUE(ego.drive(twist(0.4, 0.0, 0.0), 5.0, &nan_cmd));
  const double v_end = speedOf(ego.odom.back());
  EXPECT_GT(v_mid, 0.5);
  EXPECT_GT(v_end, v_mid + 0.5) << "speed did not keep increasing under throttle";
  EXPECT_GT(ego.odom.back().twist.twist.linear.x, 0.0) << "twist must be forward in base_link";
  EXPECT_LT(std::abs(ego.odom.back().pose.pose.position.y), 0.5) << "drove off straight";
  ASSERT_TRUE(spinUntil(
      [&] {
        for (const auto& w : ego.warnings)
          if (w.find("/ego/avt_341/cmd_vel") != std::string::npos && w.find("rejected") != std::string::npos)
            return true;
        return false;
      },
      10.0))
      << "no warning naming /ego/avt_341/cmd_vel for the NaN commands";

  // Positive steering turns left: yaw rate > 0, heading increases.
  const double yaw0 = yawOf(ego.odom.back());
  ASSERT_TRUE(ego.drive(twist(0.2, 0.0, 0.5), 7.0));
  EXPECT_GT(ego.odom.back().twist.twist.angular.z, 0.05);
  EXPECT_GT(yawOf(ego.odom.back()) - yaw0, 0.1);

  // Full brake (avt_341's -1) stops it.
  ASSERT_TRUE(ego.drive(twist(0.0, -1.0, 0.0), 10.0));
  EXPECT_LT(speedOf(ego.odom.back()), 0.05);
  EXPECT_EQ(ego.telemetry.command.brake, 1.0);

  // Moving again, then silence: the stale command (0.5 s) becomes zero throttle, full brake.
  ASSERT_TRUE(ego.drive(twist(0.4, 0.0, 0.0), 11.5));
  const double v_before = speedOf(ego.odom.back());
  EXPECT_GT(v_before, 0.5);
  const double silent_from = ego.now();
  ASSERT_TRUE(ego.idle(silent_from + 0.4));
  EXPECT_GT(speedOf(ego.odom.back()), 0.8 * v_before) << "braked before the command went stale";
  ASSERT_TRUE(ego.idle(silent_from + 4.0));
  EXPECT_LT(speedOf(ego.odom.back()), 0.05) << "a stale command must brake the vehicle to a stop";
  EXPECT_EQ(ego.telemetry.command.throttle, 0.0);
  EXPECT_EQ(ego.telemetry.command.brake, 1.0);

  // The same vehicle through cmd_drive (avsp_msgs/DriveCommand).
  avsp_msgs::DriveCommand drive;
  drive.throttle = 0.4;
  ASSERT_TRUE(ego.driveCommand(drive, ego.now() + 1.5));
  EXPECT_GT(speedOf(ego.odom.back()), 0.5);
  EXPECT_NEAR(ego.telemetry.command.throttle, 0.4, 1e-12);

  // Ruts of the drive on /terrain/ruts: well-formed patches, the track below the flat surface.
  ASSERT_FALSE(ego.ruts.empty());
  float lowest = 0.0f;
  for (const auto& p : ego.ruts)
  {
    EXPECT_EQ(p.header.frame_id, "map");
    ASSERT_EQ(p.heights.size(), static_cast<std::size_t>(p.width) * p.height);
    EXPECT_NEAR(p.resolution, 0.1, 1e-9);
    for (float h : p.heights)
      lowest = std::min(lowest, h);
  }
  EXPECT_LT(lowest, -0.002) << "no rut below the flat gravel surface";
  // Each rut instant (2 Hz) ends with its marker (width = height = 0), after its patches.
  std::size_t markers = 0;
  for (std::size_t k = 0; k < ego.ruts.size(); ++k)
  {
    const auto& p = ego.ruts[k];
    if (p.width != 0 || p.height != 0)
      continue;
    ++markers;
    const double t = p.header.stamp.toSec();
    EXPECT_NEAR(t * 2.0, std::round(t * 2.0), 1e-9) << "marker at " << t << " s";
    if (k > 0)
      EXPECT_LE(ego.ruts[k - 1].header.stamp.toSec(), t + 1e-9);
  }
  EXPECT_GE(markers, 3u);

  // ground_truth/odometry is avt_341/odometry; wheel_odometry (gyro + running gear on gravel)
  // follows it to within 5 % of the distance driven, its position variance growing with it.
  ASSERT_FALSE(ego.truth.empty());
  ASSERT_FALSE(ego.wheel_odom.empty());
  {
    auto odometryAt = [&](const ros::Time& stamp) -> const nav_msgs::Odometry* {
      for (const auto& o : ego.odom)
        if (o.header.stamp == stamp)
          return &o;
      return nullptr;
    };
    const nav_msgs::Odometry& t = ego.truth.back();
    const nav_msgs::Odometry* same = odometryAt(t.header.stamp);
    ASSERT_NE(same, nullptr);
    EXPECT_EQ(same->pose.pose.position.x, t.pose.pose.position.x);
    EXPECT_EQ(same->twist.twist.linear.x, t.twist.twist.linear.x);
    const nav_msgs::Odometry& w0 = ego.wheel_odom.front();
    const nav_msgs::Odometry& w = ego.wheel_odom.back();
    const nav_msgs::Odometry* at = odometryAt(w.header.stamp);
    ASSERT_NE(at, nullptr);
    EXPECT_EQ(w.header.frame_id, "odom");
    EXPECT_EQ(w.child_frame_id, "ego/base_link");
    double driven = 0.0;
    for (std::size_t k = 1; k < ego.odom.size(); ++k)
      driven += std::hypot(ego.odom[k].pose.pose.position.x - ego.odom[k - 1].pose.pose.position.x,
                           ego.odom[k].pose.pose.position.y - ego.odom[k - 1].pose.pose.position.y);
    ASSERT_GT(driven, 5.0);
    const double error = std::hypot(w.pose.pose.position.x - at->pose.pose.position.x,
                                    w.pose.pose.position.y - at->pose.pose.position.y);
    EXPECT_LT(error, 0.05 * driven) << "wheel odometry " << error << " m off after " << driven << " m";
    EXPECT_GT(error, 0.0) << "wheel odometry is not the ground truth";
    EXPECT_GT(w.pose.covariance[0], w0.pose.covariance[0]);
    EXPECT_EQ(w.pose.covariance[0], w.pose.covariance[7]);
  }

  // /diagnostics ("dynamics: ego", every 1 s of sim time): every NaN command counted as
  // refused, the report after them a warning, the last one (1.5 s of good commands) OK.
  auto value = [](const diagnostic_msgs::DiagnosticStatus& s, const std::string& key) {
    for (const auto& kv : s.values)
      if (kv.key == key)
        return kv.value;
    return std::string("(absent)");
  };
  ASSERT_GT(ego.nan_sent, 10u);
  ASSERT_TRUE(spinUntil(
      [&] {
        return !ego.ego_reports.empty() &&
               value(ego.ego_reports.back(), "commands refused") == std::to_string(ego.nan_sent);
      },
      30.0))
      << "refused " << (ego.ego_reports.empty() ? "(no report)" : value(ego.ego_reports.back(), "commands refused"))
      << ", NaN commands sent " << ego.nan_sent;
  const diagnostic_msgs::DiagnosticStatus& last = ego.ego_reports.back();
  EXPECT_EQ(last.level, diagnostic_msgs::DiagnosticStatus::OK) << last.message;
  EXPECT_EQ(last.message, "commanded");
  EXPECT_EQ(value(last, "stuck"), "False");
  EXPECT_EQ(value(last, "parking brake"), "False");
  EXPECT_EQ(last.hardware_id, "/dynamics");
  bool warned = false;
  for (const auto& r : ego.ego_reports)
    warned = warned || (r.level == diagnostic_msgs::DiagnosticStatus::WARN &&
                        r.message.find("command(s) refused since the last report") != std::string::npos);
  EXPECT_TRUE(warned) << "no warning for the refused commands";
  // "dynamics: simulation": the sim time is the steps at 1 ms; the target is ~real_time_factor.
  ASSERT_FALSE(ego.simulation_reports.empty());
  for (const auto& r : ego.simulation_reports)
  {
    const double sim = std::stod(value(r, "sim time (s)"));
    EXPECT_NEAR(std::stod(value(r, "steps")) * 0.001, sim, 1e-6);
    EXPECT_EQ(value(r, "real-time factor target"), "2");
    EXPECT_GT(std::stod(value(r, "real-time factor")), 0.0);
  }
}

TEST(DynamicsNode, SameCommandsGiveIdenticalOdometry)
{
  // Two nodes, each with its own world, start stepping when their (latched) command arrives;
  // it goes stale after 0.5 s, so each run is throttle + steering, then braking.
  ros::NodeHandle nh;
  std::vector<nav_msgs::Odometry> a, b, c;
  ros::Subscriber sc = nh.subscribe<nav_msgs::Odometry>(
      "/det_c/avt_341/odometry", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) { c.push_back(*m); });
  ros::Subscriber sa = nh.subscribe<nav_msgs::Odometry>(
      "/det_a/avt_341/odometry", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) { a.push_back(*m); });
  ros::Subscriber sb = nh.subscribe<nav_msgs::Odometry>(
      "/det_b/avt_341/odometry", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) { b.push_back(*m); });
  // det_b's node runs with ~publish_odom_tf false: no odom -> det_b/base_link on /tf (a
  // localisation stack owns it), while det_a's comes with each odometry message.
  // det_c's node has ~per_vehicle_odom_frames: det_c/odom -> det_c/base_link, and map -> det_c/odom
  // (identity) once on /tf_static.
  std::size_t tf_a = 0, tf_b = 0, tf_c = 0;
  ros::Subscriber tf_sub = nh.subscribe<tf2_msgs::TFMessage>("/tf", 1000, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
    for (const auto& t : m->transforms)
    {
      tf_a += t.child_frame_id == "det_a/base_link" && t.header.frame_id == "odom";
      tf_b += t.child_frame_id == "det_b/base_link";
      tf_c += t.child_frame_id == "det_c/base_link" && t.header.frame_id == "det_c/odom";
    }
  });
  std::vector<geometry_msgs::TransformStamped> statics;
  ros::Subscriber static_sub =
      nh.subscribe<tf2_msgs::TFMessage>("/tf_static", 10, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
        for (const auto& t : m->transforms)
          statics.push_back(t);
      });
  // The nodes step from their first command on: connected to both odometry streams (and /tf)
  // first, or the first messages go by unseen.
  ASSERT_TRUE(spinUntil([&] {
    return sa.getNumPublishers() > 0 && sb.getNumPublishers() > 0 && sc.getNumPublishers() > 0 &&
           tf_sub.getNumPublishers() > 0;
  })) << "no det_a / det_b / det_c odometry publisher";
  ros::Publisher pa = nh.advertise<geometry_msgs::Twist>("/det_a/avt_341/cmd_vel", 1, true);
  ros::Publisher pb = nh.advertise<geometry_msgs::Twist>("/det_b/avt_341/cmd_vel", 1, true);
  ros::Publisher pc = nh.advertise<geometry_msgs::Twist>("/det_c/avt_341/cmd_vel", 1, true);
  pa.publish(twist(0.6, 0.0, 0.4));
  pb.publish(twist(0.6, 0.0, 0.4));
  pc.publish(twist(0.6, 0.0, 0.4));
  const std::size_t n = 150;  // 1.5 s of sim time at 100 Hz
  ASSERT_TRUE(spinUntil([&] { return a.size() >= n && b.size() >= n && c.size() >= n && !statics.empty(); }, 120.0))
      << "odometry: det_a " << a.size() << ", det_b " << b.size() << ", det_c " << c.size() << "; /tf_static "
      << statics.size();
  for (std::size_t k = 0; k < n; ++k)
  {
    const auto &pa_ = a[k].pose.pose, &pb_ = b[k].pose.pose;
    const auto &ta = a[k].twist.twist, &tb = b[k].twist.twist;
    ASSERT_EQ(pa_.position.x, pb_.position.x) << "message " << k;
    ASSERT_EQ(pa_.position.y, pb_.position.y) << "message " << k;
    ASSERT_EQ(pa_.position.z, pb_.position.z) << "message " << k;
    ASSERT_EQ(pa_.orientation.z, pb_.orientation.z) << "message " << k;
    ASSERT_EQ(pa_.orientation.w, pb_.orientation.w) << "message " << k;
    ASSERT_EQ(ta.linear.x, tb.linear.x) << "message " << k;
    ASSERT_EQ(ta.angular.z, tb.angular.z) << "message " << k;
    // The same motion in det_c's own odom frame.
    ASSERT_EQ(a[k].header.frame_id, "odom");
    ASSERT_EQ(c[k].header.frame_id, "det_c/odom") << "message " << k;
    ASSERT_EQ(c[k].pose.pose.position.x, pa_.position.x) << "message " << k;
    ASSERT_EQ(c[k].pose.pose.position.y, pa_.position.y) << "message " << k;
    ASSERT_EQ(c[k].pose.pose.orientation.z, pa_.orientation.z) << "message " << k;
    // Following /clock, stamps are world time from where the node started: 100 Hz exactly.
    ASSERT_NEAR((a[k].header.stamp - a[0].header.stamp).toSec(), 0.01 * k, 1e-6) << "message " << k;
  }
  EXPECT_GT(tf_a, n / 2) << "det_a's odom -> base_link must be on /tf";
  EXPECT_EQ(tf_b, 0u) << "det_b's node has ~publish_odom_tf false";
  EXPECT_GT(tf_c, n / 2) << "det_c/odom -> det_c/base_link must be on /tf";
  std::size_t map_to_c = 0;
  for (const auto& t : statics)
    if (t.child_frame_id == "det_c/odom")
    {
      ++map_to_c;
      EXPECT_EQ(t.header.frame_id, "map");
      EXPECT_EQ(t.transform.translation.x, 0.0);
      EXPECT_EQ(t.transform.translation.y, 0.0);
      EXPECT_EQ(t.transform.translation.z, 0.0);
      EXPECT_EQ(t.transform.rotation.w, 1.0);
    }
    else
      ADD_FAILURE() << "/tf_static: " << t.header.frame_id << " -> " << t.child_frame_id
                    << " (only det_c's node has per-vehicle frames)";
  EXPECT_EQ(map_to_c, 1u);
  // Not trivially equal: the vehicles moved and turned.
  EXPECT_GT(std::hypot(a[n - 1].pose.pose.position.x - a[0].pose.pose.position.x,
                       a[n - 1].pose.pose.position.y - a[0].pose.pose.position.y),
            0.2);
}

/// Sets the private parameters of a one-vehicle dynamics_node on a 20 m gravel square under a
/// fresh name on the master (lists cannot be given on the command line; `more` adds or
/// overrides some) and returns the command line that runs it.
std::string nodeCommand(const std::string& vehicles_yaml_model, const std::string& vehicle_name,
                        const std::string& args, const std::function<void(ros::NodeHandle&, const std::string&)>& more)
{
  static int run = 0;
  const std::string name = "bad_dynamics_" + std::to_string(getpid()) + "_" + std::to_string(run++);
  ros::NodeHandle nh, pnh("~");
  std::string config_dir, soils_file;
  pnh.getParam("config_dir", config_dir);
  pnh.getParam("soils_file", soils_file);
  XmlRpc::XmlRpcValue vehicles, v;
  v["name"] = vehicle_name;
  v["model"] = vehicles_yaml_model;
  v["x"] = 0.0;
  v["y"] = 0.0;
  v["yaw"] = 0.0;
  vehicles[0] = v;
  nh.setParam("/" + name + "/vehicles", vehicles);
  nh.setParam("/" + name + "/config_dir", config_dir);
  nh.setParam("/" + name + "/soils_file", soils_file);
  nh.setParam("/" + name + "/flat_soil", std::string("gravel"));
  nh.setParam("/" + name + "/flat_size", 20.0);
  nh.setParam("/" + name + "/publish_clock", false);
  if (more)
    more(nh, "/" + name);
  return std::string(DYNAMICS_NODE_PATH) + " __name:=" + name + " " + args;
}

/// Runs a dynamics_node that should refuse to start (or stop): its exit code and output (it
/// must exit 1 and say what is wrong).
std::pair<int, std::string> runBadNode(const std::string& vehicles_yaml_model, const std::string& vehicle_name,
                                       const std::string& args = "",
                                       const std::function<void(ros::NodeHandle&, const std::string&)>& more = {})
{
  return avsp::node::runCommand(nodeCommand(vehicles_yaml_model, vehicle_name, args, more));
}

// The tracked carrier in the same world: robot_state_publisher gets every URDF joint of its
// running gear (sprockets, idlers, road arms, road wheels) with the sprockets turning under
// throttle, and telemetry has one contact per track segment carrying the carrier's weight.
TEST(DynamicsNode, TrackedCarrierPublishesRunningGearAndSegments)
{
  std::string config_dir;
  ASSERT_TRUE(ros::NodeHandle("~").getParam("config_dir", config_dir));
  const avsp::dynamics::VehicleModel model = avsp::dynamics::loadVehicleModel(config_dir + "/m113.yaml");
  ros::NodeHandle nh;
  std::vector<sensor_msgs::JointState> joints;
  std::vector<avsp_msgs::VehicleTelemetry> telemetry;
  std::vector<nav_msgs::Odometry> odom;
  auto j_sub = nh.subscribe<sensor_msgs::JointState>(
      "/carrier/joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& m) { joints.push_back(*m); });
  auto t_sub = nh.subscribe<avsp_msgs::VehicleTelemetry>(
      "/carrier/telemetry", 100, [&](const avsp_msgs::VehicleTelemetry::ConstPtr& m) { telemetry.push_back(*m); });
  auto o_sub = nh.subscribe<nav_msgs::Odometry>("/carrier/avt_341/odometry", 100,
                                                [&](const nav_msgs::Odometry::ConstPtr& m) { odom.push_back(*m); });
  ros::Publisher cmd = nh.advertise<geometry_msgs::Twist>("/carrier/avt_341/cmd_vel", 10);
  // At rest (no command: full brake) once settled.
  ASSERT_TRUE(spinUntil([&] {
    return !telemetry.empty() && telemetry.back().header.stamp.toSec() > 1.0 && !joints.empty() && !odom.empty();
  })) << "no carrier joint_states/telemetry after 1 s of sim time";

  std::vector<std::string> expected;
  std::vector<std::string> segments;
  for (const auto& t : model.tracks)
  {
    expected.push_back(t.sprocket_joint);
    expected.push_back(t.idler_joint);
    for (const auto& w : t.road_wheels)
    {
      expected.push_back(w.arm_joint);
      expected.push_back(w.spin_joint);
      segments.push_back(w.link);
    }
  }
  const sensor_msgs::JointState js = joints.back();
  EXPECT_EQ(js.name, expected);
  ASSERT_EQ(js.position.size(), expected.size());
  const avsp_msgs::VehicleTelemetry tm = telemetry.back();
  ASSERT_EQ(tm.contacts.size(), segments.size());
  double normal = 0.0;
  for (std::size_t k = 0; k < segments.size(); ++k)
  {
    EXPECT_EQ(tm.contacts[k].name, segments[k]);
    EXPECT_TRUE(tm.contacts[k].driven) << segments[k];  // a track is driven by its sprocket
    EXPECT_EQ(tm.contacts[k].soil, "gravel");
    normal += tm.contacts[k].normal_force;
  }
  EXPECT_NEAR(normal, model.total_mass * 9.81, 0.02 * model.total_mass * 9.81);
  EXPECT_FALSE(tm.stuck);

  // Throttle: the sprockets (joint 0: left, then the right one after its road wheels) turn
  // forward and the carrier moves off.
  const std::size_t right_sprocket = 2 + 2 * model.tracks[0].road_wheels.size();
  const double start_x = odom.back().pose.pose.position.x;
  const double until = odom.back().header.stamp.toSec() + 2.0;
  std::size_t seen = odom.size();
  ASSERT_TRUE(spinUntil([&] {
    if (odom.size() > seen)
    {
      seen = odom.size();
      cmd.publish(twist(0.5, 0.0, 0.0));
    }
    return !odom.empty() && odom.back().header.stamp.toSec() >= until;
  }));
  ASSERT_FALSE(joints.empty());
  EXPECT_GT(joints.back().velocity[0], 1.0) << "left sprocket rad/s";
  EXPECT_GT(joints.back().velocity[right_sprocket], 1.0) << "right sprocket rad/s";
  EXPECT_GT(odom.back().pose.pose.position.x - start_x, 0.5);
}

TEST(DynamicsNodeStartup, RefusesUnknownModelsByName)
{
  auto [code, out] = runBadNode("no_such_model", "rover7");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("rover7"), std::string::npos) << out;
  EXPECT_NE(out.find("no_such_model"), std::string::npos) << out;

  // Scalar parameters out of range, and a vehicle placed off the terrain.
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_step:=0.0");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~step"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_real_time_factor:=-1.0");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~real_time_factor"), std::string::npos) << out;
  // A value of the wrong type is refused, not replaced by the default.
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_step:=fast");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~step must be a number, got a string"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_publish_clock:=maybe");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~publish_clock must be true or false, got a string"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_partition:=7");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~partition must be a string, got an integer"), std::string::npos) << out;
  // The shared terrain parameters (terrain_source_params.hpp) too: ~transport and ~flat_soil.
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_transport:=1");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~transport must be true or false, got an integer"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_flat_soil:=3.5");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~flat_soil must be a string, got a number"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_flat_soil:=marmalade");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~flat_soil"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_flat_size:=2.0");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("'car'"), std::string::npos) << out;
  EXPECT_NE(out.find("off the terrain"), std::string::npos) << out;

  // Lockstep names must be vehicles, and the barrier needs the node to be the clock.
  const auto lockstep = [](const std::string& name) {
    return [name](ros::NodeHandle& nh, const std::string& ns) {
      XmlRpc::XmlRpcValue list;
      list[0] = name;
      nh.setParam(ns + "/lockstep_vehicles", list);
    };
  };
  std::tie(code, out) = runBadNode("fed_alpha", "car", "", lockstep("truck"));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~lockstep_vehicles[0] 'truck' is not in ~vehicles"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "", lockstep("car"));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~publish_clock"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_publish_clock:=true _lockstep_period:=0.015", lockstep("car"));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~lockstep_period"), std::string::npos) << out;

  // Peers: only for a partition, never itself, each once.
  const auto peers = [](std::vector<std::string> names) {
    return [names](ros::NodeHandle& nh, const std::string& ns) {
      XmlRpc::XmlRpcValue list;
      for (std::size_t k = 0; k < names.size(); ++k)
        list[static_cast<int>(k)] = names[k];
      nh.setParam(ns + "/peers", list);
    };
  };
  std::tie(code, out) = runBadNode("fed_alpha", "car", "", peers({ "p2" }));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~peers needs a ~partition"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_partition:=p1", peers({ "p2", "p1" }));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~peers[1] 'p1' is this partition"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_partition:=p1", peers({ "p2", "p2" }));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~peers[1] 'p2' is listed twice"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_partition:=p1", peers({ "a/b" }));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~peers[0] 'a/b' must be a plain name"), std::string::npos) << out;
  std::tie(code, out) = runBadNode("fed_alpha", "car", "_partition:=p1 _step_ahead_intervals:=2.5", peers({ "p2" }));
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~step_ahead_intervals must be an integer, got 2.5"), std::string::npos) << out;
}

// A lockstep vehicle whose controller never answers stops the run after ~lockstep_timeout with
// an error naming its command topic: no silent hang. (Its own /clock is remapped away from the
// test's clock.)
TEST(DynamicsNodeStartup, LockstepVehicleThatNeverAnswersStopsTheRunNamingIt)
{
  const auto lockstep = [](ros::NodeHandle& nh, const std::string& ns) {
    XmlRpc::XmlRpcValue list;
    list[0] = std::string("mute");
    nh.setParam(ns + "/lockstep_vehicles", list);
  };
  const ros::WallTime start = ros::WallTime::now();
  auto [code, out] =
      runBadNode("fed_alpha", "mute", "_publish_clock:=true _lockstep_timeout:=1.0 /clock:=/mute_clock", lockstep);
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("lockstep: no command for t = 0.000 s on /mute/cmd_drive"), std::string::npos) << out;
  EXPECT_LT((ros::WallTime::now() - start).toSec(), 30.0) << "the run hung instead of stopping";
}

// A barrier that waits sends /clock again (each second, wall), so a node that answers through
// the clock and connected after the last tick went out still answers: v2v_radio_node emits a
// lockstep batch only when /clock reaches it, and once missed the ticks to 0.05 s; the run then
// stood at that barrier until ~lockstep_timeout. Here the test's own /late_clock subscription
// is made only after the tick of the barrier at 0.05 s went out.
TEST(DynamicsNodeLockstep, ABarrierThatWaitsSendsTheClockAgain)
{
  const auto lockstep = [](ros::NodeHandle& nh, const std::string& ns) {
    XmlRpc::XmlRpcValue list;
    list[0] = std::string("late");
    nh.setParam(ns + "/lockstep_vehicles", list);
  };
  const std::string cmd =
      nodeCommand("fed_alpha", "late", "_publish_clock:=true _lockstep_timeout:=60.0 /clock:=/late_clock", lockstep);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0)
  {
    execl("/bin/sh", "sh", "-c", ("exec " + cmd + " > /dev/null 2>&1").c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  ros::NodeHandle nh;
  std::vector<nav_msgs::Odometry> odom;
  auto odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/late/avt_341/odometry", 1000, [&odom](const nav_msgs::Odometry::ConstPtr& m) { odom.push_back(*m); });
  auto drive_pub = nh.advertise<avsp_msgs::DriveCommand>("/late/cmd_drive", 10);
  const auto answer = [&drive_pub](const ros::Time& stamp) {
    avsp_msgs::DriveCommand c;
    c.header.stamp = stamp;
    c.brake = 1.0;
    drive_pub.publish(c);
  };
  // Answer every odometry of time 0 (the node sends it again until answered), then wait for
  // the barrier at 0.05 s without answering it.
  std::size_t seen = 0;
  const bool at_barrier = spinUntil([&] {
    for (; seen < odom.size(); ++seen)
      if (odom[seen].header.stamp.isZero())
        answer(odom[seen].header.stamp);
    return !odom.empty() && odom.back().header.stamp.toSec() > 0.05 - 1e-6;
  });
  std::vector<double> ticks;
  bool went_on = false;
  if (at_barrier)
  {
    EXPECT_NEAR(odom.back().header.stamp.toSec(), 0.05, 1e-9) << "the node stepped past its barrier";
    auto clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
        "/late_clock", 10, [&ticks](const rosgraph_msgs::Clock::ConstPtr& c) { ticks.push_back(c->clock.toSec()); });
    EXPECT_TRUE(spinUntil([&] { return !ticks.empty(); }, 20.0)) << "no /clock while the barrier waits";
    answer(odom.back().header.stamp);
    went_on = spinUntil([&] { return odom.back().header.stamp.toSec() > 0.06 - 1e-6; }, 20.0);
  }
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(at_barrier) << "no odometry of t = 0.05 s";
  ASSERT_FALSE(ticks.empty());
  EXPECT_NEAR(ticks.front(), 0.05, 1e-9) << "the tick sent again is the barrier's time";
  EXPECT_TRUE(went_on) << "the answer did not release the barrier";
}
}  // namespace

namespace
{
avsp_msgs::SpawnVehicle spawnRequest(const std::string& name, const std::string& model, double x, double y, double yaw);
}  // namespace

// Run control (run_control.test): dynamics_node (the clock, as fast as it can) paused, stepped
// and resumed through ~pause, ~step and ~resume, beside a twin vehicle in a node that follows
// that clock without any of it. The clock holds while paused, ~step advances it by exactly its
// steps (and the odometry instants they cross), the refusals change nothing, and the paused
// vehicle's odometry equals the twin's, message for message: run control takes or skips no step.
TEST(RunControl, PauseStepResumeKeepThePhysics)
{
  ros::NodeHandle nh;
  std::vector<nav_msgs::Odometry> ego, twin;
  double clock = 0.0;
  std::size_t clocks = 0;
  ros::Subscriber se = nh.subscribe<nav_msgs::Odometry>(
      "/ego/avt_341/odometry", 10000, [&](const nav_msgs::Odometry::ConstPtr& m) { ego.push_back(*m); });
  ros::Subscriber st = nh.subscribe<nav_msgs::Odometry>(
      "/twin/avt_341/odometry", 10000, [&](const nav_msgs::Odometry::ConstPtr& m) { twin.push_back(*m); });
  ros::Subscriber sc =
      nh.subscribe<rosgraph_msgs::Clock>("/clock", 10000, [&](const rosgraph_msgs::Clock::ConstPtr& c) {
        clock = c->clock.toSec();
        ++clocks;
      });
  ASSERT_TRUE(spinUntil([&] { return se.getNumPublishers() > 0 && st.getNumPublishers() > 0; }, 60.0));
  ros::ServiceClient pause = nh.serviceClient<std_srvs::Trigger>("/dynamics/pause");
  ros::ServiceClient resume = nh.serviceClient<std_srvs::Trigger>("/dynamics/resume");
  ros::ServiceClient step = nh.serviceClient<avsp_msgs::StepPhysics>("/dynamics/step");
  ASSERT_TRUE(pause.waitForExistence(ros::Duration(60.0)));
  ASSERT_TRUE(resume.waitForExistence(ros::Duration(10.0)));
  ASSERT_TRUE(step.waitForExistence(ros::Duration(10.0)));
  // Both nodes wait for their first command (latched, kept: ~command_timeout 3600 s).
  ros::Publisher pe = nh.advertise<avsp_msgs::DriveCommand>("/ego/cmd_drive", 1, true);
  ros::Publisher pt = nh.advertise<avsp_msgs::DriveCommand>("/twin/cmd_drive", 1, true);
  avsp_msgs::DriveCommand cmd;
  cmd.throttle = 0.5;
  cmd.steering = 0.3;
  pe.publish(cmd);
  pt.publish(cmd);
  ASSERT_TRUE(spinUntil([&] { return clock >= 0.3; }, 60.0)) << "clock at " << clock;

  // Refusals while running: nothing changes.
  std_srvs::Trigger trig;
  avsp_msgs::StepPhysics sp;
  sp.request.steps = 10;
  ASSERT_TRUE(step.call(sp));
  EXPECT_FALSE(sp.response.success);
  EXPECT_NE(sp.response.message.find("not paused"), std::string::npos) << sp.response.message;
  ASSERT_TRUE(resume.call(trig));
  EXPECT_FALSE(trig.response.success);

  ASSERT_TRUE(pause.call(trig));
  EXPECT_TRUE(trig.response.success) << trig.response.message;
  ASSERT_TRUE(pause.call(trig));
  EXPECT_FALSE(trig.response.success) << "a second pause: " << trig.response.message;
  // Held: the clock's last message comes at most one clock period after the pause answered;
  // then 1 s of wall time passes with no new clock time and no odometry.
  ros::WallDuration(0.2).sleep();
  ros::spinOnce();
  const double held = clock;
  const std::size_t ego_held = ego.size(), clocks_held = clocks;
  ros::WallDuration(1.0).sleep();
  ros::spinOnce();
  EXPECT_EQ(clock, held);
  EXPECT_EQ(clocks, clocks_held);
  EXPECT_EQ(ego.size(), ego_held);

  sp.request.steps = 0;
  ASSERT_TRUE(step.call(sp));
  EXPECT_FALSE(sp.response.success);
  // 25 steps of 1 ms: the clock goes to held + 0.025 s, never beyond, and the odometry
  // (100 Hz) of every multiple of 0.01 s in between comes. (The clock goes out after every
  // step, but its publisher keeps 10 messages: a subscriber may see fewer, never other ones.)
  sp.request.steps = 25;
  ASSERT_TRUE(step.call(sp));
  ASSERT_TRUE(sp.response.success) << sp.response.message;
  EXPECT_NEAR(sp.response.until, held + 0.025, 1e-9);
  ASSERT_TRUE(spinUntil([&] { return clock >= sp.response.until - 1e-9; }, 30.0)) << "clock at " << clock;
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_NEAR(clock, held + 0.025, 1e-9);
  EXPECT_LE(clocks - clocks_held, 25u);
  std::size_t crossed = 0;
  for (int k = 1; k <= 25; ++k)
  {
    const long step_index = std::lround(held * 1000.0) + k;
    crossed += step_index % 10 == 0;
  }
  EXPECT_EQ(ego.size() - ego_held, crossed);

  ASSERT_TRUE(resume.call(trig));
  EXPECT_TRUE(trig.response.success) << trig.response.message;
  ASSERT_TRUE(spinUntil([&] { return ego.size() >= 150 && twin.size() >= 150; }, 60.0))
      << "ego " << ego.size() << ", twin " << twin.size();
  // The same physics as the twin's uninterrupted stepping, message for message (the twin's
  // world starts at the first clock tick it saw: compare by sequence).
  for (std::size_t k = 0; k < 150; ++k)
  {
    const auto& a = ego[k].pose.pose;
    const auto& b = twin[k].pose.pose;
    ASSERT_EQ(a.position.x, b.position.x) << k;
    ASSERT_EQ(a.position.y, b.position.y) << k;
    ASSERT_EQ(a.position.z, b.position.z) << k;
    ASSERT_EQ(a.orientation.z, b.orientation.z) << k;
  }
  EXPECT_GT(std::hypot(ego[149].pose.pose.position.x - ego[0].pose.pose.position.x,
                       ego[149].pose.pose.position.y - ego[0].pose.pose.position.y),
            0.5);  // it drove
  std::printf(
      "[run control] paused at %.3f s, 25 steps to %.3f s, %zu odometry messages crossed, 150 equal to the twin\n",
      held, clock >= held + 0.025 ? held + 0.025 : clock, crossed);
}

// ~set_vehicle_pose (run_control.test): refusals name what is wrong and change nothing (the next
// odometry continues where the last left off); a good call sets the ego down there, stopped;
// on the default course a place inside the staging area's first building (x 53-67 m,
// y 218.5-227.5 m) is refused naming the building.
TEST(RunControl, SetVehiclePose)
{
  ros::NodeHandle nh;
  std::vector<nav_msgs::Odometry> ego;
  ros::Subscriber se = nh.subscribe<nav_msgs::Odometry>(
      "/ego/avt_341/odometry", 10000, [&](const nav_msgs::Odometry::ConstPtr& m) { ego.push_back(*m); });
  ros::ServiceClient set = nh.serviceClient<avsp_msgs::SetVehiclePose>("/dynamics/set_vehicle_pose");
  ros::ServiceClient course = nh.serviceClient<avsp_msgs::SetVehiclePose>("/course_sim/set_vehicle_pose");
  ASSERT_TRUE(set.waitForExistence(ros::Duration(60.0)));
  ASSERT_TRUE(course.waitForExistence(ros::Duration(120.0)));
  ros::Publisher pe = nh.advertise<avsp_msgs::DriveCommand>("/ego/cmd_drive", 1, true);
  avsp_msgs::DriveCommand cmd;
  cmd.throttle = 0.5;
  cmd.steering = 0.3;
  pe.publish(cmd);
  ASSERT_TRUE(spinUntil([&] { return ego.size() >= 20; }, 60.0));
  const auto position = [](const nav_msgs::Odometry& o) {
    return Eigen::Vector2d(o.pose.pose.position.x, o.pose.pose.position.y);
  };
  // Calls, then collects 0.5 s of sim time of odometry from just before the call on.
  const auto around = [&](avsp_msgs::SetVehiclePose& call, std::vector<nav_msgs::Odometry>& seen) {
    ros::spinOnce();
    const std::size_t n = ego.size();
    if (!set.call(call) || !spinUntil([&] { return ego.size() > n + 50; }, 30.0))
      return false;
    seen.assign(ego.begin() + static_cast<std::ptrdiff_t>(n - 1), ego.end());
    return true;
  };
  // Indexes k where the ego moved more than 0.1 m since message k - 1 (10 ms before).
  const auto jumps = [&](const std::vector<nav_msgs::Odometry>& seen) {
    std::vector<std::size_t> out;
    for (std::size_t k = 1; k < seen.size(); ++k)
      if ((position(seen[k]) - position(seen[k - 1])).norm() > 0.1)
        out.push_back(k);
    return out;
  };
  struct Bad
  {
    std::string vehicle;
    double x, y, yaw;
    std::string says;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Bad& b : { Bad{ "rover", 0.0, 0.0, 0.0, "no vehicle 'rover' (vehicles: ego)" },
                        Bad{ "ego", nan, 0.0, 0.0, "must be finite" }, Bad{ "ego", 0.0, 0.0, nan, "must be finite" },
                        Bad{ "ego", 100.0, 0.0, 0.0, "off the terrain" } })
  {
    avsp_msgs::SetVehiclePose call;
    call.request.vehicle = b.vehicle;
    call.request.x = b.x;
    call.request.y = b.y;
    call.request.yaw = b.yaw;
    std::vector<nav_msgs::Odometry> seen;
    ASSERT_TRUE(around(call, seen));
    EXPECT_FALSE(call.response.success) << b.says;
    EXPECT_NE(call.response.message.find(b.says), std::string::npos) << call.response.message;
    EXPECT_TRUE(jumps(seen).empty()) << b.says << ": the ego jumped";
  }
  avsp_msgs::SetVehiclePose call;
  // Across the square from where it is: a jump of well over 5 m.
  ros::spinOnce();
  const Eigen::Vector2d target(position(ego.back()).x() > 0.0 ? -20.0 : 20.0,
                               position(ego.back()).y() > 0.0 ? -15.0 : 15.0);
  call.request.vehicle = "ego";
  call.request.x = target.x();
  call.request.y = target.y();
  call.request.yaw = 1.0;
  std::vector<nav_msgs::Odometry> seen;
  ASSERT_TRUE(around(call, seen));
  ASSERT_TRUE(call.response.success) << call.response.message;
  // One jump, to the place asked for: the first odometry there is within 5 cm of it, facing
  // yaw 1, at rest but for the 10 ms of throttle since.
  const std::vector<std::size_t> j = jumps(seen);
  ASSERT_EQ(j.size(), 1u);
  const nav_msgs::Odometry& there = seen[j[0]];
  EXPECT_LT((position(there) - target).norm(), 0.05);
  EXPECT_NEAR(yawOf(there), 1.0, 0.01);
  EXPECT_LT(speedOf(there), 0.2);
  EXPECT_GT((position(seen[j[0] - 1]) - target).norm(), 5.0);

  avsp_msgs::SetVehiclePose inside;
  inside.request.vehicle = "parked";
  inside.request.x = 60.0;
  inside.request.y = 223.0;
  inside.request.yaw = 0.0;
  ASSERT_TRUE(course.call(inside));
  EXPECT_FALSE(inside.response.success);
  EXPECT_NE(inside.response.message.find("building"), std::string::npos) << inside.response.message;
  EXPECT_NE(inside.response.message.find("(60, 223)"), std::string::npos) << inside.response.message;
  inside.request.x = 40.0;
  inside.request.y = 205.0;
  ASSERT_TRUE(course.call(inside));
  EXPECT_TRUE(inside.response.success) << inside.response.message;
  // ~spawn_vehicle there too: refused naming the building.
  ros::ServiceClient course_spawn = nh.serviceClient<avsp_msgs::SpawnVehicle>("/course_sim/spawn_vehicle");
  ASSERT_TRUE(course_spawn.waitForExistence(ros::Duration(10.0)));
  avsp_msgs::SpawnVehicle spawn_inside = spawnRequest("visitor", "mrzr", 60.0, 223.0, 0.0);
  ASSERT_TRUE(course_spawn.call(spawn_inside));
  EXPECT_FALSE(spawn_inside.response.success);
  EXPECT_NE(spawn_inside.response.message.find("'visitor' would stand in building"), std::string::npos)
      << spawn_inside.response.message;
  std::printf("[set pose] %s | %s\n", call.response.message.c_str(), inside.response.message.c_str());
}

namespace
{
/// One of spawn_vehicle.test's dynamics_nodes: its clock, its vehicles' odometry (by vehicle
/// name), its run-control services.
struct SpawnSim
{
  ros::NodeHandle nh;
  std::string ns;  ///< "" or "/b": where the node's vehicles are
  double clock = -1.0;
  std::map<std::string, std::vector<nav_msgs::Odometry>> odom;
  std::map<std::string, ros::Subscriber> odom_subs;
  ros::Subscriber clock_sub;
  ros::ServiceClient pause, step, spawn, remove;
  ros::Publisher ego_cmd;
  std::string why;  ///< why the last stepBy() failed

  SpawnSim(const std::string& ns_, const std::string& node) : ns(ns_)
  {
    clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
        node + "/clock", 10000, [this](const rosgraph_msgs::Clock::ConstPtr& c) { clock = c->clock.toSec(); });
    pause = nh.serviceClient<std_srvs::Trigger>(node + "/pause");
    step = nh.serviceClient<avsp_msgs::StepPhysics>(node + "/step");
    spawn = nh.serviceClient<avsp_msgs::SpawnVehicle>(node + "/spawn_vehicle");
    remove = nh.serviceClient<avsp_msgs::RemoveVehicle>(node + "/remove_vehicle");
    ego_cmd = nh.advertise<avsp_msgs::DriveCommand>(ns + "/ego/cmd_drive", 1, true);
    watch("ego");
  }

  void watch(const std::string& vehicle)
  {
    odom_subs[vehicle] = nh.subscribe<nav_msgs::Odometry>(
        ns + "/" + vehicle + "/avt_341/odometry", 100000,
        [this, vehicle](const nav_msgs::Odometry::ConstPtr& m) { odom[vehicle].push_back(*m); });
  }

  /// ~step `n` steps (paused), then waits until the clock and the ego's odometry got there.
  bool stepBy(std::uint32_t n)
  {
    avsp_msgs::StepPhysics sp;
    sp.request.steps = n;
    if (!step.call(sp) || !sp.response.success)
    {
      why = "~step: " + sp.response.message;
      return false;
    }
    const double until = sp.response.until;
    const double last_odom = std::floor(until * 100.0 + 1e-6) / 100.0;  // 100 Hz odometry
    const bool reached = spinUntil(
        [&] {
          return clock >= until - 1e-9 && !odom["ego"].empty() &&
                 odom["ego"].back().header.stamp.toSec() >= last_odom - 1e-9;
        },
        60.0);
    if (!reached)
      why = "clock at " + std::to_string(clock) + " s, ego odometry at " +
            (odom["ego"].empty() ? std::string("none") : std::to_string(odom["ego"].back().header.stamp.toSec())) +
            ", waiting for " + std::to_string(until);
    return reached;
  }
};

avsp_msgs::SpawnVehicle spawnRequest(const std::string& name, const std::string& model, double x, double y, double yaw)
{
  avsp_msgs::SpawnVehicle call;
  call.request.name = name;
  call.request.model = model;
  call.request.x = x;
  call.request.y = y;
  call.request.yaw = yaw;
  return call;
}

bool sameOdometry(const nav_msgs::Odometry& a, const nav_msgs::Odometry& b)
{
  const auto &p = a.pose.pose, &q = b.pose.pose;
  return a.header.stamp == b.header.stamp && p.position.x == q.position.x && p.position.y == q.position.y &&
         p.position.z == q.position.z && p.orientation.x == q.orientation.x && p.orientation.y == q.orientation.y &&
         p.orientation.z == q.orientation.z && p.orientation.w == q.orientation.w &&
         a.twist.twist.linear.x == b.twist.twist.linear.x && a.twist.twist.angular.z == b.twist.twist.angular.z;
}

bool topicPublished(const std::string& topic)
{
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  return std::any_of(topics.begin(), topics.end(), [&](const ros::master::TopicInfo& t) { return t.name == topic; });
}
}  // namespace

// ~spawn_vehicle and ~remove_vehicle (spawn_vehicle.test). Both nodes are paused before their
// first step; the ego (from x = -25 m) drives along +x at throttle 0.4. At t = 0.5 s an mrzr
// "blocker" is spawned 12 m ahead in its way (braked: no command), at t = 6 s it is removed. The
// ego runs into it and pushes it, never through it, then, once it is gone, drives over the place
// where it stood. Bad requests, made
// on spawn_a only, are refused naming what is wrong; the same script gives the same odometry, bit
// for bit, in both nodes, so the refusals changed nothing and the calls act deterministically.
TEST(SpawnVehicle, SpawnedVehicleCollidesAndLeavesDeterministically)
{
  SpawnSim a("", "/spawn_a"), b("/b", "/b/spawn_b");
  for (SpawnSim* s : { &a, &b })
  {
    ASSERT_TRUE(s->pause.waitForExistence(ros::Duration(60.0)));
    ASSERT_TRUE(s->spawn.waitForExistence(ros::Duration(10.0)));
    ASSERT_TRUE(s->remove.waitForExistence(ros::Duration(10.0)));
    std_srvs::Trigger trig;
    ASSERT_TRUE(s->pause.call(trig));
    ASSERT_TRUE(trig.response.success) << trig.response.message;
    ASSERT_TRUE(spinUntil([&] { return s->odom_subs["ego"].getNumPublishers() > 0; }, 30.0));
    avsp_msgs::DriveCommand cmd;
    cmd.throttle = 0.4;
    s->ego_cmd.publish(cmd);  // latched; the node waits for it before its first step
    ASSERT_TRUE(s->stepBy(500)) << s->ns << ": " << s->why;
  }

  // Refused, naming the reason (spawn_a only).
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Bad
  {
    avsp_msgs::SpawnVehicle call;
    std::string says;
  };
  for (Bad& bad :
       std::vector<Bad>{ { spawnRequest("blocker", "rover7", 12.0, 0.0, 0.0), "no model 'rover7' in ~config_dir" },
                         { spawnRequest("blocker", "rover7", 12.0, 0.0, 0.0), "fed_alpha" },  // the known ones listed
                         { spawnRequest("ego", "mrzr", 12.0, 0.0, 0.0), "already a vehicle 'ego'" },
                         { spawnRequest("two words", "mrzr", 12.0, 0.0, 0.0), "must be a valid ROS name" },
                         { spawnRequest("blocker", "mrzr", nan, 0.0, 0.0), "must be finite" },
                         { spawnRequest("blocker", "mrzr", 12.0, 0.0, nan), "must be finite" },
                         { spawnRequest("blocker", "mrzr", 100.0, 0.0, 0.0), "off the terrain" },
                         { spawnRequest("blocker", "mrzr", -23.0, 1.0, 0.0), "would stand on vehicle 'ego'" } })
  {
    ASSERT_TRUE(a.spawn.call(bad.call));
    EXPECT_FALSE(bad.call.response.success) << bad.says;
    EXPECT_NE(bad.call.response.message.find(bad.says), std::string::npos) << bad.call.response.message;
  }
  avsp_msgs::RemoveVehicle unknown;
  unknown.request.name = "blocker";
  ASSERT_TRUE(a.remove.call(unknown));
  EXPECT_FALSE(unknown.response.success);
  EXPECT_NE(unknown.response.message.find("no vehicle 'blocker' (vehicles: ego)"), std::string::npos)
      << unknown.response.message;
  EXPECT_FALSE(topicPublished("/blocker/avt_341/odometry"));

  // The script, on both.
  for (SpawnSim* s : { &a, &b })
  {
    s->watch("blocker");
    avsp_msgs::SpawnVehicle call = spawnRequest("blocker", "mrzr", -13.0, 0.0, 0.0);
    ASSERT_TRUE(s->spawn.call(call));
    ASSERT_TRUE(call.response.success) << call.response.message;
    EXPECT_NE(call.response.message.find("at t = 0.5 s"), std::string::npos) << call.response.message;
    ASSERT_TRUE(spinUntil([&] { return s->odom_subs["blocker"].getNumPublishers() > 0; }, 30.0));
    ASSERT_TRUE(s->stepBy(5500)) << s->ns << ": " << s->why;
    avsp_msgs::RemoveVehicle remove;
    remove.request.name = "blocker";
    ASSERT_TRUE(s->remove.call(remove));
    ASSERT_TRUE(remove.response.success) << remove.response.message;
    EXPECT_NE(remove.response.message.find("at t = 6 s"), std::string::npos) << remove.response.message;
    ASSERT_TRUE(s->remove.call(remove));
    EXPECT_FALSE(remove.response.success) << "removed twice";
    ASSERT_TRUE(s->stepBy(3000)) << s->ns << ": " << s->why;
  }
  EXPECT_FALSE(topicPublished("/blocker/avt_341/odometry")) << "the removed vehicle's odometry is still advertised";

  const std::vector<nav_msgs::Odometry>& blocker = a.odom["blocker"];
  const std::vector<nav_msgs::Odometry>& ego = a.odom["ego"];
  ASSERT_FALSE(blocker.empty());
  // Odometry at every 10 ms from 0.51 s to 6 s, set down where asked.
  EXPECT_NEAR(blocker.front().header.stamp.toSec(), 0.51, 1e-6);
  EXPECT_NEAR(blocker.back().header.stamp.toSec(), 6.0, 1e-6);
  EXPECT_EQ(blocker.size(), 550u);
  EXPECT_NEAR(blocker.front().pose.pose.position.x, -13.0, 0.05);
  EXPECT_NEAR(blocker.front().pose.pose.position.y, 0.0, 0.05);
  // The ego against the blocker: its x while the blocker stood stays behind the blocker's rear.
  double ego_x_at_removal = 0.0, ego_max_x = 0.0;
  for (const nav_msgs::Odometry& o : ego)
  {
    if (o.header.stamp.toSec() <= 6.0 + 1e-9)
      ego_x_at_removal = o.pose.pose.position.x;
    ego_max_x = std::max(ego_max_x, o.pose.pose.position.x);
  }
  const double blocker_x = blocker.back().pose.pose.position.x;
  std::printf(
      "[spawn] ego at x = %.2f m when the blocker (then at x = %.2f m) was removed at 6 s; ego at %.2f m at "
      "9 s; %zu blocker and %zu ego odometry messages\n",
      ego_x_at_removal, blocker_x, ego.back().pose.pose.position.x, blocker.size(), ego.size());
  EXPECT_LT(ego_x_at_removal, blocker_x - 3.0) << "the ego passed through the blocker";
  EXPECT_GT(blocker_x, blocker.front().pose.pose.position.x + 0.5) << "the ego never pushed the blocker";
  EXPECT_GT(ego_max_x, blocker_x + 3.0) << "after the removal the ego did not drive over the blocker's place";

  // The same script, the same bits (and the refusals on spawn_a changed nothing).
  for (const std::string& v : { std::string("ego"), std::string("blocker") })
  {
    const auto &x = a.odom[v], &y = b.odom[v];
    ASSERT_EQ(x.size(), y.size()) << v;
    for (std::size_t k = 0; k < x.size(); ++k)
      ASSERT_TRUE(sameOdometry(x[k], y[k])) << v << " message " << k << " at " << x[k].header.stamp.toSec();
  }
  EXPECT_EQ(ego.size(), 900u);
}

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_dynamics_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}

// test/parking_brake.test only (dynamics_node.test filters it out): zero commands on the
// course's 17.5 deg plane. The parking brake holds "held" within 1 cm from 2 s to 12 s of sim
// time; "free", without it, coasts more than 1 m down the plane (south) in the same time.
TEST(ParkingBrake, ZeroCommandsHoldOnTheCoursePlane)
{
  ros::NodeHandle nh;
  struct Track
  {
    std::vector<std::pair<double, Eigen::Vector2d>> samples;
    ros::Subscriber sub;
    ros::Publisher cmd;
  } held, free;
  for (auto [name, t] : { std::make_pair("held", &held), std::make_pair("free", &free) })
  {
    Track* track = t;
    track->sub = nh.subscribe<nav_msgs::Odometry>(
        std::string("/") + name + "/avt_341/odometry", 1000, [track](const nav_msgs::Odometry::ConstPtr& m) {
          track->samples.emplace_back(m->header.stamp.toSec(),
                                      Eigen::Vector2d(m->pose.pose.position.x, m->pose.pose.position.y));
        });
    // Latched: each node waits for its first command (~wait_for_command) and keeps it.
    track->cmd = nh.advertise<geometry_msgs::Twist>(std::string("/") + name + "/avt_341/cmd_vel", 1, true);
    track->cmd.publish(twist(0.0, 0.0, 0.0));
  }
  const auto reached = [](const Track& t, double time) { return !t.samples.empty() && t.samples.back().first >= time; };
  ASSERT_TRUE(spinUntil([&] { return reached(held, 12.0) && reached(free, 12.0); }, 200.0))
      << "odometry: held " << held.samples.size() << ", free " << free.samples.size();
  const auto at = [](const Track& t, double time) {
    for (const auto& s : t.samples)
      if (s.first >= time)
        return s.second;
    return t.samples.back().second;
  };
  const double held_drift = (at(held, 12.0) - at(held, 2.0)).norm();
  const double free_down = at(free, 2.0).y() - at(free, 12.0).y();
  std::printf("[parking brake] held: %.2f mm from 2 s to 12 s; free (no parking brake): %.2f m down the plane\n",
              1e3 * held_drift, free_down);
  EXPECT_LT(held_drift, 0.01);
  EXPECT_GT(free_down, 1.0);
}
