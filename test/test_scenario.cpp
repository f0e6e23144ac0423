// The scenario loader (include/avsp/scenario/scenario.hpp): a valid file, every kind of bad
// file named by file and key, the start-pose check on the real default course, a seeded fuzz of
// the loader, and the launch file generated from a scenario.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <random>
#include <regex>

#include <avsp/scenario/launch_generator.hpp>
#include <avsp/scenario/rviz_config.hpp>
#include <avsp/scenario/scenario.hpp>
#include <avsp_dynamics/dem/dem_soil_config.hpp>

namespace as = avsp::scenario;

namespace
{
const std::string kConfig = AVSP_CONFIG_DIR;

const char* const kBase = R"(
terrain:
  flat: {soil: gravel, size: 200, cell_size: 1.0}
geodetic_reference: {latitude: 39.74, longitude: -105.18, altitude: 1800}
time: {start_utc: "2025-06-21T10:30:00Z", acceleration: 2}
weather:
  - {start: 10, end: 100, ramp: 20, fog_visibility: 300}
paths:
  loop:
    - {x: 0, y: 0, speed: 3}
    - {x: 50, y: 0, speed: 4.5}
    - {x: 50, y: 50, speed: 0}
formation: {type: column, spacing: 12, width: 4, vehicles: [lead, second, third]}
sensors:
  lidar: {enabled: false}
vehicles:
  - {name: lead, model: fed_alpha, start: {x: 0, y: 0, yaw: 0}, controller: {type: waypoints, path: loop}}
  - {name: second, model: mrzr, start: {x: -12, y: 0}, controller: {type: leader_follower}}
  - name: third
    model: tracer_x
    start: {x: -24, y: 0}
    sensors: {lidar: {enabled: true, preset: VLP-16}, cameras: [{name: front, width: 32, height: 24, rate: 2.0}]}
    controller: {type: leader_follower, params: {track_width_factor: 1.5}}
  - {name: ext, model: m113, start: {x: 0, y: 30, yaw: 1.5}, controller: {type: external}}
v2v: {range: 250, latency: 0.02, loss_probability: 0.05}
agents:
  - {name: deer1, type: deer, path: [[10, 10], [10, -10]], speed: 3, start_time: 5, loop: false}
seed: 7
duration: 60
)";

as::LoadOptions options()
{
  as::LoadOptions o;
  o.vehicles_dir = kConfig + "/vehicles";
  o.soils_file = kConfig + "/soils.yaml";
  return o;
}

/// A terrain of the flat scenario's extent with one building at (0, 30) (ext's start) when
/// `building` is set: the start-pose check without building a grid.
as::LoadOptions fakeTerrain(bool building)
{
  as::LoadOptions o = options();
  o.terrain_loader = [building](const as::TerrainSpec&) {
    auto t = std::make_shared<as::TerrainFootprint>();
    t->min_x = -100.0;
    t->min_y = -100.0;
    t->max_x = 100.0;
    t->max_y = 100.0;
    if (building)
    {
      avsp::terrain::TerrainObject o;
      o.type = avsp::terrain::ObjectType::kBuilding;
      o.x = 2.0;
      o.y = 31.0;
      o.length = 10.0;
      o.width = 6.0;
      o.height = 4.0;
      t->objects.add(o);
    }
    return std::shared_ptr<const as::TerrainFootprint>(t);
  };
  return o;
}

YAML::Node base()
{
  return YAML::Load(kBase);
}

std::string dump(const YAML::Node& n)
{
  YAML::Emitter e;
  e << n;
  return e.c_str();
}

/// The loader's message for `text`, or "" when it loads.
std::string errorOf(const std::string& text, const as::LoadOptions& o = fakeTerrain(false))
{
  try
  {
    as::parseScenario(text, "/some/dir/base.yaml", o);
  }
  catch (const as::ScenarioError& e)
  {
    return e.what();
  }
  return "";
}

std::string errorOf(const YAML::Node& n)
{
  return errorOf(dump(n));
}

#define EXPECT_ERROR(message, ...)                                                                         \
  do                                                                                                       \
  {                                                                                                        \
    const std::string m_ = (message);                                                                      \
    EXPECT_EQ(m_.rfind("/some/dir/base.yaml: ", 0), 0u) << "message does not start with the file: " << m_; \
    for (const std::string& part : { __VA_ARGS__ })                                                        \
      EXPECT_NE(m_.find(part), std::string::npos) << "'" << part << "' not in: " << m_;                    \
  } while (0)
}  // namespace

TEST(Scenario, ValidFileLoadsWithFormationSlots)
{
  const as::Scenario s = as::parseScenario(kBase, "/some/dir/base.yaml", fakeTerrain(false));
  EXPECT_EQ(s.name, "base");
  ASSERT_EQ(s.vehicles.size(), 4u);
  EXPECT_EQ(s.vehicles[0].controller.type, as::ControllerType::kWaypoints);
  EXPECT_EQ(s.vehicles[0].controller.path, "loop");
  ASSERT_EQ(s.paths.at("loop").size(), 3u);
  EXPECT_EQ(s.paths.at("loop")[1].speed, 4.5);
  // Column: each follows the one before at the spacing, in its tracks.
  EXPECT_EQ(s.vehicles[1].controller.leader, "lead");
  EXPECT_EQ(s.vehicles[1].controller.gap, 12.0);
  EXPECT_EQ(s.vehicles[1].controller.offset, 0.0);
  EXPECT_EQ(s.vehicles[2].controller.leader, "second");
  EXPECT_EQ(s.vehicles[2].controller.gap, 12.0);
  EXPECT_TRUE(s.vehicles[2].controller.from_formation);
  EXPECT_EQ(s.vehicles[3].controller.type, as::ControllerType::kExternal);
  EXPECT_EQ(s.vehicles[3].yaw, 1.5);
  EXPECT_EQ(s.vehicles[1].yaw, 0.0);
  EXPECT_EQ(s.latitude, 39.74);
  EXPECT_EQ(s.altitude, 1800.0);
  EXPECT_EQ(s.time_acceleration, 2.0);
  EXPECT_EQ(s.v2v.range, 250.0);
  EXPECT_EQ(s.v2v.antenna_height, 1.5);  // default
  EXPECT_EQ(s.seed, 7u);
  EXPECT_EQ(s.duration, 60.0);
  EXPECT_EQ(s.agents.size(), 1u);
  EXPECT_EQ(s.terrain.kind, as::TerrainSpec::Kind::kFlat);
  EXPECT_EQ(s.terrain.soils_file, kConfig + "/soils.yaml");
}

TEST(Scenario, LineAndDiamondFormationsTakeTheCoreSlots)
{
  for (const char* type : { "line", "diamond" })
  {
    YAML::Node n = base();
    n["formation"]["type"] = type;
    const as::Scenario s = as::parseScenario(dump(n), "/some/dir/base.yaml", fakeTerrain(false));
    const auto slots = avsp::control::formationSlots(avsp::control::formationFromString(type), 3, 12.0, 4.0);
    for (std::size_t k = 1; k < 3; ++k)
    {
      EXPECT_EQ(s.vehicles[k].controller.leader, s.formation.vehicles[static_cast<std::size_t>(slots[k].leader)]);
      EXPECT_EQ(s.vehicles[k].controller.gap, slots[k].gap);
      EXPECT_EQ(s.vehicles[k].controller.offset, slots[k].offset);
    }
    EXPECT_NE(s.vehicles[1].controller.offset, 0.0) << type;
  }
}

