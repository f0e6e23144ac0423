#include "avsp_dynamics/ros/exchange_transport.hpp"

#include <utility>

#include <avsp_msgs/PartitionExchange.h>
#include <ros/transport_hints.h>

#include "avsp_dynamics/ros/conversions.hpp"

namespace avsp
{
namespace dynamics
{
namespace node
{
namespace
{
const std::string kTopicPrefix = "/lockstep/exchange/";
}

RosExchangeTransport::RosExchangeTransport(ros::NodeHandle& nh, const std::string& partition,
                                           const std::vector<std::string>& peers, Deliver deliver)
{
  // Latched: a peer that connects after our exchange of t = 0 still gets it. Until every
  // exchange of 0 is in nobody steps, so the latched one is all a late peer can have missed.
  publisher_ = nh.advertise<avsp_msgs::PartitionExchange>(kTopicPrefix + partition, 100, true);
  for (const std::string& peer : peers)
    subscribers_[peer] = nh.subscribe<avsp_msgs::PartitionExchange>(
        kTopicPrefix + peer, 100,
        [deliver, peer](const avsp_msgs::PartitionExchange::ConstPtr& m) { deliver(peer, exchangeFromMessage(*m)); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
}

void RosExchangeTransport::send(PartitionExchange exchange)
{
  publisher_.publish(toMessage(std::move(exchange)));
}

std::string RosExchangeTransport::source(const std::string& peer) const
{
  return kTopicPrefix + peer;
}

std::vector<std::string> RosExchangeTransport::unconnectedPeers() const
{
  std::vector<std::string> out;
  for (const auto& [peer, sub] : subscribers_)
    if (sub.getNumPublishers() == 0)
      out.push_back(peer);
  return out;
}

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
