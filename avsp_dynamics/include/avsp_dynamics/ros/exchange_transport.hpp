#pragma once
/**
 * @file exchange_transport.hpp
 * @brief The partitions' exchanges over ROS: this partition's on /lockstep/exchange/<partition>
 *        (latched, so a peer that connects late still gets the first), each peer's from
 *        /lockstep/exchange/<peer>, TCP without Nagle's delay (the lockstep's round trip).
 */
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <ros/publisher.h>
#include <ros/subscriber.h>

#include "avsp_dynamics/partition_runner.hpp"

namespace avsp
{
namespace dynamics
{
namespace node
{
/// PartitionRunner's exchanges over ROS topics; the peers' arrive through `Deliver`.
class RosExchangeTransport : public ExchangeTransport
{
public:
  /// Called from the subscriber's callback with each peer's exchange as it arrives.
  using Deliver = std::function<void(const std::string& peer, PartitionExchange exchange)>;

  /// Advertises this partition's topic and subscribes to every peer's.
  RosExchangeTransport(ros::NodeHandle& nh, const std::string& partition, const std::vector<std::string>& peers,
                       Deliver deliver);

  void send(PartitionExchange exchange) override;
  /// The peer's topic, /lockstep/exchange/<peer>.
  std::string source(const std::string& peer) const override;

  /// Subscribers to this partition's topic (peers, and any other listener: a test, rostopic).
  std::uint32_t subscriberCount() const { return publisher_.getNumSubscribers(); }
  /// The peers no publisher of whose topic is connected yet.
  std::vector<std::string> unconnectedPeers() const;

private:
  ros::Publisher publisher_;
  std::map<std::string, ros::Subscriber> subscribers_;  ///< by peer
};

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
