// v2v_radio_node's class (the node's main is ../v2v_radio_node.cpp): the simulated V2V radio.
// Each listed vehicle's <v>/v2v/out (avsp_msgs/VehicleState) reaches the other vehicles'
// <v>/v2v/in when the radio model (include/avsp/v2v/radio.hpp: range, latency, loss, terrain
// line of sight, seed) lets it; v2v/fleet_markers shows the fleet and its links in RViz. This
// file only converts parameters and messages.
//
// Lockstep (~lockstep_period > 0): the broadcasts are taken in (stamp, sender) order once
// every sender's stream has reached a time (its broadcasts come in order, on a known grid of
// 1 / ~broadcast_rate), and at every multiple t_k of the period each vehicle gets on
// v2v/in_lockstep everything due in (t_{k-1}, t_k], empty or not. A lockstep controller waits
// for that batch, so what it knows at t_k does not depend on how the processes ran.
#include "avsp/ros/v2v_radio_node.hpp"

#include <algorithm>
#include <deque>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include <avsp_msgs/VehicleState.h>
#include <avsp_msgs/VehicleStateArray.h>
#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/terrain_source_params.hpp>
#include <ros/package.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <visualization_msgs/MarkerArray.h>

#include "avsp/v2v/radio.hpp"

namespace avsp
{
namespace node
{
namespace
{
namespace av = avsp::v2v;
namespace at = avsp::terrain;

/// ~vehicles: names, or {name: ...} dictionaries (the dynamics node's vehicle list works as is).
std::vector<std::string> vehiclesFromParams(const ros::NodeHandle& pnh)
{
  std::vector<std::string> names;
  for (const avsp::node::VehicleListEntry& e :
       avsp::node::vehicleListParam(pnh, false, {}, "vehicle names (or of {name: ...})"))
    names.push_back(e.name);
  return names;
}

std_msgs::ColorRGBA colour(float r, float g, float b, float a)
{
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

geometry_msgs::Point point(const av::Vec3& v)
{
  geometry_msgs::Point p;
  p.x = v.x;
  p.y = v.y;
  p.z = v.z;
  return p;
}

}  // namespace

class V2vRadioNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh)
  {
    const std::vector<std::string> vehicles = vehiclesFromParams(pnh);
    av::RadioOptions options;
    for (const av::RadioNumber& n : av::radioNumbers())
      options.*n.member = boundedParam(pnh, n.key, options.*n.member, n.min, n.max);
    options.seed = static_cast<std::uint64_t>(avsp::node::runIntParam(pnh, avsp::terrain::kRunSeed));
    options.line_of_sight = avsp::node::boolParam(pnh, "line_of_sight", false);
    const double marker_rate = boundedParam(pnh, "marker_rate", 2.0, 0.0, 100.0);
    const double update_rate = boundedParam(pnh, "update_rate", 100.0, 1.0, 10000.0);
    frame_id_ = avsp::node::stringParam(pnh, "frame_id", "map");
    lockstep_period_ = boundedParam(pnh, "lockstep_period", 0.0, 0.0, 10.0);
    broadcast_period_ = 1.0 / boundedParam(pnh, "broadcast_rate", 10.0, 0.1, 1000.0);
    latency_ = options.latency;

    av::HeightFunction height;
    std::string terrain_description = "none (line_of_sight false)";
    if (options.line_of_sight)
    {
      std::string soils_file;
      soils_file = avsp::node::stringParam(pnh, "soils_file", ros::package::getPath("avsp") + "/config/soils.yaml");
      try
      {
        soils_ = std::make_unique<at::SoilLibrary>(at::SoilLibrary::load(soils_file));
      }
      catch (const std::exception& e)
      {
        throw StartupError("parameter ~soils_file: " + std::string(e.what()));
      }
      at::LoadedSource loaded = at::node::loadTerrainFromParams(pnh, *soils_);
      terrain_ = std::move(loaded.terrain);
      terrain_description = loaded.description;
      height = [terrain = terrain_.get()](double x, double y, double& h) {
        const std::optional<double> z = terrain->height(x, y);
        if (!z)
          return false;
        h = *z;
        return true;
      };
    }
    try
    {
      radio_ = std::make_unique<av::Radio>(vehicles, options, height);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError("parameter ~" + std::string(e.what()));
    }

