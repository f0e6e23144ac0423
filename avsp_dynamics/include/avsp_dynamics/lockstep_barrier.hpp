#pragma once
/**
 * @file lockstep_barrier.hpp
 * @brief The lockstep clock's rule (issue 7): sim time advances by one sync interval only when
 *        every dynamics partition has reported the current time done. ROS-free, so the rule is
 *        unit-tested; lockstep_clock only moves messages and watches the wall clock.
 */
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace avsp
{
namespace dynamics
{
class LockstepBarrier
{
public:
  /**
   * @param partitions names, non-empty, unique, each non-empty
   * @param interval s of sim time per advance, > 0 and finite
   * @throw std::invalid_argument naming what is wrong
   */
  LockstepBarrier(const std::vector<std::string>& partitions, double interval);

  /// What done() made of a report.
  enum class Report
  {
    kAccepted,          ///< the partition has now simulated to `time` (or already had)
    kUnknownPartition,  ///< not one of the partitions
    kAhead,             ///< a time the clock has not published: a protocol error
    kNotFinite,
  };

  /// A partition reports it has simulated up to `time` (s). Older times are accepted and change
  /// nothing (a repeated report).
  Report done(const std::string& partition, double time);

  /// Every partition has reported the current time.
  bool complete() const;

  /// The current time: step k × interval (no accumulated rounding).
  double time() const { return static_cast<double>(step_) * interval_; }
  std::uint64_t step() const { return step_; }
  double interval() const { return interval_; }

  /// Moves to the next interval. @throw std::logic_error unless complete()
  double advance();

  /// Partitions that have not reported the current time, in the order given.
  std::vector<std::string> waitingFor() const;

private:
  std::vector<std::string> names_;
  std::map<std::string, double> reached_;  ///< latest time each partition reported
  double interval_;
  std::uint64_t step_ = 0;
};
}  // namespace dynamics
}  // namespace avsp
