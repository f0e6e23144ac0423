// Publishes every movable joint of robot_description at position 0 on `joint_states`, so
// robot_state_publisher can show a parked vehicle before (or without) the dynamics.
//
// Parameters (private): rate (Hz, default 10, in [0.001, 1000]).
// Parameters (namespace): robot_description (URDF string, required).
#include <exception>
#include <string>

#include <avsp_terrain/ros/node_params.hpp>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <urdf/model.h>

int main(int argc, char** argv)
{
  ros::init(argc, argv, "rest_pose_joint_publisher");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  double rate = 10.0;
  try
  {
    rate = avsp::node::boundedParam(pnh, "rate", 10.0, 1e-3, 1000.0);
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("rest_pose_joint_publisher: %s", e.what());
    return 1;
  }
  urdf::Model model;
  if (!model.initParam("robot_description"))
  {
    ROS_FATAL("rest_pose_joint_publisher: parameter '%s' is missing or not a valid URDF",
              nh.resolveName("robot_description").c_str());
    return 1;
  }
  sensor_msgs::JointState msg;
  for (const auto& kv : model.joints_)
  {
    const int type = kv.second->type;
    if (type == urdf::Joint::FIXED || type == urdf::Joint::UNKNOWN || type == urdf::Joint::FLOATING ||
        type == urdf::Joint::PLANAR)
      continue;
    msg.name.push_back(kv.first);
    msg.position.push_back(0.0);
  }
  ros::Publisher pub = nh.advertise<sensor_msgs::JointState>("joint_states", 1);
  ros::Rate loop(rate);
  while (ros::ok())
  {
    msg.header.stamp = ros::Time::now();
    pub.publish(msg);
    ros::spinOnce();
    loop.sleep();
  }
  return 0;
}