    for (std::size_t k = 0; k < vehicles.size(); ++k)
    {
      in_pubs_.push_back(nh.advertise<avsp_msgs::VehicleState>(vehicles[k] + "/v2v/in", 100));
      out_subs_.push_back(nh.subscribe<avsp_msgs::VehicleState>(
          vehicles[k] + "/v2v/out", 100,
          [this, k](const avsp_msgs::VehicleState::ConstPtr& msg) { onBroadcast(k, msg); }, ros::VoidConstPtr(),
          ros::TransportHints().tcpNoDelay()));
      if (lockstep_period_ > 0.0)
        batch_pubs_.push_back(nh.advertise<avsp_msgs::VehicleStateArray>(vehicles[k] + "/v2v/in_lockstep", 100));
    }
    queued_.resize(vehicles.size());
    last_stamp_.assign(vehicles.size(), -std::numeric_limits<double>::infinity());
    if (lockstep_period_ > 0.0 && !ros::Time::isSimTime())
      throw StartupError("parameter ~lockstep_period needs sim time (/use_sim_time true)");
    markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("v2v/fleet_markers", 1, true);
    // On sim time deliveries go out on the /clock tick that reaches their due time, so the
    // latency is exact to the clock step; on wall time a timer polls at ~update_rate.
    if (ros::Time::isSimTime())
      clock_sub_ = nh.subscribe("/clock", 100, &Impl::onClock, this, ros::TransportHints().tcpNoDelay());
    else
      poll_timer_ = nh.createTimer(ros::Duration(1.0 / update_rate),
                                   [this](const ros::TimerEvent&) { release(ros::Time::now().toSec()); });
    if (marker_rate > 0.0)
      marker_timer_ =
          nh.createTimer(ros::Duration(1.0 / marker_rate), [this](const ros::TimerEvent&) { publishMarkers(); });
    ROS_INFO(
        "v2v_radio_node: %zu vehicles, range %g m, latency %g s, loss %g, line of sight %s (terrain: %s), "
        "seed %llu",
        vehicles.size(), options.range, options.latency, options.loss_probability, options.line_of_sight ? "on" : "off",
        terrain_description.c_str(), static_cast<unsigned long long>(options.seed));
  }

private:
  struct Pending
  {
    avsp_msgs::VehicleState::ConstPtr message;
    std::size_t remaining = 0;
  };

  void onBroadcast(std::size_t sender, const avsp_msgs::VehicleState::ConstPtr& msg)
  {
    const std::string& name = radio_->vehicles()[sender];
    if (msg->vehicle_id != name)
    {
      ROS_WARN_THROTTLE(5.0, "v2v_radio_node: %s/v2v/out carries vehicle_id '%s', not '%s'; message dropped",
                        name.c_str(), msg->vehicle_id.c_str(), name.c_str());
      return;
    }
    const auto& p = msg->position;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
    {
      ROS_WARN_THROTTLE(5.0, "v2v_radio_node: %s/v2v/out has a non-finite position; message dropped", name.c_str());
      return;
    }
    double stamp = msg->header.stamp.toSec();
    if (msg->header.stamp.isZero())
    {
      stamp = ros::Time::now().toSec();
      ROS_WARN_THROTTLE(5.0, "v2v_radio_node: %s/v2v/out has no header.stamp; latency counted from reception",
                        name.c_str());
    }
    if (lockstep_period_ > 0.0)
    {
      if (!(stamp > last_stamp_[sender]))
      {
        ROS_WARN_THROTTLE(5.0, "v2v_radio_node: %s/v2v/out stamp %.3f s not after the last (%.3f s); dropped",
                          name.c_str(), stamp, last_stamp_[sender]);
        return;
      }
      last_stamp_[sender] = stamp;
      queued_[sender].push_back(msg);
      advanceLockstep();
      return;
    }
    transmit(sender, msg, stamp);
    release(std::max(latest_clock_, ros::Time::now().toSec()));
  }

  void transmit(std::size_t sender, const avsp_msgs::VehicleState::ConstPtr& msg, double stamp)
  {
    const std::uint64_t id = next_id_++;
    const auto& p = msg->position;
    const std::vector<av::Delivery> scheduled = radio_->transmit(sender, { p.x, p.y, p.z }, msg->seq, stamp, id);
    if (!scheduled.empty())
      pending_[id] = Pending{ msg, scheduled.size() };
  }

