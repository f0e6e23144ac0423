// rostest of a column convoy (test/controller_convoy.test): the leader on waypoints, each
// follower pursuing the vehicle in front from V2V alone. The test only reads odometry: the
// gap of follower k is the distance along vehicle k-1's own driven path (its odometry
// positions, 100 Hz) from vehicle k-1's position to the projection of vehicle k's, at the
// same sim time. After ~settle_time it must stay within ~tolerance of ~gap; at ~change_time
// the test publishes ~new_gap on every follower's formation/gap, and from
// ~change_time + ~converge_time to ~end_time the gap must stay within ~tolerance of it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/Float64.h>
#include <avsp_terrain/ros/spin_until.hpp>

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

/// Milliseconds of sim time: odometry of one dynamics_node carries identical stamps.
long long key(double t)
{
  return std::llround(t * 1000.0);
}

struct GapStats
{
  int n = 0;
  double worst = 0.0;  ///< m, largest |gap - desired|
  double sum_sq = 0.0;
  double mean_gap = 0.0;       ///< m
  double worst_lateral = 0.0;  ///< m, farthest from the leader's driven path
  double rms() const { return n ? std::sqrt(sum_sq / n) : 0.0; }
};
}  // namespace

TEST(ControllerConvoy, ColumnKeepsTheGapAndFollowsAGapChange)
{
  ros::NodeHandle nh, pnh("~");
  std::vector<std::string> vehicles;
  ASSERT_TRUE(pnh.getParam("vehicles", vehicles));
  ASSERT_GE(vehicles.size(), 2u);
  double gap = 0.0, settle = 0.0, change = 0.0, new_gap = 0.0, converge = 0.0, end = 0.0, tolerance = 0.0;
  ASSERT_TRUE(pnh.getParam("gap", gap) && pnh.getParam("settle_time", settle) && pnh.getParam("change_time", change) &&
              pnh.getParam("new_gap", new_gap) && pnh.getParam("converge_time", converge) &&
              pnh.getParam("end_time", end) && pnh.getParam("tolerance", tolerance));

  std::vector<std::vector<Sample>> samples(vehicles.size());
  std::vector<ros::Subscriber> subs;
  std::vector<ros::Publisher> gap_pubs;
  for (std::size_t k = 0; k < vehicles.size(); ++k)
  {
    subs.push_back(nh.subscribe<nav_msgs::Odometry>(
        "/" + vehicles[k] + "/avt_341/odometry", 1000, [&samples, k](const nav_msgs::Odometry::ConstPtr& m) {
          samples[k].push_back(
              { m->header.stamp.toSec(), m->pose.pose.position.x, m->pose.pose.position.y, m->twist.twist.linear.x });
        }));
    if (k > 0)
      gap_pubs.push_back(nh.advertise<std_msgs::Float64>("/" + vehicles[k] + "/formation/gap", 1, true));
  }
  // The slowest stream's time (each vehicle's odometry comes from the same node).
  auto now = [&] {
    double t = 1e9;
    for (const auto& s : samples)
      t = std::min(t, s.empty() ? 0.0 : s.back().t);
    return t;
  };
  const double wall_budget = 200.0;
  const ros::WallTime start = ros::WallTime::now();
  ASSERT_TRUE(spinUntil([&] { return now() >= change; }, wall_budget)) << "simulation stalled at t = " << now() << " s";
  for (auto& p : gap_pubs)
  {
    std_msgs::Float64 msg;
    msg.data = new_gap;
    p.publish(msg);
  }
  const double changed_at = now();
  ASSERT_TRUE(spinUntil([&] { return now() >= end; }, wall_budget - (ros::WallTime::now() - start).toSec()))
      << "simulation stalled at t = " << now() << " s";
  std::printf("[ controller_convoy ] %.0f s of sim time in %.1f s wall; gap %.1f -> %.1f m at t = %.2f s\n", now(),
              (ros::WallTime::now() - start).toSec(), gap, new_gap, changed_at);

  for (std::size_t k = 0; k < vehicles.size(); ++k)
  {
    std::string line;
    char buffer[64];
    for (const Sample& p : samples[k])
      if (key(p.t) % 10000 == 0)
      {
        std::snprintf(buffer, sizeof buffer, " %.0f:(%.1f, %.1f) %.2f", p.t, p.x, p.y, p.speed);
        line += buffer;
      }
    std::printf("[ controller_convoy ] %s (t:(x, y) m/s):%s\n", vehicles[k].c_str(), line.c_str());
  }
  for (std::size_t k = 1; k < vehicles.size(); ++k)
  {
    // The vehicle in front's driven path, and its arc length at each of its stamps.
    ac::Path trail;
    std::map<long long, double> s_at;
    for (const Sample& p : samples[k - 1])
    {
      trail.append({ p.x, p.y });
      s_at[key(p.t)] = trail.endS();
    }
    GapStats before, after;
    std::vector<std::pair<double, double>> series;  // (t, gap) every 0.5 s, for the log
    double s_previous = 0.0;
    bool has_previous = false;
    for (const Sample& p : samples[k])
    {
      const auto it = s_at.find(key(p.t));
      if (it == s_at.end())
        continue;
      const double lo = has_previous ? s_previous - 10.0 : trail.startS();
      const ac::PathProjection proj = trail.project({ p.x, p.y }, lo, it->second);
      s_previous = proj.s;
      has_previous = true;
      const double g = it->second - proj.s;
      if (key(p.t) % 500 == 0)
        series.emplace_back(p.t, g);
      GapStats* stats = nullptr;
      double desired = gap;
      if (p.t >= settle && p.t < changed_at)
        stats = &before;
      else if (p.t >= changed_at + converge && p.t <= end)
      {
        stats = &after;
        desired = new_gap;
      }
      if (!stats)
        continue;
      ++stats->n;
      stats->worst = std::max(stats->worst, std::abs(g - desired));
      stats->sum_sq += (g - desired) * (g - desired);
      stats->mean_gap += g;
      stats->worst_lateral = std::max(stats->worst_lateral, proj.distance);
    }
    for (GapStats* s : { &before, &after })
      if (s->n)
        s->mean_gap /= s->n;
    const std::string who = vehicles[k] + " behind " + vehicles[k - 1];
    std::printf(
        "[ controller_convoy ] %s: gap %.0f m from t = %.0f s: mean %.2f m, RMS error %.2f m, worst %.2f m, "
        "worst lateral %.2f m\n",
        who.c_str(), gap, settle, before.mean_gap, before.rms(), before.worst, before.worst_lateral);
    std::printf(
        "[ controller_convoy ] %s: gap %.0f m from t = %.0f s: mean %.2f m, RMS error %.2f m, worst %.2f m, "
        "worst lateral %.2f m\n",
        who.c_str(), new_gap, changed_at + converge, after.mean_gap, after.rms(), after.worst, after.worst_lateral);
    std::string line;
    for (const auto& [t, g] : series)
      if (std::fmod(t, 5.0) < 0.25)
        line += " " + std::to_string(static_cast<int>(t)) + ":" + std::to_string(g).substr(0, 5);
    std::printf("[ controller_convoy ] %s gap (t:m):%s\n", who.c_str(), line.c_str());
    ASSERT_GT(before.n, 1000) << who;
    ASSERT_GT(after.n, 1000) << who;
    EXPECT_LE(before.worst, tolerance) << who << ": gap " << gap << " m not kept";
    EXPECT_LE(after.worst, tolerance) << who << ": gap change to " << new_gap << " m did not converge";
    EXPECT_LT(before.worst_lateral, 1.5) << who << " left the tracks of the vehicle in front";
    EXPECT_LT(after.worst_lateral, 1.5) << who << " left the tracks of the vehicle in front";
    RecordProperty(vehicles[k] + "_gap_error_worst_m", std::to_string(before.worst));
    RecordProperty(vehicles[k] + "_new_gap_error_worst_m", std::to_string(after.worst));
  }
  // The leader kept going throughout (the convoy was not simply parked at its gaps).
  const auto& lead = samples[0];
  ASSERT_FALSE(lead.empty());
  double lead_distance = 0.0;
  for (std::size_t i = 1; i < lead.size(); ++i)
    if (lead[i].t >= settle)
      lead_distance += std::hypot(lead[i].x - lead[i - 1].x, lead[i].y - lead[i - 1].y);
  EXPECT_GT(lead_distance, 3.0 * (end - settle)) << "the leader barely moved after settling";
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_controller_convoy");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