TEST(Scenario, MissingKeysAreNamed)
{
  YAML::Node n = base();
  n.remove("time");
  EXPECT_ERROR(errorOf(n), "time: missing key");
  n = base();
  n["vehicles"][0].remove("model");
  EXPECT_ERROR(errorOf(n), "vehicles[0].model: missing key");
  n = base();
  n["vehicles"][1]["start"].remove("y");
  EXPECT_ERROR(errorOf(n), "vehicles[1].start.y: missing key");
  n = base();
  n["paths"]["loop"][2].remove("speed");
  EXPECT_ERROR(errorOf(n), "paths.loop[2].speed: missing key");
  n = base();
  n["weather"][0].remove("end");
  EXPECT_ERROR(errorOf(n), "weather[0]", "end");
  n = base();
  n["agents"][0].remove("type");
  EXPECT_ERROR(errorOf(n), "agents[0].type: missing (required)");
}

TEST(Scenario, UnknownKeysAreNamed)
{
  YAML::Node n = base();
  n["colour"] = "red";
  EXPECT_ERROR(errorOf(n), "colour: unknown key (allowed: ");
  n = base();
  n["vehicles"][1]["colour"] = "red";
  EXPECT_ERROR(errorOf(n), "vehicles[1].colour: unknown key");
  n = base();
  // Which controller keys exist is controller_node's parser's to say (test_node_checks.cpp);
  // the loader takes numbers only.
  n["vehicles"][0]["controller"]["params"]["lookahead_min"] = "far";
  EXPECT_ERROR(errorOf(n), "vehicles[0].controller.params.lookahead_min: ");
  n = base();
  n["vehicles"][2]["sensors"]["sonar"]["enabled"] = true;
  EXPECT_ERROR(errorOf(n), "vehicles[2].sensors.sonar: unknown key");
  n = base();
  n["vehicles"][2]["sensors"]["cameras"] = YAML::Load("{name: front}");  // one map, not a list
  EXPECT_ERROR(errorOf(n), "vehicles[2].sensors.cameras: must be a list of sensors");
  n = base();
  n["terrain"]["flat"]["slope"] = 3;
  EXPECT_ERROR(errorOf(n), "terrain.flat.slope: unknown key");
  n = base();
  n["weather"][0]["drizzle"] = 3;
  EXPECT_ERROR(errorOf(n), "weather[0]", "drizzle");
}

TEST(Scenario, UnknownModelControllerFormationAndPathAreNamed)
{
  YAML::Node n = base();
  n["vehicles"][0]["model"] = "rover7";
  EXPECT_ERROR(errorOf(n), "vehicles[0].model: unknown model 'rover7'", "fed_alpha, m113, mrzr, quadruped, tracer_x");
  // A legged model loads (config/vehicles/quadruped.yaml) but cannot run in a scenario yet.
  n = base();
  n["vehicles"][0]["model"] = "quadruped";
  EXPECT_ERROR(errorOf(n), "vehicles[0].model: model 'quadruped' is legged", "scenarios cannot run them");
  n = base();
  n["vehicles"][2]["controller"]["type"] = "foo";
  EXPECT_ERROR(errorOf(n), "vehicles[2].controller.type: unknown 'foo' (waypoints, leader_follower, external)");
  n = base();
  n["formation"]["type"] = "wedge";
  EXPECT_ERROR(errorOf(n), "formation.type: unknown 'wedge' (column, line, diamond)");
  n = base();
  n["vehicles"][0]["controller"]["path"] = "recon";
  EXPECT_ERROR(errorOf(n), "vehicles[0].controller.path: unknown path 'recon' (paths: loop)");
  n = base();
  n["terrain"]["flat"]["soil"] = "lava";
  EXPECT_ERROR(errorOf(n), "terrain.flat.soil: unknown soil 'lava'");
  n = base();
  n["terrain"]["default_course"] = YAML::Node(YAML::NodeType::Map);
  EXPECT_ERROR(errorOf(n), "terrain: give exactly one of default_course, file, flat");
  n = base();
  n["terrain"].remove("flat");
  n["terrain"]["file"] = "missing.tif";
  EXPECT_ERROR(errorOf(n), "terrain.file: cannot read '/some/dir/missing.tif'");
}

TEST(Scenario, EmptyPathAndNegativeSpeedsAreRefused)
{
  YAML::Node n = base();
  n["paths"]["loop"] = YAML::Node(YAML::NodeType::Sequence);
  EXPECT_ERROR(errorOf(n), "paths.loop: empty path");
  n = base();
  n["paths"]["loop"][1]["speed"] = -1.0;
  EXPECT_ERROR(errorOf(n), "paths.loop[1].speed: negative speed -1 m/s");
  n = base();
  n["paths"]["loop"][2]["speed"] = -0.5;  // the last one too
  EXPECT_ERROR(errorOf(n), "paths.loop[2].speed: negative speed");
  n = base();
  // Agents are checked by the nodes' own validator (avsp_terrain validateAgentSpecs).
  n["agents"][0]["speed"] = -2;
  EXPECT_ERROR(errorOf(n), "agents[0].speed: must be finite and >= 0 m/s, got -2");
  n = base();
  n["agents"][0]["path"] = YAML::Node(YAML::NodeType::Sequence);
  EXPECT_ERROR(errorOf(n), "agents[0].path: needs at least one point");
  // Issue 21: a looping agent on two points passed --check, then three nodes refused it.
  n = base();
  n["agents"][0]["loop"] = true;
  n["agents"][0]["path"] = YAML::Load("[[10.0, 10.0], [20.0, 10.0]]");
  n["agents"][0]["speed"] = 2.0;
  EXPECT_ERROR(errorOf(n), "agents[0].path: a moving looping agent needs at least 3 points, got 2");
  n = base();
  n["agents"][0]["type"] = "bear";
  EXPECT_ERROR(errorOf(n), "agents[0].type: unknown agent type 'bear' (deer, pedestrian or truck)");
  n = base();
  n["weather"][0]["rain_rate_mm_h"] = -5;
  EXPECT_ERROR(errorOf(n), "weather[0].rain_rate_mm_h");
  n = base();
  n["duration"] = -3;
  EXPECT_ERROR(errorOf(n), "duration: -3 must be finite and in");
  n = base();
  n["v2v"]["loss_probability"] = 1.5;
  EXPECT_ERROR(errorOf(n), "v2v.loss_probability: 1.5 must be finite and in [0, 1]");
}

TEST(Scenario, DuplicateNamesAreRefused)
{
  YAML::Node n = base();
  n["vehicles"][3]["name"] = "lead";
  EXPECT_ERROR(errorOf(n), "vehicles[3].name: duplicate name 'lead'");
  n = base();
  n["agents"][0]["name"] = "second";  // an agent may not share a vehicle's name (TF frames)
  EXPECT_ERROR(errorOf(n), "agents[0].name: duplicate name 'second'");
  n = base();
  n["formation"]["vehicles"][2] = "lead";
  EXPECT_ERROR(errorOf(n), "formation.vehicles[2]: 'lead' is listed twice");
  const std::string dup_key = std::string(kBase) + "seed: 8\n";
  EXPECT_ERROR(errorOf(dup_key), "seed: duplicate key");
}

