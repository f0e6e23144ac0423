// rostest: the reference team's URDFs through robot_state_publisher give every frame under
// the vehicle's prefix, at the pose the vehicle model (avsp_dynamics, an independent reading
// of the same URDF) and the parked pose predict. TF data arrive asynchronously, so each
// lookup waits for them with a bounded timeout; nothing is timed. Also: the bring-up tools
// (static_frame_publisher, rest_pose_joint_publisher, team_check) refuse bad parameters.
#include <string>
#include <tuple>
#include <vector>

#include <avsp_dynamics/vehicle_model.hpp>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <avsp_terrain/ros/run_command.hpp>

namespace
{
struct Member
{
  std::string name, model;
  Eigen::Vector3d parked;
};

std::unique_ptr<tf2_ros::Buffer> g_buffer;
std::vector<Member> g_team;
std::string g_config_dir;

Eigen::Vector3d lookup(const std::string& target, const std::string& source)
{
  std::string error;
  if (!g_buffer->canTransform(target, source, ros::Time(0), ros::Duration(20.0), &error))
  {
    ADD_FAILURE() << "no transform " << target << " -> " << source << ": " << error;
    return Eigen::Vector3d::Constant(std::nan(""));
  }
  const auto t = g_buffer->lookupTransform(target, source, ros::Time(0)).transform.translation;
  return { t.x, t.y, t.z };
}
}  // namespace

TEST(TeamTf, EveryVehicleFrameIsPrefixedAndWhereTheModelSays)
{
  ASSERT_EQ(g_team.size(), 4u);
  for (const Member& m : g_team)
  {
    const auto model = avsp::dynamics::loadVehicleModel(g_config_dir + "/" + m.model + ".yaml");
    const std::string p = m.name + "/";
    for (const auto& b : model.bodies)
      EXPECT_LT((lookup(p + "base_link", p + b.link) - b.rest_position).norm(), 1e-6) << p << b.link;
    for (const auto& s : model.sensor_mounts)
    {
      EXPECT_LT((lookup(p + "base_link", p + s.first) - s.second).norm(), 1e-6) << p << s.first;
      // In the world: the parked pose plus the mount offset (vehicles park facing east).
      EXPECT_LT((lookup("map", p + s.first) - (m.parked + s.second)).norm(), 1e-6) << p << s.first;
    }
  }
}

TEST(TeamTf, ContractFramesExistForEachVehicle)
{
  for (const Member& m : g_team)
    for (const char* frame : { "base_link", "lidar", "radar", "gps", "imu" })
      EXPECT_TRUE(g_buffer->canTransform("map", m.name + "/" + frame, ros::Time(0), ros::Duration(20.0)))
          << m.name << "/" << frame;
}

TEST(TeamTf, RunningGearAtPublishedDimensions)
{
  // FED-Alpha-class: wheelbase 3.30 m, track 1.90 m; M113-class: gauge 2.30 m, middle road
  // wheel under base_link. Figures from the root README's vehicle table.
  EXPECT_LT((lookup("fed_alpha/base_link", "fed_alpha/front_left_wheel") - Eigen::Vector3d(1.65, 0.95, 0)).norm(),
            1e-6);
  EXPECT_LT((lookup("fed_alpha/base_link", "fed_alpha/rear_right_wheel") - Eigen::Vector3d(-1.65, -0.95, 0)).norm(),
            1e-6);
  EXPECT_LT((lookup("m113/base_link", "m113/right_road_wheel_3") - Eigen::Vector3d(0, -1.15, 0)).norm(), 1e-6);
  EXPECT_LT((lookup("m113/left_road_wheel_1", "m113/left_road_wheel_5") - Eigen::Vector3d(-2.67, 0, 0)).norm(), 1e-6);
}

TEST(TeamTf, UnprefixedFramesDoNotExist)
{
  // Frames are written prefixed (no tf_prefix): a bare 'lidar' would collide between vehicles.
  ASSERT_TRUE(g_buffer->canTransform("map", "fed_alpha/lidar", ros::Time(0), ros::Duration(20.0)));
  EXPECT_FALSE(g_buffer->_frameExists("lidar"));
  EXPECT_FALSE(g_buffer->_frameExists("base_link"));
}

using avsp::node::runCommand;

// The bring-up tools refuse a parameter of the wrong type naming the key (NodeHandle::param
// would have used the default silently).
TEST(BringupNodes, RefuseParametersOfTheWrongTypeNamingTheKey)
{
  auto [code, out] = runCommand(std::string(STATIC_FRAME_PUBLISHER_PATH) +
                                " __name:=bad_frames _parent_frame:=map _child_frame:=odom _x:=east");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~x must be a number, got a string"), std::string::npos) << out;
  std::tie(code, out) =
      runCommand(std::string(STATIC_FRAME_PUBLISHER_PATH) + " __name:=bad_frames _parent_frame:=map _child_frame:=map");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("both 'map'"), std::string::npos) << out;
  std::tie(code, out) = runCommand(std::string(REST_POSE_JOINT_PUBLISHER_PATH) + " __name:=bad_rest _rate:=fast");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~rate must be a number, got a string"), std::string::npos) << out;
  std::tie(code, out) = runCommand(std::string(REST_POSE_JOINT_PUBLISHER_PATH) + " __name:=bad_rest _rate:=0.0");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~rate"), std::string::npos) << out;
  std::tie(code, out) = runCommand(std::string(TEAM_CHECK_PATH) + " __name:=bad_check _timeout:=soon");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~timeout must be a number, got a string"), std::string::npos) << out;
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_team_tf");
  ros::NodeHandle pnh("~");
  XmlRpc::XmlRpcValue vehicles, parked;
  if (!pnh.getParam("vehicles", vehicles) || !pnh.getParam("parked", parked) ||
      !pnh.getParam("config_dir", g_config_dir))
  {
    ROS_FATAL("test_team_tf: needs ~vehicles, ~parked and ~config_dir");
    return 1;
  }
  for (int k = 0; k < vehicles.size(); ++k)
  {
    Member m{ static_cast<std::string>(vehicles[k]["name"]), static_cast<std::string>(vehicles[k]["model"]), {} };
    XmlRpc::XmlRpcValue& xyz = parked[m.name];
    m.parked = Eigen::Vector3d(static_cast<double>(xyz[0]), static_cast<double>(xyz[1]), static_cast<double>(xyz[2]));
    g_team.push_back(m);
  }
  g_buffer = std::make_unique<tf2_ros::Buffer>();
  // The listener (and its thread) must go before the buffer it fills.
  auto listener = std::make_unique<tf2_ros::TransformListener>(*g_buffer);
  const int result = RUN_ALL_TESTS();
  listener.reset();
  g_buffer.reset();
  return result;
}
