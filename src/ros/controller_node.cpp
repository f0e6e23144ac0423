// controller_node's class (the node's main is ../controller_node.cpp): one vehicle's controller,
// in the vehicle's namespace. From its own avt_341/odometry (and, as a follower, what its radio
// received on v2v/in) it drives the vehicle through avt_341/cmd_vel: ~mode waypoints (pure
// pursuit + speed PID along ~waypoints) or leader_follower (pursuit of ~leader's V2V breadcrumbs
// at ~gap and ~offset, changeable at run time on formation/gap and formation/offset). The
// control is avsp_control (include/avsp/control/); this file only converts parameters and
// messages. With ~lockstep it answers every odometry on the grid of 1 / ~rate with a cmd_drive
// stamped with that odometry's stamp: dynamics_node's barrier (~lockstep_vehicles) waits for it.
// A lockstep follower takes its radio's v2v/in_lockstep batches instead of v2v/in and steps at t
// only once the batch of t is in, so it knows exactly what was delivered by t.
#include "avsp/ros/controller_node.hpp"

#include <deque>
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <avsp_msgs/DriveCommand.h>
#include <avsp_msgs/VehicleState.h>
#include <avsp_msgs/VehicleStateArray.h>
#include <avsp_terrain/ros/node_params.hpp>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <std_msgs/Bool.h>
#include <std_msgs/Float64.h>
#include <visualization_msgs/Marker.h>