TEST(Scenario, LeadersMustExistWithoutCycles)
{
  YAML::Node n = base();
  n.remove("formation");
  EXPECT_ERROR(errorOf(n), "vehicles[1].controller.leader: missing key");
  n["vehicles"][1]["controller"]["leader"] = "nobody";
  n["vehicles"][2]["controller"]["leader"] = "second";
  EXPECT_ERROR(errorOf(n), "vehicles[1].controller.leader: unknown vehicle 'nobody'");
  n["vehicles"][1]["controller"]["leader"] = "second";
  EXPECT_ERROR(errorOf(n), "vehicles[1].controller.leader: leader cycle second -> second");
  n["vehicles"][1]["controller"]["leader"] = "third";
  EXPECT_ERROR(errorOf(n), "vehicles[1].controller.leader: leader cycle second -> third -> second");
  n["vehicles"][1]["controller"]["leader"] = "lead";
  EXPECT_EQ(errorOf(n), "");
  // Three-cycle through the formation's head turned follower.
  n["vehicles"][0]["controller"] = YAML::Load("{type: leader_follower, leader: third}");
  EXPECT_ERROR(errorOf(n), "vehicles[0].controller.leader: leader cycle lead -> third -> second -> lead");
  // A formation member may not set its own leader.
  n = base();
  n["vehicles"][1]["controller"]["leader"] = "ext";
  EXPECT_ERROR(errorOf(n), "vehicles[1].controller.leader: set by the formation");
  n = base();
  n["vehicles"][1]["controller"] = YAML::Load("{type: external}");
  EXPECT_ERROR(errorOf(n), "vehicles[1].controller.type: 'second' is in the formation");
}

TEST(Scenario, StartInsideABuildingOrOffTheTerrainIsRefused)
{
  EXPECT_ERROR(errorOf(kBase, fakeTerrain(true)), "vehicles[3].start: 'ext' starts inside building 0 at (2, 31)");
  YAML::Node n = base();
  n["vehicles"][3]["start"]["y"] = 34.5;  // 0.5 m north of the building's north wall (y 34)
  EXPECT_ERROR(errorOf(dump(n), fakeTerrain(true)), "vehicles[3].start: 'ext' starts within 1 m of building 0");
  n["vehicles"][3]["start"]["y"] = 35.5;  // 1.5 m: clear
  EXPECT_EQ(errorOf(dump(n), fakeTerrain(true)), "");
  n["vehicles"][3]["start"]["x"] = 97.0;  // within 5 m of the edge
  EXPECT_ERROR(errorOf(dump(n), fakeTerrain(true)), "vehicles[3].start: (97, 35.5) is off the terrain");
  n = base();
  n["paths"]["loop"][2]["y"] = 150;
  EXPECT_ERROR(errorOf(n), "paths.loop[2]: (50, 150) is off the terrain");
}

// The agents' paths as the nodes build them: agents_node would stop the run at start-up with
// this error, after --check had passed it (issue 21).
TEST(Scenario, AnAgentPathLeavingTheTerrainIsRefused)
{
  YAML::Node n = base();
  n["agents"][0]["path"] = YAML::Load("[[10, 10], [150, 10]]");
  EXPECT_ERROR(errorOf(dump(n), options()), "agents[0].path: leaves the terrain at (");
  // Every point on the terrain, but the closed spline through them swings past the east edge
  // (x = 100) between the two points at x = 99.
  n["agents"][0]["path"] = YAML::Load("[[99, -60], [99, 60], [0, 90], [-60, 0], [0, -90]]");
  n["agents"][0]["loop"] = true;
  EXPECT_ERROR(errorOf(dump(n), options()), "agents[0].path: leaves the terrain at (100.");
  n["agents"][0]["path"] = YAML::Load("[[80, -60], [80, 60], [0, 90], [-60, 0], [0, -90]]");
  EXPECT_EQ(errorOf(dump(n), options()), "");
}

TEST(Scenario, StartInsideABuildingOfTheDefaultCourse)
{
  // The real course at 1 m cells: the staging area's first building spans x 53-67, y 218.5-227.5.
  YAML::Node n = base();
  n["terrain"] = YAML::Load("{default_course: {seed: 1, cell_size: 1.0}}");
  n["paths"]["loop"] = YAML::Load("[{x: 30, y: 222, speed: 3}, {x: 30, y: 260, speed: 0}]");
  n["vehicles"][0]["start"] = YAML::Load("{x: 30, y: 222}");
  n["vehicles"][1]["start"] = YAML::Load("{x: 30, y: 210}");
  n["vehicles"][2]["start"] = YAML::Load("{x: 30, y: 205}");
  n["vehicles"][3]["start"] = YAML::Load("{x: 60, y: 223}");
  n["agents"][0]["path"] = YAML::Load("[[100, 100], [120, 100]]");
  EXPECT_ERROR(errorOf(dump(n), options()), "vehicles[3].start: 'ext' starts inside building");
  n["vehicles"][3]["start"] = YAML::Load("{x: 40, y: 212}");
  EXPECT_EQ(errorOf(dump(n), options()), "");
}

