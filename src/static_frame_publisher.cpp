// Publishes one static transform parent -> child from private parameters: map -> odom
// (identity, ARCHITECTURE.md) and, until the dynamics runs, a parked vehicle's
// odom -> <vehicle>/base_link. Debian ships no tf2_ros static_transform_publisher.
//
// Parameters (private): parent_frame (string, required), child_frame (string, required),
// x, y, z (m, default 0), yaw, pitch, roll (rad, default 0).
#include <cmath>
#include <string>

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/static_transform_broadcaster.h>

namespace
{
bool readFinite(const ros::NodeHandle& pnh, const std::string& key, double& value)
{
  value = 0.0;
  pnh.param(key, value, 0.0);
  if (!std::isfinite(value))
  {
    ROS_FATAL("static_frame_publisher: parameter ~%s must be finite", key.c_str());
    return false;
  }
  return true;
}
}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "static_frame_publisher");
  ros::NodeHandle pnh("~");
  std::string parent, child;
  if (!pnh.getParam("parent_frame", parent) || parent.empty() || !pnh.getParam("child_frame", child) ||
      child.empty())
  {
    ROS_FATAL("static_frame_publisher: parameters ~parent_frame and ~child_frame are required (non-empty strings)");
    return 1;
  }
  if (parent == child)
  {
    ROS_FATAL("static_frame_publisher: ~parent_frame and ~child_frame are both '%s'", parent.c_str());
    return 1;
  }
  double x, y, z, yaw, pitch, roll;
  if (!readFinite(pnh, "x", x) || !readFinite(pnh, "y", y) || !readFinite(pnh, "z", z) ||
      !readFinite(pnh, "yaw", yaw) || !readFinite(pnh, "pitch", pitch) || !readFinite(pnh, "roll", roll))
    return 1;

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
