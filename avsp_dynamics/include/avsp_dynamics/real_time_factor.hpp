#pragma once
/**
 * @file real_time_factor.hpp
 * @brief The real-time factor a run achieves: simulated time over wall time, on a sliding
 *        window of wall time (dynamics_node's /diagnostics). A window, not the whole run: a run
 *        that slows down under load must show it while it lasts.
 */
#include <cstdint>
#include <deque>
#include <optional>

namespace avsp
{
namespace dynamics
{
/// Sim time advanced over wall time elapsed within the last `window` seconds of wall time.
class RealTimeFactorWindow
{
public:
  /// @throw std::invalid_argument unless window is finite and > 0
  explicit RealTimeFactorWindow(double window = 5.0);

  /**
   * @brief Adds a sample: sim time `sim` (s) reached at wall time `wall` (s).
   * @throw std::invalid_argument if either is not finite or goes back in time
   */
  void add(double sim, double wall);

  /**
   * @brief (newest sim − oldest sim) / (newest wall − oldest wall) over the samples kept: the
   *        newest and every sample less than `window` older than it, plus the last one at or
   *        beyond the window (so the span covers the window once the run is that long).
   * @return nothing until two samples are apart in wall time
   */
  std::optional<double> factor() const;

  /// Wall seconds the factor spans (0 with fewer than two samples).
  double span() const;

private:
  struct Sample
  {
    double sim, wall;
  };
  double window_;
  std::deque<Sample> samples_;
};

/**
 * @brief Paces sim time to r x wall time without catch-up bursts. While the host keeps up, sim
 *        time t is due at wall time anchor + (t - t_anchor) / r. When it falls more than
 *        `max_lag` wall seconds behind that pace (a slow step, a stall, a loaded host), the pace
 *        restarts from where the run is: sim time slows down instead of sprinting later to make
 *        up, which would run the sensors and controllers behind the clock for that long.
 */
class Pacer
{
public:
  /// @throw std::invalid_argument unless factor > 0 and max_lag >= 0 (both finite)
  explicit Pacer(double factor, double max_lag = 0.1);

  /**
   * @brief Wall seconds to wait before sim time `sim` may be published at wall time `wall`.
   *        The first call anchors the pace (and returns 0).
   * @throw std::invalid_argument if either is not finite
   */
  double wait(double sim, double wall);

  /// The wall time at which sim time `sim` is due on the current pace; -inf before the first
  /// wait() (nothing is due yet). Changes nothing.
  double due(double sim) const;

  /// Forgets the pace: the next wait() anchors it again (after a pause, the time paused is
  /// neither caught up nor counted as a restart).
  void reanchor() { anchor_sim_.reset(); }

  /// How often the pace restarted because the run was more than max_lag behind it.
  std::uint64_t restarts() const { return restarts_; }
  /// Wall seconds given up by those restarts (how far behind the run was, summed).
  double lost() const { return lost_; }

private:
  double factor_, max_lag_;
  std::optional<double> anchor_sim_;
  double anchor_wall_ = 0.0;
  std::uint64_t restarts_ = 0;
  double lost_ = 0.0;
};

}  // namespace dynamics
}  // namespace avsp
