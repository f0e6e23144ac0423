// A scenario's sections as the nodes receive them (rosparam's typing) and through their parsers.
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "avsp/ros/node_checks.hpp"

namespace as = avsp::scenario;
using avsp::node::checkSensorsAsTheNodeWill;
using avsp::node::toXmlRpc;
using XmlRpc::XmlRpcValue;

TEST(ToXmlRpc, TypesScalarsAsRosparamDoes)
{
  const XmlRpcValue v = toXmlRpc(YAML::Load(
      "{b1: true, b2: no, i: 42, n: -7, d: 0.5, e: 1.0e-3, inf: -.inf, s: VLP-16, q: '42', t: 'true', "
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
