#include "avsp_dynamics/ros/conversions.hpp"

#include <cmath>
#include <utility>

namespace avsp
{
namespace dynamics
{
namespace node
{
CommandCheck sanitizeDriveCommand(avsp_msgs::DriveCommand& command, std::string& why)
{
  DriveCommand checked = toDriveCommand(command);
  CommandCheck check = checkCommand(checked, why);
  if (command.gear != avsp_msgs::DriveCommand::GEAR_FORWARD && command.gear != avsp_msgs::DriveCommand::GEAR_REVERSE)
  {
    why += (why.empty() ? "" : "; ") + std::string("gear=") + std::to_string(static_cast<int>(command.gear)) +
           " is neither GEAR_FORWARD (0) nor GEAR_REVERSE (1)";
    check = CommandCheck::kRejected;
  }
  if (check == CommandCheck::kRejected)
    return check;
  command.throttle = checked.throttle;
  command.brake = checked.brake;
  command.steering = checked.steering;
  return check;
}

CommandCheck driveCommandFromTwist(const geometry_msgs::Twist& twist, avsp_msgs::DriveCommand& command,
                                   std::string& why)
{
  avsp_msgs::DriveCommand converted;
  converted.throttle = twist.linear.x;
  // avt_341 sends brake as a negative linear.y; a positive one means the same amount.
  converted.brake = std::isfinite(twist.linear.y) ? std::abs(twist.linear.y) : twist.linear.y;
  converted.steering = twist.angular.z;
  const CommandCheck check = sanitizeDriveCommand(converted, why);
  if (check != CommandCheck::kRejected)
  {
    command = converted;
  }
  return check;
}

DriveCommand toDriveCommand(const avsp_msgs::DriveCommand& command)
{
  return DriveCommand{ command.throttle, command.brake, command.steering,
                       command.gear == avsp_msgs::DriveCommand::GEAR_REVERSE };
}

geometry_msgs::Pose toPose(const Eigen::Isometry3d& pose)
{
  const Eigen::Quaterniond q(pose.linear());
  geometry_msgs::Pose m;
  m.position.x = pose.translation().x();
  m.position.y = pose.translation().y();
  m.position.z = pose.translation().z();
  m.orientation.w = q.w();
  m.orientation.x = q.x();
  m.orientation.y = q.y();
  m.orientation.z = q.z();
  return m;
}

geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v)
{
  geometry_msgs::Vector3 m;
  m.x = v.x();
  m.y = v.y();
  m.z = v.z();
  return m;
}

PartitionExchange exchangeFromMessage(const avsp_msgs::PartitionExchange& msg)
{
  PartitionExchange e;
  e.partition = msg.partition;
  e.time = msg.header.stamp.toSec();
  e.peers_applied = msg.peers_applied.toSec();
  e.vehicles.reserve(msg.vehicles.size());
  for (const avsp_msgs::ProxyVehicle& pv : msg.vehicles)
  {
    ExchangedVehicle v;
    v.name = pv.name;
    v.model = pv.model;
    const geometry_msgs::Pose& p = pv.pose;
    v.position = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
    v.orientation = Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z);
    const geometry_msgs::Twist& t = pv.velocity;
    v.linear_velocity = Eigen::Vector3d(t.linear.x, t.linear.y, t.linear.z);
    v.angular_velocity = Eigen::Vector3d(t.angular.x, t.angular.y, t.angular.z);
    e.vehicles.push_back(std::move(v));
  }
  e.soil_points = msg.soil_points;
  e.soil_before = msg.soil_before;
  e.soil_after = msg.soil_after;
  e.toppled_ids = msg.toppled_ids;
  e.toppled_directions = msg.toppled_directions;
  return e;
}

avsp_msgs::PartitionExchange toMessage(PartitionExchange exchange)
{
  avsp_msgs::PartitionExchange m;
  m.header.stamp = ros::Time(exchange.time);
  m.header.frame_id = "map";
  m.partition = std::move(exchange.partition);
  m.peers_applied = ros::Time(exchange.peers_applied);
  m.vehicles.reserve(exchange.vehicles.size());
  for (ExchangedVehicle& v : exchange.vehicles)
  {
    avsp_msgs::ProxyVehicle pv;
    pv.name = std::move(v.name);
    pv.model = std::move(v.model);
    pv.pose.position.x = v.position.x();
    pv.pose.position.y = v.position.y();
    pv.pose.position.z = v.position.z();
    pv.pose.orientation.w = v.orientation.w();
    pv.pose.orientation.x = v.orientation.x();
    pv.pose.orientation.y = v.orientation.y();
    pv.pose.orientation.z = v.orientation.z();
    pv.velocity.linear = toVector3(v.linear_velocity);
    pv.velocity.angular = toVector3(v.angular_velocity);
    m.vehicles.push_back(std::move(pv));
  }
  m.soil_points = std::move(exchange.soil_points);
  m.soil_before = std::move(exchange.soil_before);
  m.soil_after = std::move(exchange.soil_after);
  m.toppled_ids = std::move(exchange.toppled_ids);
  m.toppled_directions = std::move(exchange.toppled_directions);
  return m;
}

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
