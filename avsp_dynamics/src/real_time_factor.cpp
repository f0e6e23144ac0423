#include "avsp_dynamics/real_time_factor.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace dynamics
{
RealTimeFactorWindow::RealTimeFactorWindow(double window) : window_(window)
{
  if (!std::isfinite(window) || window <= 0.0)
    throw std::invalid_argument("RealTimeFactorWindow: window must be finite and > 0 s, got " + std::to_string(window));
}

void RealTimeFactorWindow::add(double sim, double wall)
{
  if (!std::isfinite(sim) || !std::isfinite(wall))
    throw std::invalid_argument("RealTimeFactorWindow::add: sim and wall time must be finite");
  if (!samples_.empty() && (sim < samples_.back().sim || wall < samples_.back().wall))
    throw std::invalid_argument("RealTimeFactorWindow::add: time went back (sim " + std::to_string(sim) + " after " +
                                std::to_string(samples_.back().sim) + ", wall " + std::to_string(wall) + " after " +
                                std::to_string(samples_.back().wall) + ")");
  samples_.push_back({ sim, wall });
  // Keep one sample at or beyond the window's start: drop the oldest while the next one is.
  while (samples_.size() > 2 && wall - samples_[1].wall >= window_)
    samples_.pop_front();
}

std::optional<double> RealTimeFactorWindow::factor() const
{
  const double wall = span();
  if (wall <= 0.0)
    return std::nullopt;
  return (samples_.back().sim - samples_.front().sim) / wall;
}

double RealTimeFactorWindow::span() const
{
  return samples_.size() < 2 ? 0.0 : samples_.back().wall - samples_.front().wall;
}

Pacer::Pacer(double factor, double max_lag) : factor_(factor), max_lag_(max_lag)
{
  if (!std::isfinite(factor) || factor <= 0.0 || !std::isfinite(max_lag) || max_lag < 0.0)
    throw std::invalid_argument("Pacer: factor must be finite and > 0, max_lag finite and >= 0 (got " +
                                std::to_string(factor) + ", " + std::to_string(max_lag) + ")");
}

double Pacer::due(double sim) const
{
  return anchor_sim_ ? anchor_wall_ + (sim - *anchor_sim_) / factor_ : -std::numeric_limits<double>::infinity();
}

double Pacer::wait(double sim, double wall)
{
  if (!std::isfinite(sim) || !std::isfinite(wall))
    throw std::invalid_argument("Pacer::wait: sim and wall time must be finite");
  if (!anchor_sim_)
  {
    anchor_sim_ = sim;
    anchor_wall_ = wall;
    return 0.0;
  }
  const double due = anchor_wall_ + (sim - *anchor_sim_) / factor_;
  if (wall - due > max_lag_)
  {
    ++restarts_;
    lost_ += wall - due;
    anchor_sim_ = sim;
    anchor_wall_ = wall;
    return 0.0;
  }
  return due > wall ? due - wall : 0.0;
}

}  // namespace dynamics
}  // namespace avsp
