#pragma once
/**
 * @file test_clock.hpp
 * @brief The rostests' own clock and topic recorders (one definition for every package's
 *        rostests): a /clock the test drives in whole ticks, so that the instants a node senses,
 *        publishes or answers are known exactly and counted exactly; and a subscriber that keeps
 *        every message of a topic.
 */
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include "avsp_terrain/ros/spin_until.hpp"

namespace avsp
{
namespace node
{
/// Sim time driven by the test: k ticks of `tick` seconds (k * tick, no summed rounding).
class TestClock
{
public:
  /// @param tick s of sim time per step (e.g. 0.001, 0.01)
  explicit TestClock(double tick, const std::string& topic = "/clock")
    : tick_(tick), pub_(nh_.advertise<rosgraph_msgs::Clock>(topic, 10))
  {
  }

  double now() const { return static_cast<double>(ticks_) * tick_; }
  long ticks() const { return ticks_; }
  double tick() const { return tick_; }
  std::size_t subscribers() const { return pub_.getNumSubscribers(); }

  /// Publishes the current time again (a node that subscribed late gets it).
  void publish()
  {
    rosgraph_msgs::Clock c;
    c.clock = ros::Time(now());
    pub_.publish(c);
  }

  /// `n` ticks on, published once.
  void step(long n = 1)
  {
    ticks_ += n;
    publish();
  }

  /// Steps one tick at a time up to sim time t, spinning the callback queue after each and
  /// giving the node `wall_per_step` wall seconds per step.
  void advanceTo(double t, double wall_per_step = 0.001)
  {
    while (now() < t - 1e-9 && ros::ok())
    {
      step();
      if (wall_per_step > 0.0)
        ros::WallDuration(wall_per_step).sleep();
      ros::spinOnce();
    }
  }

  /// Holds the time, publishing it every `poll` wall seconds, until `done()` or `timeout` wall
  /// seconds (spinUntil with the clock repeated).
  bool waitFor(const std::function<bool()>& done, double timeout = 10.0, double poll = 0.002)
  {
    return spinUntil(
        [&] {
          if (done())
            return true;
          publish();
          return false;
        },
        timeout, poll);
  }

private:
  ros::NodeHandle nh_;
  double tick_;
  long ticks_ = 0;
  ros::Publisher pub_;
};

/// Every message of a topic, in arrival order.
template <class M>
class TopicRecorder
{
public:
  TopicRecorder(const std::string& topic, std::size_t queue = 1000)
    : sub_(nh_.subscribe<M>(topic, queue, [this](const typename M::ConstPtr& m) { messages_.push_back(*m); }))
  {
  }
  TopicRecorder(const TopicRecorder&) = delete;
  TopicRecorder& operator=(const TopicRecorder&) = delete;

  const std::vector<M>& messages() const { return messages_; }
  std::size_t size() const { return messages_.size(); }
  bool empty() const { return messages_.empty(); }
  const M& back() const { return messages_.back(); }
  const M& operator[](std::size_t k) const { return messages_[k]; }
  void clear() { messages_.clear(); }
  /// Whether some node publishes the topic (the master told this subscriber).
  bool connected() const { return sub_.getNumPublishers() > 0; }

private:
  ros::NodeHandle nh_;
  std::vector<M> messages_;
  ros::Subscriber sub_;
};

}  // namespace node
}  // namespace avsp
