// The node classes of every package's ROS layer run in any process, this test's included: each
// refuses a bad parameter with a StartupError naming it when constructed here (the nodes' mains
// turn that into exit 1), and TerrainNode, constructed here, publishes its mesh to a subscriber
// of this process.
#include <functional>
#include <string>

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <avsp_dynamics/ros/dynamics_node.hpp>
#include <avsp_dynamics/ros/lockstep_clock.hpp>
#include <avsp_sensors/ros/sensors_node.hpp>
#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/terrain_node.hpp>

#include "avsp/ros/agents_node.hpp"
#include "avsp/ros/controller_node.hpp"
#include "avsp/ros/environment_node.hpp"
#include "avsp/ros/run_recorder.hpp"
#include "avsp/ros/start_gate.hpp"
#include "avsp/ros/v2v_broadcaster.hpp"
#include "avsp/ros/v2v_radio_node.hpp"

namespace
{
/// Constructs `Node` on the private namespace `ns` (nothing set there but `setup`'s parameters)
/// and expects a StartupError containing `text`.
template <typename Node>
void expectRefused(const std::string& ns, const std::function<void(ros::NodeHandle&)>& setup, const std::string& text)
{
  ros::NodeHandle nh, pnh(ns);
  setup(pnh);
  try
  {
    Node node(nh, pnh);
    ADD_FAILURE() << ns << ": constructed, expected a StartupError with '" << text << "'";
  }
  catch (const avsp::node::StartupError& e)
  {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << ns << ": " << e.what();
  }
}

const auto kNothing = [](ros::NodeHandle&) {};

TEST(NodeClasses, EachRefusesABadParameterNamingIt)
{
  using namespace avsp;
  expectRefused<terrain::node::TerrainNode>(
      "/bad/terrain",
      [](ros::NodeHandle& p) {
        p.setParam("soils_file", std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
        p.setParam("flat_soil", "gravel");
        p.setParam("flat_size", 20.0);
        p.setParam("mesh_resolution", -1.0);
      },
      "parameter ~mesh_resolution = -1.000000 must be finite and > 0");
  expectRefused<dynamics::node::DynamicsNode>(
      "/bad/dynamics", kNothing, "parameter ~vehicles must be a non-empty list of {name, model, x, y, yaw}");
  expectRefused<dynamics::node::LockstepClock>("/bad/clock", kNothing,
                                               "parameter ~partitions must be a non-empty list of partition names");
  expectRefused<sensors::node::SensorsNode>("/bad/sensors", kNothing,
                                            "parameter ~vehicles must be a non-empty list of {name, model}");
  expectRefused<node::EnvironmentNode>("/bad/environment", kNothing,
                                       "parameter ~latitude (deg, [-90, 90]) is required");
  expectRefused<node::V2vRadioNode>("/bad/radio", kNothing, "parameter ~vehicles must be a non-empty list");
  expectRefused<node::V2vBroadcaster>(
      "/bad/broadcaster",
      [](ros::NodeHandle& p) {
        p.setParam("vehicle_id", "alpha");
        p.setParam("rate", 0.0);
      },
      "parameter ~rate = 0.000000 must be finite and in [0.100000, 1000.000000]");
  expectRefused<node::ControllerNode>(
      "/bad/controller", [](ros::NodeHandle& p) { p.setParam("mode", "cruise"); },
      "parameter ~mode 'cruise' must be waypoints or leader_follower");
  expectRefused<node::AgentsNode>(
      "/bad/agents", [](ros::NodeHandle& p) { p.setParam("frame", ""); }, "parameter ~frame must not be empty");
  expectRefused<node::RunRecorder>("/bad/recorder", kNothing, "parameter /use_sim_time must be true");
}

TEST(NodeClasses, StartGateRefusesAMissingListNamingIt)
{
  // start_gate's list parameters throw std::runtime_error (its main logs and exits 1 alike).
  ros::NodeHandle nh, pnh("/bad/gate");
  try
  {
    avsp::node::StartGate gate(nh, pnh);
    ADD_FAILURE() << "constructed without ~nodes";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_EQ(std::string(e.what()), "parameter ~nodes: required, a list of names");
  }
}

TEST(NodeClasses, TerrainNodePublishesItsMeshToThisProcess)
{
  // A level 20 m gravel square at 0.1 m, meshed every 2 m in chunks of 50 m: one chunk of
  // 10 x 10 cells, two triangles each, all at height 0.
  ros::NodeHandle nh, pnh("/good/terrain");
  pnh.setParam("soils_file", std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  pnh.setParam("flat_soil", "gravel");
  pnh.setParam("flat_size", 20.0);
  visualization_msgs::MarkerArray mesh;
  ros::Subscriber sub = nh.subscribe<visualization_msgs::MarkerArray>(
      "/terrain/mesh", 10, [&mesh](const visualization_msgs::MarkerArray::ConstPtr& m) {
        if (mesh.markers.empty())
          mesh = *m;
      });
  avsp::terrain::node::TerrainNode node(nh, pnh);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  while (mesh.markers.empty() && ros::WallTime::now() < deadline)
  {
    ros::spinOnce();
    node.publishDirtyChunks();
    ros::WallDuration(0.01).sleep();
  }
  ASSERT_EQ(mesh.markers.size(), 1u);
  const visualization_msgs::Marker& m = mesh.markers[0];
  EXPECT_EQ(m.ns, "terrain_mesh");
  EXPECT_EQ(m.type, visualization_msgs::Marker::TRIANGLE_LIST);
  EXPECT_EQ(m.points.size(), 10u * 10u * 2u * 3u);
  for (const geometry_msgs::Point& p : m.points)
    ASSERT_EQ(p.z, 0.0);
}

}  // namespace

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_classes");
  return RUN_ALL_TESTS();
}
