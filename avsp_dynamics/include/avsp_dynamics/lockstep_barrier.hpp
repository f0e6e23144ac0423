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
   * @param lookahead intervals the time may run ahead of the slowest partition's report, >= 1:
   *        with 1 the time moves from k to k + 1 once every partition reported k; with L once
   *        every partition reported k + 1 - L (the partitions then synchronise among themselves
   *        at every interval, dynamics_node's peers, and the clock's round trip is hidden)
   * @throw std::invalid_argument naming what is wrong
   */
  LockstepBarrier(const std::vector<std::string>& partitions, double interval, unsigned lookahead = 1);

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

  /// Every partition has reported the time the next advance needs (the current time with
  /// lookahead 1; lookahead - 1 intervals before it otherwise).
  bool complete() const;

  /// The current time: step k × interval (no accumulated rounding).
  double time() const { return static_cast<double>(step_) * interval_; }
  std::uint64_t step() const { return step_; }
  double interval() const { return interval_; }

  /// Moves to the next interval. @throw std::logic_error unless complete()
  double advance();

  /// Partitions that have not reported what the next advance needs, in the order given.
  std::vector<std::string> waitingFor() const;
  /// The time every partition must have reported before the next advance (s).
  double needed() const;

private:
  std::vector<std::string> names_;
  std::map<std::string, double> reached_;  ///< latest time each partition reported
  double interval_;
  unsigned lookahead_ = 1;
  std::uint64_t step_ = 0;
};
}  // namespace dynamics
}  // namespace avsp
