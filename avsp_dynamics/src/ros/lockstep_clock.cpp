// lockstep_clock: the clock of a partitioned run (issue 7). It publishes /clock and advances it
// by ~sync_interval only when every partition in ~partitions has reported the current time
// done on /lockstep/done (dynamics_node ~partition), so a run gives the same result however its
// partitions are spread over processes and machines. A partition silent for ~timeout (wall)
// stops the run with an error naming it (exit 1). With ~real_time_factor r > 0 the clock is
// paced to r × wall time and overruns are reported. The rule is avsp_dynamics'
// LockstepBarrier; this file moves messages and watches the wall clock. The node's main is
// ../lockstep_clock.cpp.
#include "avsp_dynamics/ros/lockstep_clock.hpp"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <avsp_msgs/StepDone.h>
#include <avsp_terrain/ros/node_params.hpp>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include "avsp_dynamics/lockstep_barrier.hpp"

namespace avsp
{
namespace dynamics
{
namespace node
{
namespace
{
using avsp::node::boundedParam;
using avsp::node::StartupError;

std::vector<std::string> partitionNames(const ros::NodeHandle& pnh)
{
  XmlRpc::XmlRpcValue list;
  if (!avsp::node::structuredParam(pnh, "partitions", list) || list.getType() != XmlRpc::XmlRpcValue::TypeArray ||
      list.size() == 0)
    throw StartupError("parameter ~partitions must be a non-empty list of partition names");
  std::vector<std::string> names;
  for (int k = 0; k < list.size(); ++k)
  {
    if (list[k].getType() != XmlRpc::XmlRpcValue::TypeString)
      throw StartupError("parameter ~partitions[" + std::to_string(k) + "] must be a string");
    names.push_back(static_cast<std::string>(list[k]));
  }
  return names;
}

std::string joined(const std::vector<std::string>& names)
{
  std::string out;
  for (const std::string& n : names)
    out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

class LockstepClock::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh)
  {
    const std::vector<std::string> names = partitionNames(pnh);
    const double interval = boundedParam(pnh, "sync_interval", 0.01, 1e-4, 10.0);
    timeout_ = boundedParam(pnh, "timeout", 10.0, 0.01, 3600.0);
    startup_timeout_ = boundedParam(pnh, "startup_timeout", 300.0, 0.01, 36000.0);
    real_time_factor_ = avsp::node::runNumberParam(pnh, avsp::terrain::kRealTimeFactor);
    duration_ = boundedParam(pnh, "duration", 0.0, 0.0, 1e9);
    lookahead_ = static_cast<unsigned>(avsp::node::boundedIntParam(pnh, "lookahead", 5, 1, 1000));
    try
    {
      barrier_ = std::make_unique<avsp::dynamics::LockstepBarrier>(names, interval, lookahead_);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError("parameter ~" + std::string(e.what()));
    }
    clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    done_sub_ = nh.subscribe("/lockstep/done", 1000, &Impl::onDone, this, ros::TransportHints().tcpNoDelay());
    ROS_INFO(
        "lockstep_clock: %zu partition(s) [%s], sync interval %g s, lookahead %u, timeout %g s, "
        "real_time_factor %g",
        names.size(), joined(names).c_str(), interval, lookahead_, timeout_, real_time_factor_);
  }

