#pragma once
/**
 * @file spin_until.hpp
 * @brief The rostests' wait: run the global callback queue until a condition holds, bounded by
 *        wall time (the tests drive or follow sim time; the bound only ends a test that would
 *        otherwise hang). One definition for every package's rostests.
 */
#include <functional>

#include <ros/ros.h>

namespace avsp
{
namespace node
{
/**
 * @brief Calls ros::spinOnce() every `poll` wall seconds until `done()` holds, ros::ok() fails
 *        or `timeout` wall seconds pass.
 * @return done() at the end
 */
inline bool spinUntil(const std::function<bool()>& done, double timeout = 60.0, double poll = 0.001)
{
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && !done())
  {
    if (ros::WallTime::now() > deadline)
      return false;
    ros::spinOnce();
    ros::WallDuration(poll).sleep();
  }
  return done();
}

}  // namespace node
}  // namespace avsp
