// spawn_vehicle: calls a dynamics_node's ~spawn_vehicle once (waiting for the service) and
// exits 0 when the vehicle is in, 1 with the node's answer otherwise: the launch files'
// spawner (launch/spawn_vehicle.launch), as gazebo_ros's spawn_model is Gazebo's.
//
// Parameters (private): dynamics (the node, default /dynamics), name, model (required), x, y
// (m, map), yaw (rad, default 0), partition (partitioned runs, default ""), timeout (s wall the
// service is waited for, default 30).
#include <cmath>
#include <exception>
#include <string>

#include <avsp_msgs/SpawnVehicle.h>
#include <avsp_terrain/ros/node_params.hpp>
#include <ros/ros.h>

int main(int argc, char** argv)
{
  ros::init(argc, argv, "spawn_vehicle", ros::init_options::AnonymousName);
  ros::NodeHandle pnh("~");
  avsp_msgs::SpawnVehicle spawn;
  std::string dynamics;
  double timeout = 30.0;
  try
  {
    dynamics = avsp::node::stringParam(pnh, "dynamics", "/dynamics");
    spawn.request.name = avsp::node::stringParam(pnh, "name", "");
    spawn.request.model = avsp::node::stringParam(pnh, "model", "");
    if (spawn.request.name.empty() || spawn.request.model.empty())
      throw avsp::node::StartupError("parameters ~name and ~model are required (non-empty strings)");
    if (!pnh.hasParam("x") || !pnh.hasParam("y"))
      throw avsp::node::StartupError("parameters ~x and ~y (m, map) are required");
    const double big = 1e300;  // any finite number; the node refuses a pose off its terrain
    spawn.request.x = avsp::node::boundedParam(pnh, "x", 0.0, -big, big);
    spawn.request.y = avsp::node::boundedParam(pnh, "y", 0.0, -big, big);
    spawn.request.yaw = avsp::node::boundedParam(pnh, "yaw", 0.0, -big, big);
    spawn.request.partition = avsp::node::stringParam(pnh, "partition", "");
    timeout = avsp::node::boundedParam(pnh, "timeout", 30.0, 0.1, 3600.0);
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("spawn_vehicle: %s", e.what());
    return 1;
  }
  const std::string service = dynamics + "/spawn_vehicle";
  if (!ros::service::waitForService(service, ros::Duration(timeout)))
  {
    ROS_FATAL("spawn_vehicle: %s did not come up within ~timeout %g s (wall)", service.c_str(), timeout);
    return 1;
  }
  if (!ros::service::call(service, spawn))
  {
    ROS_FATAL("spawn_vehicle: %s did not answer", service.c_str());
    return 1;
  }
  if (!spawn.response.success)
  {
    ROS_FATAL("spawn_vehicle: %s: %s", service.c_str(), spawn.response.message.c_str());
    return 1;
  }
  ROS_INFO("spawn_vehicle: %s", spawn.response.message.c_str());
  return 0;
}
