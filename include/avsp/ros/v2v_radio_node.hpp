#pragma once
/**
 * @file v2v_radio_node.hpp
 * @brief v2v_radio_node as a class (README.md, "V2V radio node"): each listed vehicle's
 *        <v>/v2v/out reaches the others' <v>/v2v/in when the radio model (range, latency, loss,
 *        line of sight over the terrain) lets it; with ~lockstep_period, batches on
 *        <v>/v2v/in_lockstep at every period of sim time.
 */
#include <memory>

#include <ros/node_handle.h>

namespace avsp
{
namespace node
{
class V2vRadioNode
{
public:
  /**
   * @brief Reads the parameters (vehicles, radio model, terrain for the line of sight),
   *        subscribes, advertises.
   * @throw avsp::node::StartupError naming the parameter
   */
  V2vRadioNode(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  ~V2vRadioNode();
  V2vRadioNode(const V2vRadioNode&) = delete;
  V2vRadioNode& operator=(const V2vRadioNode&) = delete;

  /// Until shutdown (ros::spin()). @return 0
  int spin();

private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace node
}  // namespace avsp
