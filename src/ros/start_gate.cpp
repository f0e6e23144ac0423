// start_gate's class (the node's main is ../start_gate.cpp): holds a scenario's physics until
// every node of the run is up. dynamics_node runs with ~start_topic = this node's ~open (physics
// starts when a message arrives there; until their first commands the vehicles stand braked);
// this node waits until each node in ~nodes has advertised or subscribed a topic other than
// /rosout and /clock (they do so after loading their parameters and terrain; a node that only
// ever uses /clock gets ~grace s once registered), then publishes one latched std_msgs/Empty on
// ~open, waits for /clock to move and exits. It publishes nothing in a vehicle's namespace:
// <v>/avt_341/cmd_vel belongs to whatever drives the vehicle (the AVT-341 stack's control node,
// or controller_node standing in for it). So sensors, controllers and the recorder all see the run from sim time 0,
// however long their start-up took. Before the commands it also waits (up to ~connect_timeout)
// until every publisher holds a connection to every subscriber the master lists, on every topic:
// a subscriber registered at the master may still be forming its connection, and a message sent
// before it stands is lost. Most are sent once: the radio's /clock, a V2V broadcast, a lockstep
// batch; losing one deadlocks a lockstep run (the radio once missed the first /clock ticks and
// the run stopped at its barrier at 0.05 s), and at real-time factor 0 run_recorder would miss
// the first samples.
#include "avsp/ros/start_gate.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/ros_graph.hpp>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <std_msgs/Empty.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace avsp
{
namespace node
{
namespace
{
std::vector<std::string> stringList(const ros::NodeHandle& pnh, const std::string& name)
{
  XmlRpc::XmlRpcValue v;
  std::vector<std::string> out;
  if (!avsp::node::structuredParam(pnh, name, v) || v.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw std::runtime_error("parameter ~" + name + ": required, a list of names");
  for (int i = 0; i < v.size(); ++i)
  {
    if (v[i].getType() != XmlRpc::XmlRpcValue::TypeString)
      throw std::runtime_error("parameter ~" + name + "[" + std::to_string(i) + "]: must be a string");
    out.push_back(static_cast<std::string>(v[i]));
  }
  return out;
}

/// Nodes that have a publication or subscription other than /rosout and /clock (`out`), and
/// all nodes with any (`registered`).
bool activeNodes(std::set<std::string>& out, std::set<std::string>& registered)
{
  RosGraph graph;
  if (!readRosGraph(graph))
    return false;
  for (const TopicNodes* side : { &graph.publishers, &graph.subscribers })
    for (const auto& [topic, nodes] : *side)
    {
      registered.insert(nodes.begin(), nodes.end());
      if (topic != "/rosout" && topic != "/clock")
        out.insert(nodes.begin(), nodes.end());
    }
  return true;
}

/// Outgoing connections `node`'s publishers hold, per topic (its getBusInfo); false when the
/// node cannot be asked (not registered any more, or an answer we do not understand).
bool outgoingConnections(const std::string& node, std::map<std::string, int>& per_topic)
{
  XmlRpc::XmlRpcValue connections;
  if (!readBusInfo(node, connections) || connections.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return false;
  for (int k = 0; k < connections.size(); ++k)
  {
    XmlRpc::XmlRpcValue& c = connections[k];
    if (c.getType() != XmlRpc::XmlRpcValue::TypeArray || c.size() < 5 ||
        c[2].getType() != XmlRpc::XmlRpcValue::TypeString || c[4].getType() != XmlRpc::XmlRpcValue::TypeString)
      continue;
    const bool connected =
        c.size() < 6 || c[5].getType() != XmlRpc::XmlRpcValue::TypeBoolean || static_cast<bool>(c[5]);
    if (static_cast<std::string>(c[2]) == "o" && connected)
      ++per_topic[static_cast<std::string>(c[4])];
  }
  return true;
}

/// Topics whose publishers do not yet hold a connection to every subscriber the master lists
/// (a node subscribed to its own topic needs none), all topics but /rosout and /rosout_agg;
/// empty when all are connected. A publisher whose connections cannot be read counts as
/// connected. Each publishing node is asked once per call.
std::vector<std::string> unconnected()
{
  RosGraph graph;
  if (!readRosGraph(graph))
    return {};
  TopicNodes& publishers = graph.publishers;
  TopicNodes& subscribers = graph.subscribers;
  std::map<std::string, std::map<std::string, int>> bus;  // publishing node -> topic -> connections
  std::set<std::string> unreadable;
  std::vector<std::string> out;
  for (const auto& [topic, pubs] : publishers)
  {
    if (topic == "/rosout" || topic == "/rosout_agg")
      continue;
    const std::set<std::string>& subs = subscribers[topic];
    for (const std::string& p : pubs)
    {
      const std::size_t need = subs.size() - subs.count(p);
      if (need == 0 || unreadable.count(p))
        continue;
      auto it = bus.find(p);
      if (it == bus.end())
      {
        std::map<std::string, int> per_topic;
        if (!outgoingConnections(p, per_topic))
        {
          unreadable.insert(p);
          continue;
        }
        it = bus.emplace(p, std::move(per_topic)).first;
      }
      const auto have = it->second.find(topic);
      if (have == it->second.end() || static_cast<std::size_t>(have->second) < need)
      {
        out.push_back(topic);
        break;
      }
    }
  }
  return out;
}
}  // namespace

StartGate::StartGate(ros::NodeHandle& nh, ros::NodeHandle& pnh) : nh_(nh), pnh_(pnh)
{
  nodes_ = stringList(pnh, "nodes");
  timeout_ = avsp::node::boundedParam(pnh, "timeout", 300.0, 1e-3, 1e6);
  grace_ = avsp::node::boundedParam(pnh, "grace", 10.0, 0.0, 1e6);
  connect_timeout_ = avsp::node::boundedParam(pnh, "connect_timeout", 10.0, 0.0, 1e6);
}

int StartGate::spin()
{
  const ros::WallTime start = ros::WallTime::now();
  if (!waitForNodes(start))
    return 1;
  if (!ros::ok())
    return 0;
  waitForConnections();
  if (!ros::ok())
    return 0;
  ROS_INFO("start_gate: all %zu nodes up and connected after %.1f s (wall); starting the physics", nodes_.size(),
           (ros::WallTime::now() - start).toSec());
  release();
  return 0;
}

bool StartGate::waitForNodes(const ros::WallTime& start) const
{
  std::set<std::string> missing(nodes_.begin(), nodes_.end());
  ros::WallTime only_registered;  // since when every missing node has registered (zero: not yet)
  while (ros::ok() && !missing.empty())
  {
    std::set<std::string> active, registered;
    if (activeNodes(active, registered))
      for (const std::string& n : active)
        missing.erase(n);
    if (missing.empty())
      break;
    // A node that needs only /clock never shows more: once every missing node has registered,
    // it gets ~grace s of wall time to show more, then the physics starts anyway.
    const bool all_registered = std::all_of(missing.begin(), missing.end(),
                                            [&registered](const std::string& n) { return registered.count(n) > 0; });
    if (!all_registered)
      only_registered = ros::WallTime();
    else if (only_registered.isZero())
      only_registered = ros::WallTime::now();
    else if ((ros::WallTime::now() - only_registered).toSec() > grace_)
    {
      std::string list;
      for (const std::string& n : missing)
        list += " " + n;
      ROS_WARN("start_gate: going on after %.0f s (wall) with nodes that use only /clock:%s", grace_, list.c_str());
      break;
    }
    if ((ros::WallTime::now() - start).toSec() > timeout_)
    {
      std::string list;
      for (const std::string& n : missing)
        list += " " + n;
      ROS_FATAL("start_gate: after %.0f s (wall) still not up:%s", timeout_, list.c_str());
      return false;
    }
    ros::WallDuration(0.1).sleep();
  }
  return true;
}

void StartGate::waitForConnections() const
{
  const ros::WallTime connecting = ros::WallTime::now();
  for (std::vector<std::string> left = unconnected(); !left.empty() && ros::ok(); left = unconnected())
  {
    if ((ros::WallTime::now() - connecting).toSec() > connect_timeout_)
    {
      std::string list;
      for (const std::string& t : left)
        list += " " + t;
      ROS_WARN("start_gate: going on after %.0f s (wall) with subscribers not yet connected on:%s", connect_timeout_,
               list.c_str());
      break;
    }
    ros::WallDuration(0.05).sleep();
  }
}

void StartGate::release()
{
  ros::Publisher open = pnh_.advertise<std_msgs::Empty>("open", 1, true);
  open.publish(std_msgs::Empty());
  // Stay (latched) until the clock moves: then every dynamics_node has taken the signal.
  bool moved = false;
  ros::Subscriber clock = nh_.subscribe<rosgraph_msgs::Clock>(
      "/clock", 10, [&moved](const rosgraph_msgs::Clock::ConstPtr& c) { moved |= !c->clock.isZero(); });
  const ros::WallTime released = ros::WallTime::now();
  while (ros::ok() && !moved && (ros::WallTime::now() - released).toSec() < timeout_)
  {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  if (!moved)
    ROS_WARN("start_gate: /clock did not move after the gate opened");
}

}  // namespace node
}  // namespace avsp
