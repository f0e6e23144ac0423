#include "avsp/scenario/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <avsp/environment/astronomy.hpp>
#include <avsp/environment/weather.hpp>
#include <avsp_terrain/geodetic_reference.hpp>
#include <avsp_dynamics/dem/dem_soil_config.hpp>
#include <avsp_dynamics/vehicle_model.hpp>
#include <avsp_terrain/agents.hpp>
#include <avsp_terrain/rosparam_yaml.hpp>
#include <avsp_terrain/run_numbers.hpp>
#include <avsp_terrain/soil.hpp>
#include <avsp_terrain/terrain_source.hpp>

namespace avsp
{
namespace scenario
{
namespace fs = std::filesystem;

namespace
{
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Largest scenario file read: 4 MiB, some 50 000 waypoints.
constexpr std::uintmax_t kMaxScenarioBytes = 4u << 20;

std::string join(const std::vector<std::string>& items, const char* separator = ", ")
{
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i)
    out += (i ? separator : "") + items[i];
  return out;
}

/// Short human form of a number for messages.
std::string shortNumber(double v)
{
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// The file's errors: every message starts with its path.
class Context
{
public:
  explicit Context(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void fail(const std::string& key, const std::string& why) const
  {
    throw ScenarioError(file_ + ": " + key + ": " + why);
  }
  const std::string& file() const { return file_; }

private:
  std::string file_;
};

std::string childKey(const std::string& path, const std::string& key)
{
  return path.empty() ? key : path + "." + key;
}

std::string indexKey(const std::string& path, std::size_t i)
{
  return path + "[" + std::to_string(i) + "]";
}

/// A YAML map whose keys are checked: each read marks a key, finish() refuses the others.
class MapReader
{
public:
  MapReader(const Context& ctx, const YAML::Node& node, std::string path)
    : ctx_(ctx), node_(node), path_(std::move(path))
  {
    if (!node.IsMap())
      ctx_.fail(path_.empty() ? "(top level)" : path_, "must be a map of keys");
    std::set<std::string> seen;
    for (const auto& kv : node)
    {
      if (!kv.first.IsScalar())
        ctx_.fail(path_.empty() ? "(top level)" : path_, "a key is not a plain string");
      const std::string key = kv.first.Scalar();
      if (!seen.insert(key).second)
        ctx_.fail(childKey(path_, key), "duplicate key");
    }
  }

  bool has(const std::string& key) const
  {
    for (const auto& kv : node_)
      if (kv.first.Scalar() == key)
        return !kv.second.IsNull();
    return false;
  }

  /// The value, or an undefined/null node when absent. Marks `key` as known.
  YAML::Node get(const std::string& key)
  {
    known_.push_back(key);
    for (const auto& kv : node_)
      if (kv.first.Scalar() == key)
        return kv.second;
    return YAML::Node(YAML::NodeType::Undefined);
  }

  YAML::Node required(const std::string& key)
  {
    YAML::Node n = get(key);
    if (!n.IsDefined() || n.IsNull())
      ctx_.fail(childKey(path_, key), "missing key");
    return n;
  }

  /// Refuses keys that were never asked for.
  void finish() const
  {
    for (const auto& kv : node_)
    {
      const std::string key = kv.first.Scalar();
      if (std::find(known_.begin(), known_.end(), key) == known_.end())
        ctx_.fail(childKey(path_, key), "unknown key (allowed: " + join(known_) + ")");
    }
  }

  std::string key(const std::string& k) const { return childKey(path_, k); }
  const std::string& path() const { return path_; }

private:
  const Context& ctx_;
  YAML::Node node_;
  std::string path_;
  std::vector<std::string> known_;
};

bool present(const YAML::Node& n)
{
  return n.IsDefined() && !n.IsNull();
}

double toDouble(const Context& ctx, const YAML::Node& n, const std::string& key, double lo, double hi,
                const std::string& unit = "")
{
  if (!n.IsScalar())
    ctx.fail(key, "must be a number");
  double v = 0.0;
  try
  {
    v = n.as<double>();
  }
  catch (const YAML::Exception&)
  {
    ctx.fail(key, "'" + n.Scalar() + "' is not a number");
  }
  if (!std::isfinite(v) || v < lo || v > hi)
    ctx.fail(key, shortNumber(v) + " must be finite and in [" + shortNumber(lo) + ", " + shortNumber(hi) + "]" +
                      (unit.empty() ? "" : " (" + unit + ")"));
  return v;
}

double readDouble(const Context& ctx, MapReader& m, const std::string& key, double fallback, double lo, double hi,
                  const std::string& unit = "")
{
  const YAML::Node n = m.get(key);
  return present(n) ? toDouble(ctx, n, m.key(key), lo, hi, unit) : fallback;
}

double requiredDouble(const Context& ctx, MapReader& m, const std::string& key, double lo, double hi,
                      const std::string& unit = "")
{
  return toDouble(ctx, m.required(key), m.key(key), lo, hi, unit);
}

long long toInt(const Context& ctx, const YAML::Node& n, const std::string& key, long long lo, long long hi)
{
  if (!n.IsScalar())
    ctx.fail(key, "must be an integer");
  long long v = 0;
  try
  {
    v = n.as<long long>();
  }
  catch (const YAML::Exception&)
  {
    ctx.fail(key, "'" + n.Scalar() + "' is not an integer");
  }
  if (v < lo || v > hi)
    ctx.fail(key, std::to_string(v) + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

bool toBool(const Context& ctx, const YAML::Node& n, const std::string& key)
{
  if (!n.IsScalar())
    ctx.fail(key, "must be true or false");
  try
  {
    return n.as<bool>();
  }
  catch (const YAML::Exception&)
  {
    ctx.fail(key, "'" + n.Scalar() + "' is not true or false");
  }
}

std::string toString(const Context& ctx, const YAML::Node& n, const std::string& key)
{
  if (!n.IsScalar() || n.Scalar().empty())
    ctx.fail(key, "must be a non-empty string");
  return n.Scalar();
}

/// A ROS graph name component (namespace, frame prefix): letter first, then letters, digits, _.
bool isRosName(const std::string& s)
{
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0])))
    return false;
  return std::all_of(s.begin(), s.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::string resolvePath(const std::string& scenario_file, const std::string& p)
{
  fs::path path(p);
  if (path.is_absolute())
    return path.lexically_normal().string();
  const fs::path base = fs::absolute(fs::path(scenario_file)).parent_path();
  return (base / path).lexically_normal().string();
}

bool readableFile(const std::string& p)
{
  std::error_code ec;
  if (!fs::is_regular_file(p, ec))
    return false;
  std::ifstream f(p);
  return f.good();
}

TerrainSpec readTerrain(const Context& ctx, const YAML::Node& node, const LoadOptions& options)
{
  TerrainSpec t;
  MapReader m(ctx, node, "terrain");
  const YAML::Node course = m.get("default_course");
  const YAML::Node file = m.get("file");
  const YAML::Node flat = m.get("flat");
  const int sources = int(course.IsDefined()) + int(present(file)) + int(present(flat));
  if (sources != 1)
    ctx.fail("terrain", "give exactly one of default_course, file, flat");
  const YAML::Node soil = m.get("soil");
  const YAML::Node png = m.get("png");
  if (course.IsDefined())
  {
    t.kind = TerrainSpec::Kind::kDefaultCourse;
    if (present(course))
    {
      MapReader c(ctx, course, "terrain.default_course");
      t.course_seed = static_cast<std::uint64_t>(
          present(c.get("seed")) ? toInt(ctx, c.get("seed"), c.key("seed"), 0, 2147483647) : 1);
      t.course_length_x = readDouble(ctx, c, "length_x", 600.0, 300.0, 1e5, "m");
      t.course_length_y = readDouble(ctx, c, "length_y", 400.0, 200.0, 1e5, "m");
      t.course_cell_size =
          readDouble(ctx, c, "cell_size", 0.1, 1e-3, 0.1 * std::min(t.course_length_x, t.course_length_y), "m");
      // The grid must stay below 2^31 points (makeDefaultCourse's limit), checked here so a
      // tiny cell is named before a node tries to allocate it.
      const double points =
          (t.course_length_x / t.course_cell_size + 1.0) * (t.course_length_y / t.course_cell_size + 1.0);
      if (points > 2147483647.0)
        ctx.fail("terrain.default_course.cell_size", shortNumber(t.course_cell_size) + " m makes a grid of " +
                                                         shortNumber(points) + " points (at most 2^31)");
      c.finish();
    }
  }
  else if (present(file))
  {
    t.kind = TerrainSpec::Kind::kFile;
    t.file = resolvePath(ctx.file(), toString(ctx, file, "terrain.file"));
    if (!readableFile(t.file))
      ctx.fail("terrain.file", "cannot read '" + t.file + "'");
    const std::string ext = terrain::fileExtension(t.file);
    if (ext != ".avspterrain" && ext != ".asc" && ext != ".tif" && ext != ".tiff" && ext != ".png")
      ctx.fail("terrain.file", "'" + t.file + "': unknown extension (.avspterrain, .asc, .tif, .tiff, .png)");
    if (ext == ".png")
    {
      if (!present(png))
        ctx.fail("terrain.png", "missing key (a .png DEM needs cell_size and z_scale)");
      MapReader p(ctx, png, "terrain.png");
      t.has_png = true;
      t.png_cell_size = requiredDouble(ctx, p, "cell_size", 1e-6, 1e6, "m");
      t.png_z_scale = requiredDouble(ctx, p, "z_scale", 1e-9, 1e6, "m");
      t.png_origin_x = readDouble(ctx, p, "origin_x", 0.0, -1e9, 1e9, "m");
      t.png_origin_y = readDouble(ctx, p, "origin_y", 0.0, -1e9, 1e9, "m");
      t.png_z_offset = readDouble(ctx, p, "z_offset", 0.0, -1e6, 1e6, "m");
      p.finish();
    }
    else if (present(png))
      ctx.fail("terrain.png", "only for a .png file");
  }
  else
  {
    t.kind = TerrainSpec::Kind::kFlat;
    MapReader f(ctx, flat, "terrain.flat");
    t.flat_soil = toString(ctx, f.required("soil"), "terrain.flat.soil");
    t.flat_size = readDouble(ctx, f, "size", 100.0, 1.0, 1e4, "m");
    t.flat_cell_size = readDouble(ctx, f, "cell_size", 0.1, 0.005, t.flat_size / 10.0, "m");
    f.finish();
  }
  if (t.kind != TerrainSpec::Kind::kFile && present(png))
    ctx.fail("terrain.png", "only for a .png file");
  if (present(soil))
  {
    if (t.kind != TerrainSpec::Kind::kFile)
      ctx.fail("terrain.soil", "only for a DEM file (the course and saved terrains have their own soils)");
    t.soil = toString(ctx, soil, "terrain.soil");
  }
  const YAML::Node soils_file = m.get("soils_file");
  t.soils_file = present(soils_file) ? resolvePath(ctx.file(), toString(ctx, soils_file, "terrain.soils_file"))
                                     : options.soils_file;
  if (!readableFile(t.soils_file))
    ctx.fail("terrain.soils_file", "cannot read '" + t.soils_file + "'");
  const YAML::Node transport = m.get("transport");
  if (present(transport))
    t.transport = toBool(ctx, transport, "terrain.transport");
  const YAML::Node max_cells = m.get("max_cells");
  if (present(max_cells))
    t.max_cells = static_cast<std::uint64_t>(toInt(ctx, max_cells, "terrain.max_cells", 1, 2147483647));
  m.finish();
  // Soil names against the library, so a typo is named here and not by every node.
  try
  {
    const terrain::SoilLibrary soils = terrain::SoilLibrary::load(t.soils_file);
    const std::string& name = t.kind == TerrainSpec::Kind::kFlat ? t.flat_soil : t.soil;
    if (!soils.contains(name))
      ctx.fail(t.kind == TerrainSpec::Kind::kFlat ? "terrain.flat.soil" : "terrain.soil",
               "unknown soil '" + name + "' (" + join(soils.names()) + ")");
  }
  catch (const ScenarioError&)
  {
    throw;
  }
  catch (const std::exception& e)
  {
    ctx.fail("terrain.soils_file", e.what());
  }
  return t;
}

/// Known sensor sections of sensors_node (~sensors, ~vehicle_sensors/<v>).
const std::vector<std::string> kSensorSections = { "lidar",        "radar",      "gps",     "imu",
                                                   "magnetometer", "ultrasonic", "cameras", "occupancy" };

YAML::Node readSensors(const Context& ctx, const YAML::Node& node, const std::string& path)
{
  MapReader m(ctx, node, path);
  for (const std::string& s : kSensorSections)
  {
    const YAML::Node section = m.get(s);
    if (!section.IsDefined())
      continue;
    const bool list = s == "ultrasonic" || s == "cameras";
    if (list ? !section.IsSequence() : !section.IsMap())
      ctx.fail(m.key(s), list ? "must be a list of sensors" : "must be a map of the section's keys");
  }
  m.finish();
  return YAML::Clone(node);
}

ControllerSpec readController(const Context& ctx, const YAML::Node& node, const std::string& path)
{
  ControllerSpec c;
  MapReader m(ctx, node, path);
  const std::string type = toString(ctx, m.required("type"), m.key("type"));
  if (type == "waypoints")
  {
    c.type = ControllerType::kWaypoints;
    c.path = toString(ctx, m.required("path"), m.key("path"));
  }
  else if (type == "leader_follower")
  {
    c.type = ControllerType::kLeaderFollower;
    const YAML::Node leader = m.get("leader");
    if (present(leader))
      c.leader = toString(ctx, leader, m.key("leader"));
    c.gap = readDouble(ctx, m, "gap", 15.0, 0.0, 10000.0, "m");
    c.offset = readDouble(ctx, m, "offset", 0.0, -1000.0, 1000.0, "m");
  }
  else if (type == "external")
    c.type = ControllerType::kExternal;
  else
    ctx.fail(m.key("type"), "unknown '" + type + "' (waypoints, leader_follower, external)");
  if (c.type != ControllerType::kExternal)
  {
    const YAML::Node params = m.get("params");
    if (present(params))
    {
      // Numbers here; which keys and what ranges: controller_node's own parser, run on what the
      // launch file gives it (node_checks.hpp, checkControllersAsTheNodeWill).
      MapReader p(ctx, params, m.key("params"));
      for (const auto& kv : params)
      {
        const YAML::Node v = p.get(kv.first.Scalar());
        if (present(v))
          toDouble(ctx, v, p.key(kv.first.Scalar()), -1e9, 1e9);
      }
      p.finish();
      c.params = YAML::Clone(params);
    }
  }
  m.finish();
  return c;
}

std::vector<Waypoint> readPath(const Context& ctx, const YAML::Node& node, const std::string& path)
{
  if (!node.IsSequence())
    ctx.fail(path, "must be a list of waypoints {x, y, speed}");
  if (node.size() == 0)
    ctx.fail(path, "empty path");
  if (node.size() < 2)
    ctx.fail(path, "a path needs at least 2 waypoints");
  std::vector<Waypoint> out;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const std::string key = indexKey(path, i);
    MapReader m(ctx, node[i], key);
    Waypoint w;
    w.x = requiredDouble(ctx, m, "x", -1e7, 1e7, "m");
    w.y = requiredDouble(ctx, m, "y", -1e7, 1e7, "m");
    const YAML::Node speed = m.required("speed");
    w.speed = toDouble(ctx, speed, m.key("speed"), -kInf, kInf, "m/s");
    if (w.speed < 0.0)
      ctx.fail(m.key("speed"), "negative speed " + shortNumber(w.speed) + " m/s");
    if (w.speed == 0.0 && i + 1 < node.size())
      ctx.fail(m.key("speed"), "0 m/s before the last waypoint: the vehicle would never get there");
    if (w.speed > 50.0)
      ctx.fail(m.key("speed"), shortNumber(w.speed) + " m/s is above 50 m/s");
    m.finish();
    if (!out.empty() && std::hypot(w.x - out.back().x, w.y - out.back().y) < 0.01)
      ctx.fail(key, "less than 1 cm from the waypoint before it");
    out.push_back(w);
  }
  return out;
}

YAML::Node readAgents(const Context& ctx, const YAML::Node& node, std::set<std::string>& names,
                      std::vector<terrain::AgentSpec>& specs)
{
  // The nodes' own parser and validator (dynamics_node, sensors_node and agents_node read ~agents
  // with it), on the section as they will read it (typed by rosparam's rules, numbers as
  // doubles: what the launch file's text gives them); the scenario adds that an agent's name is
  // a plain name no vehicle has.
  YAML::Node typed;
  try
  {
    typed = terrain::rosparamTyped(node, true, "agents");
    specs = terrain::parseAgentSpecs(typed, "agents");
  }
  catch (const std::invalid_argument& e)
  {
    throw ScenarioError(ctx.file() + ": " + e.what());
  }
  for (std::size_t i = 0; i < specs.size(); ++i)
  {
    const std::string key = indexKey("agents", i) + ".name";
    if (!isRosName(specs[i].name))
      ctx.fail(key, "'" + specs[i].name + "' is not a valid name (a letter, then letters, digits, _)");
    if (!names.insert(specs[i].name).second)
      ctx.fail(key, "duplicate name '" + specs[i].name + "'");
  }
  return typed;
}

YAML::Node readWeather(const Context& ctx, const YAML::Node& node)
{
  std::vector<environment::WeatherEvent> events;
  YAML::Node typed;
  try
  {
    // environment_node's reader, on the section as the node will read it (agents above).
    typed = terrain::rosparamTyped(node, true, "weather");
    events = environment::parseWeatherEvents(typed, "weather");
  }
  catch (const std::exception& e)
  {
    throw ScenarioError(ctx.file() + ": " + e.what());
  }
  try
  {
    environment::WeatherTimeline timeline(events);
  }
  catch (const std::exception& e)
  {
    throw ScenarioError(ctx.file() + ": " + e.what());
  }
  return typed;
}

std::vector<std::string> knownModels(const std::string& dir)
{
  std::vector<std::string> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().extension() == ".yaml")
      out.push_back(it->path().stem().string());
  std::sort(out.begin(), out.end());
  return out;
}

/// Distance (m) from (x, y) to an object's rotated footprint rectangle; 0 inside.
double distanceToFootprint(const terrain::TerrainObject& o, double x, double y)
{
  const double c = std::cos(o.yaw), s = std::sin(o.yaw);
  const double dx = x - o.x, dy = y - o.y;
  const double u = c * dx + s * dy, v = -s * dx + c * dy;
  const double ou = std::max(0.0, std::abs(u) - 0.5 * o.length);
  const double ov = std::max(0.0, std::abs(v) - 0.5 * o.width);
  return std::hypot(ou, ov);
}

void checkOnTerrain(const Context& ctx, const TerrainFootprint& t, double x, double y, double margin,
                    const std::string& key)
{
  if (x < t.min_x + margin || x > t.max_x - margin || y < t.min_y + margin || y > t.max_y - margin)
    ctx.fail(key, "(" + shortNumber(x) + ", " + shortNumber(y) + ") is off the terrain (x " + shortNumber(t.min_x) +
                      " to " + shortNumber(t.max_x) + ", y " + shortNumber(t.min_y) + " to " + shortNumber(t.max_y) +
                      (margin > 0.0 ? ", less " + shortNumber(margin) + " m" : std::string()) + ")");
}

}  // namespace

const char* toString(ControllerType type)
{
  switch (type)
  {
    case ControllerType::kWaypoints:
      return "waypoints";
    case ControllerType::kLeaderFollower:
      return "leader_follower";
    case ControllerType::kExternal:
      return "external";
  }
  return "?";
}

std::vector<NodeParam> TerrainSpec::nodeParams() const
{
  std::vector<NodeParam> p;
  switch (kind)
  {
    case Kind::kDefaultCourse:
      p.push_back({ "course_seed", std::to_string(course_seed), "int" });
      p.push_back({ "course_cell_size", terrain::rosparamDouble(course_cell_size), "double" });
      p.push_back({ "course_length_x", terrain::rosparamDouble(course_length_x), "double" });
      p.push_back({ "course_length_y", terrain::rosparamDouble(course_length_y), "double" });
      break;
    case Kind::kFile:
      if (terrain::fileExtension(file) == ".avspterrain")
        p.push_back({ "terrain_file", file, "str" });
      else
      {
        p.push_back({ "dem_file", file, "str" });
        p.push_back({ "soil", soil, "str" });
        if (has_png)
        {
          p.push_back({ "png_cell_size", terrain::rosparamDouble(png_cell_size), "double" });
          p.push_back({ "png_z_scale", terrain::rosparamDouble(png_z_scale), "double" });
          p.push_back({ "png_origin_x", terrain::rosparamDouble(png_origin_x), "double" });
          p.push_back({ "png_origin_y", terrain::rosparamDouble(png_origin_y), "double" });
          p.push_back({ "png_z_offset", terrain::rosparamDouble(png_z_offset), "double" });
        }
      }
      break;
    case Kind::kFlat:
      p.push_back({ "flat_soil", flat_soil, "str" });
      p.push_back({ "flat_size", terrain::rosparamDouble(flat_size), "double" });
      p.push_back({ "flat_cell_size", terrain::rosparamDouble(flat_cell_size), "double" });
      break;
  }
  p.push_back({ "transport", transport ? "true" : "false", "bool" });
  p.push_back({ "max_cells", std::to_string(max_cells), "int" });
  p.push_back({ "soils_file", soils_file, "str" });
  return p;
}

int Scenario::vehicleIndex(const std::string& vehicle) const
{
  for (std::size_t i = 0; i < vehicles.size(); ++i)
    if (vehicles[i].name == vehicle)
      return static_cast<int>(i);
  return -1;
}

std::shared_ptr<const TerrainFootprint> loadTerrainFootprint(const TerrainSpec& spec)
{
  terrain::TerrainSource source;
  switch (spec.kind)
  {
    case TerrainSpec::Kind::kDefaultCourse:
      source.course.seed = spec.course_seed;
      source.course.cell_size = spec.course_cell_size;
      source.course.length_x = spec.course_length_x;
      source.course.length_y = spec.course_length_y;
      break;
    case TerrainSpec::Kind::kFile:
      if (terrain::fileExtension(spec.file) == ".avspterrain")
        source.terrain_file = spec.file;
      else
      {
        source.dem_file = spec.file;
        source.soil = spec.soil;
        source.png.cell_size = spec.png_cell_size;
        source.png.z_scale = spec.png_z_scale;
        source.png.origin_x = spec.png_origin_x;
        source.png.origin_y = spec.png_origin_y;
        source.png.z_offset = spec.png_z_offset;
      }
      break;
    case TerrainSpec::Kind::kFlat:
      source.flat_soil = spec.flat_soil;
      source.flat_size = spec.flat_size;
      source.flat_cell_size = spec.flat_cell_size;
      break;
  }
  source.transport = spec.transport;
  source.max_cells = spec.max_cells;
  const terrain::SoilLibrary soils = terrain::SoilLibrary::load(spec.soils_file);
  return footprintOf(terrain::loadTerrainSource(source, soils));
}

std::shared_ptr<const TerrainFootprint> footprintOf(terrain::LoadedSource loaded)
{
  auto out = std::make_shared<TerrainFootprint>();
  const terrain::ElevationGrid& g = loaded.terrain->base();
  out->min_x = g.originX();
  out->min_y = g.originY();
  out->max_x = g.originX() + g.dx() * static_cast<double>(g.columns() - 1);
  out->max_y = g.originY() + g.dy() * static_cast<double>(g.rows() - 1);
  out->objects = std::move(loaded.objects);
  out->ground = std::move(loaded.terrain);
  return out;
}

namespace
{
// parseScenario's sections, in the order it reads them (an error names the first bad key).

/// geodetic_reference and time.
void readPlaceAndTime(const Context& ctx, MapReader& top, Scenario& s)
{
  {
    MapReader g(ctx, top.required("geodetic_reference"), "geodetic_reference");
    // The nodes' own table (environment_node and sensors_node read the same keys).
    double* const value[] = { &s.latitude, &s.longitude, &s.altitude };
    for (std::size_t k = 0; k < 3; ++k)
    {
      const terrain::GeodeticNumber& n = terrain::geodeticReferenceNumbers()[k];
      *value[k] = n.required ? requiredDouble(ctx, g, n.key, n.min, n.max, n.unit)
                             : readDouble(ctx, g, n.key, n.fallback, n.min, n.max, n.unit);
    }
    g.finish();
  }
  {
    MapReader t(ctx, top.required("time"), "time");
    s.start_utc = toString(ctx, t.required("start_utc"), "time.start_utc");
    try
    {
      environment::parseRunStartUtc(s.start_utc);  // environment_node's rule
    }
    catch (const std::exception& e)
    {
      ctx.fail("time.start_utc", e.what());
    }
    s.time_acceleration =
        readDouble(ctx, t, "acceleration", terrain::kTimeAcceleration.fallback, terrain::kTimeAcceleration.min,
                   terrain::kTimeAcceleration.max, "world s per sim s");
    t.finish();
  }
}

/// paths: named waypoint lists.
void readPaths(const Context& ctx, MapReader& top, Scenario& s)
{
  const YAML::Node paths = top.get("paths");
  if (present(paths))
  {
    MapReader p(ctx, paths, "paths");
    for (const auto& kv : paths)
    {
      const std::string name = kv.first.Scalar();
      s.paths[name] = readPath(ctx, p.get(name), p.key(name));
    }
    p.finish();
  }
}

/// dem: the DEM soil's section, read as dynamics_node will read it (its flow YAML through
/// parseDemSoilSpec); only with vehicles on `terramechanics: dem`, and in one dynamics_node.
void readDem(const Context& ctx, MapReader& top, Scenario& s)
{
  const YAML::Node dem = top.get("dem");
  std::vector<std::string> names;
  for (const VehicleSpec& v : s.vehicles)
    if (v.dem)
      names.push_back(v.name);
  if (!present(dem))
  {
    if (!names.empty())
      ctx.fail("dem", "required: vehicle '" + names.front() +
                          "' has terramechanics: dem (the section gives the segment and the DEM soil)");
    return;
  }
  if (names.empty())
    ctx.fail("dem", "no vehicle has terramechanics: dem");
  if (!s.partitions.empty())
    ctx.fail("dem", "the DEM contact mode runs in one dynamics_node: not with partitions");
  try
  {
    s.dem = terrain::rosparamFlow(dem);
    dynamics::dem::parseDemSoilSpec(s.dem, "dem");
  }
  catch (const std::invalid_argument& e)  // DemParameterError, or a value rosparam cannot hold
  {
    throw ScenarioError(ctx.file() + ": " + e.what());
  }
}

/// vehicles: each checked against its model's files (as dynamics_node will read them) and the
/// paths. Returns the YAML list (the formation checks what each vehicle's controller sets).
YAML::Node readVehicles(const Context& ctx, MapReader& top, const LoadOptions& options, Scenario& s)
{
  const YAML::Node vehicles = top.required("vehicles");
  if (!vehicles.IsSequence() || vehicles.size() == 0)
    ctx.fail("vehicles", "must be a non-empty list of vehicles");
  std::set<std::string> names;
  struct ModelLimits
  {
    double max_speed = 0.0, rest_height = 0.0, wheel_radius = 0.0;
    bool tracked = false;
  };
  std::map<std::string, ModelLimits> loaded_models;
  const std::vector<std::string> models = knownModels(options.vehicles_dir);
  for (std::size_t i = 0; i < vehicles.size(); ++i)
  {
    const std::string key = indexKey("vehicles", i);
    MapReader m(ctx, vehicles[i], key);
    VehicleSpec v;
    v.name = toString(ctx, m.required("name"), m.key("name"));
    if (!isRosName(v.name))
      ctx.fail(m.key("name"), "'" + v.name + "' is not a valid name (a letter, then letters, digits, _)");
    if (!names.insert(v.name).second)
      ctx.fail(m.key("name"), "duplicate name '" + v.name + "'");
    v.model = toString(ctx, m.required("model"), m.key("model"));
    if (std::find(models.begin(), models.end(), v.model) == models.end())
      ctx.fail(m.key("model"), "unknown model '" + v.model + "' (no " + options.vehicles_dir + "/" + v.model +
                                   ".yaml; known: " + join(models) + ")");
    // The vehicle's files as dynamics_node will read them (YAML, URDF, their consistency),
    // whatever the layout: a bad file fails here, not at run time.
    if (!loaded_models.count(v.model))
    {
      try
      {
        const dynamics::VehicleModel model = dynamics::loadVehicleModel(options.vehicles_dir + "/" + v.model + ".yaml");
        if (model.drive_type == dynamics::DriveType::kLegged)
          ctx.fail(m.key("model"), "model '" + v.model +
                                       "' is legged: legged vehicles stand in avsp_dynamics' World but have no gait "
                                       "controller, cmd_vel or node support yet, so scenarios cannot run them");
        // The lowest running-gear point sets the rest height of base_link (suspension at 0).
        ModelLimits limits;
        limits.max_speed = model.drivetrain.max_speed;
        double lowest = kInf;
        auto consider = [&](const Eigen::Vector3d& centre, double radius) {
          if (centre.z() - radius < lowest)
          {
            lowest = centre.z() - radius;
            limits.wheel_radius = radius;
          }
        };
        for (const dynamics::WheelSpec& w : model.wheels)
          consider(w.rest_position, w.radius);
        for (const dynamics::TrackSpec& t : model.tracks)
          for (const dynamics::RoadWheelSpec& r : t.road_wheels)
            consider(r.rest_position, r.radius);
        limits.rest_height = -lowest;
        limits.tracked = !model.tracks.empty();
        loaded_models[v.model] = limits;
      }
      catch (const std::exception& e)
      {
        ctx.fail(m.key("model"), "'" + v.model + "': " + e.what());
      }
    }
    v.max_speed = loaded_models[v.model].max_speed;
    v.rest_height = loaded_models[v.model].rest_height;
    v.wheel_radius = loaded_models[v.model].wheel_radius;
    {
      MapReader st(ctx, m.required("start"), m.key("start"));
      v.x = requiredDouble(ctx, st, "x", -1e7, 1e7, "m");
      v.y = requiredDouble(ctx, st, "y", -1e7, 1e7, "m");
      v.yaw = readDouble(ctx, st, "yaw", 0.0, -100.0, 100.0, "rad");
      st.finish();
    }
    const YAML::Node vs = m.get("sensors");
    if (present(vs))
      v.sensors = readSensors(ctx, vs, m.key("sensors"));
    const YAML::Node tm = m.get("terramechanics");
    if (present(tm))
    {
      const std::string mode = toString(ctx, tm, m.key("terramechanics"));
      if (mode != "soil" && mode != "dem")
        ctx.fail(
            m.key("terramechanics"),
            "'" + mode +
                "' is not a contact mode (soil: the terrain's model; dem: the DEM moving patch over `dem:`'s segment)");
      v.dem = mode == "dem";
      if (v.dem && loaded_models[v.model].tracked)
        ctx.fail(m.key("terramechanics"), "model '" + v.model + "' has tracks: the DEM contact mode needs wheels");
    }
    v.controller = readController(ctx, m.required("controller"), m.key("controller"));
    if (v.controller.type == ControllerType::kWaypoints && !s.paths.count(v.controller.path))
    {
      std::vector<std::string> known;
      for (const auto& kv : s.paths)
        known.push_back(kv.first);
      ctx.fail(m.key("controller.path"),
               "unknown path '" + v.controller.path + "' (paths: " + (known.empty() ? "none" : join(known)) + ")");
    }
    m.finish();
    s.vehicles.push_back(v);
  }

  return vehicles;
}

/// formation: leader, gap and offset of every member but the first.
void readFormation(const Context& ctx, MapReader& top, const YAML::Node& vehicles, Scenario& s)
{
  const YAML::Node formation = top.get("formation");
  if (present(formation))
  {
    MapReader f(ctx, formation, "formation");
    FormationSpec& fs_ = s.formation;
    fs_.present = true;
    fs_.type_name = toString(ctx, f.required("type"), "formation.type");
    try
    {
      fs_.type = control::formationFromString(fs_.type_name);
    }
    catch (const std::exception&)
    {
      ctx.fail("formation.type", "unknown '" + fs_.type_name + "' (column, line, diamond)");
    }
    fs_.spacing = readDouble(ctx, f, "spacing", 15.0, 0.1, 10000.0, "m");
    fs_.width = readDouble(ctx, f, "width", 5.0, 0.1, 1000.0, "m");
    const YAML::Node members = f.required("vehicles");
    if (!members.IsSequence() || members.size() < 2)
      ctx.fail("formation.vehicles", "must be a list of at least 2 vehicle names (the first leads)");
    std::set<std::string> seen;
    for (std::size_t k = 0; k < members.size(); ++k)
    {
      const std::string mk = indexKey("formation.vehicles", k);
      const std::string name = toString(ctx, members[k], mk);
      if (s.vehicleIndex(name) < 0)
        ctx.fail(mk, "unknown vehicle '" + name + "'");
      if (!seen.insert(name).second)
        ctx.fail(mk, "'" + name + "' is listed twice");
      fs_.vehicles.push_back(name);
    }
    f.finish();
    const std::vector<control::FormationSlot> slots =
        control::formationSlots(fs_.type, fs_.vehicles.size(), fs_.spacing, fs_.width);
    for (std::size_t k = 1; k < fs_.vehicles.size(); ++k)
    {
      const int vi = s.vehicleIndex(fs_.vehicles[k]);
      VehicleSpec& v = s.vehicles[static_cast<std::size_t>(vi)];
      const std::string ck = indexKey("vehicles", static_cast<std::size_t>(vi)) + ".controller";
      if (v.controller.type != ControllerType::kLeaderFollower)
        ctx.fail(ck + ".type", "'" + v.name + "' is in the formation: its controller must be leader_follower");
      const YAML::Node vc = vehicles[static_cast<std::size_t>(vi)]["controller"];
      for (const char* k2 : { "leader", "gap", "offset" })
        if (present(vc[k2]))
          ctx.fail(ck + "." + k2, "set by the formation ('" + v.name + "' is in formation.vehicles)");
      v.controller.leader = fs_.vehicles[static_cast<std::size_t>(slots[k].leader)];
      v.controller.gap = slots[k].gap;
      v.controller.offset = slots[k].offset;
      v.controller.from_formation = true;
    }
  }
}

/// Every leader_follower's leader: known, not itself, no cycles.
void checkLeaders(const Context& ctx, const Scenario& s)
{
  for (std::size_t i = 0; i < s.vehicles.size(); ++i)
  {
    const VehicleSpec& v = s.vehicles[i];
    if (v.controller.type != ControllerType::kLeaderFollower)
      continue;
    const std::string ck = indexKey("vehicles", i) + ".controller.leader";
    if (v.controller.leader.empty())
      ctx.fail(ck, "missing key (a leader_follower outside the formation names its leader)");
    if (s.vehicleIndex(v.controller.leader) < 0)
      ctx.fail(ck, "unknown vehicle '" + v.controller.leader + "'");
    std::vector<std::string> chain = { v.name };
    std::size_t cur = i;
    while (s.vehicles[cur].controller.type == ControllerType::kLeaderFollower)
    {
      const std::string& next = s.vehicles[cur].controller.leader;
      const int ni = s.vehicleIndex(next);
      if (ni < 0)
        break;  // named when that vehicle is checked
      chain.push_back(next);
      if (std::find(chain.begin(), chain.end() - 1, next) != chain.end() - 1)
        ctx.fail(ck, "leader cycle " + join(chain, " -> "));
      cur = static_cast<std::size_t>(ni);
    }
  }
}

/// v2v: the radio.
void readV2v(const Context& ctx, MapReader& top, Scenario& s)
{
  {
    const YAML::Node v2v = top.get("v2v");
    if (present(v2v))
    {
      MapReader r(ctx, v2v, "v2v");
      for (const v2v::RadioNumber& n : v2v::radioNumbers())  // the radio node's own table
        s.v2v.*n.member = readDouble(ctx, r, n.key, s.v2v.*n.member, n.min, n.max, n.unit);
      const YAML::Node los = r.get("line_of_sight");
      if (present(los))
        s.v2v.line_of_sight = toBool(ctx, los, "v2v.line_of_sight");
      r.finish();
    }
  }
}

/// machines: the hosts partitions may run on.
void readMachines(const Context& ctx, MapReader& top, Scenario& s)
{
  const YAML::Node machines = top.get("machines");
  if (present(machines))
  {
    MapReader mr(ctx, machines, "machines");
    for (const auto& kv : machines)
    {
      MachineSpec m;
      m.name = kv.first.Scalar();
      const std::string mk = mr.key(m.name);
      if (!isRosName(m.name))
        ctx.fail(mk, "'" + m.name + "' is not a valid name (a letter, then letters, digits, _)");
      MapReader e(ctx, mr.get(m.name), mk);
      m.address = toString(ctx, e.required("address"), e.key("address"));
      m.env_loader = toString(ctx, e.required("env_loader"), e.key("env_loader"));
      const YAML::Node user = e.get("user");
      if (present(user))
        m.user = toString(ctx, user, e.key("user"));
      e.finish();
      s.machines.push_back(m);
    }
    mr.finish();
  }
}

/// partitions: a count (balanced by running-gear cost) or a list naming vehicles and machines.
void readPartitions(const Context& ctx, MapReader& top, const LoadOptions& options, Scenario& s)
{
  const YAML::Node partitions = top.get("partitions");
  if (present(partitions))
  {
    if (partitions.IsScalar())
    {
      const std::size_t n =
          static_cast<std::size_t>(toInt(ctx, partitions, "partitions", 1, static_cast<long long>(s.vehicles.size())));
      std::vector<std::string> names;
      std::vector<double> costs;
      for (const VehicleSpec& v : s.vehicles)
      {
        names.push_back(v.name);
        double cost = 1.0;
        try
        {
          const dynamics::VehicleModel m = dynamics::loadVehicleModel(options.vehicles_dir + "/" + v.model + ".yaml");
          cost += static_cast<double>(m.wheels.size());
          for (const dynamics::TrackSpec& t : m.tracks)
            cost += static_cast<double>(t.road_wheels.size());
        }
        catch (const std::exception& e)
        {
          ctx.fail("partitions", "model '" + v.model + "' of '" + v.name + "': " + e.what());
        }
        costs.push_back(cost);
      }
      if (n > 1)
        s.partitions = balancedPartitions(names, costs, n);
    }
    else
    {
      if (!partitions.IsSequence() || partitions.size() == 0)
        ctx.fail("partitions", "must be a number of partitions or a list of {name, vehicles, machine}");
      std::map<std::string, std::string> placed;  // vehicle -> partition
      std::set<std::string> partition_names;
      for (std::size_t k = 0; k < partitions.size(); ++k)
      {
        const std::string pk = indexKey("partitions", k);
        MapReader pr(ctx, partitions[k], pk);
        PartitionSpec p;
        p.name = toString(ctx, pr.required("name"), pr.key("name"));
        if (!isRosName(p.name))
          ctx.fail(pr.key("name"), "'" + p.name + "' is not a valid name (a letter, then letters, digits, _)");
        if (p.name == "sensors")
          ctx.fail(pr.key("name"), "'sensors' is sensors_node's name in the lockstep");
        if (!partition_names.insert(p.name).second)
          ctx.fail(pr.key("name"), "duplicate partition '" + p.name + "'");
        const YAML::Node pv = pr.required("vehicles");
        if (!pv.IsSequence() || pv.size() == 0)
          ctx.fail(pr.key("vehicles"), "must be a non-empty list of vehicle names");
        std::set<std::string> mine;
        for (std::size_t j = 0; j < pv.size(); ++j)
        {
          const std::string vk = indexKey(pr.key("vehicles"), j);
          const std::string name = toString(ctx, pv[j], vk);
          if (s.vehicleIndex(name) < 0)
            ctx.fail(vk, "unknown vehicle '" + name + "'");
          if (placed.count(name))
            ctx.fail(vk, "'" + name + "' is already in partition '" + placed[name] + "'");
          placed[name] = p.name;
          mine.insert(name);
        }
        for (const VehicleSpec& v : s.vehicles)  // scenario order
          if (mine.count(v.name))
            p.vehicles.push_back(v.name);
        const YAML::Node machine = pr.get("machine");
        if (present(machine))
        {
          p.machine = toString(ctx, machine, pr.key("machine"));
          if (std::none_of(s.machines.begin(), s.machines.end(),
                           [&](const MachineSpec& m) { return m.name == p.machine; }))
            ctx.fail(pr.key("machine"), "unknown machine '" + p.machine + "' (not in machines)");
        }
        pr.finish();
        s.partitions.push_back(p);
      }
      for (const VehicleSpec& v : s.vehicles)
        if (!placed.count(v.name))
          ctx.fail("partitions", "vehicle '" + v.name + "' is in no partition");
      if (s.partitions.size() == 1 && !s.partitions[0].machine.empty())
        ctx.fail("partitions", "a single partition cannot run on a machine (use two or more)");
      if (s.partitions.size() == 1)
        s.partitions.clear();  // one partition: the plain single dynamics_node
    }
  }
  else if (!s.machines.empty())
    ctx.fail("machines", "given but no partitions use them");
}

/// Start poses, paths and agents against the terrain (options.check_terrain).
void checkAgainstTerrain(const Context& ctx, const LoadOptions& options, const Scenario& s,
                         const std::vector<terrain::AgentSpec>& agent_specs)
{
  if (!options.check_terrain)
    return;
  std::shared_ptr<const TerrainFootprint> t;
  try
  {
    t = options.terrain_loader ? options.terrain_loader(s.terrain) : loadTerrainFootprint(s.terrain);
  }
  catch (const std::exception& e)
  {
    ctx.fail("terrain", e.what());
  }
  if (!t)
    ctx.fail("terrain", "could not be loaded");
  const double c = options.start_clearance;
  for (std::size_t i = 0; i < s.vehicles.size(); ++i)
  {
    const VehicleSpec& v = s.vehicles[i];
    const std::string key = indexKey("vehicles", i) + ".start";
    checkOnTerrain(ctx, *t, v.x, v.y, 5.0, key);
    for (std::uint32_t id : t->objects.query(v.x - c, v.y - c, v.x + c, v.y + c))
    {
      const terrain::TerrainObject& o = t->objects.get(id);
      if (o.type == terrain::ObjectType::kGrass)
        continue;
      const double d = distanceToFootprint(o, v.x, v.y);
      if (d < c)
        ctx.fail(key, "'" + v.name + "' starts " +
                          (d <= 0.0 ? std::string("inside") : "within " + shortNumber(c) + " m of") + " " +
                          terrain::toString(o.type) + " " + std::to_string(id) + " at (" + shortNumber(o.x) + ", " +
                          shortNumber(o.y) + ")");
    }
  }
  for (const auto& kv : s.paths)
    for (std::size_t k = 0; k < kv.second.size(); ++k)
      checkOnTerrain(ctx, *t, kv.second[k].x, kv.second[k].y, 0.0, indexKey("paths." + kv.first, k));
  // Each agent as agents_node, dynamics_node and sensors_node build it: the spline through
  // its points (which can swing outside them) must stay on the ground, within the sample budget.
  if (t->ground)
    for (std::size_t i = 0; i < agent_specs.size(); ++i)
    {
      try
      {
        terrain::Agent(agent_specs[i], t->ground->base(), indexKey("agents", i));
      }
      catch (const std::invalid_argument& e)
      {
        throw ScenarioError(ctx.file() + ": " + e.what());
      }
    }
}
}  // namespace

Scenario loadScenario(const std::string& path, const LoadOptions& options)
{
  // A regular file of bounded size: a device never ends, and a huge file (1.4 M waypoints
  // once needed 4.8 GB to check) is no scenario anyone wrote.
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!ec && fs::exists(st) && !fs::is_regular_file(st))
    throw ScenarioError(path + ": not a regular file");
  if (fs::is_regular_file(st) && fs::file_size(path, ec) > kMaxScenarioBytes)
    throw ScenarioError(path + ": " + std::to_string(fs::file_size(path, ec)) + " bytes, more than the " +
                        std::to_string(kMaxScenarioBytes) + " a scenario file may have");
  std::ifstream in(path);
  if (!in)
    throw ScenarioError(path + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  return parseScenario(text.str(), path, options);
}

Scenario parseScenario(const std::string& text, const std::string& path, const LoadOptions& options)
{
  const Context ctx(path);
  YAML::Node root;
  try
  {
    root = YAML::Load(text);
  }
  catch (const YAML::Exception& e)
  {
    throw ScenarioError(path + ": line " + std::to_string(e.mark.line + 1) + ", column " +
                        std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
  try
  {
    Scenario s;
    s.file = path;
    s.name = fs::path(path).stem().string();
    if (!root.IsDefined() || root.IsNull())
      ctx.fail("(top level)", "empty file");
    MapReader top(ctx, root, "");

    s.terrain = readTerrain(ctx, top.required("terrain"), options);

    readPlaceAndTime(ctx, top, s);
    const YAML::Node weather = top.get("weather");
    if (present(weather))
      s.weather = readWeather(ctx, weather);

    const YAML::Node sensors = top.get("sensors");
    if (present(sensors))
      s.sensors = readSensors(ctx, sensors, "sensors");

    readPaths(ctx, top, s);
    const YAML::Node vehicles = readVehicles(ctx, top, options, s);
    readFormation(ctx, top, vehicles, s);
    checkLeaders(ctx, s);
    readV2v(ctx, top, s);
    const YAML::Node agents = top.get("agents");
    std::vector<terrain::AgentSpec> agent_specs;  // the agents as parsed, for the terrain check below
    if (present(agents))
    {
      std::set<std::string> agent_names;  // an agent may not share a vehicle's name
      for (const VehicleSpec& v : s.vehicles)
        agent_names.insert(v.name);
      s.agents = readAgents(ctx, agents, agent_names, agent_specs);
    }

    readMachines(ctx, top, s);
    readPartitions(ctx, top, options, s);
    readDem(ctx, top, s);
    s.seed = static_cast<std::uint64_t>(toInt(ctx, top.required("seed"), "seed",
                                              static_cast<long long>(terrain::kRunSeed.min),
                                              static_cast<long long>(terrain::kRunSeed.max)));
    s.duration = requiredDouble(ctx, top, "duration", terrain::kRunDuration.min, terrain::kRunDuration.max, "s");
    top.finish();

    checkAgainstTerrain(ctx, options, s, agent_specs);
    return s;
  }
  catch (const YAML::Exception& e)
  {
    // Anything yaml-cpp throws past the checks above (it should not) still names the file.
    throw ScenarioError(path + ": line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

std::vector<PartitionSpec> balancedPartitions(const std::vector<std::string>& names, const std::vector<double>& costs,
                                              std::size_t count)
{
  if (names.size() != costs.size())
    throw std::invalid_argument("balancedPartitions: " + std::to_string(names.size()) + " names but " +
                                std::to_string(costs.size()) + " costs");
  if (count == 0 || count > names.size())
    throw std::invalid_argument("balancedPartitions: " + std::to_string(count) + " partitions for " +
                                std::to_string(names.size()) + " vehicles");
  std::vector<std::size_t> order(names.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return costs[a] > costs[b]; });
  std::vector<double> load(count, 0.0);
  std::vector<std::size_t> home(names.size());
  for (std::size_t i : order)
  {
    const std::size_t p = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[p] += costs[i];
    home[i] = p;
  }
  std::vector<PartitionSpec> out(count);
  for (std::size_t p = 0; p < count; ++p)
    out[p].name = "p" + std::to_string(p + 1);
  for (std::size_t i = 0; i < names.size(); ++i)
    out[home[i]].vehicles.push_back(names[i]);
  return out;
}

}  // namespace scenario
}  // namespace avsp
