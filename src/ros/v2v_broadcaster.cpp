// v2v_broadcaster's class (the node's main is ../v2v_broadcaster.cpp): a vehicle's V2V
// transmitter, in the vehicle's namespace. Turns its own avt_341/odometry into the
// avsp_msgs/VehicleState it broadcasts on v2v/out (DSRC practice: 10 Hz), which v2v_radio_node
// relays to the other vehicles' v2v/in.
//
// Broadcasts go out on the first odometry at or after each multiple of 1 / ~rate on the
// odometry's clock (sim time in lockstep runs), stamped with that odometry's stamp.
#include "avsp/ros/v2v_broadcaster.hpp"

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include <avsp_msgs/VehicleState.h>
#include <avsp_terrain/ros/node_params.hpp>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

namespace avsp
{
namespace node
{
namespace
{

}  // namespace

class V2vBroadcaster::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh)
  {
    const std::string ns = ros::names::clean(nh.getNamespace());
    const std::string last = ns.substr(ns.find_last_of('/') + 1);
    vehicle_id_ = avsp::node::stringParam(pnh, "vehicle_id", last);
    if (vehicle_id_.empty())
      throw StartupError("parameter ~vehicle_id is required when the node is not in a vehicle's namespace");
    period_ = 1.0 / boundedParam(pnh, "rate", 10.0, 0.1, 1000.0);
    frame_id_ = avsp::node::stringParam(pnh, "frame_id", "map");
    pub_ = nh.advertise<avsp_msgs::VehicleState>("v2v/out", 10);
    sub_ = nh.subscribe("avt_341/odometry", 10, &Impl::onOdometry, this,
                        ros::TransportHints().tcpNoDelay());  // on the lockstep path to the radio
    ROS_INFO("v2v_broadcaster: '%s' broadcasts on %s at %g Hz", vehicle_id_.c_str(), pub_.getTopic().c_str(),
             1.0 / period_);
  }

private:
  void onOdometry(const nav_msgs::Odometry::ConstPtr& odom)
  {
    const double t = odom->header.stamp.toSec();
    const double slot = std::floor(t / period_ + 1e-6);
    if (has_last_ && slot <= last_slot_)
      return;
    const auto& q = odom->pose.pose.orientation;
    const auto& w = odom->twist.twist.angular;
    avsp_msgs::VehicleState s;
    s.header.stamp = odom->header.stamp;
    s.header.frame_id = frame_id_;
    s.vehicle_id = vehicle_id_;
    s.position = odom->pose.pose.position;
    s.heading = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
    s.speed = odom->twist.twist.linear.x;
    // Yaw rate about map z: the third row of the body-to-map rotation times the body rate.
    s.yaw_rate = 2.0 * (q.x * q.z - q.w * q.y) * w.x + 2.0 * (q.y * q.z + q.w * q.x) * w.y +
                 (1.0 - 2.0 * (q.x * q.x + q.y * q.y)) * w.z;
    s.acceleration = has_last_ && t > last_t_ ? (s.speed - last_speed_) / (t - last_t_) : 0.0;
    s.seq = seq_;
    if (!std::isfinite(s.position.x) || !std::isfinite(s.position.y) || !std::isfinite(s.heading) ||
        !std::isfinite(s.speed))
    {
      ROS_WARN_THROTTLE(5.0, "v2v_broadcaster: non-finite odometry; nothing broadcast");
      return;
    }
    pub_.publish(s);
    ++seq_;
    has_last_ = true;
    last_slot_ = slot;
    last_t_ = t;
    last_speed_ = s.speed;
  }

  std::string vehicle_id_;
  std::string frame_id_;
  double period_ = 0.1;
  bool has_last_ = false;
  double last_slot_ = 0.0;
  double last_t_ = 0.0;
  double last_speed_ = 0.0;
  std::uint32_t seq_ = 0;
  ros::Publisher pub_;
  ros::Subscriber sub_;
};

V2vBroadcaster::V2vBroadcaster(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

V2vBroadcaster::~V2vBroadcaster() = default;

int V2vBroadcaster::spin()
{
  ros::spin();
  return 0;
}

}  // namespace node
}  // namespace avsp
