#include "avsp_msgs/drive_command_conversions.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace avsp
{
namespace msgs
{
namespace
{
// Checks one field; appends to `why` when it is non-finite or outside [lo, hi].
void checkField(const char* name, double value, double lo, double hi, bool& non_finite, bool& clamped,
                std::ostringstream& why)
{
  if (!std::isfinite(value))
  {
    non_finite = true;
    why << (why.tellp() > 0 ? "; " : "") << name << " is " << value;
  }
  else if (value < lo || value > hi)
  {
    clamped = true;
    why << (why.tellp() > 0 ? "; " : "") << name << "=" << value << " outside [" << lo << ", " << hi << "]";
  }
}
}  // namespace

CommandCheck sanitizeDriveCommand(avsp_msgs::DriveCommand& command, std::string& why)
{
  bool non_finite = false;
  bool clamped = false;
  std::ostringstream reasons;
  checkField("throttle", command.throttle, 0.0, 1.0, non_finite, clamped, reasons);
  checkField("brake", command.brake, 0.0, 1.0, non_finite, clamped, reasons);
  checkField("steering", command.steering, -1.0, 1.0, non_finite, clamped, reasons);
  // An unknown gear is not clamped to either: driving the wrong way is worse than not at all.
  const bool bad_gear = command.gear != avsp_msgs::DriveCommand::GEAR_FORWARD &&
                        command.gear != avsp_msgs::DriveCommand::GEAR_REVERSE;
  if (bad_gear)
    reasons << (reasons.tellp() > 0 ? "; " : "") << "gear=" << static_cast<int>(command.gear)
            << " is neither GEAR_FORWARD (0) nor GEAR_REVERSE (1)";
  why = reasons.str();
  if (non_finite || bad_gear)
  {
    return CommandCheck::kRejected;
  }
  command.throttle = std::clamp(command.throttle, 0.0, 1.0);
  command.brake = std::clamp(command.brake, 0.0, 1.0);
  command.steering = std::clamp(command.steering, -1.0, 1.0);
  return clamped ? CommandCheck::kClamped : CommandCheck::kAccepted;
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

}  // namespace msgs
}  // namespace avsp
