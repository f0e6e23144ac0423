#include "avsp_dynamics/lockstep_barrier.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace avsp
{
namespace dynamics
{
namespace
{
// Reports are sim times the clock published (k × interval) echoed back; allow for a partition
// that computed its time as a sum of steps.
constexpr double kTimeTolerance = 1e-9;
}  // namespace

LockstepBarrier::LockstepBarrier(const std::vector<std::string>& partitions, double interval, unsigned lookahead)
  : names_(partitions), interval_(interval), lookahead_(lookahead)
{
  if (lookahead < 1)
    throw std::invalid_argument("lookahead: must be >= 1 (got " + std::to_string(lookahead) + ")");
  if (partitions.empty())
    throw std::invalid_argument("partitions: at least one is needed");
  if (!std::isfinite(interval) || !(interval > 0.0))
    throw std::invalid_argument("interval: must be finite and > 0 (got " + std::to_string(interval) + ")");
  for (std::size_t k = 0; k < partitions.size(); ++k)
  {
    if (partitions[k].empty())
      throw std::invalid_argument("partitions[" + std::to_string(k) + "]: empty name");
    if (!reached_.emplace(partitions[k], -std::numeric_limits<double>::infinity()).second)
      throw std::invalid_argument("partitions[" + std::to_string(k) + "]: '" + partitions[k] + "' is listed twice");
  }
}

LockstepBarrier::Report LockstepBarrier::done(const std::string& partition, double t)
{
  if (!std::isfinite(t))
    return Report::kNotFinite;
  auto it = reached_.find(partition);
  if (it == reached_.end())
    return Report::kUnknownPartition;
  if (t > time() + kTimeTolerance)
    return Report::kAhead;
  it->second = std::max(it->second, t);
  return Report::kAccepted;
}

double LockstepBarrier::needed() const
{
  const std::uint64_t behind = lookahead_ - 1;
  return step_ >= behind ? static_cast<double>(step_ - behind) * interval_ : 0.0;
}

bool LockstepBarrier::complete() const
{
  const double now = needed() - kTimeTolerance;
  for (const auto& [name, reached] : reached_)
    if (reached < now)
      return false;
  return true;
}

double LockstepBarrier::advance()
{
  if (!complete())
    throw std::logic_error("LockstepBarrier::advance: partitions have not all reported " + std::to_string(time()));
  ++step_;
  return time();
}

std::vector<std::string> LockstepBarrier::waitingFor() const
{
  std::vector<std::string> out;
  const double now = needed() - kTimeTolerance;
  for (const std::string& name : names_)
    if (reached_.at(name) < now)
      out.push_back(name);
  return out;
}
}  // namespace dynamics
}  // namespace avsp
