#include "avsp_dynamics/clock_followers.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace avsp
{
namespace dynamics
{
namespace
{
/// s: a ROS stamp's resolution; reports and clock times travel as stamps.
constexpr double kStampResolution = 1e-9;
}  // namespace

ClockFollowers::ClockFollowers(const std::vector<std::string>& names, double lag) : names_(names), lag_(lag)
{
  if (names.empty())
    throw std::invalid_argument("clock_followers: the list of followers is empty");
  if (!std::isfinite(lag) || lag < 0.0)
    throw std::invalid_argument("clock_followers: lag " + std::to_string(lag) + " s must be finite and >= 0");
  for (const std::string& n : names)
  {
    if (n.empty())
      throw std::invalid_argument("clock_followers: a follower name is empty");
    if (!reached_.emplace(n, -std::numeric_limits<double>::infinity()).second)
      throw std::invalid_argument("clock_followers: follower '" + n + "' is listed twice");
  }
}

ClockFollowers::Report ClockFollowers::done(const std::string& name, double time)
{
  if (!std::isfinite(time))
    return Report::kNotFinite;
  const auto it = reached_.find(name);
  if (it == reached_.end())
    return Report::kUnknown;
  if (time > it->second)
    it->second = time;
  return Report::kAccepted;
}

bool ClockFollowers::allows(double time) const
{
  for (const auto& entry : reached_)
    if (entry.second < time - lag_ - kStampResolution)
      return false;
  return true;
}

std::vector<std::string> ClockFollowers::holding(double time) const
{
  std::vector<std::string> out;
  for (const std::string& n : names_)
    if (reached_.at(n) < time - lag_ - kStampResolution)
      out.push_back(n);
  return out;
}

}  // namespace dynamics
}  // namespace avsp
