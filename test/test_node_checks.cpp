// A scenario's sections as the nodes receive them (rosparam's typing) and through their parsers.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "avsp/ros/node_checks.hpp"

namespace as = avsp::scenario;
using avsp::node::checkSensorsAsTheNodeWill;
using avsp::node::toXmlRpc;
using XmlRpc::XmlRpcValue;

TEST(ToXmlRpc, TypesScalarsAsRosparamDoes)
{
  const XmlRpcValue v = toXmlRpc(
      YAML::Load("{b1: true, b2: no, i: 42, n: -7, d: 0.5, e: 1.0e-3, inf: -.inf, s: VLP-16, q: '42', t: 'true', "
                 "l: [1, 2.5, x], m: {}, big: 10000000000}"));
  ASSERT_EQ(v.getType(), XmlRpcValue::TypeStruct);
  XmlRpcValue c = v;
  EXPECT_EQ(c["b1"].getType(), XmlRpcValue::TypeBoolean);
  EXPECT_TRUE(static_cast<bool>(c["b1"]));
  EXPECT_FALSE(static_cast<bool>(c["b2"]));
  EXPECT_EQ(static_cast<int>(c["i"]), 42);
  EXPECT_EQ(static_cast<int>(c["n"]), -7);
  EXPECT_DOUBLE_EQ(static_cast<double>(c["d"]), 0.5);
  EXPECT_DOUBLE_EQ(static_cast<double>(c["e"]), 1.0e-3);
  EXPECT_TRUE(std::isinf(static_cast<double>(c["inf"])) && static_cast<double>(c["inf"]) < 0);
  EXPECT_EQ(static_cast<std::string>(c["s"]), "VLP-16");
  // Quoted scalars stay strings, whatever they spell.
  EXPECT_EQ(c["q"].getType(), XmlRpcValue::TypeString);
  EXPECT_EQ(c["t"].getType(), XmlRpcValue::TypeString);
  ASSERT_EQ(c["l"].getType(), XmlRpcValue::TypeArray);
  EXPECT_EQ(c["l"][0].getType(), XmlRpcValue::TypeInt);
  EXPECT_EQ(c["l"][1].getType(), XmlRpcValue::TypeDouble);
  EXPECT_EQ(c["l"][2].getType(), XmlRpcValue::TypeString);
  EXPECT_EQ(c["m"].getType(), XmlRpcValue::TypeStruct);
  EXPECT_EQ(c["m"].size(), 0);
  // Beyond XML-RPC's 32-bit ints: a double, as roslaunch sends it.
  EXPECT_EQ(c["big"].getType(), XmlRpcValue::TypeDouble);
  EXPECT_THROW(toXmlRpc(YAML::Load("{a: ~}")), std::invalid_argument);
}

