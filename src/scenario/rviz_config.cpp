#include "avsp/scenario/rviz_config.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace avsp
{
namespace scenario
{
namespace
{
/// QMainWindow::saveState() of RViz 1.14 with the panels of generateRvizConfig() (hex).
const char* const kDockLayout =
    "000000ff00000000fd00000004000000000000013c0000025ffc0200000008fb0000001200530065006c0065006300740069"
    "006f006e00000001e10000009b0000006400fffffffb0000001e0054006f006f006c002000500072006f0070006500720074"
    "00690065007302000001ed000001df00000185000000a3fb000000120056006900650077007300200054006f006f02000001"
    "df000002110000018500000122fb000000200054006f006f006c002000500072006f00700065007200740069006500730032"
    "03000002880000011d000002210000017afb000000100044006900730070006c00610079007301000000410000025f000000"
    "dd00fffffffb0000002000730065006c0065006300740069006f006e00200062007500660066006500720200000138000000"
    "aa0000023a00000294fb00000014005700690064006500530074006500720065006f02000000e6000000d2000003ee000003"
    "0bfb0000000c004b0069006e0065006300740200000186000001060000030c00000261000000010000010f0000025ffc0200"
    "000003fb0000001e0054006f006f006c002000500072006f0070006500720074006900650073010000004100000078000000"
    "0000000000fb0000000a0056006900650077007301000000410000025f000000b000fffffffb0000001200530065006c0065"
    "006300740069006f006e010000025a000000b200000000000000000000000200000490000000a9fc0100000001fb0000000a"
    "00560069006500770073030000004e00000080000002e10000019700000003000004420000003efc0100000002fb00000008"
    "00540069006d00650100000000000004420000028900fffffffb0000000800540069006d0065010000000000000450000000"
    "0000000000000001eb0000025f00000004000000040000000800000008fc0000000100000002000000010000000a0054006f"
    "006f006c00730100000000ffffffff0000000000000000";

YAML::Node display(const std::string& cls, const std::string& name, bool enabled)
{
  YAML::Node d;
  d["Class"] = cls;
  d["Name"] = name;
  d["Enabled"] = enabled;
  return d;
}

YAML::Node markers(const std::string& name, const std::string& topic, bool enabled)
{
  YAML::Node d = display("rviz/MarkerArray", name, enabled);
  d["Marker Topic"] = topic;
  d["Queue Size"] = 100;
  return d;
}

/// A PointCloud2 display: points drawn as `style`, coloured by `colour_transformer`, the latest
/// cloud only.
YAML::Node pointCloud(const std::string& name, const std::string& topic, const std::string& style,
                      const std::string& colour_transformer)
{
  YAML::Node d = display("rviz/PointCloud2", name, true);
  d["Topic"] = topic;
  d["Style"] = style;
  d["Color Transformer"] = colour_transformer;
  d["Decay Time"] = 0;
  d["Queue Size"] = 10;
  return d;
}

/// Displays of one vehicle's topics, in a group named after it.
YAML::Node vehicleGroup(const VehicleSpec& v, const VehicleDisplays& shown)
{
  const std::string ns = "/" + v.name + "/";
  YAML::Node group = display("rviz/Group", v.name, true);
  YAML::Node list(YAML::NodeType::Sequence);

  YAML::Node model = display("rviz/RobotModel", "Robot model", true);
  model["Robot Description"] = v.name + "/robot_description";
  model["Visual Enabled"] = true;
  model["Collision Enabled"] = false;
  list.push_back(model);

  YAML::Node odom = display("rviz/Odometry", "Odometry (avt_341/odometry)", true);
  odom["Topic"] = ns + "avt_341/odometry";
  odom["Keep"] = 1;
  odom["Shape"]["Value"] = "Arrow";
  odom["Shape"]["Color"] = "255; 25; 0";
  odom["Shape"]["Shaft Length"] = 2;
  odom["Shape"]["Shaft Radius"] = 0.1;
  odom["Shape"]["Head Length"] = 0.5;
  odom["Shape"]["Head Radius"] = 0.25;
  list.push_back(odom);

  if (v.controller.type != ControllerType::kExternal)
  {
    YAML::Node path = display("rviz/Path", "Controller path (controller/path)", true);
    path["Topic"] = ns + "controller/path";
    path["Color"] = "25; 255; 0";
    path["Line Style"] = "Billboards";
    path["Line Width"] = 0.15;
    list.push_back(path);
    YAML::Node target = display("rviz/Marker", "Controller target (controller/target)", true);
    target["Marker Topic"] = ns + "controller/target";
    target["Queue Size"] = 10;
    list.push_back(target);
  }
  if (shown.lidar)
  {
    YAML::Node points = pointCloud("Lidar points (avt_341/points)", ns + "avt_341/points", "Points", "Intensity");
    points["Size (Pixels)"] = 2;
    points["Channel Name"] = "intensity";
    points["Use rainbow"] = true;
    list.push_back(points);
  }
  if (shown.radar)
  {
    YAML::Node points = pointCloud("Radar points (radar/points)", ns + "radar/points", "Spheres", "FlatColor");
    points["Size (m)"] = 0.2;
    points["Color"] = "255; 85; 0";
    list.push_back(points);
    list.push_back(markers("Radar targets (radar/markers)", ns + "radar/markers", true));
  }
  if (shown.occupancy)
  {
    // Off: sensors_node builds these only while someone subscribes.
    list.push_back(markers("OctoMap cells (octomap/occupied_cells)", ns + "octomap/occupied_cells", false));
    YAML::Node grid = display("rviz/Map", "Occupancy grid (occupancy/grid)", false);
    grid["Topic"] = ns + "occupancy/grid";
    grid["Alpha"] = 0.6;
    grid["Color Scheme"] = "map";
    list.push_back(grid);
  }
  for (std::size_t k = 0; k < shown.rgb_cameras.size(); ++k)
  {
    const std::string& camera = shown.rgb_cameras[k];
    YAML::Node image = display("rviz/Image", "Camera " + camera + " (" + camera + "/image_raw)", k == 0);
    image["Image Topic"] = ns + camera + "/image_raw";
    image["Transport Hint"] = "raw";
    image["Queue Size"] = 2;
    image["Normalize Range"] = true;
    list.push_back(image);
  }
  group["Displays"] = list;
  return group;
}
}  // namespace

const VehicleSpec& leadVehicle(const Scenario& s)
{
  if (s.vehicles.empty())
    throw std::invalid_argument("leadVehicle: the scenario has no vehicle");
  if (s.formation.present && !s.formation.vehicles.empty())
  {
    const int k = s.vehicleIndex(s.formation.vehicles.front());
    if (k >= 0)
      return s.vehicles[static_cast<std::size_t>(k)];
  }
  for (const VehicleSpec& v : s.vehicles)
    if (v.controller.type == ControllerType::kWaypoints)
      return v;
  return s.vehicles.front();
}

std::string generateRvizConfig(const Scenario& s, const std::vector<VehicleDisplays>& displays)
{
  std::map<std::string, const VehicleDisplays*> by_name;
  for (const VehicleDisplays& d : displays)
  {
    if (s.vehicleIndex(d.name) < 0)
      throw std::invalid_argument("generateRvizConfig: displays for '" + d.name + "', which is not a vehicle of " +
                                  s.file);
    by_name[d.name] = &d;
  }
  YAML::Node list(YAML::NodeType::Sequence);
  YAML::Node grid = display("rviz/Grid", "Grid", false);
  grid["Reference Frame"] = "<Fixed Frame>";
  grid["Plane Cell Count"] = 60;
  grid["Cell Size"] = 10;
  list.push_back(grid);
  YAML::Node tf = display("rviz/TF", "TF", false);
  tf["Show Names"] = false;
  tf["Marker Scale"] = 2;
  list.push_back(tf);
  list.push_back(markers("Terrain mesh (/terrain/mesh)", "/terrain/mesh", true));
  list.push_back(markers("Ruts (/terrain/rut_markers)", "/terrain/rut_markers", true));
  list.push_back(markers("Terrain objects (/terrain/objects)", "/terrain/objects", true));
  if (s.agents.IsDefined() && !s.agents.IsNull() && s.agents.size() > 0)
    list.push_back(markers("Agents (/agents/markers)", "/agents/markers", true));
  list.push_back(markers("V2V links (/v2v/fleet_markers)", "/v2v/fleet_markers", true));
  for (const VehicleSpec& v : s.vehicles)
  {
    const auto it = by_name.find(v.name);
    if (it == by_name.end())
      throw std::invalid_argument("generateRvizConfig: no displays given for vehicle '" + v.name + "'");
    list.push_back(vehicleGroup(v, *it->second));
  }

  YAML::Node root;
  YAML::Node panels(YAML::NodeType::Sequence);
  for (const char* panel : { "Displays", "Selection", "Tool Properties", "Views", "Time" })
  {
    YAML::Node p;
    p["Class"] = std::string("rviz/") + panel;
    p["Name"] = panel;
    panels.push_back(p);
  }
  root["Panels"] = panels;
  YAML::Node manager;
  manager["Class"] = "";
  manager["Displays"] = list;
  manager["Enabled"] = true;
  manager["Global Options"]["Fixed Frame"] = "map";
  manager["Global Options"]["Background Color"] = "40; 44; 52";
  manager["Global Options"]["Frame Rate"] = 30;
  manager["Name"] = "root";
  YAML::Node tools(YAML::NodeType::Sequence);
  for (const char* tool : { "Interact", "MoveCamera", "Select", "FocusCamera", "Measure" })
  {
    YAML::Node t;
    t["Class"] = std::string("rviz/") + tool;
    tools.push_back(t);
  }
  manager["Tools"] = tools;
  // Behind the lead (yaw pi in its frame) and above, looking at a point 15 m behind it: the
  // column of a formation (10-15 m spacing) is then in view as the lead turns.
  const VehicleSpec& lead = leadVehicle(s);
  YAML::Node view;
  view["Class"] = "rviz/ThirdPersonFollower";
  view["Name"] = "Follow " + lead.name;
  view["Target Frame"] = lead.name + "/base_link";
  view["Distance"] = 60.0;
  view["Focal Point"]["X"] = -15.0;
  view["Focal Point"]["Y"] = 0.0;
  view["Focal Point"]["Z"] = 0.0;
  view["Focal Shape Size"] = 0.05;
  view["Pitch"] = 0.55;
  view["Yaw"] = 2.6;
  view["Near Clip Distance"] = 0.01;
  manager["Views"]["Current"] = view;
  root["Visualization Manager"] = manager;
  // Qt's saved dock layout (RViz's own format): Displays on the left, Views on the right
  // (collapsed, so the 3D view is wide), Time below.
  YAML::Node window;
  window["Displays"]["collapsed"] = false;
  window["Height"] = 900;
  window["Hide Left Dock"] = false;
  window["Hide Right Dock"] = true;
  window["QMainWindow State"] = kDockLayout;
  window["Selection"]["collapsed"] = false;
  window["Time"]["collapsed"] = false;
  window["Tool Properties"]["collapsed"] = false;
  window["Views"]["collapsed"] = true;
  window["Width"] = 1280;
  window["X"] = 20;
  window["Y"] = 20;
  root["Window Geometry"] = window;

  YAML::Emitter out;
  out << root;
  return std::string("# Generated by avsp's scenario_launch from ") + s.file + " (scenario '" + s.name +
         "'): the run's topics, the view following " + lead.name + ". Do not edit: edit the scenario.\n" + out.c_str() +
         "\n";
}

std::vector<std::string> rvizConfigTopics(const std::string& config_yaml)
{
  std::set<std::string> topics;
  std::vector<YAML::Node> stack{ YAML::Load(config_yaml) };
  while (!stack.empty())
  {
    const YAML::Node n = stack.back();
    stack.pop_back();
    if (n.IsSequence())
      for (const YAML::Node& c : n)
        stack.push_back(c);
    else if (n.IsMap())
      for (const auto& kv : n)
      {
        const std::string key = kv.first.Scalar();
        if (kv.second.IsScalar() && (key == "Topic" || key == "Marker Topic" || key == "Image Topic"))
          topics.insert(kv.second.Scalar());
        else
          stack.push_back(kv.second);
      }
  }
  return std::vector<std::string>(topics.begin(), topics.end());
}

}  // namespace scenario
}  // namespace avsp