TEST(Scenario, SyntaxErrorsAndBadValuesNameTheFile)
{
  EXPECT_ERROR(errorOf("terrain: {flat: [\n"), "line ");
  EXPECT_ERROR(errorOf(""), "(top level): empty file");
  EXPECT_ERROR(errorOf("- a\n- b\n"), "(top level): must be a map");
  YAML::Node n = base();
  n["time"]["start_utc"] = "yesterday";
  EXPECT_ERROR(errorOf(n), "time.start_utc: ");
  n = base();
  n["geodetic_reference"]["latitude"] = "north";
  EXPECT_ERROR(errorOf(n), "geodetic_reference.latitude: 'north' is not a number");
  n = base();
  n["vehicles"][0]["name"] = "a/b";
  EXPECT_ERROR(errorOf(n), "vehicles[0].name: 'a/b' is not a valid name");
  try
  {
    as::loadScenario("/nonexistent/x.yaml", options());
    FAIL() << "no error";
  }
  catch (const as::ScenarioError& e)
  {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/x.yaml: cannot open the file");
  }
  // Issue 21: a device is read forever, a 60 MB scenario took 4.8 GB to check.
  const auto refusal = [](const std::string& path) {
    try
    {
      as::loadScenario(path, options());
    }
    catch (const as::ScenarioError& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refusal("/dev/zero"), "/dev/zero: not a regular file");
  const std::string big = "/tmp/avsp_test_scenario_big_" + std::to_string(::getpid()) + ".yaml";
  {
    std::ofstream f(big);
    f << "# " << std::string((4u << 20), 'x') << "\n";
  }
  EXPECT_NE(refusal(big).find("bytes, more than the 4194304 a scenario file may have"), std::string::npos)
      << refusal(big);
  std::remove(big.c_str());
}

TEST(Scenario, FuzzedTextsNeverCrashAndAlwaysNameTheFile)
{
  // Mutations of the valid text: characters deleted, inserted or replaced, lines dropped,
  // duplicated or swapped, numbers replaced by odd ones. Every outcome is a scenario or a
  // ScenarioError naming the file; anything else (another exception, a crash) fails.
  std::mt19937 rng(20261123);
  const std::string text = kBase;
  const std::string alphabet = "abcxyz019-.:{}[],# \n\"'!&*|>-";
  const char* const numbers[] = { "-1",   "0", "1e308", "-1e308", ".nan", ".inf", "1e-320", "99999999999999999999",
                                  "0x10", "~" };
  int loaded = 0, refused = 0;
  const as::LoadOptions o = fakeTerrain(false);
  for (int iteration = 0; iteration < 3000; ++iteration)
  {
    std::string t = text;
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int e = 0; e < edits; ++e)
    {
      const std::size_t pos = rng() % t.size();
      switch (rng() % 6)
      {
        case 0:
          t.erase(pos, 1 + rng() % 4);
          break;
        case 1:
          t.insert(pos, 1, alphabet[rng() % alphabet.size()]);
          break;
        case 2:
          t[pos] = alphabet[rng() % alphabet.size()];
          break;
        case 3:
        {
          // drop or duplicate the line at pos
          const std::size_t b = t.rfind('\n', pos), en = t.find('\n', pos);
          if (b != std::string::npos && en != std::string::npos)
          {
            const std::string line = t.substr(b, en - b);
            if (rng() % 2)
              t.erase(b, en - b);
            else
              t.insert(en, line);
          }
          break;
        }
        case 4:
        {
          // replace the number at or after pos
          const std::size_t d = t.find_first_of("0123456789", pos);
          if (d != std::string::npos)
          {
            std::size_t end = d;
            while (end < t.size() && (std::isdigit(static_cast<unsigned char>(t[end])) || t[end] == '.'))
              ++end;
            t.replace(d, end - d, numbers[rng() % (sizeof numbers / sizeof *numbers)]);
          }
          break;
        }
        default:
        {
          // swap two lines
          std::vector<std::string> lines;
          std::stringstream ss(t);
          for (std::string l; std::getline(ss, l);)
            lines.push_back(l);
          std::swap(lines[rng() % lines.size()], lines[rng() % lines.size()]);
          t.clear();
          for (const auto& l : lines)
            t += l + "\n";
        }
      }
      if (t.empty())
        t = "x";
    }
    try
    {
      as::parseScenario(t, "/fuzz/fuzz.yaml", o);
      ++loaded;
    }
    catch (const as::ScenarioError& e)
    {
      ++refused;
      ASSERT_EQ(std::string(e.what()).rfind("/fuzz/fuzz.yaml: ", 0), 0u) << e.what() << "\n--- text:\n" << t;
    }
    catch (const std::exception& e)
    {
      FAIL() << "not a ScenarioError: " << e.what() << "\n--- text:\n" << t;
    }
  }
  // Both outcomes occur, so the mutations exercise the checks and the valid paths.
  EXPECT_GT(loaded, 50);
  EXPECT_GT(refused, 1000);
  std::printf("fuzz: %d loaded, %d refused\n", loaded, refused);
}

// ---- Launch generation ----

namespace
{
/// The body of `<rosparam param="name">` inside the first `<node ... name="node">` ... `</node>`.
YAML::Node rosparamOf(const std::string& xml, const std::string& node, const std::string& param)
{
  const std::size_t n = xml.find("name=\"" + node + "\"");
  if (n == std::string::npos)
    return YAML::Node();
  const std::size_t end = xml.find("</node>", n);
  const std::string open = "<rosparam param=\"" + param + "\">";
  const std::size_t p = xml.find(open, n);
  if (p == std::string::npos || p > end)
    return YAML::Node();
  const std::size_t b = p + open.size();
  std::string body = xml.substr(b, xml.find("</rosparam>", b) - b);
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           { "&quot;", "\"" }, { "&lt;", "<" }, { "&gt;", ">" }, { "&amp;", "&" } })
    for (std::size_t k; (k = body.find(from)) != std::string::npos;)
      body.replace(k, from.size(), to);
  return YAML::Load(body);
}

/// value="..." of `<param name="param" ...>` inside the node called `node` (in the group `ns`
/// when given).
std::string paramOf(const std::string& xml, const std::string& node, const std::string& param,
                    const std::string& ns = "")
{
  std::size_t from = 0;
  if (!ns.empty())
    from = xml.find("<group ns=\"" + ns + "\">");
  const std::size_t n = xml.find("name=\"" + node + "\"", from);
  if (n == std::string::npos)
    return "<no node>";
  const std::size_t end = xml.find("</node>", n);
  const std::size_t p = xml.find("<param name=\"" + param + "\"", n);
  if (p == std::string::npos || p > end)
    return "<no param>";
  const std::size_t v = xml.find("value=\"", p) + 7;
  return xml.substr(v, xml.find('"', v) - v);
}
}  // namespace

TEST(LaunchGenerator, NumbersReadBackExactly)
{
  for (double v : { 0.0, 1.0, -3.0, 0.1, 1.0 / 3.0, 600.0, 1e-7, 123456789.125, -2.5e300 })
  {
    const std::string s = as::yamlDouble(v);
    EXPECT_EQ(YAML::Load(s).as<double>(), v) << s;
    EXPECT_NE(s.find_first_of(".eE"), std::string::npos) << s;  // a float for XML-RPC
  }
  EXPECT_EQ(as::yamlDouble(600.0), "600.0");
  EXPECT_EQ(as::yamlDouble(0.1), "0.1");
  EXPECT_EQ(as::flowYaml(YAML::Load("{a: 50, b: true, c: \"50\", d: [1, x]}"), true),
            "{\"a\": 50.0, \"b\": true, \"c\": \"50\", \"d\": [1.0, \"x\"]}");
  EXPECT_EQ(as::flowYaml(YAML::Load("{cluster_min_points: 3, preset: VLP-16}"), false),
            "{\"cluster_min_points\": 3, \"preset\": \"VLP-16\"}");
}

