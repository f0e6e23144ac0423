// Publishes one static transform parent -> child from private parameters: map -> odom
// (identity, docs/ARCHITECTURE.md) and, until the dynamics runs, a parked vehicle's
// odom -> <vehicle>/base_link. Debian ships no tf2_ros static_transform_publisher.
//
// Parameters (private): parent_frame (string, required), child_frame (string, required),
// x, y, z (m, default 0), yaw, pitch, roll (rad, default 0).
#include <cmath>
#include <exception>
#include <string>

#include <avsp_terrain/ros/node_params.hpp>
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/static_transform_broadcaster.h>

int main(int argc, char** argv)
{
  ros::init(argc, argv, "static_frame_publisher");
  ros::NodeHandle pnh("~");
  std::string parent, child;
  double x, y, z, yaw, pitch, roll;
  try
  {
    parent = avsp::node::stringParam(pnh, "parent_frame", "");
    child = avsp::node::stringParam(pnh, "child_frame", "");
    if (parent.empty() || child.empty())
      throw avsp::node::StartupError("parameters ~parent_frame and ~child_frame are required (non-empty strings)");
    if (parent == child)
      throw avsp::node::StartupError("~parent_frame and ~child_frame are both '" + parent + "'");
    // Any finite number; a wrong type (a string, say) is refused naming the key.
    const double big = 1e300;
    x = avsp::node::boundedParam(pnh, "x", 0.0, -big, big);
    y = avsp::node::boundedParam(pnh, "y", 0.0, -big, big);
    z = avsp::node::boundedParam(pnh, "z", 0.0, -big, big);
    yaw = avsp::node::boundedParam(pnh, "yaw", 0.0, -big, big);
    pitch = avsp::node::boundedParam(pnh, "pitch", 0.0, -big, big);
    roll = avsp::node::boundedParam(pnh, "roll", 0.0, -big, big);
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("static_frame_publisher: %s", e.what());
    return 1;
  }

  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time::now();
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = x;
  t.transform.translation.y = y;
  t.transform.translation.z = z;
  tf2::Quaternion q;
  q.setRPY(roll, pitch, yaw);
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  t.transform.rotation.w = q.w();
  tf2_ros::StaticTransformBroadcaster broadcaster;
  broadcaster.sendTransform(t);
  ros::spin();
  return 0;
}