// The way back (a node's parameters to the core's YAML parsers): every type and value survives
// the round trip; a string that spells a number or a boolean stays a string.
TEST(ToYaml, IsTheInverseOfToXmlRpc)
{
  const XmlRpcValue v =
      toXmlRpc(YAML::Load("{b: true, i: -7, d: 0.1, tiny: 4.9406564584124654e-324, inf: -.inf, s: deer, q: '42', t: "
                          "'yes', l: [1, 2.5, x], m: {}}"));
  XmlRpcValue back = toXmlRpc(avsp::node::toYaml(v));
  XmlRpcValue c = v;
  ASSERT_EQ(back.getType(), XmlRpcValue::TypeStruct);
  for (const char* key : { "b", "i", "d", "tiny", "inf", "s", "q", "t", "l", "m" })
    EXPECT_EQ(back[key].getType(), c[key].getType()) << key;
  EXPECT_TRUE(static_cast<bool>(back["b"]));
  EXPECT_EQ(static_cast<int>(back["i"]), -7);
  EXPECT_EQ(static_cast<double>(back["d"]), 0.1);  // %.17g: the same double, bit for bit
  EXPECT_EQ(static_cast<double>(back["tiny"]), 5e-324);
  EXPECT_EQ(static_cast<double>(back["inf"]), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(static_cast<std::string>(back["q"]), "42");
  EXPECT_EQ(static_cast<std::string>(back["t"]), "yes");
  EXPECT_EQ(back["l"].size(), 3);
  EXPECT_EQ(back["l"][2].getType(), XmlRpcValue::TypeString);
  EXPECT_EQ(back["m"].size(), 0);
}

TEST(NodeChecks, SensorsGoThroughSensorsNodesParser)
{
  as::Scenario s;
  s.file = "t.yaml";
  as::VehicleSpec a, b;
  a.name = "alpha";
  a.model = "fed_alpha";
  b.name = "bravo";
  b.model = "mrzr";
  s.vehicles = { a, b };
  s.sensors = YAML::Load("{lidar: {preset: VLP-16, columns: 360}, radar: {enabled: false}}");
  s.latitude = 39.7425;
  s.longitude = -105.1786;
  s.altitude = 1829.0;
  s.start_utc = "2025-10-15T15:00:00Z";  // the magnetometers' World Magnetic Model date
  const std::string vehicles = AVSP_CONFIG_DIR "/vehicles";
  EXPECT_NO_THROW(checkSensorsAsTheNodeWill(s, vehicles));
  // A start after the magnetometers' model (WMM2025: 2025.0-2030.0): sensors_node would exit 1.
  s.start_utc = "2031-03-01T12:00:00Z";
  try
  {
    checkSensorsAsTheNodeWill(s, vehicles);
    FAIL() << "a 2031 start passed with WMM2025 magnetometers";
  }
  catch (const as::ScenarioError& e)
  {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("t.yaml: time.start_utc 2031-03-01T12:00:00Z with the vehicles' magnetometers: ", 0), 0u) << m;
    EXPECT_NE(m.find("valid for decimal years 2025.0 to 2030.0"), std::string::npos) << m;
  }
  s.start_utc = "2025-10-15T15:00:00Z";
  s.vehicles[1].sensors = YAML::Load("{lidar: {preset: VLP-16, colour: red}}");
  try
  {
    checkSensorsAsTheNodeWill(s, vehicles);
    FAIL() << "an unknown key passed";
  }
  catch (const as::ScenarioError& e)
  {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("t.yaml: vehicles[1].sensors (as sensors_node reads it for 'bravo'): ", 0), 0u) << m;
    EXPECT_NE(m.find("~vehicle_sensors/bravo/lidar/colour is not a known key"), std::string::npos) << m;
  }
  // Cameras in a scenario are read by sensors_node's parser too: a good one passes, a bad key is
  // named as the node would name it.
  s.vehicles[1].sensors = YAML::Load("{cameras: [{name: front, width: 64, height: 48, rate: 2.0}]}");
  EXPECT_NO_THROW(checkSensorsAsTheNodeWill(s, vehicles));
  s.vehicles[1].sensors = YAML::Load("{cameras: [{name: front, lens: wide}]}");
  try
  {
    checkSensorsAsTheNodeWill(s, vehicles);
    FAIL() << "an unknown camera key passed";
  }
  catch (const as::ScenarioError& e)
  {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("t.yaml: vehicles[1].sensors (as sensors_node reads it for 'bravo'): ", 0), 0u) << m;
    EXPECT_NE(m.find("~vehicle_sensors/bravo/cameras[0]/lens is not a known key"), std::string::npos) << m;
  }
  // rosparam types the launch file's text as YAML 1.1 does: 1e3 is text to it (a YAML 1.2 reader
  // takes it for a number), so sensors_node would refuse it, and the check does too; 1.0e+3 is a
  // number to both.
  s.vehicles[1].sensors = YAML::Load("{lidar: {preset: VLP-16, max_range: 1e3}}");
  try
  {
    checkSensorsAsTheNodeWill(s, vehicles);
    FAIL() << "max_range: 1e3 passed (sensors_node reads the string '1e3')";
  }
  catch (const as::ScenarioError& e)
  {
    const std::string m = e.what();
    EXPECT_NE(m.find("~vehicle_sensors/bravo/lidar/max_range"), std::string::npos) << m;
  }
  s.vehicles[1].sensors = YAML::Load("{lidar: {preset: VLP-16, max_range: 1.0e+3}}");
  EXPECT_NO_THROW(checkSensorsAsTheNodeWill(s, vehicles));
  // The section as a whole, as sensors_node validates it at start-up.
  s.vehicles[1].sensors = YAML::Load("{lidar: {preset: VLP-16}, occupancy: {min_height: 0.5, obstacle_height: 0.2}}");
  try
  {
    checkSensorsAsTheNodeWill(s, vehicles);
    FAIL() << "an obstacle height below the minimum height passed";
  }
  catch (const as::ScenarioError& e)
  {
    const std::string m = e.what();
    EXPECT_EQ(m,
              "t.yaml: vehicles[1].sensors (as sensors_node reads it for 'bravo'): parameter "
              "~vehicle_sensors/bravo/occupancy: occupancy: obstacle_height must be > min_height")
        << m;
  }
  s.vehicles[1].sensors = YAML::Node();
  s.sensors = YAML::Load("{lidar: {channels: sixteen}}");  // a wrong type in the shared section
  EXPECT_THROW(checkSensorsAsTheNodeWill(s, vehicles), as::ScenarioError);
  // A lidar on a link the URDF lacks: sensors_node refuses it at start-up, so does the check.
  s.sensors = YAML::Node();
  s.vehicles[0].sensors = YAML::Load("{lidar: {frame: no_such_link}}");
  try
  {
    checkSensorsAsTheNodeWill(s, vehicles);
    FAIL() << "a missing link passed";
  }
  catch (const as::ScenarioError& e)
  {
    const std::string m = e.what();
    EXPECT_NE(m.find("parameter ~vehicle_sensors/alpha/lidar/frame = 'no_such_link' is not a link of"),
              std::string::npos)
        << m;
  }
}