TEST(LaunchGenerator, EveryNodeGetsTheScenariosParameters)
{
  const as::Scenario s = as::parseScenario(kBase, "/some/dir/base.yaml", fakeTerrain(false));
  as::LaunchOptions o;
  o.output_dir = "/tmp/results/base";
  o.vehicles_dir = kConfig + "/vehicles";
  o.duration = 30.0;
  const std::string xml = as::generateLaunch(s, o);

  // dynamics: every vehicle with its start pose, the terrain, lockstep.
  const YAML::Node dyn = rosparamOf(xml, "dynamics", "vehicles");
  ASSERT_EQ(dyn.size(), 4u);
  EXPECT_EQ(dyn[3]["name"].as<std::string>(), "ext");
  EXPECT_EQ(dyn[3]["model"].as<std::string>(), "m113");
  EXPECT_EQ(dyn[3]["yaw"].as<double>(), 1.5);
  EXPECT_EQ(dyn[1]["x"].as<double>(), -12.0);
  EXPECT_EQ(paramOf(xml, "dynamics", "flat_soil"), "gravel");
  EXPECT_EQ(paramOf(xml, "dynamics", "flat_cell_size"), "1.0");
  EXPECT_EQ(paramOf(xml, "dynamics", "real_time_factor"), "0.0");
  // The physics waits for start_gate's signal, not for commands: the gate publishes nothing in
  // a vehicle's namespace (avt_341/cmd_vel belongs to whatever drives it).
  EXPECT_EQ(paramOf(xml, "dynamics", "start_topic"), "/start_gate/open");
  EXPECT_EQ(paramOf(xml, "dynamics", "wait_for_command"), "<no param>");
  EXPECT_TRUE(rosparamOf(xml, "start_gate", "vehicles").IsNull());  // no such rosparam (a list if there were)
  EXPECT_EQ(paramOf(xml, "terrain", "flat_size"), "200.0");
  EXPECT_EQ(paramOf(xml, "terrain", "soils_file"), kConfig + "/soils.yaml");
  // sensors: shared sections, per-vehicle ones, geodetic reference.
  EXPECT_EQ(rosparamOf(xml, "sensors", "sensors")["lidar"]["enabled"].as<bool>(), false);
  EXPECT_EQ(rosparamOf(xml, "sensors", "vehicle_sensors/third")["lidar"]["preset"].as<std::string>(), "VLP-16");
  // Cameras from the scenario file reach sensors_node as they were written.
  const YAML::Node cameras = rosparamOf(xml, "sensors", "vehicle_sensors/third")["cameras"];
  ASSERT_TRUE(cameras.IsSequence());
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_EQ(cameras[0]["name"].as<std::string>(), "front");
  EXPECT_EQ(cameras[0]["width"].as<int>(), 32);
  EXPECT_EQ(cameras[0]["rate"].as<double>(), 2.0);
  EXPECT_TRUE(rosparamOf(xml, "sensors", "vehicle_sensors/lead").IsNull());
  EXPECT_EQ(paramOf(xml, "sensors", "latitude"), "39.74");
  EXPECT_EQ(paramOf(xml, "sensors", "date"), "2025-06-21");  // the magnetometer's model date
  // environment: world time and weather (numbers as floats).
  EXPECT_EQ(paramOf(xml, "environment", "start_utc"), "2025-06-21T10:30:00Z");
  EXPECT_EQ(paramOf(xml, "environment", "time_acceleration"), "2.0");
  EXPECT_EQ(rosparamOf(xml, "environment", "weather")[0]["fog_visibility"].Scalar(), "300.0");
  // V2V radio.
  EXPECT_EQ(rosparamOf(xml, "v2v_radio", "vehicles").size(), 4u);
  EXPECT_EQ(paramOf(xml, "v2v_radio", "range"), "250.0");
  EXPECT_EQ(paramOf(xml, "v2v_radio", "loss_probability"), "0.05");
  EXPECT_EQ(paramOf(xml, "v2v_radio", "seed"), "7");
  // agents: the same list for agents_node, dynamics and sensors.
  for (const char* node : { "agents", "dynamics", "sensors" })
  {
    const YAML::Node a = rosparamOf(xml, node, "agents");
    ASSERT_EQ(a.size(), 1u) << node;
    EXPECT_EQ(a[0]["type"].as<std::string>(), "deer");
    EXPECT_EQ(a[0]["path"][1][1].as<double>(), -10.0);
    EXPECT_EQ(a[0]["loop"].as<bool>(), false);
  }
  EXPECT_EQ(paramOf(xml, "agents", "flat_soil"), "gravel");
  // controllers: waypoints with speeds, formation slots, extra params; none for external.
  const YAML::Node wps = rosparamOf(xml, "controller", "waypoints");
  ASSERT_EQ(wps.size(), 3u);
  EXPECT_EQ(wps[1]["speed"].as<double>(), 4.5);
  EXPECT_EQ(paramOf(xml, "controller", "mode", "lead"), "waypoints");
  EXPECT_EQ(paramOf(xml, "controller", "leader", "second"), "lead");
  EXPECT_EQ(paramOf(xml, "controller", "gap", "second"), "12.0");
  EXPECT_EQ(paramOf(xml, "controller", "leader", "third"), "second");
  EXPECT_EQ(paramOf(xml, "controller", "track_width_factor", "third"), "1.5");
  const std::size_t ext = xml.find("<group ns=\"ext\">");
  ASSERT_NE(ext, std::string::npos);
  const std::string ext_group = xml.substr(ext, xml.find("</group>", ext) - ext);
  EXPECT_NE(ext_group.find("v2v_broadcaster"), std::string::npos);
  EXPECT_EQ(ext_group.find("controller_node"), std::string::npos);
  // recorder: required, vehicles with leaders, the duration override.
  EXPECT_NE(xml.find("type=\"run_recorder\" name=\"run_recorder\" clear_params=\"true\" required=\"true\""),
            std::string::npos);
  // Every node starts from an empty private namespace: on a master that ran another scenario,
  // its parameters (another vehicle's sensors, its agents) must not be read as this run's.
  std::size_t nodes = 0;
  for (std::size_t at = xml.find("<node "); at != std::string::npos; at = xml.find("<node ", at + 1), ++nodes)
    EXPECT_NE(xml.substr(at, xml.find('>', at) - at).find(" clear_params=\"true\""), std::string::npos)
        << xml.substr(at, xml.find('>', at) - at);
  EXPECT_GE(nodes, 10u);
  const YAML::Node rec = rosparamOf(xml, "run_recorder", "vehicles");
  ASSERT_EQ(rec.size(), 4u);
  EXPECT_EQ(rec[0]["leader"].as<std::string>(), "");
  EXPECT_EQ(rec[2]["leader"].as<std::string>(), "second");
  // What each model can do, from its files, for the recorder's anomaly counts: tracer_x is
  // governed at 2 m/s (config/vehicles/tracer_x.yaml) on wheels whose axles carry base_link.
  EXPECT_DOUBLE_EQ(rec[2]["max_speed"].as<double>(), 2.0);
  EXPECT_GT(rec[2]["wheel_radius"].as<double>(), 0.1);
  EXPECT_LT(rec[2]["wheel_radius"].as<double>(), 0.2);
  EXPECT_DOUBLE_EQ(rec[2]["rest_height"].as<double>(), rec[2]["wheel_radius"].as<double>());
  EXPECT_DOUBLE_EQ(rec[3]["max_speed"].as<double>(), 18.0) << "the m113";
  EXPECT_EQ(paramOf(xml, "run_recorder", "duration"), "30.0");
  EXPECT_EQ(paramOf(xml, "run_recorder", "end_launch"), "true");  // a finished run ends its roslaunch
  EXPECT_EQ(paramOf(xml, "run_recorder", "output_dir"), "/tmp/results/base");
  // Every node holding the terrain gets the same point budget.
  EXPECT_EQ(paramOf(xml, "terrain", "max_cells"), "250000000");
  EXPECT_EQ(paramOf(xml, "sensors", "max_cells"), "250000000");
  // SaveMap services write into the run's results folder (issue 21).
  EXPECT_EQ(paramOf(xml, "terrain", "output_dir"), "/tmp/results/base");
  EXPECT_EQ(paramOf(xml, "sensors", "output_dir"), "/tmp/results/base");
  // run_recorder watches every node that must live for the whole run (and not start_gate,
  // which exits once the physics starts): each node of the file, each vehicle's three.
  {
    const YAML::Node watch = rosparamOf(xml, "run_recorder", "watch");
    std::set<std::string> names;
    for (const YAML::Node& n : watch)
      names.insert(n.as<std::string>());
    for (const char* n : { "/map_to_odom", "/terrain", "/sensors", "/environment", "/v2v_radio", "/dynamics" })
      EXPECT_EQ(names.count(n), 1u) << n;
    EXPECT_EQ(names.count("/start_gate"), 0u);
    EXPECT_EQ(names.count("/run_recorder"), 0u);
    for (std::size_t k = 0; (k = xml.find("<group ns=\"", k)) != std::string::npos; ++k)
    {
      const std::string ns = xml.substr(k + 11, xml.find('"', k + 11) - k - 11);
      EXPECT_EQ(names.count("/" + ns + "/v2v_broadcaster"), 1u) << ns;
      EXPECT_EQ(names.count("/" + ns + "/robot_state_publisher"), 1u) << ns;
    }
    EXPECT_EQ(names.count("/agents"), 1u) << "the scenario has agents";
    EXPECT_EQ(names.size(), 6u + 1u + 4u * 2u + 3u) << "three of the four vehicles have a controller";
  }
  EXPECT_EQ(paramOf(xml, "run_recorder", "scenario_name"), "base");
  // one description per vehicle, the start gate, no RViz unless asked.
  std::size_t descriptions = 0;
  for (std::size_t k = 0; (k = xml.find("vehicle_description.launch", k)) != std::string::npos; ++k)
    ++descriptions;
  EXPECT_EQ(descriptions, 4u);
  EXPECT_EQ(rosparamOf(xml, "start_gate", "nodes").size(), 5u + 1u + 4u * 2u + 3u);
  EXPECT_EQ(xml.find("rviz"), std::string::npos);
  o.rviz = true;
  o.duration = 0.0;
  const std::string with_rviz = as::generateLaunch(s, o);
  EXPECT_NE(with_rviz.find("type=\"rviz\""), std::string::npos);
  EXPECT_EQ(paramOf(with_rviz, "run_recorder", "duration"), "60.0");
}

