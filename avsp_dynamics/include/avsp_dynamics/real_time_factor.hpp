#pragma once
/**
 * @file real_time_factor.hpp
 * @brief The real-time factor a run achieves: simulated time over wall time, on a sliding
 *        window of wall time (dynamics_node's /diagnostics). A window, not the whole run: a run
 *        that slows down under load must show it while it lasts.
 */
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

}  // namespace dynamics
}  // namespace avsp