// One parser over the master or a tree (issue 19, item 4): the same value reads the same, the
// same bad value gives the same message, and the keys read are kept.
TEST(ParamSource, ATreeReadsAsTheMasterWould)
{
  const avsp::node::ParamSource tree(toXmlRpc(
      YAML::Load("{rate: 50, gain: 0.5, name: ego, on: true, nested: {depth: 3}, list: '[a, b]', bad: fast}")));
  EXPECT_EQ(avsp::node::boundedParam(tree, "rate", 20.0, 1.0, 100.0), 50.0);  // an int read as a number
  EXPECT_EQ(avsp::node::boundedParam(tree, "gain", 1.0, 0.0, 1.0), 0.5);
  EXPECT_EQ(avsp::node::boundedParam(tree, "absent", 7.0, 0.0, 10.0), 7.0);  // the default when unset
  EXPECT_EQ(avsp::node::stringParam(tree, "name", ""), "ego");
  EXPECT_TRUE(avsp::node::boolParam(tree, "on", false));
  EXPECT_EQ(avsp::node::boundedIntParam(tree, "nested/depth", 0, 0, 10), 3);
  EXPECT_EQ(avsp::node::plainNamesParam(tree, "list", "names"), (std::vector<std::string>{ "a", "b" }));
  try
  {
    avsp::node::boundedParam(tree, "bad", 1.0, 0.0, 1.0);
    FAIL() << "a string read as a number";
  }
  catch (const avsp::node::StartupError& e)
  {
    EXPECT_STREQ(e.what(), "parameter ~bad must be a number, got a string");
  }
  EXPECT_THROW(avsp::node::boundedParam(tree, "rate", 20.0, 1.0, 10.0), avsp::node::StartupError);
  EXPECT_FALSE(tree.has("nested/none"));
  EXPECT_EQ(tree.keysRead(), (std::set<std::string>{ "rate", "gain", "absent", "name", "on", "nested/depth", "list",
                                                     "bad", "nested/none" }));
}

