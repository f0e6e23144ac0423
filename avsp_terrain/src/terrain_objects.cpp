#include "avsp_terrain/terrain_objects.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace avsp
{
namespace terrain
{
const char* toString(ObjectType type)
{
  switch (type)
  {
    case ObjectType::kTree:
      return "tree";
    case ObjectType::kShrub:
      return "shrub";
    case ObjectType::kGrass:
      return "grass";
    case ObjectType::kRock:
      return "rock";
    case ObjectType::kPole:
      return "pole";
    case ObjectType::kFence:
      return "fence";
    case ObjectType::kBarrier:
      return "barrier";
    case ObjectType::kBuilding:
      return "building";
  }
  return "?";
}

ObjectType objectTypeFromString(const std::string& name)
{
  for (const ObjectType t : { ObjectType::kTree, ObjectType::kShrub, ObjectType::kGrass, ObjectType::kRock,
                              ObjectType::kPole, ObjectType::kFence, ObjectType::kBarrier, ObjectType::kBuilding })
    if (name == toString(t))
      return t;
  throw std::invalid_argument("unknown object type '" + name +
                              "' (known: tree, shrub, grass, rock, pole, fence, barrier, building)");
}

void footprintHalfExtents(const TerrainObject& o, double& half_x, double& half_y)
{
  const double c = std::abs(std::cos(o.yaw)), s = std::abs(std::sin(o.yaw));
  half_x = 0.5 * (o.length * c + o.width * s);
  half_y = 0.5 * (o.length * s + o.width * c);
}

ObjectSet::ObjectSet(double bucket_size) : bucket_size_(bucket_size)
{
  if (!(bucket_size > 0.0) || !std::isfinite(bucket_size))
    throw std::invalid_argument("ObjectSet: bucket_size must be finite and > 0");
}

long ObjectSet::bucketKeyX(double x) const
{
  return static_cast<long>(std::floor(x / bucket_size_));
}

long ObjectSet::bucketKeyY(double y) const
{
  return static_cast<long>(std::floor(y / bucket_size_));
}

void ObjectSet::insertIntoBuckets(const TerrainObject& o)
{
  double hx = 0.0, hy = 0.0;
  footprintHalfExtents(o, hx, hy);
  for (long by = bucketKeyY(o.y - hy); by <= bucketKeyY(o.y + hy); ++by)
  {
    for (long bx = bucketKeyX(o.x - hx); bx <= bucketKeyX(o.x + hx); ++bx)
    {
      const std::pair<long, long> key{ bx, by };
      auto it = std::lower_bound(buckets_.begin(), buckets_.end(), key,
                                 [](const auto& entry, const std::pair<long, long>& k) { return entry.first < k; });
      if (it == buckets_.end() || it->first != key)
        it = buckets_.insert(it, { key, {} });
      it->second.push_back(o.id);
    }
  }
}

std::uint32_t ObjectSet::add(TerrainObject object)
{
  // Errors name the object as it would have been listed: its id-to-be, kind and position.
  auto reject = [&](const std::string& why) {
    std::ostringstream what;
    what << "ObjectSet::add: object " << objects_.size() << " (" << toString(object.type) << " at (" << object.x << ", "
         << object.y << ")): " << why;
    throw std::invalid_argument(what.str());
  };
  auto describe = [](const char* name, double value, const char* rule) {
    std::ostringstream what;
    what << name << " must be " << rule << ", got " << value;
    return what.str();
  };
  if (!std::isfinite(object.x) || !std::isfinite(object.y) || !std::isfinite(object.yaw))
    reject("position and yaw must be finite");
  if (!std::isfinite(object.length) || !(object.length > 0.0))
    reject(describe("length", object.length, "finite and > 0 m"));
  if (!std::isfinite(object.width) || !(object.width > 0.0))
    reject(describe("width", object.width, "finite and > 0 m"));
  if (!std::isfinite(object.height) || !(object.height >= 0.0))
    reject(describe("height", object.height, "finite and >= 0 m"));
  if (!(object.strength >= 0.0))
    reject(describe("strength", object.strength, ">= 0 N (+inf = rigid)"));
  if (!(object.rolling_resistance >= 0.0))
    reject(describe("rolling_resistance", object.rolling_resistance, ">= 0"));
  object.id = static_cast<std::uint32_t>(objects_.size());
  objects_.push_back(object);
  insertIntoBuckets(objects_.back());
  return object.id;
}

std::vector<std::uint32_t> ObjectSet::query(double min_x, double min_y, double max_x, double max_y) const
{
  std::vector<std::uint32_t> out;
  for (long by = bucketKeyY(min_y); by <= bucketKeyY(max_y); ++by)
  {
    for (long bx = bucketKeyX(min_x); bx <= bucketKeyX(max_x); ++bx)
    {
      const std::pair<long, long> key{ bx, by };
      const auto it =
          std::lower_bound(buckets_.begin(), buckets_.end(), key,
                           [](const auto& entry, const std::pair<long, long>& k) { return entry.first < k; });
      if (it == buckets_.end() || it->first != key)
        continue;
      for (const std::uint32_t id : it->second)
      {
        const TerrainObject& o = objects_[id];
        double hx = 0.0, hy = 0.0;
        footprintHalfExtents(o, hx, hy);
        if (o.x + hx >= min_x && o.x - hx <= max_x && o.y + hy >= min_y && o.y - hy <= max_y)
          out.push_back(id);
      }
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::uint32_t> ObjectSet::at(double x, double y) const
{
  std::vector<std::uint32_t> out;
  for (const std::uint32_t id : query(x, y, x, y))
  {
    const TerrainObject& o = objects_[id];
    // Into the object's own frame: inside when within half length and half width.
    const double dx = x - o.x, dy = y - o.y;
    const double along = dx * std::cos(o.yaw) + dy * std::sin(o.yaw);
    const double across = -dx * std::sin(o.yaw) + dy * std::cos(o.yaw);
    if (std::abs(along) <= 0.5 * o.length && std::abs(across) <= 0.5 * o.width)
      out.push_back(id);
  }
  return out;
}

bool ObjectSet::push(std::uint32_t id, double force, double direction)
{
  if (id >= objects_.size())
    throw std::out_of_range("ObjectSet::push: no object with id " + std::to_string(id));
  TerrainObject& o = objects_[id];
  if (o.toppled || !std::isfinite(o.strength) || !(force >= o.strength))
    return false;
  o.toppled = true;
  o.fall_direction = direction;
  return true;
}

bool ObjectSet::applyToppled(std::uint32_t id, double fall_direction, std::string& why)
{
  if (id >= objects_.size())
  {
    why = "no object with id " + std::to_string(id) + " (have " + std::to_string(objects_.size()) + ")";
    return false;
  }
  if (!std::isfinite(fall_direction))
  {
    why = "object " + std::to_string(id) + ": fall direction is not finite";
    return false;
  }
  const TerrainObject& o = objects_[id];
  if (!std::isfinite(o.strength))
  {
    why = "object " + std::to_string(id) + " is rigid: it cannot topple";
    return false;
  }
  push(id, o.strength, fall_direction);
  return true;
}

const TerrainObject& ObjectSet::get(std::uint32_t id) const
{
  if (id >= objects_.size())
    throw std::out_of_range("ObjectSet::get: no object with id " + std::to_string(id));
  return objects_[id];
}

}  // namespace terrain
}  // namespace avsp
