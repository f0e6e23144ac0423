// agents_node's class (the node's main is ../agents_node.cpp): the dynamic agents (deer,
// pedestrians, trucks) for everybody who is not a sensor or the physics: TF <frame> ->
// agents/<name>, /agents/markers for RViz and /agents/states for external consumers, at ~rate on
// sim time.
//
// Thin: an agent's motion is avsp_terrain's Agent::state(t), a pure function of sim time; the
// same ~agents list given to sensors_node and dynamics_node makes them see and collide with the
// agents exactly where this node says they are, with no message between them. Parameters and
// topics: README.md, "Agents node".
#include "avsp/ros/agents_node.hpp"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <avsp_msgs/AgentStateArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/callback_queue.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/agent_params.hpp>
#include <avsp_terrain/soil.hpp>
#include <avsp_terrain/ros/terrain_source_params.hpp>

namespace avsp
{
namespace node
{
namespace at = avsp::terrain;

namespace
{

/// RGBA of each type's markers: deer brown, pedestrians orange (high-visibility), trucks grey-blue.
std_msgs::ColorRGBA colour(at::AgentType type)
{
  std_msgs::ColorRGBA c;
  c.a = 1.0f;
  switch (type)
  {
    case at::AgentType::kDeer:
      c.r = 0.55f, c.g = 0.35f, c.b = 0.17f;
      break;
    case at::AgentType::kPedestrian:
      c.r = 1.0f, c.g = 0.5f, c.b = 0.0f;
      break;
    case at::AgentType::kTruck:
      c.r = 0.35f, c.g = 0.45f, c.b = 0.6f;
      break;
  }
  return c;
}

geometry_msgs::Quaternion yawQuaternion(double yaw)
{
  geometry_msgs::Quaternion q;
  q.w = std::cos(0.5 * yaw);
  q.z = std::sin(0.5 * yaw);
  return q;
}

}  // namespace

class AgentsNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh)
  {
    rate_ = boundedParam(pnh, "rate", 20.0, 0.1, 1000.0);
    frame_ = avsp::node::stringParam(pnh, "frame", "map");
    if (frame_.empty())
      throw StartupError("parameter ~frame must not be empty");
    const std::string soils_file =
        avsp::node::stringParam(pnh, "soils_file", ros::package::getPath("avsp") + "/config/soils.yaml");
    std::unique_ptr<at::SoilLibrary> soils;
    try
    {
      soils = std::make_unique<at::SoilLibrary>(at::SoilLibrary::load(soils_file));
    }
    catch (const std::exception& e)
    {
      throw StartupError("parameter ~soils_file: " + std::string(e.what()));
    }
    // The ground only gives the agents their heights; it is dropped once they have them.
    const at::LoadedSource loaded = at::node::loadTerrainFromParams(pnh, *soils);
    agents_ = at::node::agentsFromParams(pnh, loaded.terrain->base());
    markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("/agents/markers", 2);
    states_pub_ = nh.advertise<avsp_msgs::AgentStateArray>("/agents/states", 10);
    ROS_INFO("agents_node: %zu agent(s) on %s, frame '%s', %g Hz", agents_.size(), loaded.description.c_str(),
             frame_.c_str(), rate_);
  }