TEST(LaunchGenerator, CommandLine)
{
  const as::LaunchCommand c = as::parseLaunchCommand(
      { "s.yaml", "--duration", "30", "--real-time-factor", "1", "--rviz", "false", "__name:=x", "--out", "-" });
  EXPECT_EQ(c.scenario, "s.yaml");
  EXPECT_EQ(c.options.duration, 30.0);
  EXPECT_EQ(c.options.real_time_factor, 1.0);
  EXPECT_FALSE(c.options.rviz);
  EXPECT_EQ(c.out, "-");
  EXPECT_TRUE(as::parseLaunchCommand({ "s.yaml", "--rviz" }).options.rviz);
  EXPECT_TRUE(as::parseLaunchCommand({ "s.yaml", "--end-launch" }).end_launch);
  EXPECT_FALSE(as::parseLaunchCommand({ "s.yaml" }).end_launch);
  EXPECT_THROW(as::parseLaunchCommand({ "s.yaml", "--duration", "-1" }), std::invalid_argument);
  // The nodes' ranges (run_numbers.hpp): what dynamics_node or run_recorder would refuse at
  // start-up is refused on the command line, naming the option and the range.
  EXPECT_EQ(as::parseLaunchCommand({ "s.yaml", "--real-time-factor", "1000" }).options.real_time_factor, 1000.0);
  auto refusal = [](const std::vector<std::string>& args) {
    try
    {
      as::parseLaunchCommand(args);
    }
    catch (const std::invalid_argument& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(refusal({ "s.yaml", "--real-time-factor", "2000" }),
            "--real-time-factor: must be in [0.0, 1000.0] x wall-clock pace (0: as fast as possible)");
  EXPECT_EQ(refusal({ "s.yaml", "--duration", "1e-4" }),
            "--duration: must be in [0.001, 1000000000.0] s of sim time (0: the scenario's)");
  EXPECT_EQ(refusal({ "s.yaml", "--progress-period", "0.001" }),
            "--progress-period: must be in [0.01, 3600.0] s of wall time");
  EXPECT_EQ(as::parseLaunchCommand({ "s.yaml", "--duration", "0" }).options.duration, 0.0);
  EXPECT_THROW(as::parseLaunchCommand({ "s.yaml", "--duration" }), std::invalid_argument);
  EXPECT_THROW(as::parseLaunchCommand({ "s.yaml", "--speed", "2" }), std::invalid_argument);
  EXPECT_THROW(as::parseLaunchCommand({}), std::invalid_argument);
}

TEST(ReferenceScenario, LoadsOnTheRealCourse)
{
  for (const char* file : { "reference_traverse.yaml", "reference_traverse_ci.yaml" })
  {
    const as::Scenario s = as::loadScenario(kConfig + "/scenarios/" + file, options());
    ASSERT_EQ(s.vehicles.size(), 4u) << file;
    EXPECT_EQ(s.vehicles[0].model, "m113");
    EXPECT_EQ(s.vehicles[0].controller.type, as::ControllerType::kWaypoints);
    for (std::size_t i = 1; i < 4; ++i)
      EXPECT_EQ(s.vehicles[i].controller.type, as::ControllerType::kLeaderFollower);
    EXPECT_GE(s.agents.size(), 2u);
    EXPECT_GE(s.weather.size(), 1u);
  }
}

TEST(ReferenceScenario, CarriersRouteKeepsClearOfObjects)
{
  // The leader's path (the followers drive in its tracks) stays 2.5 m from every object but
  // grass, so no vehicle (at most 2.7 m wide) meets one on the way; through the slalom that is
  // the distance to the gates' barriers.
  const as::Scenario s = as::loadScenario(kConfig + "/scenarios/reference_traverse.yaml", options());
  const auto terrain = as::loadTerrainFootprint(s.terrain);
  const std::vector<as::Waypoint>& path = s.paths.at("traverse");
  double worst = 1e9;
  std::string worst_what;
  for (std::size_t k = 0; k + 1 < path.size(); ++k)
  {
    const double len = std::hypot(path[k + 1].x - path[k].x, path[k + 1].y - path[k].y);
    const int n = static_cast<int>(std::ceil(len / 0.25));
    for (int i = 0; i <= n; ++i)
    {
      const double t = static_cast<double>(i) / n;
      const double x = path[k].x + t * (path[k + 1].x - path[k].x), y = path[k].y + t * (path[k + 1].y - path[k].y);
      for (std::uint32_t id : terrain->objects.query(x - 4.0, y - 4.0, x + 4.0, y + 4.0))
      {
        const auto& o = terrain->objects.get(id);
        if (o.type == avsp::terrain::ObjectType::kGrass)
          continue;
        const double c = std::cos(o.yaw), sn = std::sin(o.yaw);
        const double u = c * (x - o.x) + sn * (y - o.y), v = -sn * (x - o.x) + c * (y - o.y);
        const double d =
            std::hypot(std::max(0.0, std::abs(u) - 0.5 * o.length), std::max(0.0, std::abs(v) - 0.5 * o.width));
        if (d < 2.5 && std::getenv("AVSP_LIST_CLOSE"))
          std::printf("  %s %u at (%.1f, %.1f) %.2f m from (%.1f, %.1f), segment %zu\n",
                      avsp::terrain::toString(o.type), id, o.x, o.y, d, x, y, k);
        if (d < worst)
        {
          worst = d;
          worst_what = std::string(avsp::terrain::toString(o.type)) + " " + std::to_string(id) + " near (" +
                       std::to_string(x) + ", " + std::to_string(y) + ")";
        }
      }
    }
  }
  std::printf("closest object to the route: %.2f m (%s)\n", worst, worst_what.c_str());
  EXPECT_GE(worst, 2.5) << worst_what;
}

TEST(Scenario, PartitionsBalanceByCostOrFollowTheList)
{
  // base(): lead fed_alpha (4 wheels: cost 5), second mrzr (5), third tracer_x (5), ext m113
  // (10 road wheels: 11). Two partitions: m113 alone, the three 4x4s together.
  YAML::Node n = base();
  n["partitions"] = 2;
  as::Scenario s = as::parseScenario(dump(n), "/some/dir/base.yaml", fakeTerrain(false));
  ASSERT_EQ(s.partitions.size(), 2u);
  EXPECT_EQ(s.partitions[0].name, "p1");
  EXPECT_EQ(s.partitions[0].vehicles, std::vector<std::string>{ "ext" });
  EXPECT_EQ(s.partitions[1].vehicles, (std::vector<std::string>{ "lead", "second", "third" }));
  // One partition is the plain single process.
  n["partitions"] = 1;
  EXPECT_TRUE(as::parseScenario(dump(n), "/some/dir/base.yaml", fakeTerrain(false)).partitions.empty());
  // Explicit, with a machine.
  n["partitions"] = YAML::Load(
      "[{name: north, vehicles: [third, lead], machine: hostb}, "
      "{name: south, vehicles: [second, ext]}]");
  n["machines"] = YAML::Load("{hostb: {address: 10.0.0.2, env_loader: /opt/avsp/env.sh, user: sim}}");
  s = as::parseScenario(dump(n), "/some/dir/base.yaml", fakeTerrain(false));
  ASSERT_EQ(s.partitions.size(), 2u);
  EXPECT_EQ(s.partitions[0].vehicles, (std::vector<std::string>{ "lead", "third" }));  // scenario order
  EXPECT_EQ(s.partitions[0].machine, "hostb");
  EXPECT_EQ(s.partitions[1].machine, "");
  ASSERT_EQ(s.machines.size(), 1u);
  EXPECT_EQ(s.machines[0].address, "10.0.0.2");
  EXPECT_EQ(s.machines[0].user, "sim");
}

TEST(Scenario, BalancedPartitionsAreGreedyByCost)
{
  // Costs 11, 5, 5, 5, 11, 5, 5, 5 over 3: the two 11s apart, then the 5s to the lightest.
  const std::vector<std::string> names{ "a", "b", "c", "d", "e", "f", "g", "h" };
  const std::vector<as::PartitionSpec> p = as::balancedPartitions(names, { 11, 5, 5, 5, 11, 5, 5, 5 }, 3);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0].vehicles, (std::vector<std::string>{ "a", "f" }));            // 16
  EXPECT_EQ(p[1].vehicles, (std::vector<std::string>{ "e", "g" }));            // 16
  EXPECT_EQ(p[2].vehicles, (std::vector<std::string>{ "b", "c", "d", "h" }));  // 20
  EXPECT_THROW(as::balancedPartitions(names, { 1, 2 }, 2), std::invalid_argument);
  EXPECT_THROW(as::balancedPartitions(names, std::vector<double>(8, 1.0), 9), std::invalid_argument);
  EXPECT_THROW(as::balancedPartitions(names, std::vector<double>(8, 1.0), 0), std::invalid_argument);
}