#include "avsp/control/leader_follower.hpp"
#include "avsp/control/steering.hpp"
#include "avsp/control/waypoint_follower.hpp"
#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace node
{
namespace
{
namespace ac = avsp::control;

std::string requiredString(const ParamSource& params, const std::string& key, const std::string& what)
{
  XmlRpc::XmlRpcValue value;
  if (!params.get(key, value))
    throw StartupError("parameter ~" + key + " (" + what + ") is required");
  if (value.getType() != XmlRpc::XmlRpcValue::TypeString || static_cast<std::string>(value).empty())
    throw StartupError("parameter ~" + key + " must be a non-empty string (" + what + ")");
  return static_cast<std::string>(value);
}

/// ~waypoints: a list of {x, y, speed} (m, m, m/s); no other keys.
std::vector<ac::Waypoint> waypointsFromParams(const ParamSource& pnh)
{
  XmlRpc::XmlRpcValue list;
  if (!avsp::node::structuredParam(pnh, "waypoints", list))
    throw StartupError("parameter ~waypoints (list of {x, y, speed}) is required in mode waypoints");
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw StartupError("parameter ~waypoints must be a list of {x, y, speed} entries");
  std::vector<ac::Waypoint> waypoints;
  for (int k = 0; k < list.size(); ++k)
  {
    const std::string where = "~waypoints[" + std::to_string(k) + "]";
    XmlRpc::XmlRpcValue& entry = list[k];
    if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct)
      throw StartupError("parameter " + where + " must be a dictionary {x, y, speed}");
    std::map<std::string, double> values;
    for (auto it = entry.begin(); it != entry.end(); ++it)
    {
      const std::string& key = it->first;
      if (key != "x" && key != "y" && key != "speed")
        throw StartupError("parameter " + where + "." + key + ": unknown key (known: x, y, speed)");
      XmlRpc::XmlRpcValue& v = it->second;
      if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
        values[key] = static_cast<double>(v);
      else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
        values[key] = static_cast<int>(v);
      else
        throw StartupError("parameter " + where + "." + key + " must be a number");
    }
    for (const char* key : { "x", "y", "speed" })
      if (!values.count(key))
        throw StartupError("parameter " + where + "." + key + " is missing");
    waypoints.push_back({ values["x"], values["y"], values["speed"] });
  }
  try
  {
    ac::validateWaypoints(waypoints);
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError("parameter ~" + std::string(e.what()));
  }
  return waypoints;
}

/// The pursuit and speed-loop parameters, defaults from the mode's options.
ac::TrackingOptions trackingFromParams(const ParamSource& pnh, ac::TrackingOptions o)
{
  o.lookahead.min = boundedParam(pnh, "lookahead_min", o.lookahead.min, 0.1, 1000.0);
  o.lookahead.gain = boundedParam(pnh, "lookahead_gain", o.lookahead.gain, 0.0, 100.0);
  o.lookahead.max = boundedParam(pnh, "lookahead_max", o.lookahead.max, o.lookahead.min, 1000.0);
  o.pid.kp = boundedParam(pnh, "speed_kp", o.pid.kp, 0.0, 100.0);
  o.pid.ki = boundedParam(pnh, "speed_ki", o.pid.ki, 0.0, 100.0);
  o.pid.kd = boundedParam(pnh, "speed_kd", o.pid.kd, 0.0, 100.0);
  o.pid.integral_limit = boundedParam(pnh, "speed_integral_limit", o.pid.integral_limit, 0.01, 1.0);
  o.coast_band = boundedParam(pnh, "coast_band", o.coast_band, 0.0, 0.99);
  o.brake_gain = boundedParam(pnh, "brake_gain", o.brake_gain, 0.01, 100.0);
  o.max_accel = boundedParam(pnh, "max_accel", o.max_accel, 0.01, 100.0);
  return o;
}

double yawOf(const geometry_msgs::Quaternion& q)
{
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

geometry_msgs::PoseStamped poseStamped(const std::string& frame, double x, double y, double z)
{
  geometry_msgs::PoseStamped p;
  p.header.frame_id = frame;
  p.pose.position.x = x;
  p.pose.position.y = y;
  p.pose.position.z = z;
  p.pose.orientation.w = 1.0;
  return p;
}

}  // namespace

ControllerSetup readControllerParams(const ParamSource& pnh)
{
  ControllerSetup out;
  out.mode = requiredString(pnh, "mode", "waypoints | leader_follower");
  const std::string& mode = out.mode;
  if (mode != "waypoints" && mode != "leader_follower")
    throw StartupError("parameter ~mode '" + mode + "' must be waypoints or leader_follower");
  out.model_name = requiredString(pnh, "model", "vehicle model, <config_dir>/<model>.yaml");
  const std::string& model_name = out.model_name;
  const std::string config_dir =
      avsp::node::stringParam(pnh, "config_dir", ros::package::getPath("avsp") + "/config/vehicles");
  const double track_width_factor = boundedParam(pnh, "track_width_factor", 1.0, 1.0, 10.0);
  try
  {
    out.geometry = ac::steeringGeometry(avsp::dynamics::loadVehicleModel(config_dir + "/" + model_name + ".yaml"),
                                        track_width_factor);
  }
  catch (const std::exception& e)
  {
    throw StartupError("parameter ~model '" + model_name + "': " + e.what());
  }
  const ac::SteeringGeometry& geometry = out.geometry;
  out.rate = boundedParam(pnh, "rate", 20.0, 1.0, 1000.0);
  out.frame_id = avsp::node::stringParam(pnh, "frame_id", "map");
  out.lockstep = avsp::node::boolParam(pnh, "lockstep", false);
  if (out.lockstep)
  {
    // dynamics_node waits at every multiple of its ~lockstep_period for this controller's
    // command: each must be on the controller's own grid k / ~rate, or the barrier waits for an
    // answer that never comes (the run stops at ~lockstep_timeout).
    const double barrier = boundedParam(pnh, "lockstep_period", 0.05, 1e-4, 10.0);
    const double periods = barrier * out.rate;
    if (std::abs(periods - std::round(periods)) > 1e-9 * std::max(1.0, periods) || std::round(periods) < 1.0)
      throw StartupError("parameter ~rate = " + std::to_string(out.rate) + " Hz: with ~lockstep the barrier period " +
                         "~lockstep_period = " + std::to_string(barrier) + " s must be a whole number of control " +
                         "periods (a rate that is a multiple of " + std::to_string(1.0 / barrier) + " Hz)");
  }
  try
  {
    if (mode == "waypoints")
    {
      ac::WaypointFollowerOptions o;
      o.tracking = trackingFromParams(pnh, o.tracking);
      o.decel = boundedParam(pnh, "decel", o.decel, 0.05, 20.0);
      o.approach_speed = boundedParam(pnh, "approach_speed", o.approach_speed, 0.05, 10.0);
      o.goal_tolerance = boundedParam(pnh, "goal_tolerance", o.goal_tolerance, 0.05, 100.0);
      out.waypoints = std::make_unique<ac::WaypointFollower>(waypointsFromParams(pnh), geometry, o);
    }
    else
    {
      ac::LeaderFollowerOptions o;
      o.tracking = trackingFromParams(pnh, o.tracking);
      out.leader = requiredString(pnh, "leader", "the vehicle_id of the vehicle to follow");
      o.gap = boundedParam(pnh, "gap", o.gap, 0.0, 10000.0);
      o.offset = boundedParam(pnh, "offset", o.offset, -1000.0, 1000.0);
      o.gap_gain = boundedParam(pnh, "gap_gain", o.gap_gain, 0.001, 10.0);
      o.accel_lead_time = boundedParam(pnh, "accel_lead_time", o.accel_lead_time, 0.0, 10.0);
      o.max_speed = boundedParam(pnh, "max_speed", std::min(o.max_speed, geometry.max_speed), 0.01, 1000.0);
      o.safety_distance = boundedParam(pnh, "safety_distance", o.safety_distance, 0.0, 1000.0);
      o.leader_timeout = boundedParam(pnh, "leader_timeout", o.leader_timeout, 0.01, 3600.0);
      o.breadcrumb_spacing = boundedParam(pnh, "breadcrumb_spacing", o.breadcrumb_spacing, 0.01, 100.0);
      o.max_path_length = boundedParam(pnh, "max_path_length", o.max_path_length, 10.0, 1e6);
      out.follower = std::make_unique<ac::LeaderFollower>(geometry, o);
    }
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError("parameter ~" + std::string(e.what()));
  }
  return out;
}

class ControllerNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh)
  {
    ControllerSetup setup = readControllerParams(pnh);
    period_ = 1.0 / setup.rate;
    frame_id_ = setup.frame_id;
    lockstep_ = setup.lockstep;
    leader_ = setup.leader;
    waypoints_ = std::move(setup.waypoints);
    follower_ = std::move(setup.follower);
    const std::string& mode = setup.mode;
    const std::string& model_name = setup.model_name;
    const ac::SteeringGeometry& geometry = setup.geometry;
    const double rate = setup.rate;

    if (lockstep_)
      drive_pub_ = nh.advertise<avsp_msgs::DriveCommand>("cmd_drive", 10);
    else
      cmd_pub_ = nh.advertise<geometry_msgs::Twist>("avt_341/cmd_vel", 10);
    path_pub_ = nh.advertise<nav_msgs::Path>("controller/path", 1, true);
    target_pub_ = nh.advertise<visualization_msgs::Marker>("controller/target", 1);
    odom_sub_ = nh.subscribe("avt_341/odometry", 10, &Impl::onOdometry, this,
                             ros::TransportHints().tcpNoDelay());  // lockstep round trip: no Nagle delay
    if (waypoints_)
    {
      goal_pub_ = nh.advertise<std_msgs::Bool>("controller/goal_reached", 1, true);
      publishGoal(false);
      publishWaypointPath();
    }
    else
    {
      if (lockstep_)
        v2v_sub_ = nh.subscribe("v2v/in_lockstep", 100, &Impl::onV2vBatch, this, ros::TransportHints().tcpNoDelay());
      else
        v2v_sub_ = nh.subscribe("v2v/in", 100, &Impl::onV2v, this);
      gap_sub_ = nh.subscribe("formation/gap", 10, &Impl::onGap, this);
      offset_sub_ = nh.subscribe("formation/offset", 10, &Impl::onOffset, this);
      path_timer_ = nh.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { publishBreadcrumbs(); });
    }
    std::string following;
    if (follower_)
      following = ", following '" + leader_ + "' at gap " + std::to_string(follower_->desiredGap()) + " m, offset " +
                  std::to_string(follower_->offset()) + " m";
    ROS_INFO("controller_node: mode %s, model %s (%s steering, reference point %.2f m ahead of base_link), %g Hz%s",
             mode.c_str(), model_name.c_str(), ac::toString(geometry.kind), geometry.reference_x, rate,
             following.c_str());
  }

