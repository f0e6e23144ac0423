#pragma once
/**
 * @file gap.hpp
 * @brief The gap of a follower to its leader over a run (no ROS), as the leader–follower
 *        controller defines it (README, "Controller node"): the distance along the leader's
 *        driven path from the point of that path nearest the follower to the leader's position
 *        at the same time. Here the path is the leader's recorded odometry (ground truth), not
 *        the V2V breadcrumbs the controller sees.
 *
 * - Path: the leader's base_link positions in the map plane (x, y), points closer than 1 mm
 *   to the previous one skipped; s = arc length from its first sample.
 * - Leader's place at time t: s interpolated in time between its samples around t.
 * - Follower's place: its base_link projected on the path's segments, with s in
 *   [s_previous - kBacktrack, s_leader(t)]: the window keeps it on its own passage of a path
 *   that loops back over itself and never ahead of the leader.
 * - Before the path's start (a follower behind the leader's start position, where the path
 *   does not yet reach): gap = s_leader + the straight distance to the path's first point, as
 *   the controller's first breadcrumb is the follower's own position.
 * - Samples: the follower's first sample and then its first sample at or after each multiple of
 *   the period (as trajectories.csv), from the leader's first sample to its last.
 *
 * GapTracker computes the series as the samples arrive, in memory that does not grow with the
 * run: the leader's samples are kept only back to the follower's latest, its path only back to
 * kKeepBehind behind the follower's place on it. The result does not depend on how the two
 * topics' messages interleave (the leader may run ahead of the follower or behind it).
 */
#include <cstddef>
#include <deque>
#include <functional>
#include <optional>
#include <vector>

#include "avsp/results/vehicle_record.hpp"

namespace avsp
{
namespace results
{
/// m: how far back along the path the follower's projection may move between two samples.
constexpr double kBacktrack = 10.0;
/// m: how much of the leader's path behind the follower's place on it is kept (a follower that
/// backs up further along the path is projected on the oldest part kept).
constexpr double kKeepBehind = 500.0;
/// Follower samples waiting for the leader's (kept when the leader falls silent, then dropped oldest first).
constexpr std::size_t kMaxPendingGapSamples = 100000;

/// The gap at one time.
struct GapSample
{
  double t = 0.0;        ///< s, sim time
  double gap = 0.0;      ///< m, along the leader's path
  double lateral = 0.0;  ///< m, follower's distance from the leader's path (0 before its start)
};

/// Minimum and mean of a gap series.
struct GapStats
{
  double min = 0.0;   ///< m
  double mean = 0.0;  ///< m, over the samples (equally spaced in time)
};

/// One follower's gap series, computed as the leader's and the follower's samples arrive.
class GapTracker
{
public:
  /**
   * @param period s (> 0) between the gap samples
   * @param out receives each gap sample, in time order
   * @throw std::invalid_argument if period is not > 0
   */
  GapTracker(double period, std::function<void(const GapSample&)> out);

  /// A leader sample (in time order, as VehicleRecord accepted it).
  void addLeader(const OdometrySample& s);
  /// A follower sample (in time order, as VehicleRecord accepted it).
  void addFollower(const OdometrySample& s);
  /// Min and mean of the samples given out so far; nullopt before any.
  std::optional<GapStats> stats() const;
  /// Follower samples dropped because the leader stayed silent (kMaxPendingGapSamples).
  std::size_t dropped() const { return dropped_; }
  /// Samples held now (leader samples + path points + waiting follower samples): bounded.
  std::size_t held() const { return leader_.size() + path_.size() + pending_.size(); }

private:
  struct PathPoint
  {
    double x, y, s;
  };
  struct Projection
  {
    double s = 0.0, distance = 0.0;
    bool before_start = false;
  };
  void release();
  double sAtTime(double t) const;
  Projection project(double px, double py, double lo, double hi) const;

  PeriodicPick pick_;  ///< which follower samples are due
  std::function<void(const GapSample&)> out_;
  std::deque<std::pair<double, double>> leader_;  ///< (t, s) of the leader's samples still needed
  std::deque<PathPoint> path_;                    ///< the kept part of the leader's path
  std::size_t path_begin_ = 0;                    ///< index of path_.front() on the whole path
  double first_x_ = 0.0, first_y_ = 0.0;          ///< the path's first point
  bool has_leader_ = false;
  double leader_t_begin_ = 0.0;
  std::deque<OdometrySample> pending_;  ///< follower samples due, waiting for the leader's
  bool has_follower_ = false;
  double follower_t_ = 0.0;  ///< the latest follower sample's time
  double s_previous_ = 0.0;
  bool has_previous_ = false;
  std::size_t count_ = 0, dropped_ = 0;
  double min_ = 0.0, sum_ = 0.0;
};

/**
 * @brief The whole gap series of two recorded sample lists (a GapTracker fed the leader's
 *        samples, then the follower's).
 * @return empty if either has no sample or the spans do not overlap
 * @throw std::invalid_argument if period is not > 0
 */
std::vector<GapSample> gapSeries(const std::vector<OdometrySample>& leader, const std::vector<OdometrySample>& follower,
                                 double period);

/// nullopt for an empty series.
std::optional<GapStats> gapStats(const std::vector<GapSample>& series);

}  // namespace results
}  // namespace avsp
