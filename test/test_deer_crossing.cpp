// rostest of the dynamic agents end to end (test/deer_crossing.test): a deer crossing in front of
// a braked fed_alpha appears in its lidar cloud where the agent core puts it at each sweep's
// time, and nowhere else; agents_node's /agents/states, TF and /agents/markers follow the same
// pure function of sim time. Time is the messages' sim time; wall deadlines only guard a hang.
// Bad ~agents: the agents_node binary, run to completion, must exit 1 naming the key.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <avsp_msgs/AgentStateArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <avsp_terrain/ros/agent_params.hpp>
#include <avsp_terrain/agents.hpp>
#include <avsp_terrain/ros/spin_until.hpp>

#include <avsp_terrain/ros/run_command.hpp>

namespace at = avsp::terrain;

namespace
{
/// avsp::node::spinUntil, polling every 0.001 s here.
bool spinUntil(const std::function<bool()>& done, double timeout)
{
  return avsp::node::spinUntil(done, timeout, 0.001);
}

template <typename M>
struct Topic
{
  std::vector<M> messages;
  ros::Subscriber sub;
  void subscribe(ros::NodeHandle& nh, const std::string& name)
  {
    sub = nh.subscribe<M>(name, 1000, [this](const typename M::ConstPtr& m) { messages.push_back(*m); });
  }
};

/// The deer of ~agents, on a level grid at z = 0 (the flat gravel square of the launch file).
at::Agent deerFromParams()
{
  XmlRpc::XmlRpcValue list;
  EXPECT_TRUE(ros::param::get("~agents", list));
  const std::vector<at::AgentSpec> specs = at::node::parseAgents(list);
  EXPECT_EQ(specs.size(), 1u);
  const std::size_t n = 601;
  const at::ElevationGrid flat(-30.0, -30.0, 0.1, 0.1, n, n, std::vector<float>(n * n, 0.f));
  return at::Agent(specs.at(0), flat, "~agents[0]");
}

/// Is map point p inside one of the agent's boxes at state s, grown by `margin` m on every side?
bool insideAgent(const at::Agent& a, const at::AgentState& s, const Eigen::Vector3d& p, double margin)
{
  const Eigen::Vector3d d = p - s.position;
  const double c = std::cos(s.yaw), sn = std::sin(s.yaw);
  const Eigen::Vector3d local(c * d.x() + sn * d.y(), -sn * d.x() + c * d.y(), d.z());
  for (const at::AgentBox& b : at::agentBoxes(a.spec().type))
    if (((local - b.centre).cwiseAbs() - 0.5 * b.size).maxCoeff() <= margin)
      return true;
  return false;
}

/// Runs agents_node as `name` with its private parameters already set; exit code and output.
std::pair<int, std::string> runNode(const std::string& name)
{
  return avsp::node::runCommand(std::string(AGENTS_NODE_PATH) + " __name:=" + name);
}
}  // namespace

