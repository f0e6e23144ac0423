// rostest of launch/spawn_vehicle.launch (test/spawn_controller.test): the spawned vehicle gets
// its topics and a waypoint controller that drives it along the path given to the launch file.
#include <cmath>
#include <vector>

#include <avsp_terrain/ros/spin_until.hpp>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>

TEST(SpawnController, TheLaunchFileSpawnsTheVehicleAndItsControllerDrivesIt)
{
  ros::NodeHandle nh;
  std::vector<nav_msgs::Odometry> odom;
  nav_msgs::Path path;
  ros::Subscriber odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/visitor/avt_341/odometry", 1000, [&](const nav_msgs::Odometry::ConstPtr& m) { odom.push_back(*m); });
  ros::Subscriber path_sub = nh.subscribe<nav_msgs::Path>("/visitor/controller/path", 1,
                                                          [&](const nav_msgs::Path::ConstPtr& m) { path = *m; });
  // Spawned where the launch file said, at rest.
  ASSERT_TRUE(avsp::node::spinUntil([&] { return !odom.empty(); }, 60.0)) << "no odometry of the spawned vehicle";
  EXPECT_NEAR(odom.front().pose.pose.position.x, -20.0, 0.05);
  EXPECT_NEAR(odom.front().pose.pose.position.y, 10.0, 0.05);
  // Its controller publishes the path it was given and drives it along: 10 m east along y = 10.
  ASSERT_TRUE(avsp::node::spinUntil([&] { return path.poses.size() == 2; }, 30.0)) << "no controller path";
  EXPECT_DOUBLE_EQ(path.poses[1].pose.position.x, 30.0);
  ASSERT_TRUE(avsp::node::spinUntil([&] { return odom.back().pose.pose.position.x > -10.0; }, 60.0))
      << "the controller did not drive it: x = " << odom.back().pose.pose.position.x;
  EXPECT_NEAR(odom.back().pose.pose.position.y, 10.0, 1.0);
  const double t = odom.back().header.stamp.toSec() - odom.front().header.stamp.toSec();
  std::printf("[ spawn_controller ] 10 m along the path in %.2f s of sim time\n", t);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_spawn_controller");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
