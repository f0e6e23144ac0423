#pragma once
/**
 * @file clock_followers.hpp
 * @brief The rule that keeps the nodes that follow the clock in step with it (issue 20,
 *        deliverable 4): the clock's source publishes a time T only once every follower (e.g.
 *        sensors_node) has reported on /lockstep/done that it has processed everything up to
 *        T - lag. So /clock never runs more than `lag` ahead of the slowest follower, at any
 *        real-time factor and under any load. ROS-free; dynamics_node moves the messages.
 */
#include <map>
#include <string>
#include <vector>

namespace avsp
{
namespace dynamics
{
class ClockFollowers
{
public:
  /**
   * @param names followers (their /lockstep/done partition names): non-empty, unique, each non-empty
   * @param lag s the clock may run ahead of the slowest follower's report: finite, >= 0
   * @throw std::invalid_argument naming what is wrong
   */
  ClockFollowers(const std::vector<std::string>& names, double lag);

  /// What done() made of a report.
  enum class Report
  {
    kAccepted,  ///< the follower has now processed up to `time` (or already had: a repeat)
    kUnknown,   ///< not one of the followers
    kNotFinite,
  };
  /// A follower reports that it has processed everything up to `time` (s). Older times change nothing.
  Report done(const std::string& name, double time);

  /// Whether the clock may publish `time`: every follower has reported at least time - lag
  /// (to 1 ns, the resolution of a ROS stamp). False before a follower's first report.
  bool allows(double time) const;
  /// The followers that hold `time` back, in the order given.
  std::vector<std::string> holding(double time) const;
  /// The latest time `name` reported (-inf before its first report). @throw std::out_of_range
  double reached(const std::string& name) const { return reached_.at(name); }
  const std::vector<std::string>& names() const { return names_; }
  double lag() const { return lag_; }

private:
  std::vector<std::string> names_;
  std::map<std::string, double> reached_;
  double lag_;
};

}  // namespace dynamics
}  // namespace avsp
