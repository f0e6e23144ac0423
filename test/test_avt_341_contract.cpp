// The topic contract with the AVT-341 stack (test/avt_341_contract.test, issue 20): under
// <vehicle>/avt_341/ AVSP publishes only what the stack consumes from a simulator (odometry,
// points) and reads only what it sends (cmd_vel) besides those two (AVSP's own nodes read
// the odometry: sensors, V2V). Never a topic the stack itself
// publishes: in CGoodin/avt_341 (master 79bcd10) avt_341_perception_node advertises
// avt_341/occupancy_grid, avt_341_global_path_node avt_341/global_path and avt_341/waypoints,
// avt_341_local_planner_node avt_341/local_path, avt_341_control_node avt_341/cmd_vel. AVSP's
// own grid is <vehicle>/occupancy/grid. Judged from the master's getSystemState once every
// AVSP node of avt_341.launch has advertised.
#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <avsp_terrain/ros/ros_graph.hpp>
#include <gtest/gtest.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcValue.h>

TEST(Avt341Contract, AvspLeavesTheStacksTopicsToTheStack)
{
  const std::string ns = "/ego/avt_341/";
  avsp::node::RosGraph graph;
  // Ready once the dynamics (odometry, cmd_vel) and the sensors (points, AVSP's grid) are up.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(150.0);
  bool ready = false;
  while (ros::ok() && ros::WallTime::now() < deadline)
  {
    ASSERT_TRUE(avsp::node::readRosGraph(graph));
    ready = graph.published(ns + "odometry") && graph.published(ns + "points") && graph.subscribed(ns + "cmd_vel") &&
            graph.published("/ego/occupancy/grid");
    if (ready)
      break;
    ros::WallDuration(0.2).sleep();
  }
  ASSERT_TRUE(ready) << "avt_341.launch's nodes did not all advertise within 150 s";

  const std::set<std::string> avsp_publishes = { ns + "odometry", ns + "points" };
  const std::set<std::string> avsp_subscribes = { ns + "cmd_vel", ns + "odometry", ns + "points" };
  for (const auto& [topic, nodes] : graph.publishers)
  {
    if (topic.rfind(ns, 0) == 0 && !nodes.empty())
    {
      EXPECT_TRUE(avsp_publishes.count(topic)) << topic << " is published by " << *nodes.begin()
                                               << ": under avt_341/ AVSP publishes only odometry and points";
    }
  }
  for (const auto& [topic, nodes] : graph.subscribers)
  {
    if (topic.rfind(ns, 0) == 0 && !nodes.empty())
    {
      EXPECT_TRUE(avsp_subscribes.count(topic))
          << topic << " is read by " << *nodes.begin()
          << ": under avt_341/ AVSP reads only cmd_vel (and its own odometry and points)";
    }
  }
  // The stack's own outputs, by name (the check above covers them; this says which).
  for (const char* stack : { "occupancy_grid", "global_path", "waypoints", "local_path", "cmd_vel" })
    EXPECT_FALSE(graph.published(ns + stack)) << ns + stack << " belongs to the AVT-341 stack";
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "avt_341_contract");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
