#include "avsp/control/pure_pursuit.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace control
{
void validate(const LookaheadOptions& o)
{
  if (!std::isfinite(o.min) || o.min <= 0.0)
    throw std::invalid_argument("lookahead_min = " + std::to_string(o.min) + " must be finite and > 0 (m)");
  if (!std::isfinite(o.gain) || o.gain < 0.0)
    throw std::invalid_argument("lookahead_gain = " + std::to_string(o.gain) + " must be finite and >= 0 (s)");
  if (!std::isfinite(o.max) || o.max < o.min)
    throw std::invalid_argument("lookahead_max = " + std::to_string(o.max) +
                                " must be finite and >= lookahead_min (m)");
}

double lookaheadDistance(const LookaheadOptions& o, double speed)
{
  return std::clamp(o.min + o.gain * std::abs(speed), o.min, o.max);
}

double purePursuitCurvature(const Pose2& pose, const Vec2& target)
{
  const double dx = target.x - pose.x;
  const double dy = target.y - pose.y;
  const double d2 = dx * dx + dy * dy;
  if (d2 < 1e-12)
    return 0.0;
  // Lateral offset of the target in the vehicle frame: y = L_d sin(alpha), so
  // 2 sin(alpha) / L_d = 2 y / L_d^2.
  const double lateral = -std::sin(pose.yaw) * dx + std::cos(pose.yaw) * dy;
  return 2.0 * lateral / d2;
}

PursuitTarget pursue(const Path& path, const Pose2& pose, double s_reference, double lookahead, double offset)
{
  PursuitTarget t;
  t.s = s_reference + lookahead;
  t.point = path.offsetPointAt(t.s, offset);
  t.curvature = purePursuitCurvature(pose, t.point);
  return t;
}

}  // namespace control
}  // namespace avsp