  void onClock(const rosgraph_msgs::Clock::ConstPtr& clock)
  {
    latest_clock_ = clock->clock.toSec();
    if (lockstep_period_ > 0.0)
      advanceLockstep();
    else
      release(latest_clock_);
  }

  /// Emits every lockstep batch whose instant the clock has reached and whose broadcasts are
  /// all in: for the batch at t_k, each sender must have broadcast at or after the last grid
  /// time at or before t_k - latency (in-order streams: then all earlier ones are here too).
  void advanceLockstep()
  {
    while (true)
    {
      const double t = static_cast<double>(next_batch_) * lockstep_period_;
      if (t > latest_clock_ + 1e-9)
        return;
      const double sent_by = std::max(t - latency_, 0.0);
      const double grid = std::floor(sent_by / broadcast_period_ + 1e-6) * broadcast_period_;
      std::string waiting;
      for (std::size_t k = 0; k < queued_.size(); ++k)
        if (last_stamp_[k] < grid - 1e-9)
          waiting += (waiting.empty() ? "" : ", ") + radio_->vehicles()[k] + "/v2v/out";
      if (!waiting.empty())
      {
        // Waiting a moment for a broadcast in flight is normal; seconds of it mean one is missing.
        const ros::WallTime now = ros::WallTime::now();
        if (waiting_batch_ != next_batch_)
        {
          waiting_batch_ = next_batch_;
          waiting_since_ = now;
        }
        else if ((now - waiting_since_).toSec() > 2.0 && (now - last_wait_warning_).toSec() > 5.0)
        {
          ROS_WARN(
              "v2v_radio_node: lockstep batch at %.3f s has waited %.1f s (wall) for broadcasts up to %.3f s "
              "from %s (is its v2v_broadcaster running?)",
              t, (now - waiting_since_).toSec(), grid, waiting.c_str());
          last_wait_warning_ = now;
        }
        return;
      }
      // Transmit in (stamp, sender) order: the range test uses the other antennas' positions.
      while (true)
      {
        std::size_t best = queued_.size();
        for (std::size_t k = 0; k < queued_.size(); ++k)
          if (!queued_[k].empty() && queued_[k].front()->header.stamp.toSec() <= sent_by + 1e-9 &&
              (best == queued_.size() ||
               queued_[k].front()->header.stamp.toSec() < queued_[best].front()->header.stamp.toSec()))
            best = k;
        if (best == queued_.size())
          break;
        transmit(best, queued_[best].front(), queued_[best].front()->header.stamp.toSec());
        queued_[best].pop_front();
      }
      std::vector<avsp_msgs::VehicleStateArray> batches(batch_pubs_.size());
      for (const av::Delivery& d : radio_->due(t))
      {
        auto it = pending_.find(d.message);
        if (it == pending_.end())
          continue;
        in_pubs_[d.receiver].publish(it->second.message);
        batches[d.receiver].states.push_back(*it->second.message);
        if (--it->second.remaining == 0)
          pending_.erase(it);
      }
      for (std::size_t k = 0; k < batches.size(); ++k)
      {
        batches[k].header.stamp = ros::Time(t);
        batches[k].header.frame_id = frame_id_;
        batch_pubs_[k].publish(batches[k]);
      }
      ++next_batch_;
    }
  }

  void release(double now)
  {
    for (const av::Delivery& d : radio_->due(now))
    {
      auto it = pending_.find(d.message);
      if (it == pending_.end())
        continue;
      in_pubs_[d.receiver].publish(it->second.message);
      if (--it->second.remaining == 0)
        pending_.erase(it);
    }
  }