  /// Publishes every grid time k / rate (sim time) up to now that was not published yet, so the
  /// stamps and the set of publications do not depend on how the clock's steps fall between
  /// polls (a clock that jumps far ahead: only the last kMaxCatchUp grid times, warned).
  void update()
  {
    const ros::Time now = ros::Time::now();
    if (now.isZero())
      return;  // no /clock yet
    const long k = static_cast<long>(std::floor(now.toSec() * rate_ + 1e-9));
    long first = published_ ? last_k_ + 1 : k;
    if (k - first >= kMaxCatchUp)
    {
      ROS_WARN_THROTTLE(5.0, "agents_node: the clock jumped %ld periods ahead; publishing the last %ld", k - first + 1,
                        kMaxCatchUp);
      first = k - kMaxCatchUp + 1;
    }
    for (long j = first; j <= k; ++j)
      publish(static_cast<double>(j) / rate_);
    if (first <= k)
    {
      published_ = true;
      last_k_ = k;
    }
  }

private:
  void publish(double t)
  {
    ros::Time stamp;
    stamp.fromSec(t);
    avsp_msgs::AgentStateArray states;
    states.header.stamp = stamp;
    states.header.frame_id = frame_;
    visualization_msgs::MarkerArray markers;
    std::vector<geometry_msgs::TransformStamped> frames;
    for (const at::Agent& agent : agents_)
    {
      const at::AgentSpec& spec = agent.spec();
      const at::AgentState s = agent.state(t);
      geometry_msgs::Pose pose;
      pose.position.x = s.position.x();
      pose.position.y = s.position.y();
      pose.position.z = s.position.z();
      pose.orientation = yawQuaternion(s.yaw);

      avsp_msgs::AgentState m;
      m.name = spec.name;
      m.type = at::toString(spec.type);
      m.pose = pose;
      m.twist.linear.x = s.velocity.x();
      m.twist.linear.y = s.velocity.y();
      m.twist.linear.z = s.velocity.z();
      m.twist.angular.z = s.yaw_rate;
      const Eigen::Vector3d size = at::agentSize(spec.type), centre = at::agentBoundsCentre(spec.type);
      m.size.x = size.x();
      m.size.y = size.y();
      m.size.z = size.z();
      m.size_centre.x = centre.x();
      m.size_centre.y = centre.y();
      m.size_centre.z = centre.z();
      m.moving = s.moving;
      states.agents.push_back(m);

      geometry_msgs::TransformStamped tf;
      tf.header = states.header;
      tf.child_frame_id = "agents/" + spec.name;
      tf.transform.translation.x = pose.position.x;
      tf.transform.translation.y = pose.position.y;
      tf.transform.translation.z = pose.position.z;
      tf.transform.rotation = pose.orientation;
      frames.push_back(tf);

      // The body's boxes, in the agent's own frame (RViz places them through TF), and its name.
      const std::vector<at::AgentBox>& boxes = at::agentBoxes(spec.type);
      for (std::size_t b = 0; b < boxes.size(); ++b)
      {
        visualization_msgs::Marker box;
        box.header.stamp = stamp;
        box.header.frame_id = tf.child_frame_id;
        box.ns = spec.name;
        box.id = static_cast<int>(b);
        box.type = visualization_msgs::Marker::CUBE;
        box.action = visualization_msgs::Marker::ADD;
        box.pose.position.x = boxes[b].centre.x();
        box.pose.position.y = boxes[b].centre.y();
        box.pose.position.z = boxes[b].centre.z();
        box.pose.orientation.w = 1.0;
        box.scale.x = boxes[b].size.x();
        box.scale.y = boxes[b].size.y();
        box.scale.z = boxes[b].size.z();
        box.color = colour(spec.type);
        box.frame_locked = true;
        markers.markers.push_back(box);
      }
      visualization_msgs::Marker label;
      label.header.stamp = stamp;
      label.header.frame_id = tf.child_frame_id;
      label.ns = spec.name;
      label.id = static_cast<int>(boxes.size());
      label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
      label.action = visualization_msgs::Marker::ADD;
      label.pose.position.z = size.z() + 0.5;
      label.pose.orientation.w = 1.0;
      label.scale.z = 0.6;
      label.color.r = label.color.g = label.color.b = label.color.a = 1.0f;
      label.text = spec.name;
      label.frame_locked = true;
      markers.markers.push_back(label);
    }
    if (!frames.empty())
      broadcaster_.sendTransform(frames);
    states_pub_.publish(states);
    markers_pub_.publish(markers);
  }

  static constexpr long kMaxCatchUp = 100;
  double rate_ = 20.0;
  std::string frame_ = "map";
  std::vector<at::Agent> agents_;
  ros::Publisher markers_pub_, states_pub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  bool published_ = false;
  long last_k_ = 0;
};

AgentsNode::AgentsNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

AgentsNode::~AgentsNode() = default;

void AgentsNode::update()
{
  impl_->update();
}

int AgentsNode::spin()
{
  // Polls the clock rather than a ros::Timer: a timer's expected times count from its creation,
  // not from 0, and a fast simulated clock would queue one callback per missed period.
  ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
  while (ros::ok())
  {
    queue->callAvailable(ros::WallDuration(0.002));
    impl_->update();
  }
  return 0;
}

}  // namespace node
}  // namespace avsp
