// Scenario sections through the nodes' own parameter parsers (node_checks.hpp).
#include "avsp/ros/node_checks.hpp"

#include <map>
#include <stdexcept>

#include <avsp_sensors/ros/sensor_params.hpp>
#include <avsp_terrain/ros/terrain_source_params.hpp>

#include "avsp/ros/controller_node.hpp"
#include "avsp/scenario/launch_generator.hpp"

namespace avsp
{
namespace node
{
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
        frames =
            frames_of.emplace(v.model, avsp::sensors::node::loadVehicleFrames(vehicles_dir + "/" + v.model + ".yaml"))
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
      throw scenario::ScenarioError(s.file + ": " + (has_own ? key : std::string("sensors")) +
                                    " (as sensors_node reads it for '" + v.name + "'): " + e.what());
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
    throw scenario::ScenarioError(s.file + ": time.start_utc " + s.start_utc +
                                  " with the vehicles' magnetometers: " + e.what());
  }
  return displays;
}

std::shared_ptr<const scenario::TerrainFootprint> loadTerrainAsTheNodesWill(const scenario::TerrainSpec& spec)
{
  const std::vector<scenario::NodeParam> params = spec.nodeParams();
  const ParamSource source(paramTree(params));
  terrain::TerrainSource terrain_source;
  std::string soils_file;
  try
  {
    terrain_source = terrain::node::terrainSourceFromParams(source);
    soils_file = stringParam(source, "soils_file", "");
  }
  catch (const StartupError& e)
  {
    throw std::invalid_argument(std::string("as the nodes read it: ") + e.what());
  }
  for (const scenario::NodeParam& p : params)
    if (!source.keysRead().count(p.name))
      throw std::logic_error("terrain parameter ~" + p.name + " is written for the nodes but none reads it");
  return scenario::footprintOf(terrain::loadTerrainSource(terrain_source, terrain::SoilLibrary::load(soils_file)));
}

XmlRpc::XmlRpcValue paramTree(const std::vector<scenario::NodeParam>& params)
{
  int offset = 0;
  XmlRpc::XmlRpcValue tree("<value><struct></struct></value>", &offset);
  for (const scenario::NodeParam& p : params)
  {
    if (p.type == "str")
      tree[p.name] = p.value;
    else if (p.type == "bool")
      tree[p.name] = p.value == "true";
    else if (p.type == "yaml")
      tree[p.name] = toXmlRpc(YAML::Load(p.value));
    else
    {
      std::size_t used = 0;
      const double v = std::stod(p.value, &used);
      if (used != p.value.size())
        throw std::invalid_argument("parameter " + p.name + ": '" + p.value + "' is not a number");
      if (p.type == "int")
        tree[p.name] = static_cast<int>(v);
      else
        tree[p.name] = v;
    }
  }
  return tree;
}

void checkControllersAsTheNodeWill(const scenario::Scenario& s, const std::string& vehicles_dir)
{
  for (std::size_t i = 0; i < s.vehicles.size(); ++i)
  {
    const scenario::VehicleSpec& v = s.vehicles[i];
    const std::vector<scenario::NodeParam> params = scenario::controllerNodeParams(s, v, vehicles_dir);
    if (params.empty())
      continue;  // external control: no controller_node
    const std::string key = "vehicles[" + std::to_string(i) + "].controller";
    const ParamSource source(paramTree(params));
    try
    {
      readControllerParams(source);
    }
    catch (const std::exception& e)
    {
      throw scenario::ScenarioError(s.file + ": " + key + " (as controller_node reads it for '" + v.name +
                                    "'): " + e.what());
    }
    if (!v.controller.params.IsDefined() || !v.controller.params.IsMap())
      continue;
    std::string read;
    for (const std::string& k : source.keysRead())
      read += (read.empty() ? "" : ", ") + k;
    for (const auto& kv : v.controller.params)
      if (source.keysRead().count(kv.first.Scalar()) == 0)
        throw scenario::ScenarioError(s.file + ": " + key + ".params." + kv.first.Scalar() +
                                      ": unknown key (controller_node in mode " +
                                      scenario::toString(v.controller.type) + " reads " + read + ")");
  }
}

}  // namespace node
}  // namespace avsp
