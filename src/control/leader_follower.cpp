#include "avsp/control/leader_follower.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace control
{
namespace
{
void require(bool ok, const char* name, double value, const char* rule)
{
  if (!ok)
    throw std::invalid_argument(std::string(name) + " = " + std::to_string(value) + " must be " + rule);
}

const LeaderFollowerOptions& checked(const LeaderFollowerOptions& o)
{
  validate(o);
  return o;
}
}  // namespace

void validate(const LeaderFollowerOptions& o)
{
  validate(o.tracking);
  require(std::isfinite(o.gap) && o.gap >= 0.0, "gap", o.gap, "finite and >= 0 (m)");
  require(std::isfinite(o.offset), "offset", o.offset, "finite (m)");
  require(std::isfinite(o.gap_gain) && o.gap_gain > 0.0 && o.gap_gain <= 10.0, "gap_gain", o.gap_gain,
          "finite and in (0, 10] (1/s)");
  require(std::isfinite(o.accel_lead_time) && o.accel_lead_time >= 0.0 && o.accel_lead_time <= 10.0, "accel_lead_time",
          o.accel_lead_time, "finite and in [0, 10] (s)");
  require(std::isfinite(o.max_speed) && o.max_speed > 0.0, "max_speed", o.max_speed, "finite and > 0 (m/s)");
  require(std::isfinite(o.safety_distance) && o.safety_distance >= 0.0, "safety_distance", o.safety_distance,
          "finite and >= 0 (m)");
  require(std::isfinite(o.leader_timeout) && o.leader_timeout > 0.0, "leader_timeout", o.leader_timeout,
          "finite and > 0 (s)");
  require(std::isfinite(o.breadcrumb_spacing) && o.breadcrumb_spacing >= 0.01 && o.breadcrumb_spacing <= 100.0,
          "breadcrumb_spacing", o.breadcrumb_spacing, "finite and in [0.01, 100] (m)");
  require(std::isfinite(o.max_path_length) && o.max_path_length >= 10.0, "max_path_length", o.max_path_length,
          "finite and >= 10 (m)");
}

LeaderFollower::LeaderFollower(const SteeringGeometry& geometry, const LeaderFollowerOptions& options)
  : options_(checked(options)), tracker_(geometry, options.tracking)
{
}

bool LeaderFollower::addLeaderState(const LeaderState& state)
{
  if (!std::isfinite(state.stamp) || !std::isfinite(state.x) || !std::isfinite(state.y) ||
      !std::isfinite(state.heading) || !std::isfinite(state.speed) || !std::isfinite(state.acceleration))
    return false;
  if (leader_known_ && state.stamp < leader_.stamp)
    return true;  // late: an older state adds nothing
  const Vec2 p{ state.x, state.y };
  if (!leader_known_)
  {
    // The first crumb is the follower itself, so it has a path to the leader from the start.
    if (has_own_ && std::hypot(p.x - own_.x, p.y - own_.y) > options_.breadcrumb_spacing)
      crumbs_.append(own_);
    crumbs_.append(p);
  }
  else
  {
    const std::size_t n = crumbs_.size();
    const std::vector<Vec2>& pts = crumbs_.points();
    if (n >= 2 && std::hypot(pts[n - 1].x - pts[n - 2].x, pts[n - 1].y - pts[n - 2].y) < options_.breadcrumb_spacing)
      crumbs_.moveBack(p);  // the tip follows the leader until it is a spacing from the last crumb
    else
      crumbs_.append(p);
  }
  crumbs_.setEndHeading(state.heading);
  leader_ = state;
  leader_known_ = true;
  return true;
}

FollowerStatus LeaderFollower::update(const Pose2& base, double speed, double t)
{
  own_ = { base.x, base.y };
  has_own_ = true;
  FollowerStatus fs;
  fs.desired_gap = options_.gap;
  fs.leader_known = leader_known_;
  if (!leader_known_ || crumbs_.empty())
  {
    fs.tracking.speed = speed;
    fs.tracking.command = tracker_.stop();
    return fs;
  }
  const double age = t - leader_.stamp;
  fs.leader_fresh = age <= options_.leader_timeout;
  fs.leader_speed = leader_.speed;

  // Gap along the path, from base_link to the leader's predicted position.
  const double s_leader = crumbs_.endS() + leader_.speed * std::clamp(age, 0.0, options_.leader_timeout);
  const Vec2 own{ base.x, base.y };
  const PathProjection own_projection = has_base_s_ ? crumbs_.project(own, base_s_ - PathTracker::kSearchBehind,
                                                                      base_s_ + 3.0 * PathTracker::kSearchAhead)
                                                    : crumbs_.project(own);
  base_s_ = own_projection.s;
  has_base_s_ = true;
  fs.gap = s_leader - own_projection.s;
  const Vec2 leader_now = crumbs_.pointAt(s_leader);
  fs.too_close = std::hypot(leader_now.x - base.x, leader_now.y - base.y) < options_.safety_distance;

  double target = 0.0;
  if (fs.leader_fresh && !fs.too_close)
    target = std::clamp(
        leader_.speed + options_.accel_lead_time * leader_.acceleration + options_.gap_gain * (fs.gap - options_.gap),
        0.0, options_.max_speed);
  fs.tracking = tracker_.track(crumbs_, base, speed, target, options_.offset, t);
  if (!fs.leader_fresh || fs.too_close)
  {
    const double steering = fs.tracking.command.steering;
    fs.tracking.command = tracker_.stop();
    fs.tracking.command.steering = steering;
  }

  crumbs_.dropBefore(std::min(own_projection.s, tracker_.progress()) - kKeepBehind);
  if (crumbs_.length() > options_.max_path_length)
    crumbs_.dropBefore(crumbs_.endS() - options_.max_path_length);
  return fs;
}

void LeaderFollower::setGap(double gap)
{
  require(std::isfinite(gap) && gap >= 0.0, "gap", gap, "finite and >= 0 (m)");
  options_.gap = gap;
}

void LeaderFollower::setOffset(double offset)
{
  require(std::isfinite(offset), "offset", offset, "finite (m)");
  options_.offset = offset;
}

FormationType formationFromString(const std::string& name)
{
  if (name == "column")
    return FormationType::kColumn;
  if (name == "line")
    return FormationType::kLine;
  if (name == "diamond")
    return FormationType::kDiamond;
  throw std::invalid_argument("formation '" + name + "' is not one of column, line, diamond");
}

std::vector<FormationSlot> formationSlots(FormationType type, std::size_t count, double spacing, double width)
{
  if (count == 0)
    throw std::invalid_argument("formation: count must be > 0");
  require(std::isfinite(spacing) && spacing > 0.0, "spacing", spacing, "finite and > 0 (m)");
  require(std::isfinite(width) && width > 0.0, "width", width, "finite and > 0 (m)");
  std::vector<FormationSlot> slots(count);
  for (std::size_t k = 1; k < count; ++k)
  {
    FormationSlot& slot = slots[k];
    const int previous = static_cast<int>(k) - 1;
    switch (type)
    {
      case FormationType::kColumn:
        slot = { previous, spacing, 0.0 };
        break;
      case FormationType::kLine:
      {
        const double rank = static_cast<double>((k + 1) / 2);
        slot = { 0, 0.0, (k % 2 == 1 ? -1.0 : 1.0) * rank * width };
        break;
      }
      case FormationType::kDiamond:
        if (k == 1)
          slot = { 0, spacing, width };
        else if (k == 2)
          slot = { 0, spacing, -width };
        else if (k == 3)
          slot = { 0, 2.0 * spacing, 0.0 };
        else
          slot = { previous, spacing, 0.0 };
        break;
    }
  }
  return slots;
}

}  // namespace control
}  // namespace avsp
