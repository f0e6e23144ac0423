#pragma once
/**
 * @file v2v_broadcaster.hpp
 * @brief v2v_broadcaster as a class (README.md, "V2V broadcaster"): a vehicle's V2V
 *        transmitter in its namespace, its avt_341/odometry as the avsp_msgs/VehicleState it
 *        broadcasts on v2v/out at ~rate (sim time).
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
class V2vBroadcaster
{
public:
  /**
   * @brief Reads the parameters, subscribes, advertises.
   * @throw avsp::node::StartupError naming the parameter
   */
  V2vBroadcaster(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~V2vBroadcaster();
  V2vBroadcaster(const V2vBroadcaster&) = delete;
  V2vBroadcaster& operator=(const V2vBroadcaster&) = delete;

  /// Until shutdown (ros::spin()). @return 0
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace avsp
