#pragma once
/**
 * @file ros_graph.hpp
 * @brief The ROS graph as the start gate and the rostests see it: who publishes and subscribes
 *        what (the master's getSystemState), a node's connections (its getBusInfo), and whether
 *        a node's subscriptions are connected to every publisher. A test that must not lose the
 *        first messages of a run waits for the connections themselves instead of sleeping and
 *        hoping; start_gate opens only once every topic is connected.
 */
#include <map>
#include <set>
#include <string>

#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcClient.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace avsp
{
namespace node
{
/// Topic -> the nodes (full names) on one side of it.
using TopicNodes = std::map<std::string, std::set<std::string>>;

/// The master's graph: publishers and subscribers by topic.
struct RosGraph
{
  TopicNodes publishers;
  TopicNodes subscribers;

  /// Whether any node publishes `topic`.
  bool published(const std::string& topic) const
  {
    const auto it = publishers.find(topic);
    return it != publishers.end() && !it->second.empty();
  }
  /// Whether any node subscribes `topic`.
  bool subscribed(const std::string& topic) const
  {
    const auto it = subscribers.find(topic);
    return it != subscribers.end() && !it->second.empty();
  }
  /// Whether `node` subscribes `topic`.
  bool subscribes(const std::string& node, const std::string& topic) const
  {
    const auto it = subscribers.find(topic);
    return it != subscribers.end() && it->second.count(node) > 0;
  }
};

/**
 * @brief Reads the graph from the master (getSystemState).
 * @return false if the master did not answer
 */
inline bool readRosGraph(RosGraph& graph)
{
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", args, result, payload, false) ||
      payload.getType() != XmlRpc::XmlRpcValue::TypeArray || payload.size() < 2)
    return false;
  graph = RosGraph{};
  for (int kind = 0; kind < 2; ++kind)
  {
    TopicNodes& out = kind == 0 ? graph.publishers : graph.subscribers;
    for (int t = 0; t < payload[kind].size(); ++t)
    {
      std::set<std::string>& nodes = out[static_cast<std::string>(payload[kind][t][0])];
      for (int n = 0; n < payload[kind][t][1].size(); ++n)
        nodes.insert(static_cast<std::string>(payload[kind][t][1][n]));
    }
  }
  return true;
}

/**
 * @brief The connections of `node` (a full name) from the node itself: getBusInfo through its
 *        XML-RPC server (roscpp answers from its own thread, so a test may ask about itself).
 *        Each entry: [id, other end, direction "i"/"o", transport, topic, connected, ...].
 * @return false if the master or the node did not answer
 */
inline bool readBusInfo(const std::string& node, XmlRpc::XmlRpcValue& connections)
{
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, false))
    return false;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(static_cast<std::string>(payload), host, port))
    return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue caller, bus;
  caller[0] = ros::this_node::getName();
  if (!client.execute("getBusInfo", caller, bus) || bus.getType() != XmlRpc::XmlRpcValue::TypeArray || bus.size() < 3 ||
      static_cast<int>(bus[0]) != 1)
    return false;
  connections = bus[2];
  return true;
}

/**
 * @brief Whether each node the master lists as publishing a topic that `node` subscribes has
 *        taken `node` among its subscribers (an outbound connection to it: the publisher adds it
 *        once the connection header is in, from then on every message reaches `node`).
 * @return false while any connection is missing, or if the master or a publisher did not answer
 */
inline bool subscriptionsConnected(const std::string& node)
{
  RosGraph graph;
  if (!readRosGraph(graph))
    return false;
  std::map<std::string, std::set<std::string>> served;  // publisher -> topics it sends to `node`
  std::set<std::string> asked;
  for (const auto& [topic, subscribers] : graph.subscribers)
  {
    if (subscribers.count(node) == 0 || graph.publishers.count(topic) == 0)
      continue;
    for (const std::string& publisher : graph.publishers.at(topic))
    {
      if (asked.insert(publisher).second)
      {
        XmlRpc::XmlRpcValue connections;
        if (!readBusInfo(publisher, connections))
          return false;
        for (int k = 0; k < connections.size(); ++k)
        {
          XmlRpc::XmlRpcValue& c = connections[k];
          if (c.size() >= 6 && static_cast<std::string>(c[2]) == "o" && static_cast<std::string>(c[1]) == node &&
              static_cast<bool>(c[5]))
            served[publisher].insert(static_cast<std::string>(c[4]));
        }
      }
      if (served[publisher].count(topic) == 0)
        return false;
    }
  }
  return true;
}

}  // namespace node
}  // namespace avsp
