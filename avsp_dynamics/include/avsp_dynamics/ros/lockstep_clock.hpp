#pragma once
/**
 * @file lockstep_clock.hpp
 * @brief lockstep_clock as a class (avsp_dynamics/README.md, "lockstep_clock"): the clock of a
 *        partitioned run. It publishes /clock and advances it by ~sync_interval only when every
 *        partition in ~partitions has reported the current time done on /lockstep/done (the rule:
 *        LockstepBarrier); a partition silent for ~timeout (wall) stops the run naming it.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace dynamics
{
namespace node
{
class LockstepClock
{
public:
  /**
   * @brief Reads the parameters, advertises /clock, subscribes to /lockstep/done.
   * @throw avsp::node::StartupError naming the parameter
   */
  LockstepClock(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~LockstepClock();
  LockstepClock(const LockstepClock&) = delete;
  LockstepClock& operator=(const LockstepClock&) = delete;

  /// Runs until shutdown or ~duration. @return 0, or 1 after a partition timed out
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