  void publishMarkers()
  {
    const std::vector<std::string>& names = radio_->vehicles();
    const double range = radio_->options().range;
    visualization_msgs::MarkerArray array;
    visualization_msgs::Marker clear;
    clear.action = visualization_msgs::Marker::DELETEALL;
    array.markers.push_back(clear);
    auto base = [this](const std::string& ns, int id, int type) {
      visualization_msgs::Marker m;
      m.header.frame_id = frame_id_;
      m.header.stamp = ros::Time::now();
      m.ns = ns;
      m.id = id;
      m.type = type;
      m.action = visualization_msgs::Marker::ADD;
      m.pose.orientation.w = 1.0;
      return m;
    };
    visualization_msgs::Marker up = base("links", 0, visualization_msgs::Marker::LINE_LIST);
    up.scale.x = 0.5;
    up.color = colour(0.1f, 0.9f, 0.2f, 0.9f);
    visualization_msgs::Marker blocked = base("blocked_links", 0, visualization_msgs::Marker::LINE_LIST);
    blocked.scale.x = 0.3;
    blocked.color = colour(0.95f, 0.2f, 0.1f, 0.7f);
    for (std::size_t a = 0; a < names.size(); ++a)
    {
      av::Vec3 pa;
      if (!radio_->antenna(a, pa))
        continue;
      visualization_msgs::Marker dot = base("vehicles", static_cast<int>(a), visualization_msgs::Marker::SPHERE);
      dot.pose.position = point(pa);
      dot.scale.x = dot.scale.y = dot.scale.z = 3.0;
      dot.color = colour(0.2f, 0.5f, 1.0f, 1.0f);
      array.markers.push_back(dot);
      visualization_msgs::Marker label =
          base("labels", static_cast<int>(a), visualization_msgs::Marker::TEXT_VIEW_FACING);
      label.pose.position = point(pa);
      label.pose.position.z += 4.0;
      label.scale.z = 3.0;
      label.color = colour(1.0f, 1.0f, 1.0f, 1.0f);
      label.text = names[a];
      array.markers.push_back(label);
      visualization_msgs::Marker circle = base("range", static_cast<int>(a), visualization_msgs::Marker::LINE_STRIP);
      circle.scale.x = 0.3;
      circle.color = colour(0.2f, 0.5f, 1.0f, 0.35f);
      for (int k = 0; k <= 72; ++k)
      {
        const double angle = 2.0 * M_PI * k / 72.0;
        circle.points.push_back(point({ pa.x + range * std::cos(angle), pa.y + range * std::sin(angle), pa.z }));
      }
      array.markers.push_back(circle);
      for (std::size_t b = a + 1; b < names.size(); ++b)
      {
        av::Vec3 pb;
        if (!radio_->antenna(b, pb))
          continue;
        const av::Link link = radio_->link(a, b);
        visualization_msgs::Marker* lines = link == av::Link::Up ? &up : link == av::Link::Blocked ? &blocked : nullptr;
        if (lines)
        {
          lines->points.push_back(point(pa));
          lines->points.push_back(point(pb));
        }
      }
    }
    for (visualization_msgs::Marker* lines : { &up, &blocked })
      if (!lines->points.empty())
        array.markers.push_back(*lines);
    markers_pub_.publish(array);
  }

  std::unique_ptr<at::SoilLibrary> soils_;
  std::unique_ptr<at::DeformableTerrain> terrain_;  // outlives radio_, whose height function points to it
  std::unique_ptr<av::Radio> radio_;
  std::unordered_map<std::uint64_t, Pending> pending_;
  std::uint64_t next_id_ = 0;
  double latest_clock_ = 0.0;
  double lockstep_period_ = 0.0;   ///< s, 0: no lockstep batches
  double broadcast_period_ = 0.1;  ///< s, the broadcasters' grid
  double latency_ = 0.0;
  std::uint64_t next_batch_ = 0;                       ///< the next lockstep batch is at next_batch_ * period
  std::uint64_t waiting_batch_ = ~std::uint64_t{ 0 };  ///< the batch waited for since waiting_since_
  ros::WallTime waiting_since_, last_wait_warning_;
  std::vector<std::deque<avsp_msgs::VehicleState::ConstPtr>> queued_;  ///< lockstep: not yet transmitted
  std::vector<double> last_stamp_;                                     ///< per sender, s
  std::vector<ros::Publisher> batch_pubs_;
  std::string frame_id_;
  std::vector<ros::Publisher> in_pubs_;
  std::vector<ros::Subscriber> out_subs_;
  ros::Subscriber clock_sub_;
  ros::Publisher markers_pub_;
  ros::Timer poll_timer_, marker_timer_;
};

V2vRadioNode::V2vRadioNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

V2vRadioNode::~V2vRadioNode() = default;

int V2vRadioNode::spin()
{
  ros::spin();
  return 0;
}

}  // namespace node
}  // namespace avsp
