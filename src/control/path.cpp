#include "avsp/control/path.hpp"

#include <algorithm>
#include <cmath>

namespace avsp
{
namespace control
{
namespace
{
constexpr double kMinSpacing = 1e-3;  // m, points closer than this are one point

double distance(const Vec2& a, const Vec2& b)
{
  return std::hypot(b.x - a.x, b.y - a.y);
}
}  // namespace

double wrapAngle(double angle)
{
  angle = std::remainder(angle, 2.0 * M_PI);
  return angle <= -M_PI ? angle + 2.0 * M_PI : angle;
}

Path::Path(const std::vector<Vec2>& points)
{
  for (const Vec2& p : points)
    append(p);
}

void Path::append(const Vec2& p)
{
  if (points_.empty())
  {
    points_.push_back(p);
    s_.push_back(0.0);
    return;
  }
  const double d = distance(points_.back(), p);
  if (d < kMinSpacing)
    return;
  s_.push_back(s_.back() + d);
  points_.push_back(p);
}

void Path::moveBack(const Vec2& p)
{
  if (points_.size() < 2)
  {
    append(p);  // the first point, or the second that makes the first segment
    return;
  }
  const std::size_t n = points_.size();
  const double d = distance(points_[n - 2], p);
  if (d < kMinSpacing)
  {
    points_.pop_back();
    s_.pop_back();
    return;
  }
  points_[n - 1] = p;
  s_[n - 1] = s_[n - 2] + d;
}

void Path::dropBefore(double s)
{
  std::size_t drop = 0;
  while (drop + 2 < points_.size() && s_[drop + 1] <= s)
    ++drop;
  if (drop == 0)
    return;
  points_.erase(points_.begin(), points_.begin() + static_cast<std::ptrdiff_t>(drop));
  s_.erase(s_.begin(), s_.begin() + static_cast<std::ptrdiff_t>(drop));
}

void Path::setEndHeading(double heading)
{
  has_end_heading_ = true;
  end_heading_ = heading;
}

double Path::endHeading() const
{
  if (has_end_heading_)
    return end_heading_;
  if (points_.size() < 2)
    return 0.0;
  const Vec2& a = points_[points_.size() - 2];
  const Vec2& b = points_.back();
  return std::atan2(b.y - a.y, b.x - a.x);
}

std::size_t Path::segmentAt(double s) const
{
  // First point with arc length > s, minus one: the segment's start.
  const auto it = std::upper_bound(s_.begin(), s_.end(), s);
  std::size_t i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - s_.begin() - 1, 0));
  return std::min(i, points_.size() - 2);
}

Vec2 Path::pointAt(double s) const
{
  if (points_.empty())
    return {};
  if (s <= startS())
    return points_.front();
  if (s >= endS())
  {
    const double h = endHeading();
    const double beyond = s - endS();
    return { points_.back().x + beyond * std::cos(h), points_.back().y + beyond * std::sin(h) };
  }
  const std::size_t i = segmentAt(s);
  const double f = (s - s_[i]) / (s_[i + 1] - s_[i]);
  return { points_[i].x + f * (points_[i + 1].x - points_[i].x), points_[i].y + f * (points_[i + 1].y - points_[i].y) };
}

double Path::headingAt(double s) const
{
  if (points_.size() < 2 || s >= endS())
    return endHeading();
  const std::size_t i = segmentAt(s);
  return std::atan2(points_[i + 1].y - points_[i].y, points_[i + 1].x - points_[i].x);
}

Vec2 Path::offsetPointAt(double s, double offset) const
{
  const Vec2 p = pointAt(s);
  const double h = headingAt(s);
  return { p.x - offset * std::sin(h), p.y + offset * std::cos(h) };
}

PathProjection Path::project(const Vec2& p, double s_min, double s_max) const
{
  PathProjection best;
  best.distance = std::numeric_limits<double>::infinity();
  if (points_.empty())
    return best;
  s_min = std::max(s_min, startS());
  if (s_max < s_min)
    s_max = s_min;
  auto consider = [&](const Vec2& a, double s_a, double heading, double t_max) {
    // Nearest point to p on the ray a + t (cos h, sin h), t in [0, t_max], within the window.
    const double ux = std::cos(heading), uy = std::sin(heading);
    double t = (p.x - a.x) * ux + (p.y - a.y) * uy;
    t = std::clamp(t, std::max(0.0, s_min - s_a), std::min(t_max, s_max - s_a));
    const Vec2 q{ a.x + t * ux, a.y + t * uy };
    const double d = distance(q, p);
    if (d < best.distance)
    {
      best.distance = d;
      best.s = s_a + t;
      best.point = q;
      best.lateral = -(p.x - q.x) * uy + (p.y - q.y) * ux;
      // Off the segment's ends the offset is not along the normal: keep the sign of the cross product.
      if (std::abs(std::abs(best.lateral) - d) > 1e-9)
        best.lateral = (best.lateral >= 0.0 ? 1.0 : -1.0) * d;
    }
  };
  for (std::size_t i = 0; i + 1 < points_.size(); ++i)
  {
    if (s_[i + 1] < s_min || s_[i] > s_max)
      continue;
    const Vec2& a = points_[i];
    const Vec2& b = points_[i + 1];
    consider(a, s_[i], std::atan2(b.y - a.y, b.x - a.x), s_[i + 1] - s_[i]);
  }
  if (s_max >= endS())
    consider(points_.back(), endS(), endHeading(), std::numeric_limits<double>::infinity());
  return best;
}

PathProjection Path::projectFirst(const Vec2& p, double slack, double separation) const
{
  PathProjection best = project(p);
  const double limit = best.distance + slack;
  for (;;)
  {
    if (best.s - separation <= startS())
      return best;
    const PathProjection earlier = project(p, startS(), best.s - separation);
    if (earlier.distance > limit)
      return best;
    best = earlier;
  }
}

}  // namespace control
}  // namespace avsp
