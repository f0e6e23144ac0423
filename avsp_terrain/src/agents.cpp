#include "avsp_terrain/agents.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace avsp
{
namespace terrain
{
namespace
{
/// m: consecutive path points closer than this are refused (the spline's knot spacing would vanish).
constexpr double kMinPointSpacing = 1e-3;
/// m: longest step between height samples along a path (half a grid cell when finer).
constexpr double kMaxProfileStep = 0.1;
/// Height samples per path at most (a 1000 km path at 0.1 m): a guard against absurd input.
constexpr std::size_t kMaxProfileSamples = 10000000;

// 5-point Gauss-Legendre on [-1, 1]: exact for polynomials up to degree 9; |C'(u)| of a cubic is
// the square root of a quartic, smooth within each of a segment's 32 sub-intervals.
constexpr std::array<double, 5> kGaussX = { 0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                                            0.9061798459386640 };
constexpr std::array<double, 5> kGaussW = { 0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                            0.2369268850561891, 0.2369268850561891 };

std::string str(double v)
{
  std::ostringstream s;
  s << v;
  return s.str();
}

AgentBox box(double cx, double cy, double cz, double sx, double sy, double sz)
{
  return AgentBox{ Eigen::Vector3d(cx, cy, cz), Eigen::Vector3d(sx, sy, sz) };
}
}  // namespace

const char* toString(AgentType type)
{
  switch (type)
  {
    case AgentType::kDeer:
      return "deer";
    case AgentType::kPedestrian:
      return "pedestrian";
    case AgentType::kTruck:
      return "truck";
  }
  return "unknown";
}

std::optional<AgentType> agentTypeFromString(const std::string& name)
{
  for (AgentType t : { AgentType::kDeer, AgentType::kPedestrian, AgentType::kTruck })
    if (name == toString(t))
      return t;
  return std::nullopt;
}

const std::vector<AgentBox>& agentBoxes(AgentType type)
{
  // Origin on the ground under the torso's (or the body's) centre, x forward.
  static const std::vector<AgentBox> deer = {
    box(0.0, 0.0, 0.775, 1.3, 0.4, 0.45),   // torso: 0.55-1.0 m (1.0 m at the shoulder)
    box(0.8, 0.0, 1.15, 0.3, 0.2, 0.6),     // neck and head, up to 1.45 m, nose at 0.95 m
    box(0.5, 0.12, 0.275, 0.1, 0.1, 0.55),  // legs
    box(0.5, -0.12, 0.275, 0.1, 0.1, 0.55),  box(-0.5, 0.12, 0.275, 0.1, 0.1, 0.55),
    box(-0.5, -0.12, 0.275, 0.1, 0.1, 0.55),
  };
  static const std::vector<AgentBox> pedestrian = { box(0.0, 0.0, 0.875, 0.3, 0.5, 1.75) };
  static const std::vector<AgentBox> truck = {
    box(0.0, 0.0, 1.85, 8.0, 2.5, 2.7),  // cab and cargo body, 0.5-3.2 m
    box(0.0, 0.0, 0.25, 6.5, 2.4, 0.5),  // axles, wheels, frame
  };
  switch (type)
  {
    case AgentType::kDeer:
      return deer;
    case AgentType::kPedestrian:
      return pedestrian;
    case AgentType::kTruck:
      return truck;
  }
  return deer;
}

namespace
{
void bounds(AgentType type, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (const AgentBox& b : agentBoxes(type))
  {
    lo = lo.cwiseMin(b.centre - 0.5 * b.size);
    hi = hi.cwiseMax(b.centre + 0.5 * b.size);
  }
}
}  // namespace

double agentMass(AgentType type)
{
  switch (type)
  {
    case AgentType::kDeer:
      return 100.0;
    case AgentType::kPedestrian:
      return 80.0;
    case AgentType::kTruck:
      return 10000.0;
  }
  return 100.0;
}

double agentPushForce(AgentType type)
{
  const double weight = agentMass(type) * 9.81;
  switch (type)
  {
    case AgentType::kDeer:
      return weight;
    case AgentType::kPedestrian:
      return 0.5 * weight;
    case AgentType::kTruck:
      return 0.7 * weight;
  }
  return weight;
}

Eigen::Vector3d agentSize(AgentType type)
{
  Eigen::Vector3d lo, hi;
  bounds(type, lo, hi);
  return hi - lo;
}

Eigen::Vector3d agentBoundsCentre(AgentType type)
{
  Eigen::Vector3d lo, hi;
  bounds(type, lo, hi);
  return 0.5 * (lo + hi);
}

void validateAgentSpec(const AgentSpec& spec, const std::string& key)
{
  auto fail = [&](const std::string& field, const std::string& why) {
    throw std::invalid_argument(key + "." + field + ": " + why);
  };
  if (spec.name.empty())
    fail("name", "must not be empty");
  for (char c : spec.name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_'))
      fail("name",
           "'" + spec.name + "' must be letters, digits and '_' only (it names the frame agents/" + spec.name + ")");
  if (!std::isalpha(static_cast<unsigned char>(spec.name[0])))
    fail("name", "'" + spec.name + "' must start with a letter");
  if (!std::isfinite(spec.speed) || spec.speed < 0.0)
    fail("speed", "must be finite and >= 0 m/s, got " + str(spec.speed));
  if (!std::isfinite(spec.start_time) || spec.start_time < 0.0)
    fail("start_time", "must be finite and >= 0 s, got " + str(spec.start_time));
  if (!std::isfinite(spec.yaw))
    fail("yaw", "must be finite (rad), got " + str(spec.yaw));
  if (spec.path.empty())
    fail("path", "needs at least one point");
  for (std::size_t k = 0; k < spec.path.size(); ++k)
    if (!spec.path[k].allFinite())
      fail("path[" + std::to_string(k) + "]",
           "must be finite (x, y) m, got (" + str(spec.path[k].x()) + ", " + str(spec.path[k].y()) + ")");
  const std::size_t needed = spec.loop ? 3 : 2;
  if (spec.speed > 0.0 && spec.path.size() < needed)
    fail("path", std::string("a moving ") + (spec.loop ? "looping " : "") + "agent needs at least " +
                     std::to_string(needed) + " points, got " + std::to_string(spec.path.size()));
  if (spec.loop && spec.path.size() < 3 && spec.path.size() > 1)
    fail("loop", "a loop needs at least 3 points, got " + std::to_string(spec.path.size()));
  const std::size_t n = spec.path.size();
  const std::size_t pairs = spec.loop ? n : n - 1;
  for (std::size_t k = 0; n > 1 && k < pairs; ++k)
  {
    const std::size_t next = (k + 1) % n;
    if ((spec.path[next] - spec.path[k]).norm() < kMinPointSpacing)
      fail("path[" + std::to_string(next) + "]",
           "is within 1 mm of path[" + std::to_string(k) + "]" +
               (next == 0 ? std::string(" (a loop closes itself: do not repeat the first point)") : std::string()));
  }
}

void validateAgentSpecs(const std::vector<AgentSpec>& specs, const std::string& list_key)
{
  std::set<std::string> names;
  for (std::size_t k = 0; k < specs.size(); ++k)
  {
    const std::string key = list_key + "[" + std::to_string(k) + "]";
    validateAgentSpec(specs[k], key);
    if (!names.insert(specs[k].name).second)
      throw std::invalid_argument(key + ".name: '" + specs[k].name + "' is used by another agent");
  }
}

namespace
{
/// A plain YAML scalar that reads as a number (a quoted scalar is a string).
bool yamlNumber(const YAML::Node& n, double& out)
{
  if (!n.IsScalar() || n.Tag() == "!")
    return false;
  try
  {
    out = n.as<double>();
    return true;
  }
  catch (const YAML::Exception&)
  {
    return false;
  }
}

/// A plain YAML scalar that reads as a string.
bool yamlString(const YAML::Node& n, std::string& out)
{
  if (!n.IsScalar())
    return false;
  out = n.Scalar();
  return true;
}
}  // namespace

std::vector<AgentSpec> parseAgentSpecs(const YAML::Node& list, const std::string& list_key)
{
  if (!list.IsSequence())
    throw std::invalid_argument(list_key + " must be a list of {name, type, path, speed, start_time, loop, yaw}");
  std::vector<AgentSpec> specs;
  for (std::size_t k = 0; k < list.size(); ++k)
  {
    const std::string where = list_key + "[" + std::to_string(k) + "]";
    const YAML::Node e = list[k];
    if (!e.IsMap())
      throw std::invalid_argument(where + " must be a map {name, type, path, ...}");
    static const std::array<const char*, 7> known{ "name", "type", "path", "speed", "start_time", "loop", "yaw" };
    for (const auto& kv : e)
    {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string("?");
      if (std::none_of(known.begin(), known.end(), [&](const char* n) { return key == n; }))
        throw std::invalid_argument(where + "." + key +
                                    ": unknown key (known: name, type, path, speed, start_time, loop, yaw)");
    }
    for (const char* required : { "name", "type", "path" })
      if (!e[required])
        throw std::invalid_argument(where + "." + required + ": missing (required)");
    AgentSpec s;
    if (!yamlString(e["name"], s.name))
      throw std::invalid_argument(where + ".name: must be a string");
    std::string type;
    if (!yamlString(e["type"], type))
      throw std::invalid_argument(where + ".type: must be a string (deer, pedestrian or truck)");
    const std::optional<AgentType> t = agentTypeFromString(type);
    if (!t)
      throw std::invalid_argument(where + ".type: unknown agent type '" + type + "' (deer, pedestrian or truck)");
    s.type = *t;
    const YAML::Node path = e["path"];
    if (!path.IsSequence())
      throw std::invalid_argument(where + ".path: must be a list of [x, y] points (m)");
    for (std::size_t p = 0; p < path.size(); ++p)
    {
      double x = 0.0, y = 0.0;
      if (!path[p].IsSequence() || path[p].size() != 2 || !yamlNumber(path[p][0], x) || !yamlNumber(path[p][1], y))
        throw std::invalid_argument(where + ".path[" + std::to_string(p) + "]: must be a pair of numbers [x, y] (m)");
      s.path.emplace_back(x, y);
    }
    for (const auto& [field, target] : { std::pair<const char*, double*>{ "speed", &s.speed },
                                         std::pair<const char*, double*>{ "start_time", &s.start_time },
                                         std::pair<const char*, double*>{ "yaw", &s.yaw } })
      if (e[field] && !yamlNumber(e[field], *target))
        throw std::invalid_argument(where + "." + field + ": must be a number");
    if (e["loop"])
    {
      const YAML::Node loop = e["loop"];
      bool value = false;
      if (!loop.IsScalar() || loop.Tag() == "!" || !YAML::convert<bool>::decode(loop, value))
        throw std::invalid_argument(where + ".loop: must be true or false");
      s.loop = value;
    }
    specs.push_back(std::move(s));
  }
  validateAgentSpecs(specs, list_key);
  return specs;
}

// ---- AgentPath ------------------------------------------------------------------------------

AgentPath::AgentPath(std::vector<Eigen::Vector2d> points, bool closed) : closed_(closed)
{
  const std::size_t n = points.size();
  if (n < (closed ? 3u : 2u))
    throw std::invalid_argument("AgentPath: " + std::to_string(n) + " points, need " + (closed ? "3" : "2"));
  for (std::size_t k = 0; k + 1 < n + (closed ? 1 : 0); ++k)
    if ((points[(k + 1) % n] - points[k]).norm() < kMinPointSpacing)
      throw std::invalid_argument("AgentPath: points " + std::to_string(k) + " and " + std::to_string((k + 1) % n) +
                                  " coincide");
  // Neighbour k of the path, with phantom points reflected through the ends of an open path.
  auto at = [&](long k) -> Eigen::Vector2d {
    const long m = static_cast<long>(n);
    if (closed)
      return points[static_cast<std::size_t>(((k % m) + m) % m)];
    if (k < 0)
      return 2.0 * points[0] - points[1];
    if (k >= m)
      return 2.0 * points[n - 1] - points[n - 2];
    return points[static_cast<std::size_t>(k)];
  };
  const std::size_t count = closed ? n : n - 1;
  double s = 0.0;
  for (std::size_t i = 0; i < count; ++i)
  {
    const long k = static_cast<long>(i);
    const Eigen::Vector2d p0 = at(k - 1), p1 = at(k), p2 = at(k + 1), p3 = at(k + 2);
    // Centripetal knot intervals |P_{i+1} - P_i|^(1/2); the tangents of the non-uniform
    // Catmull-Rom segment in Hermite form (derivative by knot parameter, scaled to u in [0, 1]).
    const double d0 = std::sqrt((p1 - p0).norm()), d1 = std::sqrt((p2 - p1).norm()), d2 = std::sqrt((p3 - p2).norm());
    Segment g;
    g.p1 = p1;
    g.p2 = p2;
    g.m1 = d1 * ((p1 - p0) / d0 - (p2 - p0) / (d0 + d1) + (p2 - p1) / d1);
    g.m2 = d1 * ((p2 - p1) / d1 - (p3 - p1) / (d1 + d2) + (p3 - p2) / d2);
    g.s.resize(kSubdivisions + 1);
    g.s[0] = s;
    for (int j = 0; j < kSubdivisions; ++j)
      g.s[j + 1] =
          g.s[j] + arcLength(g, static_cast<double>(j) / kSubdivisions, static_cast<double>(j + 1) / kSubdivisions);
    s = g.s.back();
    segments_.push_back(std::move(g));
  }
  length_ = s;
}

Eigen::Vector2d AgentPath::point(const Segment& g, double u) const
{
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * g.p1 + (u3 - 2 * u2 + u) * g.m1 + (-2 * u3 + 3 * u2) * g.p2 + (u3 - u2) * g.m2;
}

Eigen::Vector2d AgentPath::derivative(const Segment& g, double u) const
{
  const double u2 = u * u;
  return (6 * u2 - 6 * u) * g.p1 + (3 * u2 - 4 * u + 1) * g.m1 + (-6 * u2 + 6 * u) * g.p2 + (3 * u2 - 2 * u) * g.m2;
}

Eigen::Vector2d AgentPath::secondDerivative(const Segment& g, double u) const
{
  return (12 * u - 6) * g.p1 + (6 * u - 4) * g.m1 + (-12 * u + 6) * g.p2 + (6 * u - 2) * g.m2;
}

double AgentPath::arcLength(const Segment& g, double u0, double u1) const
{
  const double half = 0.5 * (u1 - u0), mid = 0.5 * (u0 + u1);
  double sum = 0.0;
  for (std::size_t k = 0; k < kGaussX.size(); ++k)
    sum += kGaussW[k] * derivative(g, mid + half * kGaussX[k]).norm();
  return half * sum;
}

PathSample AgentPath::sample(double s) const
{
  if (closed_)
  {
    s = std::fmod(s, length_);
    if (s < 0.0)
      s += length_;
  }
  s = std::clamp(s, 0.0, length_);
  // The segment, then the sub-interval holding s.
  std::size_t i = 0;
  while (i + 1 < segments_.size() && s > segments_[i].s.back())
    ++i;
  const Segment& g = segments_[i];
  const auto it = std::upper_bound(g.s.begin() + 1, g.s.end() - 1, s);
  const std::size_t j = static_cast<std::size_t>(it - g.s.begin()) - 1;
  double lo = static_cast<double>(j) / kSubdivisions, hi = static_cast<double>(j + 1) / kSubdivisions;
  const double s_lo = g.s[j], s_hi = g.s[j + 1];
  const double u_lo = lo;
  // Newton on s(u) = s within [lo, hi], bisecting when a step leaves the bracket.
  double u = s_hi > s_lo ? lo + (hi - lo) * (s - s_lo) / (s_hi - s_lo) : lo;
  for (int iteration = 0; iteration < 50; ++iteration)
  {
    const double f = s_lo + arcLength(g, u_lo, u) - s;
    if (std::abs(f) < 1e-12 * std::max(1.0, length_))
      break;
    if (f > 0.0)
      hi = u;
    else
      lo = u;
    const double speed = derivative(g, u).norm();
    double next = speed > 0.0 ? u - f / speed : 0.5 * (lo + hi);
    if (!(next > lo && next < hi))
      next = 0.5 * (lo + hi);
    if (next == u)
      break;
    u = next;
  }
  PathSample out;
  out.position = point(g, u);
  const Eigen::Vector2d d1 = derivative(g, u), d2 = secondDerivative(g, u);
  const double speed = d1.norm();
  if (speed > 0.0)
  {
    out.tangent = d1 / speed;
    out.curvature = (d1.x() * d2.y() - d1.y() * d2.x()) / (speed * speed * speed);
  }
  return out;
}

// ---- Agent ----------------------------------------------------------------------------------

Agent::Agent(AgentSpec spec, const ElevationGrid& ground, const std::string& key) : spec_(std::move(spec))
{
  validateAgentSpec(spec_, key);
  if (spec_.path.size() >= 2)
    path_.emplace(spec_.path, spec_.loop);
  profile_step_ = std::min(kMaxProfileStep, 0.5 * std::min(ground.dx(), ground.dy()));
  const double length = this->length();
  const std::size_t intervals = static_cast<std::size_t>(std::ceil(length / profile_step_));
  if (intervals > kMaxProfileSamples)
    throw std::invalid_argument(key + ".path: " + str(length) + " m long, more than the " +
                                std::to_string(kMaxProfileSamples) + " height samples allowed at " +
                                str(profile_step_) + " m");
  if (intervals > 0)
    profile_step_ = length / static_cast<double>(intervals);
  profile_.resize(intervals + 1);
  for (std::size_t k = 0; k <= intervals; ++k)
  {
    const Eigen::Vector2d p = path_ ? path_->sample(static_cast<double>(k) * profile_step_).position : spec_.path[0];
    const std::optional<double> z = ground.height(p.x(), p.y());
    if (!z)
      throw std::invalid_argument(key + ".path: leaves the terrain at (" + str(p.x()) + ", " + str(p.y()) +
                                  ") m (the spline through the points included)");
    profile_[k] = *z;
  }
}

double Agent::period() const
{
  if (!path_ || !(spec_.speed > 0.0))
    return std::numeric_limits<double>::infinity();
  return path_->length() / spec_.speed;
}

double Agent::heightAt(double s, double& slope) const
{
  slope = 0.0;
  if (profile_.size() < 2)
    return profile_.front();
  const double x = std::clamp(s / profile_step_, 0.0, static_cast<double>(profile_.size() - 1));
  const std::size_t k = std::min(static_cast<std::size_t>(x), profile_.size() - 2);
  const double f = x - static_cast<double>(k);
  slope = (profile_[k + 1] - profile_[k]) / profile_step_;
  return profile_[k] + f * (profile_[k + 1] - profile_[k]);
}

AgentState Agent::state(double t) const
{
  AgentState out;
  if (!path_)
  {
    out.position = Eigen::Vector3d(spec_.path[0].x(), spec_.path[0].y(), profile_.front());
    out.yaw = spec_.yaw;
    return out;
  }
  double s = 0.0;
  if (spec_.speed > 0.0 && t > spec_.start_time)
  {
    const double travelled = spec_.speed * (t - spec_.start_time);
    if (spec_.loop)
    {
      s = std::fmod(travelled, path_->length());
      out.moving = true;
    }
    else if (travelled < path_->length())
    {
      s = travelled;
      out.moving = true;
    }
    else
      s = path_->length();
  }
  const PathSample p = path_->sample(s);
  double slope = 0.0;
  const double z = heightAt(s, slope);
  out.position = Eigen::Vector3d(p.position.x(), p.position.y(), z);
  out.yaw = std::atan2(p.tangent.y(), p.tangent.x());
  if (out.moving)
  {
    out.velocity = Eigen::Vector3d(spec_.speed * p.tangent.x(), spec_.speed * p.tangent.y(), spec_.speed * slope);
    out.yaw_rate = spec_.speed * p.curvature;
  }
  return out;
}

std::vector<Agent> makeAgents(const std::vector<AgentSpec>& specs, const ElevationGrid& ground,
                              const std::string& list_key)
{
  validateAgentSpecs(specs, list_key);
  std::vector<Agent> agents;
  agents.reserve(specs.size());
  for (std::size_t k = 0; k < specs.size(); ++k)
    agents.emplace_back(specs[k], ground, list_key + "[" + std::to_string(k) + "]");
  return agents;
}

}  // namespace terrain
}  // namespace avsp