// controller_node's parameters from a scenario go through controller_node's own parser (issue 19,
// item 4): its keys, its ranges, in the controller's mode; no list of names copied beside it.
TEST(NodeChecks, ControllersGoThroughControllerNodesParser)
{
  as::LoadOptions load;
  load.vehicles_dir = AVSP_CONFIG_DIR "/vehicles";
  load.soils_file = AVSP_CONFIG_DIR "/soils.yaml";
  load.check_terrain = false;
  const as::Scenario reference = as::loadScenario(AVSP_CONFIG_DIR "/scenarios/reference_traverse_ci.yaml", load);
  ASSERT_EQ(reference.vehicles[0].controller.type, as::ControllerType::kWaypoints);
  ASSERT_EQ(reference.vehicles[1].controller.type, as::ControllerType::kLeaderFollower);
  EXPECT_NO_THROW(avsp::node::checkControllersAsTheNodeWill(reference, load.vehicles_dir));

  auto refusal = [&](std::size_t vehicle, const std::string& params) {
    as::Scenario s = reference;
    s.vehicles[vehicle].controller.params.reset(YAML::Load(params));  // rebinds: `=` would write into reference's
    try
    {
      avsp::node::checkControllersAsTheNodeWill(s, load.vehicles_dir);
    }
    catch (const as::ScenarioError& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string file = reference.file + ": ";
  // In range for the node: accepted; a follower's own keys on a follower.
  EXPECT_EQ(refusal(0, "{lookahead_min: 2.0, speed_kp: 0.8, track_width_factor: 1.8}"), "");
  EXPECT_EQ(refusal(1, "{gap_gain: 0.5, safety_distance: 4}"), "");
  // Out of the node's range: its own message, under the vehicle's controller.
  const std::string low = refusal(0, "{lookahead_min: 0.01}");
  EXPECT_EQ(low.rfind(file + "vehicles[0].controller (as controller_node reads it for '" + reference.vehicles[0].name +
                          "'): parameter ~lookahead_min = 0.010000 must be finite",
                      0),
            0u)
      << low;
  EXPECT_NE(refusal(1, "{max_speed: 0}").find("parameter ~max_speed = 0.000000"), std::string::npos);
  // A key the node never reads: a typo, or a follower's key on a waypoint controller.
  const std::string typo = refusal(0, "{lookahed_min: 2.0}");
  EXPECT_EQ(typo.rfind(file + "vehicles[0].controller.params.lookahed_min: unknown key (controller_node in mode "
                              "waypoints reads ",
                       0),
            0u)
      << typo;
  EXPECT_NE(typo.find("lookahead_min"), std::string::npos) << typo;
  EXPECT_NE(refusal(0, "{gap_gain: 0.5}").find("params.gap_gain: unknown key"), std::string::npos);
  EXPECT_NE(refusal(1, "{goal_tolerance: 1.0}").find("params.goal_tolerance: unknown key"), std::string::npos);
  // A value of the wrong type reaches the node's reader with rosparam's type for it (it was
  // left out of the launch file, and the node took its default).
  const std::string text = refusal(0, "{speed_kp: fast}");
  EXPECT_NE(text.find("parameter ~speed_kp must be a number, got a string"), std::string::npos) << text;
  // With the lockstep, dynamics_node waits at every 0.05 s for the controller's command: a
  // rate whose grid misses those instants would stop the run at ~lockstep_timeout.
  EXPECT_EQ(refusal(0, "{rate: 40}"), "");
  const std::string rate = refusal(0, "{rate: 30}");
  EXPECT_NE(rate.find("parameter ~rate = 30.000000 Hz: with ~lockstep the barrier period ~lockstep_period = 0.050000 s "
                      "must be a whole number of control periods"),
            std::string::npos)
      << rate;
}

// The terrain as every node that holds it loads it: their reader on the generated parameters,
// the same footprint as the scenario's own reading; a value the nodes refuse, refused with
// their message.
TEST(NodeChecks, TerrainLoadsAsTheNodesLoadIt)
{
  as::TerrainSpec flat;
  flat.kind = as::TerrainSpec::Kind::kFlat;
  flat.flat_soil = "gravel";
  flat.flat_size = 60.0;
  flat.flat_cell_size = 0.2;
  flat.soils_file = AVSP_CONFIG_DIR "/soils.yaml";
  const auto nodes = avsp::node::loadTerrainAsTheNodesWill(flat);
  const auto own = as::loadTerrainFootprint(flat);
  EXPECT_EQ(nodes->min_x, own->min_x);
  EXPECT_EQ(nodes->max_x, own->max_x);
  EXPECT_EQ(nodes->min_y, own->min_y);
  EXPECT_EQ(nodes->max_y, own->max_y);
  EXPECT_EQ(nodes->max_x - nodes->min_x, 60.0);
  ASSERT_TRUE(nodes->ground);
  EXPECT_EQ(nodes->ground->palette().front().name, "gravel");
  flat.flat_size = 2e4;  // beyond terrain_node's ~flat_size range
  try
  {
    avsp::node::loadTerrainAsTheNodesWill(flat);
    FAIL() << "a 20 km flat square passed";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_EQ(std::string(e.what()).rfind("as the nodes read it: parameter ~flat_size = 20000", 0), 0u) << e.what();
  }
}

// The run's RViz configuration (issue 22, item 5) from what sensors_node will publish: a display
// for each topic the run has that RViz draws, and none for a sensor a vehicle does not carry.
TEST(NodeChecks, RvizConfigShowsExactlyTheRunsTopics)
{
  as::LoadOptions load;
  load.vehicles_dir = AVSP_CONFIG_DIR "/vehicles";
  load.soils_file = AVSP_CONFIG_DIR "/soils.yaml";
  as::Scenario s = as::loadScenario(AVSP_CONFIG_DIR "/scenarios/reference_traverse.yaml", load);
  // The fed_alpha (lidar and radar by the scenario) also carries a stereo pair and a mono camera
  // without RGB output.
  s.vehicles[2].sensors["cameras"] = YAML::Load(
      "[{name: pod, stereo_baseline: 0.3, width: 64, height: 48, rate: 2.0}, "
      "{name: depth_only, width: 32, height: 24, rate: 2.0, outputs: [depth]}]");
  const std::vector<as::VehicleDisplays> shown = checkSensorsAsTheNodeWill(s, load.vehicles_dir);
  ASSERT_EQ(shown.size(), 4u);
  EXPECT_EQ(shown[0].name, "m113");
  EXPECT_FALSE(shown[0].lidar || shown[0].radar || shown[0].occupancy);
  EXPECT_TRUE(shown[2].lidar && shown[2].radar);
  EXPECT_EQ(shown[2].rgb_cameras, (std::vector<std::string>{ "pod/left", "pod/right" }));
  EXPECT_TRUE(shown[3].lidar);
  EXPECT_FALSE(shown[3].radar);

  const std::string config = as::generateRvizConfig(s, shown);
  std::vector<std::string> expected = { "/terrain/mesh", "/terrain/rut_markers", "/terrain/objects", "/agents/markers",
                                        "/v2v/fleet_markers" };
  for (const as::VehicleSpec& v : s.vehicles)  // every vehicle has a controller here
    for (const char* t : { "avt_341/odometry", "controller/path", "controller/target" })
      expected.push_back("/" + v.name + "/" + t);
  for (const char* t :
       { "avt_341/points", "radar/points", "radar/markers", "pod/left/image_raw", "pod/right/image_raw" })
    expected.push_back(std::string("/fed_alpha/") + t);
  expected.push_back("/tracer_x/avt_341/points");
  for (const as::VehicleDisplays& d : shown)
    if (d.occupancy)
      for (const char* t : { "octomap/occupied_cells", "occupancy/grid" })
        expected.push_back("/" + d.name + "/" + t);
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(as::rvizConfigTopics(config), expected);

  // The view follows the formation's lead from behind; RViz reads the file as YAML.
  const YAML::Node root = YAML::Load(config);
  const YAML::Node view = root["Visualization Manager"]["Views"]["Current"];
  EXPECT_EQ(view["Class"].as<std::string>(), "rviz/ThirdPersonFollower");
  EXPECT_EQ(view["Target Frame"].as<std::string>(), "m113/base_link");
  EXPECT_EQ(root["Visualization Manager"]["Global Options"]["Fixed Frame"].as<std::string>(), "map");
  // One group per vehicle, named after it, with its robot description.
  std::vector<std::string> groups;
  for (const YAML::Node& d : root["Visualization Manager"]["Displays"])
    if (d["Class"].as<std::string>() == "rviz/Group")
    {
      groups.push_back(d["Name"].as<std::string>());
      EXPECT_EQ(d["Displays"][0]["Robot Description"].as<std::string>(), groups.back() + "/robot_description");
    }
  EXPECT_EQ(groups, (std::vector<std::string>{ "m113", "mrzr", "fed_alpha", "tracer_x" }));

  // An external vehicle has no controller displays; without agents there is no agents display.
  s.vehicles[1].controller.type = as::ControllerType::kExternal;
  s.agents = YAML::Node();
  const std::vector<std::string> fewer = as::rvizConfigTopics(as::generateRvizConfig(s, shown));
  EXPECT_EQ(fewer.size(), expected.size() - 3u);
  EXPECT_EQ(std::count(fewer.begin(), fewer.end(), "/mrzr/controller/path"), 0);
  EXPECT_EQ(std::count(fewer.begin(), fewer.end(), "/agents/markers"), 0);
}