TEST(DeerCrossing, DeerInTheLidarCloudWhereAndWhenTheAgentIs)
{
  ros::NodeHandle nh;
  Topic<sensor_msgs::PointCloud2> cloud;
  Topic<avsp_msgs::AgentStateArray> states;
  Topic<visualization_msgs::MarkerArray> markers;
  cloud.subscribe(nh, "/ego/avt_341/points");
  states.subscribe(nh, "/agents/states");
  markers.subscribe(nh, "/agents/markers");
  tf2_ros::Buffer tf_buffer(ros::Duration(30.0));
  tf2_ros::TransformListener tf_listener(tf_buffer);
  const at::Agent deer = deerFromParams();
  // The deer sets off at 1.5 s from y = -8 at 4 m/s: in front of ego (|y| < 1.5) from 3.125 s to
  // 3.875 s, at its end (y = 8) from 5.5 s. Until 6.5 s of sim time have been swept.
  const double until = 6.5;
  ASSERT_TRUE(
      spinUntil([&] { return !cloud.messages.empty() && cloud.messages.back().header.stamp.toSec() >= until; }, 60.0))
      << cloud.messages.size() << " sweeps";

  // The sweep's world is the world at its end (avsp_sensors README): the deer's pose then.
  const double sweep = 0.1;
  std::size_t in_front_sweeps = 0, before_sweeps = 0, after_sweeps = 0, seen_sweeps = 0;
  for (const sensor_msgs::PointCloud2& c : cloud.messages)
  {
    const double t_end = c.header.stamp.toSec() + sweep;
    if (t_end < 0.5)
      continue;  // the vehicle settling on its wheels
    const at::AgentState s = deer.state(t_end);
    std::size_t on_deer = 0, in_front = 0, stray = 0;
    for (sensor_msgs::PointCloud2ConstIterator<float> it(c, "x"); it != it.end(); ++it)
    {
      const Eigen::Vector3d p(it[0], it[1], it[2]);
      const bool on = insideAgent(deer, s, p, 0.05);
      on_deer += on;
      // The crossing corridor 10 m ahead, above the ground.
      if (std::abs(p.x() - 10.0) < 1.0 && std::abs(p.y()) < 3.0 && p.z() > 0.25)
      {
        ++in_front;
        stray += !insideAgent(deer, s, p, 0.1);
      }
    }
    // Wherever it is (waiting at y = -8, crossing, standing at y = 8), the lidar sees it, and
    // nothing stands in the corridor but the deer at this sweep's time.
    EXPECT_GE(on_deer, 10u) << "sweep at " << c.header.stamp.toSec() << " s";
    EXPECT_EQ(stray, 0u) << "sweep at " << c.header.stamp.toSec() << " s";
    seen_sweeps += on_deer >= 10;
    if (std::abs(s.position.y()) < 1.5)
    {
      ++in_front_sweeps;
      EXPECT_GE(in_front, 20u) << "deer in front at " << t_end << " s";
      EXPECT_GE(on_deer, 20u);
    }
    if (t_end < 1.5)
    {
      ++before_sweeps;
      EXPECT_EQ(in_front, 0u) << "before it set off, sweep ending " << t_end << " s";
    }
    if (s.position.y() > 4.5)
    {
      ++after_sweeps;
      EXPECT_EQ(in_front, 0u) << "after it passed, sweep ending " << t_end << " s";
    }
  }
  EXPECT_GE(in_front_sweeps, 5u);
  EXPECT_GE(before_sweeps, 5u);
  EXPECT_GE(after_sweeps, 5u);
  std::printf(
      "[deer crossing] %zu sweeps with the deer in them (%zu with it in front, %zu before it set off, %zu "
      "after it passed)\n",
      seen_sweeps, in_front_sweeps, before_sweeps, after_sweeps);

  // agents_node: states on the 20 Hz grid of sim time, each the core's state at its stamp.
  ASSERT_TRUE(spinUntil([&] { return states.messages.size() >= 50u; }, 30.0)) << states.messages.size() << " states";
  for (const avsp_msgs::AgentStateArray& m : states.messages)
  {
    const double t = m.header.stamp.toSec();
    EXPECT_NEAR(t * 20.0, std::round(t * 20.0), 1e-6);
    EXPECT_EQ(m.header.frame_id, "map");
    ASSERT_EQ(m.agents.size(), 1u);
    const avsp_msgs::AgentState& a = m.agents[0];
    const at::AgentState s = deer.state(t);
    EXPECT_EQ(a.name, "deer");
    EXPECT_EQ(a.type, "deer");
    EXPECT_NEAR(a.pose.position.x, s.position.x(), 1e-6) << t;
    EXPECT_NEAR(a.pose.position.y, s.position.y(), 1e-6) << t;
    EXPECT_NEAR(a.pose.position.z, 0.0, 1e-6) << t;
    EXPECT_NEAR(a.twist.linear.y, s.moving ? 4.0 : 0.0, 1e-9) << t;
    EXPECT_EQ(a.moving, s.moving) << t;
    EXPECT_NEAR(a.size.x, 1.6, 1e-9);
  }
  // TF: map -> agents/deer at a grid time while it crosses.
  const ros::Time crossing(3.5);
  ASSERT_TRUE(tf_buffer.canTransform("map", "agents/deer", crossing)) << "no TF map -> agents/deer at 3.5 s";
  const geometry_msgs::TransformStamped tf = tf_buffer.lookupTransform("map", "agents/deer", crossing);
  EXPECT_NEAR(tf.transform.translation.x, 10.0, 1e-6);
  EXPECT_NEAR(tf.transform.translation.y, deer.state(3.5).position.y(), 1e-6);
  EXPECT_NEAR(2.0 * std::atan2(tf.transform.rotation.z, tf.transform.rotation.w), M_PI / 2, 1e-9);
  // Markers: the deer's six boxes and its name, in its own frame.
  ASSERT_FALSE(markers.messages.empty());
  const visualization_msgs::MarkerArray& last = markers.messages.back();
  std::size_t cubes = 0, texts = 0;
  for (const visualization_msgs::Marker& m : last.markers)
  {
    EXPECT_EQ(m.ns, "deer");
    EXPECT_EQ(m.header.frame_id, "agents/deer");
    cubes += m.type == visualization_msgs::Marker::CUBE;
    texts += m.type == visualization_msgs::Marker::TEXT_VIEW_FACING && m.text == "deer";
  }
  EXPECT_EQ(cubes, at::agentBoxes(at::AgentType::kDeer).size());
  EXPECT_EQ(texts, 1u);
}

TEST(DeerCrossing, BadAgentsExitNamingTheKey)
{
  std::string soils;
  ASSERT_TRUE(ros::param::get("~soils_file", soils));
  struct Case
  {
    std::string field, value;  // one field of an otherwise good deer made bad
    std::string said;
  };
  const std::vector<Case> cases = {
    { "speed", "-1", "~agents[0].speed: must be finite and >= 0 m/s, got -1" },
    { "type", "moose", "~agents[0].type: unknown agent type 'moose'" },
    { "sped", "2", "~agents[0].sped: unknown key" },
    { "path", "one point", "~agents[0].path: a moving agent needs at least 2 points, got 1" },
  };
  for (const Case& c : cases)
  {
    XmlRpc::XmlRpcValue deer;
    deer["name"] = std::string("deer");
    deer["type"] = std::string("deer");
    XmlRpc::XmlRpcValue path;
    path[0][0] = 0.0;
    path[0][1] = 0.0;
    if (c.field != "path")
    {
      path[1][0] = 5.0;
      path[1][1] = 0.0;
    }
    deer["path"] = path;
    deer["speed"] = 2.0;
    if (c.field == "speed" || c.field == "sped")
      deer[c.field] = std::stod(c.value);
    if (c.field == "type")
      deer["type"] = c.value;
    XmlRpc::XmlRpcValue list;
    list[0] = deer;
    ros::param::set("/bad_agents/agents", list);
    ros::param::set("/bad_agents/soils_file", soils);
    ros::param::set("/bad_agents/flat_soil", std::string("gravel"));
    ros::param::set("/bad_agents/flat_size", 20.0);
    const auto [code, out] = runNode("bad_agents");
    EXPECT_EQ(code, 1) << out;
    EXPECT_NE(out.find(c.said), std::string::npos) << "'" << c.said << "' not in: " << out;
  }
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_deer_crossing");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
