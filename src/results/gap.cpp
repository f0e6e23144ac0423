#include "avsp/results/gap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace avsp
{
namespace results
{
namespace
{
/// The leader's path in the map plane with arc length, and its arc length at each sample.
struct LeaderPath
{
  std::vector<double> x, y, s;        ///< path points (deduplicated) and their arc length
  std::vector<double> sample_t, sample_s;  ///< per leader sample: time and arc length

  explicit LeaderPath(const std::vector<OdometrySample>& samples)
  {
    for (const OdometrySample& p : samples)
    {
      if (x.empty())
      {
        x.push_back(p.x);
        y.push_back(p.y);
        s.push_back(0.0);
      }
      else
      {
        const double d = std::hypot(p.x - x.back(), p.y - y.back());
        if (d >= 1e-3)
        {
          x.push_back(p.x);
          y.push_back(p.y);
          s.push_back(s.back() + d);
        }
      }
      sample_t.push_back(p.t);
      sample_s.push_back(s.back());
    }
  }

  /// Arc length of the leader at time t (interpolated between the samples around it).
  double sAtTime(double t) const
  {
    const auto it = std::upper_bound(sample_t.begin(), sample_t.end(), t);
    if (it == sample_t.begin())
      return sample_s.front();
    const std::size_t k = static_cast<std::size_t>(it - sample_t.begin());
    if (k == sample_t.size())
      return sample_s.back();
    const double t0 = sample_t[k - 1], t1 = sample_t[k];
    const double f = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
    return sample_s[k - 1] + f * (sample_s[k] - sample_s[k - 1]);
  }

  struct Projection
  {
    double s = 0.0, distance = std::numeric_limits<double>::infinity();
    bool before_start = false;
  };

  /// Nearest point to (px, py) on the segments with arc length in [lo, hi].
  Projection project(double px, double py, double lo, double hi) const
  {
    Projection best;
    lo = std::max(lo, 0.0);
    hi = std::max(hi, lo);
    // Segment i joins points i and i+1; the first one that can reach lo and the last that starts before hi.
    const std::size_t first =
        static_cast<std::size_t>(std::max<std::ptrdiff_t>(std::upper_bound(s.begin(), s.end(), lo) - s.begin() - 1, 0));
    const std::size_t last = static_cast<std::size_t>(std::upper_bound(s.begin(), s.end(), hi) - s.begin());
    if (x.size() == 1)
    {
      best.s = 0.0;
      best.distance = std::hypot(px - x[0], py - y[0]);
      best.before_start = true;
      return best;
    }
    for (std::size_t i = first; i + 1 < x.size() && i < last; ++i)
    {
      const double len = s[i + 1] - s[i];
      const double ux = (x[i + 1] - x[i]) / len, uy = (y[i + 1] - y[i]) / len;
      const double along = (px - x[i]) * ux + (py - y[i]) * uy;
      const double a = std::clamp(along, std::max(0.0, lo - s[i]), std::min(len, hi - s[i]));
      const double d = std::hypot(px - (x[i] + a * ux), py - (y[i] + a * uy));
      if (d < best.distance)
      {
        best.distance = d;
        best.s = s[i] + a;
        best.before_start = i == 0 && along < 0.0 && a == 0.0;
      }
    }
    return best;
  }
};
}  // namespace

std::vector<GapSample> gapSeries(const std::vector<OdometrySample>& leader, const std::vector<OdometrySample>& follower,
                                 double period)
{
  if (!(period > 0.0) || !std::isfinite(period))
    throw std::invalid_argument("gapSeries: period must be > 0 s");
  std::vector<GapSample> out;
  if (leader.empty() || follower.empty())
    return out;
  const LeaderPath path(leader);
  const double t_begin = leader.front().t, t_end = leader.back().t;
  double next = std::ceil(std::max(t_begin, follower.front().t) / period - 1e-9) * period;
  double s_previous = 0.0;
  bool has_previous = false;
  for (const OdometrySample& f : follower)
  {
    if (f.t < next - 1e-9 || f.t < t_begin)
      continue;
    if (f.t > t_end)
      break;
    next = (std::floor(f.t / period + 1e-9) + 1.0) * period;
    const double s_leader = path.sAtTime(f.t);
    const double lo = has_previous ? s_previous - kBacktrack : 0.0;
    const LeaderPath::Projection p = path.project(f.x, f.y, lo, s_leader);
    GapSample g;
    g.t = f.t;
    if (p.before_start)
    {
      // Behind the leader's start: the controller's first breadcrumb is the follower itself.
      g.gap = s_leader + std::hypot(f.x - path.x[0], f.y - path.y[0]);
      g.lateral = 0.0;
      s_previous = 0.0;
    }
    else
    {
      g.gap = s_leader - p.s;
      g.lateral = p.distance;
      s_previous = p.s;
    }
    has_previous = true;
    out.push_back(g);
  }
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