TEST(Scenario, BadPartitionsAreNamed)
{
  YAML::Node n = base();
  n["partitions"] = 5;
  EXPECT_ERROR(errorOf(n), "partitions: 5 must be in [1, 4]");
  n["partitions"] = "two";
  EXPECT_ERROR(errorOf(n), "partitions", "not an integer");
  n["partitions"] = YAML::Load("[{name: a, vehicles: [lead, second]}, {name: b, vehicles: [second, third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[1].vehicles[0]", "'second' is already in partition 'a'");
  n["partitions"] = YAML::Load("[{name: a, vehicles: [lead, second]}, {name: b, vehicles: [third]}]");
  EXPECT_ERROR(errorOf(n), "partitions", "vehicle 'ext' is in no partition");
  n["partitions"] = YAML::Load("[{name: a, vehicles: [lead, second, nobody]}, {name: b, vehicles: [third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[0].vehicles[2]", "unknown vehicle 'nobody'");
  n["partitions"] = YAML::Load("[{name: a, vehicles: [lead, second]}, {name: a, vehicles: [third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[1].name", "duplicate partition 'a'");
  n["partitions"] =
      YAML::Load("[{name: a, vehicles: [lead, second], machine: far}, {name: b, vehicles: [third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[0].machine", "unknown machine 'far'");
  n["partitions"] = YAML::Load("[{name: sensors, vehicles: [lead, second]}, {name: b, vehicles: [third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[0].name", "'sensors' is sensors_node's name");
  n["partitions"] = YAML::Load("[{name: a/b, vehicles: [lead, second]}, {name: b, vehicles: [third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[0].name", "not a valid name");
  n["partitions"] = YAML::Load("[{name: a, vehicles: []}, {name: b, vehicles: [lead, second, third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[0].vehicles", "non-empty list");
  n["partitions"] = YAML::Load("[{name: a, vehicles: [lead, second], speed: 3}, {name: b, vehicles: [third, ext]}]");
  EXPECT_ERROR(errorOf(n), "partitions[0].speed");
  n.remove("partitions");
  n["machines"] = YAML::Load("{hostb: {address: 10.0.0.2, env_loader: /opt/env.sh}}");
  EXPECT_ERROR(errorOf(n), "machines", "no partitions use them");
  n["partitions"] = 2;
  n["machines"] = YAML::Load("{hostb: {address: 10.0.0.2}}");
  EXPECT_ERROR(errorOf(n), "machines.hostb.env_loader: missing key");
}

TEST(LaunchGenerator, PartitionsGetTheClockPeersAndMachines)
{
  YAML::Node n = base();
  n["partitions"] = YAML::Load(
      "[{name: north, vehicles: [third, lead], machine: hostb}, "
      "{name: south, vehicles: [second, ext]}]");
  n["machines"] = YAML::Load("{hostb: {address: 10.0.0.2, env_loader: /opt/avsp/env.sh}}");
  const as::Scenario s = as::parseScenario(dump(n), "/some/dir/base.yaml", fakeTerrain(false));
  as::LaunchOptions o;
  o.output_dir = "/tmp/results/base";
  o.vehicles_dir = kConfig + "/vehicles";
  o.real_time_factor = 1.0;
  const std::string xml = as::generateLaunch(s, o);
  EXPECT_NE(xml.find("<machine name=\"hostb\" address=\"10.0.0.2\" env-loader=\"/opt/avsp/env.sh\"/>"),
            std::string::npos)
      << xml;
  EXPECT_EQ(xml.find("name=\"dynamics\""), std::string::npos);  // no single dynamics_node
  // The clock and the partitions are watched by run_recorder, not required: roslaunch would
  // stop the run without saying which node died.
  EXPECT_NE(xml.find("type=\"lockstep_clock\" name=\"clock\" clear_params=\"true\">"), std::string::npos);
  const YAML::Node parts = rosparamOf(xml, "clock", "partitions");
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].as<std::string>(), "north");
  EXPECT_EQ(parts[2].as<std::string>(), "sensors");  // sensors_node holds the clock too
  EXPECT_EQ(paramOf(xml, "sensors", "lockstep_partition"), "sensors");
  EXPECT_EQ(paramOf(xml, "sensors", "lockstep_interval"), "0.01");
  EXPECT_EQ(paramOf(xml, "clock", "real_time_factor"), "1.0");
  EXPECT_EQ(paramOf(xml, "clock", "sync_interval"), "0.01");
  EXPECT_NE(xml.find("name=\"dynamics_north\" clear_params=\"true\" machine=\"hostb\""), std::string::npos);
  {
    std::set<std::string> watched;
    for (const YAML::Node& n : rosparamOf(xml, "run_recorder", "watch"))
      watched.insert(n.as<std::string>());
    for (const char* n : { "/clock", "/dynamics_north", "/dynamics_south", "/sensors" })
      EXPECT_EQ(watched.count(n), 1u) << n;
    EXPECT_EQ(watched.count("/dynamics"), 0u);
  }
  const YAML::Node north = rosparamOf(xml, "dynamics_north", "vehicles");
  ASSERT_EQ(north.size(), 2u);
  EXPECT_EQ(north[0]["name"].as<std::string>(), "lead");
  EXPECT_EQ(north[1]["name"].as<std::string>(), "third");
  EXPECT_EQ(paramOf(xml, "dynamics_north", "partition"), "north");
  EXPECT_EQ(rosparamOf(xml, "dynamics_north", "peers")[0].as<std::string>(), "south");
  EXPECT_EQ(paramOf(xml, "dynamics_north", "publish_clock"), "false");
  EXPECT_EQ(rosparamOf(xml, "dynamics_north", "lockstep_vehicles").size(), 2u);
  EXPECT_EQ(rosparamOf(xml, "dynamics_south", "vehicles").size(), 2u);
  EXPECT_EQ(rosparamOf(xml, "dynamics_south", "peers")[0].as<std::string>(), "north");
  // ext is external: only "second" is in south's lockstep.
  EXPECT_EQ(rosparamOf(xml, "dynamics_south", "lockstep_vehicles").size(), 1u);
  EXPECT_EQ(paramOf(xml, "dynamics_south", "flat_soil"), "gravel");
}

