#include "avsp/v2v/radio.hpp"

#include <cmath>
#include <set>
#include <sstream>

namespace avsp
{
namespace v2v
{
namespace
{
std::string number(double v)
{
  std::ostringstream s;
  s << v;
  return s.str();
}

/// 64-bit FNV-1a of a string: a fixed function, unlike std::hash, so draws are the same everywhere.
std::uint64_t fnv1a(const std::string& text)
{
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text)
  {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

/// SplitMix64's finaliser: a bijective mix whose output bits all depend on every input bit.
std::uint64_t mix(std::uint64_t z)
{
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
}  // namespace

const std::vector<RadioNumber>& radioNumbers()
{
  static const std::vector<RadioNumber> numbers{
    { "range", &RadioOptions::range, 1e-3, 1e6, "m" },
    { "latency", &RadioOptions::latency, 0.0, 3600.0, "s" },
    { "loss_probability", &RadioOptions::loss_probability, 0.0, 1.0, "" },
    { "antenna_height", &RadioOptions::antenna_height, 0.0, 1000.0, "m" },
    { "los_step", &RadioOptions::los_step, 0.01, 100.0, "m" },
  };
  return numbers;
}

Radio::Radio(std::vector<std::string> vehicles, const RadioOptions& options, HeightFunction terrain)
  : vehicles_(std::move(vehicles)), options_(options), terrain_(std::move(terrain))
{
  if (vehicles_.empty())
    throw std::invalid_argument("vehicles: the list is empty");
  std::set<std::string> seen;
  for (const std::string& v : vehicles_)
  {
    if (v.empty())
      throw std::invalid_argument("vehicles: a name is empty");
    if (!seen.insert(v).second)
      throw std::invalid_argument("vehicles: '" + v + "' is listed twice");
  }
  for (const RadioNumber& n : radioNumbers())
  {
    const double v = options_.*n.member;
    if (!(std::isfinite(v) && v >= n.min && v <= n.max))
      throw std::invalid_argument(std::string(n.key) + " = " + number(v) + " must be finite and in [" + number(n.min) +
                                  ", " + number(n.max) + "]" + (*n.unit ? std::string(" ") + n.unit : ""));
  }
  if (options_.line_of_sight && !terrain_)
    throw std::invalid_argument("line_of_sight is on but no terrain was given");
  antennas_.resize(vehicles_.size());
  known_.assign(vehicles_.size(), false);
}

double Radio::lossDraw(std::uint64_t seed, const std::string& sender, const std::string& receiver, std::uint32_t seq)
{
  std::uint64_t h = mix(seed);
  h = mix(h ^ fnv1a(sender));
  h = mix(h ^ (fnv1a(receiver) * 0x9e3779b97f4a7c15ull));
  h = mix(h ^ seq);
  return static_cast<double>(h >> 11) * 0x1.0p-53;  // 53 random bits -> [0, 1)
}

std::size_t Radio::indexOf(const std::string& name) const
{
  for (std::size_t k = 0; k < vehicles_.size(); ++k)
    if (vehicles_[k] == name)
      return k;
  return vehicles_.size();
}

bool Radio::antenna(std::size_t k, Vec3& out) const
{
  if (k >= vehicles_.size() || !known_[k])
    return false;
  out = antennas_[k];
  return true;
}

bool Radio::lineOfSight(const Vec3& a, const Vec3& b) const
{
  if (!terrain_)
    return true;
  const double dx = b.x - a.x, dy = b.y - a.y, dz = b.z - a.z;
  const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
  const std::size_t intervals = static_cast<std::size_t>(std::ceil(length / options_.los_step));
  for (std::size_t k = 1; k < intervals; ++k)  // the end points are the antennas themselves
  {
    const double u = static_cast<double>(k) / static_cast<double>(intervals);
    double ground = 0.0;
    if (terrain_(a.x + u * dx, a.y + u * dy, ground) && ground > a.z + u * dz)
      return false;
  }
  return true;
}

Link Radio::linkBetween(const Vec3& a, const Vec3& b) const
{
  const double distance = std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
  if (!(distance <= options_.range))
    return Link::OutOfRange;
  if (options_.line_of_sight && !lineOfSight(a, b))
    return Link::Blocked;
  return Link::Up;
}

Link Radio::link(std::size_t a, std::size_t b) const
{
  if (a >= vehicles_.size() || b >= vehicles_.size() || !known_[a] || !known_[b])
    return Link::Unknown;
  return linkBetween(antennas_[a], antennas_[b]);
}

std::vector<Delivery> Radio::transmit(std::size_t sender, const Vec3& position, std::uint32_t seq, double stamp,
                                      std::uint64_t message)
{
  if (sender >= vehicles_.size())
    throw std::out_of_range("Radio::transmit: sender " + std::to_string(sender) + " is not a listed vehicle");
  ++stats_.broadcasts;
  antennas_[sender] = Vec3{ position.x, position.y, position.z + options_.antenna_height };
  known_[sender] = true;
  std::vector<Delivery> scheduled;
  for (std::size_t r = 0; r < vehicles_.size(); ++r)
  {
    if (r == sender)
      continue;
    if (!known_[r])
    {
      ++stats_.unknown;
      continue;
    }
    switch (linkBetween(antennas_[sender], antennas_[r]))
    {
      case Link::OutOfRange:
        ++stats_.out_of_range;
        continue;
      case Link::Blocked:
        ++stats_.blocked;
        continue;
      default:
        break;
    }
    if (lossDraw(options_.seed, vehicles_[sender], vehicles_[r], seq) < options_.loss_probability)
    {
      ++stats_.lost;
      continue;
    }
    const Delivery d{ stamp + options_.latency, r, message };
    scheduled.push_back(d);
    queue_.push(d);
    ++stats_.delivered;
  }
  return scheduled;
}

std::vector<Delivery> Radio::due(double now)
{
  std::vector<Delivery> out;
  while (!queue_.empty() && queue_.top().due <= now + 1e-9)
  {
    out.push_back(queue_.top());
    queue_.pop();
  }
  return out;
}

}  // namespace v2v
}  // namespace avsp
