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
 */
#include <cstddef>
#include <optional>
#include <vector>

#include "avsp/results/vehicle_record.hpp"

namespace avsp
{
namespace results
{
/// m: how far back along the path the follower's projection may move between two samples.
constexpr double kBacktrack = 10.0;

/// The gap at one time.
struct GapSample
{
  double t = 0.0;        ///< s, sim time
  double gap = 0.0;      ///< m, along the leader's path
  double lateral = 0.0;  ///< m, follower's distance from the leader's path (0 before its start)
};

/**
 * @brief The gap series at the first follower sample at or after each multiple of `period`
 *        (s, > 0) within the leader's sampled time span.
 * @param leader, follower odometry samples in time order (VehicleRecord::samples())
 * @return empty if either has no sample or the spans do not overlap
 * @throw std::invalid_argument if period is not > 0
 */
std::vector<GapSample> gapSeries(const std::vector<OdometrySample>& leader, const std::vector<OdometrySample>& follower,
                                 double period);

/// Minimum and mean of a gap series.
struct GapStats
{
  double min = 0.0;   ///< m
  double mean = 0.0;  ///< m, over the samples (equally spaced in time)
};

/// nullopt for an empty series.
std::optional<GapStats> gapStats(const std::vector<GapSample>& series);

}  // namespace results
}  // namespace avsp
