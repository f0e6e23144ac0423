// External control through launch/avt_341.launch: a node in the vehicle's namespace, as the
// AVT-341 stack would be, drives it only through avt_341/cmd_vel (relative names) and sees it
// respond on avt_341/odometry and avt_341/points.
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <avsp_terrain/ros/spin_until.hpp>

namespace
{
/// avsp::node::spinUntil, polling every 0.002 s here.
bool spinUntil(const std::function<bool()>& done, double timeout)
{
  return avsp::node::spinUntil(done, timeout, 0.002);
}

double yawOf(const geometry_msgs::Quaternion& q)
{
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

TEST(ExternalControl, DrivenThroughCmdVelItMovesAndItsLidarSeesTheWorld)
{
  ros::NodeHandle nh;  // the vehicle's namespace: every name below is relative, as the stack's
  std::vector<nav_msgs::Odometry> odom;
  std::vector<sensor_msgs::PointCloud2> clouds;
  ros::Subscriber o = nh.subscribe<nav_msgs::Odometry>(
      "avt_341/odometry", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) { odom.push_back(*m); });
  ros::Subscriber p = nh.subscribe<sensor_msgs::PointCloud2>(
      "avt_341/points", 20, [&](const sensor_msgs::PointCloud2::ConstPtr& m) { clouds.push_back(*m); });
  ros::Publisher cmd = nh.advertise<geometry_msgs::Twist>("avt_341/cmd_vel", 10);
  EXPECT_EQ(o.getTopic(), "/ego/avt_341/odometry");
  EXPECT_EQ(cmd.getTopic(), "/ego/avt_341/cmd_vel");

  // Settled and braked (no command yet) with the lidar running.
  ASSERT_TRUE(
      spinUntil([&] { return !odom.empty() && odom.back().header.stamp.toSec() > 2.0 && clouds.size() >= 3; }, 90.0))
      << odom.size() << " odometry messages, " << clouds.size() << " clouds";
  const nav_msgs::Odometry start = odom.back();
  EXPECT_EQ(start.header.frame_id, "odom");
  EXPECT_EQ(start.child_frame_id, "ego/base_link");
  EXPECT_LT(std::abs(start.twist.twist.linear.x), 0.1) << "not braked before the first command";

  // Throttle 0.5 straight ahead for 6 s of sim time, as avt_341 sends it (brake as linear.y <= 0).
  geometry_msgs::Twist go;
  go.linear.x = 0.5;
  const double t_go = start.header.stamp.toSec();
  ros::WallTime last_pub;
  double top_speed = 0.0;
  ASSERT_TRUE(spinUntil(
      [&] {
        if ((ros::WallTime::now() - last_pub).toSec() > 0.05)
        {
          cmd.publish(go);
          last_pub = ros::WallTime::now();
        }
        top_speed = std::max(top_speed, odom.back().twist.twist.linear.x);
        return odom.back().header.stamp.toSec() > t_go + 6.0;
      },
      60.0));
  const nav_msgs::Odometry moved = odom.back();
  const double heading = yawOf(start.pose.pose.orientation);
  const double forward = (moved.pose.pose.position.x - start.pose.pose.position.x) * std::cos(heading) +
                         (moved.pose.pose.position.y - start.pose.pose.position.y) * std::sin(heading);
  EXPECT_GT(top_speed, 1.0);
  EXPECT_GT(forward, 3.0) << "moved " << forward << " m along its heading";

  // Full brake as avt_341 sends it: linear.y = -1.
  geometry_msgs::Twist stop;
  stop.linear.y = -1.0;
  const double t_stop = moved.header.stamp.toSec();
  ASSERT_TRUE(spinUntil(
      [&] {
        if ((ros::WallTime::now() - last_pub).toSec() > 0.05)
        {
          cmd.publish(stop);
          last_pub = ros::WallTime::now();
        }
        return odom.back().header.stamp.toSec() > t_stop + 4.0;
      },
      60.0));
  EXPECT_LT(std::abs(odom.back().twist.twist.linear.x), 0.1) << "did not stop under brake";

  // The lidar: registered in odom, the contract's fields, returns around the vehicle.
  ASSERT_GE(clouds.size(), 50u) << "lidar at 10 Hz over > 12 s of sim time";
  std::size_t near = 0, points = 0;
  for (const sensor_msgs::PointCloud2& c : clouds)
  {
    EXPECT_EQ(c.header.frame_id, "odom");
    std::vector<std::string> names;
    for (const auto& f : c.fields)
      names.push_back(f.name);
    for (const char* f : { "x", "y", "z", "intensity", "ring" })
      EXPECT_NE(std::find(names.begin(), names.end(), f), names.end()) << "field " << f;
  }
  const sensor_msgs::PointCloud2& last = clouds.back();
  const auto& at = odom.back().pose.pose.position;
  for (sensor_msgs::PointCloud2ConstIterator<float> x(last, "x"), y(last, "y"); x != x.end(); ++x, ++y)
  {
    ++points;
    if (std::hypot(*x - at.x, *y - at.y) < 60.0)
      ++near;
  }
  EXPECT_GT(points, 1000u);
  EXPECT_GT(near, points * 9 / 10) << "registered points should lie around the vehicle in odom";
  std::printf("[ external_control ] top speed %.2f m/s, %.1f m forward, %zu clouds, last %zu points\n", top_speed,
              forward, clouds.size(), points);
}
}  // namespace

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_external_control");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