TEST(RvizConfig, FollowsTheLeadAndNeedsEveryVehicle)
{
  as::Scenario s = as::loadScenario(kConfig + "/scenarios/reference_traverse.yaml", options());
  EXPECT_EQ(as::leadVehicle(s).name, "m113");  // the formation's first
  s.formation.present = false;
  std::swap(s.vehicles[0], s.vehicles[1]);     // mrzr (leader-follower) first now
  EXPECT_EQ(as::leadVehicle(s).name, "m113");  // the first on waypoints
  for (as::VehicleSpec& v : s.vehicles)
    v.controller.type = as::ControllerType::kExternal;
  EXPECT_EQ(as::leadVehicle(s).name, "mrzr");  // the first

  std::vector<as::VehicleDisplays> shown(s.vehicles.size());
  for (std::size_t i = 0; i < s.vehicles.size(); ++i)
    shown[i].name = s.vehicles[i].name;
  EXPECT_NO_THROW(as::generateRvizConfig(s, shown));
  shown.pop_back();
  EXPECT_THROW(as::generateRvizConfig(s, shown), std::invalid_argument);
  shown.push_back(as::VehicleDisplays());
  shown.back().name = "ghost";
  EXPECT_THROW(as::generateRvizConfig(s, shown), std::invalid_argument);

  // The launch file opens RViz with the run's configuration when given one.
  as::LaunchOptions o;
  o.output_dir = "/tmp/out";
  o.vehicles_dir = kConfig + "/vehicles";
  o.rviz = true;
  o.rviz_config = "/tmp/out/run.rviz";
  EXPECT_NE(as::generateLaunch(s, o).find("args=\"-d '/tmp/out/run.rviz'\""), std::string::npos);
}

// terramechanics: dem and the `dem:` section (issue 25, items 1 and 5): read as dynamics_node
// reads ~dem, passed to it with ~dem_vehicles; refused where the node would refuse it.
TEST(Scenario, TheDemContactModeIsCheckedAndReachesDynamicsNode)
{
  const char* const kDem =
      "{segment: {x_min: 10.0, x_max: 11.8}, patch: {length: 1.2, front_margin: 0.3}, "
      "template: {length: 0.12, width: 0.3, depth: 0.1}, "
      "particles: [{radius: 0.018, mass_fraction: 0.5}, {radius: 0.022, mass_fraction: 0.5}], "
      "youngs_modulus: 2.0e7, timestep: 2.0e-4, seed: 3}";
  YAML::Node n = base();
  n["vehicles"][2]["terramechanics"] = "dem";  // third: the tracer_x
  n["dem"] = YAML::Load(kDem);
  const as::Scenario s = as::parseScenario(dump(n), "/some/dir/base.yaml", fakeTerrain(false));
  EXPECT_TRUE(s.vehicles[2].dem);
  EXPECT_FALSE(s.vehicles[0].dem);
  // The text the node gets reads back to the section's values.
  const auto spec = avsp::dynamics::dem::parseDemSoilSpec(s.dem, "~dem");
  EXPECT_EQ(spec.segment.x_max, 11.8);
  EXPECT_EQ(spec.parameters.timestep, 2.0e-4);
  EXPECT_EQ(spec.parameters.seed, 3u);
  as::LaunchOptions o;
  o.output_dir = "/tmp/results/base";
  o.vehicles_dir = kConfig + "/vehicles";
  const std::string xml = as::generateLaunch(s, o);
  const YAML::Node names = rosparamOf(xml, "dynamics", "dem_vehicles");
  ASSERT_EQ(names.size(), 1u);
  EXPECT_EQ(names[0].as<std::string>(), "third");
  std::string text = paramOf(xml, "dynamics", "dem");
  for (std::size_t k; (k = text.find("&quot;")) != std::string::npos;)
    text.replace(k, 6, "\"");
  EXPECT_EQ(text, s.dem);
  EXPECT_EQ(avsp::dynamics::dem::parseDemSoilSpec(text, "~dem").segment.x_min, 10.0);

  // Without it, no DEM parameter at all.
  const std::string plain = as::generateLaunch(as::parseScenario(kBase, "/some/dir/base.yaml", fakeTerrain(false)), o);
  EXPECT_EQ(plain.find("dem_vehicles"), std::string::npos);

  YAML::Node bad = YAML::Clone(n);
  bad["vehicles"][2]["terramechanics"] = "sph";
  EXPECT_ERROR(errorOf(bad), "vehicles[2].terramechanics", "'sph' is not a contact mode");
  bad = YAML::Clone(n);
  bad["vehicles"][3]["terramechanics"] = "dem";  // ext: the m113
  EXPECT_ERROR(errorOf(bad), "vehicles[3].terramechanics", "has tracks");
  bad = YAML::Clone(n);
  bad.remove("dem");
  EXPECT_ERROR(errorOf(bad), "dem: required", "'third'");
  bad = YAML::Clone(n);
  bad["vehicles"][2].remove("terramechanics");
  EXPECT_ERROR(errorOf(bad), "dem: no vehicle has terramechanics: dem");
  bad = YAML::Clone(n);
  bad["partitions"] = 2;
  EXPECT_ERROR(errorOf(bad), "dem: the DEM contact mode runs in one dynamics_node");
  bad = YAML::Clone(n);
  bad["dem"]["timestep"] = 5.0e-4;  // above the 18 mm particles' stability limit
  EXPECT_ERROR(errorOf(bad), "dem.timestep");
  bad = YAML::Clone(n);
  bad["dem"]["particles"][0]["radius"] = -0.01;
  EXPECT_ERROR(errorOf(bad), "dem.particles[0]");
  bad = YAML::Clone(n);
  bad["dem"]["memory_budget"] = 1.0e6;
  EXPECT_ERROR(errorOf(bad), "dem.memory_budget");
  bad = YAML::Clone(n);
  bad["dem"]["patch"]["lenght"] = 1.2;
  EXPECT_ERROR(errorOf(bad), "dem.patch.lenght: unknown key");
}
