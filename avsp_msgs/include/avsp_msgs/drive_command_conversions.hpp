#pragma once
/**
 * @file drive_command_conversions.hpp
 * @brief Turns avt_341 `cmd_vel` twists and raw DriveCommands into commands the physics can
 *        use: finite, in range, with the brake sign convention resolved.
 */
#include <string>

#include <avsp_msgs/DriveCommand.h>
#include <geometry_msgs/Twist.h>

namespace avsp
{
namespace msgs
{
/// Outcome of sanitising a command.
enum class CommandCheck
{
  kAccepted,  ///< every field was finite and in range
  kClamped,   ///< some field was out of range and was clamped; `why` says which
  kRejected   ///< some field was NaN or infinite, or the gear unknown; the command must not be used
};

/**
 * @brief Clamps a DriveCommand into throttle [0,1], brake [0,1], steering [-1,1].
 * @param[in,out] command the command; left unchanged when rejected
 * @param[out] why names the offending field(s) and value(s) when not accepted
 * @return kRejected if any field is NaN/inf or the gear is neither GEAR_FORWARD nor GEAR_REVERSE,
 *         kClamped if any was out of range
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

}  // namespace msgs
}  // namespace avsp
