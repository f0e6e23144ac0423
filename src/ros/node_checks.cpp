// Scenario sections through the nodes' own parameter parsers (node_checks.hpp).
#include "avsp/ros/node_checks.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <regex>
#include <stdexcept>

#include <avsp_sensors/ros/sensor_params.hpp>

namespace avsp
{
namespace node
{
namespace
{
/// A plain scalar typed as PyYAML's safe_load (rosparam) types it.
XmlRpc::XmlRpcValue plainScalar(const std::string& text)
{
  static const std::regex kTrue("true|True|TRUE|yes|Yes|YES|on|On|ON");
  static const std::regex kFalse("false|False|FALSE|no|No|NO|off|Off|OFF");
  static const std::regex kInt("[-+]?(0|[1-9][0-9_]*)");
  static const std::regex kFloat("[-+]?([0-9][0-9_]*)?\\.[0-9_]*([eE][-+][0-9]+)?|[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+");
  static const std::regex kInf("[-+]?\\.(inf|Inf|INF)");
  static const std::regex kNan("\\.(nan|NaN|NAN)");
  if (std::regex_match(text, kTrue))
    return XmlRpc::XmlRpcValue(true);
  if (std::regex_match(text, kFalse))
    return XmlRpc::XmlRpcValue(false);
  if (std::regex_match(text, kInt))
  {
    errno = 0;
    const long long v = std::strtoll(text.c_str(), nullptr, 10);
    if (errno == 0 && v >= std::numeric_limits<int>::min() && v <= std::numeric_limits<int>::max())
      return XmlRpc::XmlRpcValue(static_cast<int>(v));
    return XmlRpc::XmlRpcValue(std::strtod(text.c_str(), nullptr));  // XML-RPC ints are 32-bit
  }
  if (std::regex_match(text, kFloat))
    return XmlRpc::XmlRpcValue(std::strtod(text.c_str(), nullptr));
  if (std::regex_match(text, kInf))
    return XmlRpc::XmlRpcValue(text[0] == '-' ? -std::numeric_limits<double>::infinity()
                                              : std::numeric_limits<double>::infinity());
  if (std::regex_match(text, kNan))
    return XmlRpc::XmlRpcValue(std::numeric_limits<double>::quiet_NaN());
  return XmlRpc::XmlRpcValue(text);
}
}  // namespace

XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node)
{
  switch (node.Type())
  {
    case YAML::NodeType::Scalar:
      // yaml-cpp tags a quoted scalar "!": a string whatever it spells.
      return node.Tag() == "!" ? XmlRpc::XmlRpcValue(node.Scalar()) : plainScalar(node.Scalar());
    case YAML::NodeType::Sequence:
    {
      XmlRpc::XmlRpcValue out;
      out.setSize(static_cast<int>(node.size()));
      for (std::size_t k = 0; k < node.size(); ++k)
        out[static_cast<int>(k)] = toXmlRpc(node[k]);
      return out;
    }
    case YAML::NodeType::Map:
    {
      // Parsed from XML so that an empty map is still a struct (XmlRpcValue has no other way).
      int offset = 0;
      XmlRpc::XmlRpcValue out("<value><struct></struct></value>", &offset);
      for (const auto& kv : node)
      {
        if (!kv.first.IsScalar())
          throw std::invalid_argument("a map key that is not a string");
        out[kv.first.Scalar()] = toXmlRpc(kv.second);
      }
      return out;
    }
    default:
      throw std::invalid_argument("a null value (rosparam cannot set it)");
  }
}

std::vector<scenario::VehicleDisplays> checkSensorsAsTheNodeWill(const scenario::Scenario& s,
                                                                 const std::string& vehicles_dir)
{
  const bool has_common = s.sensors.IsDefined() && !s.sensors.IsNull();
  XmlRpc::XmlRpcValue common;
  try
  {
    if (has_common)
      common = toXmlRpc(s.sensors);
  }
  catch (const std::invalid_argument& e)
  {
    throw scenario::ScenarioError(s.file + ": sensors: " + e.what());
  }
  std::map<std::string, avsp::sensors::node::VehicleFrames> frames_of;
  std::vector<avsp::sensors::node::SensorsSpec> specs;
  std::vector<scenario::VehicleDisplays> displays;
  for (std::size_t i = 0; i < s.vehicles.size(); ++i)
  {
    const scenario::VehicleSpec& v = s.vehicles[i];
    const std::string key = "vehicles[" + std::to_string(i) + "].sensors";
    const bool has_own = v.sensors.IsDefined() && !v.sensors.IsNull();
    try
    {
      XmlRpc::XmlRpcValue own;
      if (has_own)
        own = toXmlRpc(v.sensors);
      avsp::sensors::node::SensorsSpec spec = avsp::sensors::node::parseSensors(
          has_own ? &own : nullptr, "~vehicle_sensors/" + v.name, has_common ? &common : nullptr, "~sensors");
      auto frames = frames_of.find(v.model);  // a model's files are read once, not per vehicle
      if (frames == frames_of.end())
        frames = frames_of.emplace(v.model, avsp::sensors::node::loadVehicleFrames(vehicles_dir + "/" + v.model + ".yaml"))
                     .first;
      avsp::sensors::node::mountSensors(spec, frames->second, "model '" + v.model + "'");
      scenario::VehicleDisplays shown;
      shown.name = v.name;
      shown.lidar = spec.suite.lidar.has_value();
      shown.radar = spec.suite.radar.has_value();
      shown.occupancy = spec.suite.occupancy.has_value();
      for (const avsp::sensors::CameraConfig& c : spec.cameras)
        if (c.rgb)
          shown.rgb_cameras.push_back(c.name);
      displays.push_back(std::move(shown));
      specs.push_back(std::move(spec));
    }
    catch (const std::exception& e)
    {
      throw scenario::ScenarioError(s.file + ": " + (has_own ? key : std::string("sensors")) + " (as sensors_node reads it for '" +
                          v.name + "'): " + e.what());
    }
  }
  // The magnetometers' model on the run's date (the generator gives sensors_node the date of
  // time.start_utc as ~date) at the site: a date outside the model's validity stops the node.
  try
  {
    avsp::sensors::node::placeMagnetometers(specs, avsp::sensors::EnuFrame({ s.latitude, s.longitude, s.altitude }),
                                            s.start_utc.substr(0, 10));
  }
  catch (const std::exception& e)
  {
    throw scenario::ScenarioError(s.file + ": time.start_utc " + s.start_utc + " with the vehicles' magnetometers: " +
                                  e.what());
  }
  return displays;
}

}  // namespace node
}  // namespace avsp
