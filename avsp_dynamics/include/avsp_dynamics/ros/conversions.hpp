#pragma once
/**
 * @file conversions.hpp
 * @brief avsp_dynamics' conversions between ROS messages and the core's types, as plain
 *        functions: avt_341 `cmd_vel` twists and DriveCommands in, checked by the core's one
 *        command rule (checkCommand(), drivetrain.hpp); poses and vectors out; the partitions'
 *        exchanges both ways.
 */
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <avsp_msgs/DriveCommand.h>
#include <avsp_msgs/PartitionExchange.h>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/Vector3.h>

#include "avsp_dynamics/drivetrain.hpp"
#include "avsp_dynamics/partition_runner.hpp"

namespace avsp
{
namespace dynamics
{
namespace node
{
/**
 * @brief Checks a DriveCommand message: the fields by checkCommand() (NaN/inf rejected, throttle
 *        and brake clamped to [0, 1], steering to [-1, 1]), and the gear, which must be
 *        GEAR_FORWARD or GEAR_REVERSE (an unknown gear is not clamped to either: driving the
 *        wrong way is worse than not at all).
 * @param[in,out] command the command; left unchanged when rejected
 * @param[out] why names the offending field(s) and value(s) when not accepted, empty otherwise
 * @return kRejected for a NaN/inf field or an unknown gear, kClamped if a field was out of range
 */
CommandCheck sanitizeDriveCommand(avsp_msgs::DriveCommand& command, std::string& why);

/**
 * @brief Converts an avt_341 `cmd_vel` twist to a DriveCommand (not yet stamped).
 *
 * linear.x is throttle; linear.y is brake, which avt_341 sends in [-1, 0] (brake =
 * |linear.y|, so [0, 1] is accepted too); angular.z is steering, + = left. Other twist
 * fields are ignored. The result is sanitised as by sanitizeDriveCommand().
 * @param[in] twist the received twist
 * @param[out] command the converted command; valid unless kRejected is returned
 * @param[out] why names the offending field(s) when not accepted
 */
CommandCheck driveCommandFromTwist(const geometry_msgs::Twist& twist, avsp_msgs::DriveCommand& command,
                                   std::string& why);

/// The core's command of a sanitised message (GEAR_REVERSE: reverse).
DriveCommand toDriveCommand(const avsp_msgs::DriveCommand& command);

/// A pose message of an isometry (the quaternion of its rotation, w >= 0 not enforced).
geometry_msgs::Pose toPose(const Eigen::Isometry3d& pose);
geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v);

/**
 * @brief A partition's exchange as the core holds it, field for field: the stamp and
 *        peers_applied as seconds, each proxy's pose as position and quaternion (not checked
 *        here: PartitionRunner::receive() and prepare() refuse a bad exchange naming what).
 */
PartitionExchange exchangeFromMessage(const avsp_msgs::PartitionExchange& msg);

/// The message of a core exchange (its arrays moved in), stamped at its time, frame "map".
avsp_msgs::PartitionExchange toMessage(PartitionExchange exchange);

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