  /// Runs until shutdown or ~duration; false after a partition timed out.
  bool run()
  {
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    publish();
    ros::WallTime progress = ros::WallTime::now();  // when the clock last moved
    ros::WallTime resend = progress;
    std::uint64_t overruns = 0;
    std::optional<ros::WallTime> wall_start, since_one;
    while (ros::ok())
    {
      // Block for a report only when the clock cannot move: after an advance the lookahead may
      // allow the next one at once.
      queue->callAvailable(barrier_->complete() ? ros::WallDuration(0.0) : ros::WallDuration(0.001));
      const ros::WallTime now = ros::WallTime::now();
      if (!barrier_->complete())
      {
        // A partition that connected after the last tick would wait for ever: tell it again.
        if ((now - resend).toSec() > 0.2)
        {
          publish();
          resend = now;
        }
        // Time 0 waits for the partitions to load their worlds and for the run's start.
        const bool starting = barrier_->needed() == 0.0;
        const double limit = starting ? startup_timeout_ : timeout_;
        if ((now - progress).toSec() > limit)
        {
          ROS_FATAL(
              "lockstep_clock: partition(s) %s did not report t = %.3f s within ~%s %g s (wall); "
              "stopping the run",
              joined(barrier_->waitingFor()).c_str(), barrier_->needed(), starting ? "startup_timeout" : "timeout",
              limit);
          ros::shutdown();
          return false;
        }
        continue;
      }
      if (!since_one && barrier_->time() >= 1.0 - 1e-9)
        since_one = now;  // the pace is measured from t = 1 s: start-up is not simulated time
      if (duration_ > 0.0 && barrier_->time() >= duration_ - 1e-9)
      {
        const double wall = since_one ? (now - *since_one).toSec() : 0.0;
        ROS_INFO("lockstep_clock: ~duration %g s reached; from t = 1 s: %.3f s wall, real-time factor %.3f", duration_,
                 wall, wall > 0.0 ? (barrier_->time() - 1.0) / wall : 0.0);
        return true;
      }
      if (real_time_factor_ > 0.0)
      {
        // Paced from the first complete tick (start-up time is not simulated time).
        if (!wall_start)
          wall_start = now - ros::WallDuration(barrier_->time() / real_time_factor_);
        const ros::WallTime due =
            *wall_start + ros::WallDuration((barrier_->time() + barrier_->interval()) / real_time_factor_);
        if (now > due + ros::WallDuration(barrier_->interval() / real_time_factor_))
        {
          ++overruns;
          ROS_WARN_THROTTLE(5.0,
                            "lockstep_clock: overrun: sim time %.3f s is %.3f s (wall) behind the pace "
                            "(%llu late intervals so far)",
                            barrier_->time(), (now - due).toSec(), static_cast<unsigned long long>(overruns));
        }
        else if (due > now)
          (due - now).sleep();
      }
      barrier_->advance();
      publish();
      progress = resend = ros::WallTime::now();
    }
    return true;
  }

private:
  void onDone(const avsp_msgs::StepDone::ConstPtr& msg)
  {
    using Report = avsp::dynamics::LockstepBarrier::Report;
    switch (barrier_->done(msg->partition, msg->header.stamp.toSec()))
    {
      case Report::kAccepted:
        break;
      case Report::kUnknownPartition:
        ROS_WARN_THROTTLE(5.0, "lockstep_clock: /lockstep/done from unknown partition '%s' ignored (~partitions: %s)",
                          msg->partition.c_str(), joined(barrier_->waitingFor()).c_str());
        break;
      case Report::kAhead:
        ROS_WARN_THROTTLE(5.0,
                          "lockstep_clock: /lockstep/done: partition '%s' reports t = %.3f s, ahead of the "
                          "clock (%.3f s); ignored",
                          msg->partition.c_str(), msg->header.stamp.toSec(), barrier_->time());
        break;
      case Report::kNotFinite:
        break;  // ros::Time cannot carry one
    }
  }

  void publish()
  {
    rosgraph_msgs::Clock c;
    c.clock = ros::Time(barrier_->time());
    clock_pub_.publish(c);
  }

  std::unique_ptr<avsp::dynamics::LockstepBarrier> barrier_;
  unsigned lookahead_ = 5;
  double timeout_ = 10.0, startup_timeout_ = 300.0, real_time_factor_ = 0.0, duration_ = 0.0;
  ros::Publisher clock_pub_;
  ros::Subscriber done_sub_;
};

LockstepClock::LockstepClock(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

LockstepClock::~LockstepClock() = default;

int LockstepClock::spin()
{
  return impl_->run() ? 0 : 1;
}

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
