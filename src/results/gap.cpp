#include "avsp/results/gap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace avsp
{
namespace results
{
GapTracker::GapTracker(double period, std::function<void(const GapSample&)> out) : pick_(period), out_(std::move(out))
{
  if (!(period > 0.0) || !std::isfinite(period))
    throw std::invalid_argument("GapTracker: period must be > 0 s");
}

void GapTracker::addLeader(const OdometrySample& p)
{
  if (!has_leader_)
  {
    has_leader_ = true;
    leader_t_begin_ = p.t;
    first_x_ = p.x;
    first_y_ = p.y;
    path_.push_back({ p.x, p.y, 0.0 });
  }
  else
  {
    const PathPoint& b = path_.back();
    const double d = std::hypot(p.x - b.x, p.y - b.y);
    if (d >= 1e-3)
      path_.push_back({ p.x, p.y, b.s + d });
  }
  leader_.emplace_back(p.t, path_.back().s);
  release();
}

void GapTracker::addFollower(const OdometrySample& f)
{
  has_follower_ = true;
  follower_t_ = f.t;
  if (pick_.take(f.t))
  {
    if (pending_.size() == kMaxPendingGapSamples)
    {
      pending_.pop_front();
      ++dropped_;
    }
    pending_.push_back(f);
  }
  release();
}

void GapTracker::release()
{
  if (has_leader_)
  {
    while (!pending_.empty())
    {
      const OdometrySample& f = pending_.front();
      if (f.t < leader_t_begin_)
      {
        pending_.pop_front();  // before the leader's first sample: no gap
        continue;
      }
      if (leader_.back().first < f.t)
        break;  // the leader's samples around f.t have not all arrived
      const double s_leader = sAtTime(f.t);
      const double lo = has_previous_ ? s_previous_ - kBacktrack : 0.0;
      const Projection p = project(f.x, f.y, lo, s_leader);
      GapSample g;
      g.t = f.t;
      if (p.before_start)
      {
        // Behind the leader's start: the controller's first breadcrumb is the follower itself.
        g.gap = s_leader + std::hypot(f.x - first_x_, f.y - first_y_);
        g.lateral = 0.0;
        s_previous_ = 0.0;
      }
      else
      {
        g.gap = s_leader - p.s;
        g.lateral = p.distance;
        s_previous_ = p.s;
      }
      has_previous_ = true;
      min_ = count_ ? std::min(min_, g.gap) : g.gap;
      sum_ += g.gap;
      ++count_;
      pending_.pop_front();
      out_(g);
    }
    // The path far behind the follower's place on it is not looked at again.
    while (path_.size() >= 2 && path_[1].s < s_previous_ - kKeepBehind)
    {
      path_.pop_front();
      ++path_begin_;
    }
  }
  // Leader samples before the last one at or before every time still to be asked.
  if (has_follower_)
  {
    const double t = pending_.empty() ? follower_t_ : pending_.front().t;
    while (leader_.size() >= 2 && leader_[1].first <= t)
      leader_.pop_front();
  }
}

double GapTracker::sAtTime(double t) const
{
  const auto it = std::upper_bound(leader_.begin(), leader_.end(), t,
                                   [](double v, const std::pair<double, double>& e) { return v < e.first; });
  if (it == leader_.begin())
    return leader_.front().second;
  if (it == leader_.end())
    return leader_.back().second;
  const auto& a = *(it - 1);
  const auto& b = *it;
  const double f = b.first > a.first ? (t - a.first) / (b.first - a.first) : 1.0;
  return a.second + f * (b.second - a.second);
}

GapTracker::Projection GapTracker::project(double px, double py, double lo, double hi) const
{
  Projection best;
  best.distance = std::numeric_limits<double>::infinity();
  lo = std::max(lo, 0.0);
  hi = std::max(hi, lo);
  // The segment that can reach lo, and every later one starting before hi: those exist whatever
  // the leader did after this time, so the result does not depend on how far ahead its samples are.
  const auto after_lo =
      std::upper_bound(path_.begin(), path_.end(), lo, [](double v, const PathPoint& q) { return v < q.s; });
  const std::size_t first = static_cast<std::size_t>(std::max<std::ptrdiff_t>(after_lo - path_.begin() - 1, 0));
  for (std::size_t i = first; i + 1 < path_.size() && path_[i].s < hi; ++i)
  {
    const PathPoint &a = path_[i], &b = path_[i + 1];
    const double len = b.s - a.s;
    const double ux = (b.x - a.x) / len, uy = (b.y - a.y) / len;
    const double along = (px - a.x) * ux + (py - a.y) * uy;
    const double c = std::clamp(along, std::max(0.0, lo - a.s), std::min(len, hi - a.s));
    const double d = std::hypot(px - (a.x + c * ux), py - (a.y + c * uy));
    if (d < best.distance)
    {
      best.distance = d;
      best.s = a.s + c;
      best.before_start = path_begin_ + i == 0 && along < 0.0 && c == 0.0;
    }
  }
  if (std::isinf(best.distance))
  {
    // No segment starts before hi (the leader has not left this point by then): the point itself,
    // and at the path's first point the follower counts as behind the start.
    const PathPoint& a = path_[first];
    best.distance = std::hypot(px - a.x, py - a.y);
    best.s = a.s;
    best.before_start = path_begin_ + first == 0;
  }
  return best;
}

std::optional<GapStats> GapTracker::stats() const
{
  if (count_ == 0)
    return std::nullopt;
  return GapStats{ min_, sum_ / static_cast<double>(count_) };
}

std::vector<GapSample> gapSeries(const std::vector<OdometrySample>& leader, const std::vector<OdometrySample>& follower,
                                 double period)
{
  std::vector<GapSample> out;
  GapTracker tracker(period, [&out](const GapSample& g) { out.push_back(g); });
  for (const OdometrySample& p : leader)
    tracker.addLeader(p);
  for (const OdometrySample& f : follower)
    tracker.addFollower(f);
  return out;
}

std::optional<GapStats> gapStats(const std::vector<GapSample>& series)
{
  if (series.empty())
    return std::nullopt;
  GapStats st;
  st.min = std::numeric_limits<double>::infinity();
  double sum = 0.0;
  for (const GapSample& g : series)
  {
    st.min = std::min(st.min, g.gap);
    sum += g.gap;
  }
  st.mean = sum / static_cast<double>(series.size());
  return st;
}

}  // namespace results
}  // namespace avsp