private:
  void onOdometry(const nav_msgs::Odometry::ConstPtr& odom)
  {
    if (lockstep_ && follower_ && !(odom->header.stamp.toSec() <= batch_through_ + 1e-9))
    {
      waiting_.push_back(odom);  // its radio batch is not in yet
      return;
    }
    step(odom);
  }

  /// A lockstep follower's radio batch: the leader states due by its stamp; then the waiting
  /// odometry up to that stamp is stepped.
  void onV2vBatch(const avsp_msgs::VehicleStateArray::ConstPtr& batch)
  {
    const double t = batch->header.stamp.toSec();
    if (!(t > batch_through_))
    {
      ROS_WARN_THROTTLE(5.0, "controller_node: v2v/in_lockstep batch at %.3f s not after the last; dropped", t);
      return;
    }
    for (const avsp_msgs::VehicleState& s : batch->states)
      addLeaderState(s);
    batch_through_ = t;
    while (!waiting_.empty() && waiting_.front()->header.stamp.toSec() <= batch_through_ + 1e-9)
    {
      step(waiting_.front());
      waiting_.pop_front();
    }
  }

  void step(const nav_msgs::Odometry::ConstPtr& odom)
  {
    const double t = odom->header.stamp.toSec();
    const auto& p = odom->pose.pose.position;
    const double speed = odom->twist.twist.linear.x;
    const double yaw = yawOf(odom->pose.pose.orientation);
    if (lockstep_)
    {
      // Lockstep: exactly the odometry on the grid k / ~rate (the barrier instants).
      if (std::fabs(t - std::round(t / period_) * period_) > 1e-6 || (has_step_ && t < last_step_))
        return;
      // Once per instant. dynamics_node sends the odometry of time 0 again until answered: our
      // answer may have gone out before its cmd_drive subscription connected. The same instant
      // again gets the same command again (the controller is not stepped twice).
      if (has_step_ && t == last_step_)
      {
        publishCommand(odom->header.stamp, last_command_);
        return;
      }
    }
    else if (has_step_ && t < last_step_ + period_ - 1e-6)
      return;  // control at ~rate on the odometry's own clock: the same sim instants at any speed
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(yaw) || !std::isfinite(speed))
    {
      ROS_WARN_THROTTLE(5.0, "controller_node: non-finite odometry on avt_341/odometry dropped");
      if (lockstep_)
        publishCommand(odom->header.stamp, ac::Command{ 0.0, 1.0, 0.0 });  // the barrier waits: brake
      return;
    }
    has_step_ = true;
    last_step_ = t;
    z_ = p.z;
    const ac::Pose2 pose{ p.x, p.y, yaw };
    ac::TrackingStatus st;
    if (waypoints_)
    {
      const bool was_reached = waypoints_->goalReached();
      st = waypoints_->update(pose, speed, t);
      if (waypoints_->goalReached() && !was_reached)
      {
        const auto& goal = waypoints_->waypoints().back();
        ROS_INFO("controller_node: goal (%.1f, %.1f) reached at t = %.2f s, %.2f m from it", goal.x, goal.y, t,
                 std::hypot(p.x - goal.x, p.y - goal.y));
        publishGoal(true);
      }
    }
    else
    {
      const ac::FollowerStatus fs = follower_->update(pose, speed, t);
      st = fs.tracking;
      if (!fs.leader_known)
        ROS_WARN_THROTTLE(10.0, "controller_node: no V2V state from leader '%s' on v2v/in yet; holding",
                          leader_.c_str());
      else if (!fs.leader_fresh)
        ROS_WARN_THROTTLE(5.0, "controller_node: leader '%s' silent for more than %g s; braking", leader_.c_str(),
                          follower_->options().leader_timeout);
    }
    last_command_ = st.command;
    publishCommand(odom->header.stamp, st.command);
    if (target_pub_.getNumSubscribers() > 0)
      publishTarget(odom->header.stamp, st);
  }

  void publishCommand(const ros::Time& stamp, const ac::Command& c)
  {
    if (lockstep_)
    {
      avsp_msgs::DriveCommand cmd;
      cmd.header.stamp = stamp;
      cmd.throttle = c.throttle;
      cmd.brake = c.brake;
      cmd.steering = c.steering;
      drive_pub_.publish(cmd);
      return;
    }
    geometry_msgs::Twist cmd;
    cmd.linear.x = c.throttle;
    cmd.linear.y = -c.brake;  // avt_341's convention: brake in [-1, 0]
    cmd.angular.z = c.steering;
    cmd_pub_.publish(cmd);
  }

  void onV2v(const avsp_msgs::VehicleState::ConstPtr& msg) { addLeaderState(*msg); }

  void addLeaderState(const avsp_msgs::VehicleState& msg)
  {
    if (msg.vehicle_id != leader_)
      return;
    ac::LeaderState s;
    s.stamp = msg.header.stamp.toSec();
    s.x = msg.position.x;
    s.y = msg.position.y;
    s.heading = msg.heading;
    s.speed = msg.speed;
    s.acceleration = msg.acceleration;
    if (!follower_->addLeaderState(s))
      ROS_WARN_THROTTLE(5.0, "controller_node: leader '%s' state with a non-finite field dropped", leader_.c_str());
  }

  void onGap(const std_msgs::Float64::ConstPtr& msg)
  {
    try
    {
      follower_->setGap(msg->data);
      ROS_INFO("controller_node: gap to '%s' now %g m", leader_.c_str(), msg->data);
    }
    catch (const std::invalid_argument& e)
    {
      ROS_WARN_THROTTLE(1.0, "controller_node: formation/gap rejected: %s", e.what());
    }
  }

  void onOffset(const std_msgs::Float64::ConstPtr& msg)
  {
    try
    {
      follower_->setOffset(msg->data);
      ROS_INFO("controller_node: offset from '%s''s path now %g m", leader_.c_str(), msg->data);
    }
    catch (const std::invalid_argument& e)
    {
      ROS_WARN_THROTTLE(1.0, "controller_node: formation/offset rejected: %s", e.what());
    }
  }

  void publishGoal(bool reached)
  {
    std_msgs::Bool b;
    b.data = reached;
    goal_pub_.publish(b);
  }

  void publishWaypointPath()
  {
    nav_msgs::Path path;
    path.header.frame_id = frame_id_;
    path.header.stamp = ros::Time::now();
    for (const ac::Waypoint& w : waypoints_->waypoints())
      path.poses.push_back(poseStamped(frame_id_, w.x, w.y, 0.0));
    path_pub_.publish(path);
  }

  void publishBreadcrumbs()
  {
    if (path_pub_.getNumSubscribers() == 0)
      return;
    nav_msgs::Path path;
    path.header.frame_id = frame_id_;
    path.header.stamp = ros::Time::now();
    const ac::Path& crumbs = follower_->breadcrumbs();
    for (const ac::Vec2& p : crumbs.points())
      path.poses.push_back(poseStamped(frame_id_, p.x, p.y, z_));
    path_pub_.publish(path);
  }

  void publishTarget(const ros::Time& stamp, const ac::TrackingStatus& st)
  {
    visualization_msgs::Marker m;
    m.header.frame_id = frame_id_;
    m.header.stamp = stamp;
    m.ns = "pursuit_target";
    m.id = 0;
    m.type = visualization_msgs::Marker::SPHERE;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.position.x = st.target.x;
    m.pose.position.y = st.target.y;
    m.pose.position.z = z_;
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = m.scale.z = 1.0;
    m.color.r = 1.0f;
    m.color.g = 0.6f;
    m.color.a = 1.0f;
    target_pub_.publish(m);
  }

  std::unique_ptr<ac::WaypointFollower> waypoints_;
  std::unique_ptr<ac::LeaderFollower> follower_;
  std::string leader_;
  std::string frame_id_;
  double period_ = 0.05;
  bool has_step_ = false;
  bool lockstep_ = false;
  ac::Command last_command_{ 0.0, 1.0, 0.0 };         ///< the answer to the odometry of last_step_ (lockstep)
  double batch_through_ = -1e300;                     ///< s, stamp of the last radio batch (lockstep)
  std::deque<nav_msgs::Odometry::ConstPtr> waiting_;  ///< lockstep odometry waiting for its batch
  double last_step_ = 0.0;
  double z_ = 0.0;
  ros::Publisher cmd_pub_, drive_pub_, path_pub_, target_pub_, goal_pub_;
  ros::Subscriber odom_sub_, v2v_sub_, gap_sub_, offset_sub_;
  ros::Timer path_timer_;
};

ControllerNode::ControllerNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

ControllerNode::~ControllerNode() = default;

int ControllerNode::spin()
{
  ros::spin();
  return 0;
}

}  // namespace node
}  // namespace avsp
