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

#include <gtest/gtest.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace
{
using Graph = std::map<std::string, std::set<std::string>>;  // topic -> nodes

/// The master's publishers and subscribers (getSystemState).
bool systemState(Graph& publishers, Graph& subscribers)
{
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", args, result, payload, true))
    return false;
  publishers.clear();
  subscribers.clear();
  for (int kind = 0; kind < 2; ++kind)
  {
    Graph& out = kind == 0 ? publishers : subscribers;
    for (int t = 0; t < payload[kind].size(); ++t)
    {
      std::set<std::string>& nodes = out[static_cast<std::string>(payload[kind][t][0])];
      for (int n = 0; n < payload[kind][t][1].size(); ++n)
        nodes.insert(static_cast<std::string>(payload[kind][t][1][n]));
    }
  }
  return true;
}

bool has(const Graph& g, const std::string& topic)
{
  const auto it = g.find(topic);
  return it != g.end() && !it->second.empty();
}
}  // namespace

TEST(Avt341Contract, AvspLeavesTheStacksTopicsToTheStack)
{
  const std::string ns = "/ego/avt_341/";
  Graph publishers, subscribers;
  // Ready once the dynamics (odometry, cmd_vel) and the sensors (points, AVSP's grid) are up.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(150.0);
  bool ready = false;
  while (ros::ok() && ros::WallTime::now() < deadline)
  {
    ASSERT_TRUE(systemState(publishers, subscribers));
    ready = has(publishers, ns + "odometry") && has(publishers, ns + "points") && has(subscribers, ns + "cmd_vel") &&
            has(publishers, "/ego/occupancy/grid");
    if (ready)
      break;
    ros::WallDuration(0.2).sleep();
  }
  ASSERT_TRUE(ready) << "avt_341.launch's nodes did not all advertise within 150 s";

  const std::set<std::string> avsp_publishes = { ns + "odometry", ns + "points" };
  const std::set<std::string> avsp_subscribes = { ns + "cmd_vel", ns + "odometry", ns + "points" };
  for (const auto& [topic, nodes] : publishers)
    if (topic.rfind(ns, 0) == 0 && !nodes.empty())
      EXPECT_TRUE(avsp_publishes.count(topic)) << topic << " is published by " << *nodes.begin()
                                               << ": under avt_341/ AVSP publishes only odometry and points";
  for (const auto& [topic, nodes] : subscribers)
    if (topic.rfind(ns, 0) == 0 && !nodes.empty())
      EXPECT_TRUE(avsp_subscribes.count(topic))
          << topic << " is read by " << *nodes.begin()
          << ": under avt_341/ AVSP reads only cmd_vel (and its own odometry and points)";
  // The stack's own outputs, by name (the check above covers them; this says which).
  for (const char* stack : { "occupancy_grid", "global_path", "waypoints", "local_path", "cmd_vel" })
    EXPECT_FALSE(has(publishers, ns + stack)) << ns + stack << " belongs to the AVT-341 stack";
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "avt_341_contract");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
