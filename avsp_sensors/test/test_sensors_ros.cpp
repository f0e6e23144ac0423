// sensors_node's ROS layer without a master: the parameters (defaults, per-section precedence,
// every malformed key named), the vehicle frames from the reference URDFs, and the message
// conversions (PointCloud2 layout, stamps on the microsecond, odometry twist into the map,
// weather checks).
#include <cmath>
#include <cstring>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <avsp_terrain/ros/node_params.hpp>

#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/ros/camera_conversions.hpp"
#include "avsp_sensors/ros/conversions.hpp"
#include "avsp_sensors/ros/sensor_params.hpp"
#include "avsp_sensors/ros/vehicle_frames.hpp"
#include "avsp_sensors/scene.hpp"

using namespace avsp::sensors;
using namespace avsp::sensors::node;
using XmlRpc::XmlRpcValue;

namespace
{
/// A YAML-like map built in code: {{"key", value}, ...}.
XmlRpcValue map(std::vector<std::pair<std::string, XmlRpcValue>> entries)
{
  XmlRpcValue v;
  v.begin();  // makes it a struct even when empty
  for (auto& [k, x] : entries)
    v[k] = x;
  return v;
}

XmlRpcValue list(std::vector<XmlRpcValue> items)
{
  XmlRpcValue v;
  v.setSize(static_cast<int>(items.size()));
  for (std::size_t k = 0; k < items.size(); ++k)
    v[static_cast<int>(k)] = items[k];
  return v;
}

XmlRpcValue str(const char* s)
{
  return XmlRpcValue(std::string(s));
}

/// The StartupError message of parsing `common` as ~sensors (and `own` as the vehicle's).
std::string error(const XmlRpcValue& common, const XmlRpcValue* own = nullptr)
{
  try
  {
    parseSensors(own, "~vehicle_sensors/ego", &common, "~sensors");
  }
  catch (const avsp::node::StartupError& e)
  {
    return e.what();
  }
  return "(no error)";
}

bool mentions(const std::string& text, std::initializer_list<const char*> parts)
{
  for (const char* p : parts)
    if (text.find(p) == std::string::npos)
      return false;
  return true;
}
}  // namespace

/// The text contains every one of the strings that follow it.
#define EXPECT_MENTIONS(text, ...)                          \
  do                                                        \
  {                                                         \
    const std::string said_ = (text);                       \
    EXPECT_TRUE(mentions(said_, { __VA_ARGS__ })) << said_; \
  } while (0)

TEST(SensorParams, DefaultsGiveEverySensorButUltrasonicsOnTheStandardLinks)
{
  const SensorsSpec s = parseSensors(nullptr, "~vehicle_sensors/ego", nullptr, "~sensors");
  ASSERT_TRUE(s.suite.lidar);
  EXPECT_EQ(s.suite.lidar->config.name, "VLP-16");
  EXPECT_TRUE(s.suite.lidar->registered);
  ASSERT_TRUE(s.suite.radar);
  EXPECT_EQ(s.suite.radar->rate, 10.0);
  EXPECT_TRUE(s.suite.gps && s.suite.imu && s.suite.magnetometer && s.suite.occupancy);
  EXPECT_TRUE(s.suite.ultrasonics.empty());
  EXPECT_EQ(s.lidar_link, "lidar");
  EXPECT_EQ(s.magnetometer_link, "imu");
  EXPECT_EQ(s.keys.at("radar"), "~sensors/radar");
  EXPECT_TRUE(needsOrigin({ s }));
  // The magnetometer on the shipped World Magnetic Model by default.
  ASSERT_TRUE(s.magnetometer_model);
  EXPECT_EQ(s.magnetometer_model->name(), "wmm2025");
}

TEST(SensorParams, VehicleSectionsReplaceCommonOnesSectionBySection)
{
  const XmlRpcValue common = map({ { "lidar", map({ { "preset", str("HDL-32E") }, { "max_range", 80.0 } }) },
                                   { "radar", map({ { "rate", 20 }, { "cluster_eps", 1.5 } }) },
                                   { "gps", map({ { "enabled", false } }) } });
  const XmlRpcValue own =
      map({ { "lidar", map({ { "registered", false }, { "sub_rays", 2 } }) },
            { "magnetometer", map({ { "model", str("fixed") },
                                    { "intensity", 4.8e-5 },
                                    { "inclination_deg", 65 },
                                    { "declination_deg", -8.5 } }) },
            { "ultrasonic",
              list({ map({ { "name", str("rear") }, { "x", -2.0 }, { "yaw", 3.14159 }, { "max_range", 3.0 } }) }) } });
  const SensorsSpec s = parseSensors(&own, "~vehicle_sensors/ego", &common, "~sensors");
  ASSERT_TRUE(s.suite.lidar);
  EXPECT_EQ(s.suite.lidar->config.name, "VLP-16");  // the vehicle's lidar section, not HDL-32E
  EXPECT_FALSE(s.suite.lidar->registered);
  EXPECT_EQ(s.suite.lidar->config.sub_rays, 2u);
  EXPECT_EQ(s.keys.at("lidar"), "~vehicle_sensors/ego/lidar");
  ASSERT_TRUE(s.suite.radar);
  EXPECT_EQ(s.suite.radar->rate, 20.0);
  EXPECT_EQ(s.suite.radar->config.cluster_eps, 1.5);
  EXPECT_FALSE(s.suite.gps);
  ASSERT_TRUE(s.suite.magnetometer);
  EXPECT_EQ(s.suite.magnetometer->field.intensity, 4.8e-5);
  EXPECT_EQ(s.suite.magnetometer->field.inclination_deg, 65.0);
  EXPECT_EQ(s.suite.magnetometer->field.declination_deg, -8.5);
  EXPECT_FALSE(s.magnetometer_model);
  EXPECT_FALSE(needsOrigin({ s }));  // no GPS, the magnetometer's field given
  ASSERT_EQ(s.suite.ultrasonics.size(), 1u);
  EXPECT_EQ(s.suite.ultrasonics[0].name, "rear");
  EXPECT_EQ(s.suite.ultrasonics[0].config.max_range, 3.0);
  ASSERT_TRUE(s.ultrasonic_mounts[0].pose);
  EXPECT_NEAR(s.ultrasonic_mounts[0].pose->translation().x(), -2.0, 1e-12);
  EXPECT_NEAR((s.ultrasonic_mounts[0].pose->linear() * Eigen::Vector3d::UnitX()).x(), -1.0, 1e-9);

  // A custom lidar from its channels.
  const XmlRpcValue custom =
      map({ { "lidar", map({ { "preset", str("custom") },
                             { "channels", list({ map({ { "elevation", -0.1 } }),
                                                  map({ { "elevation", 0.1 }, { "time_offset", 1e-6 } }) }) },
                             { "columns", 360 } }) } });
  const SensorsSpec c = parseSensors(nullptr, "", &custom, "~sensors");
  ASSERT_EQ(c.suite.lidar->config.channels.size(), 2u);
  EXPECT_EQ(c.suite.lidar->config.columns, 360u);
  // Without a lidar the occupancy map is off unless asked for.
  const XmlRpcValue no_lidar = map({ { "lidar", map({ { "enabled", false } }) } });
  EXPECT_FALSE(parseSensors(nullptr, "", &no_lidar, "~sensors").suite.occupancy);
}

TEST(SensorParams, EveryMalformedKeyIsNamed)
{
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "presett", str("VLP-16") } }) } })), "~sensors/lidar/presett",
                  "not a known key");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "preset", str("VLP-17") } }) } })), "~sensors/lidar/preset", "VLP-17");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "preset", str("custom") } }) } })), "~sensors/lidar/channels",
                  "required");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "max_range", str("far") } }) } })), "~sensors/lidar/max_range",
                  "must be a number");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "min_range", 200.0 } }) } })), "~sensors/lidar", "max_range");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "return_mode", str("first") } }) } })), "~sensors/lidar/return_mode",
                  "'strongest' or 'last'");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "columns", -5 } }) } })), "~sensors/lidar/columns");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "registered", 1 } }) } })), "~sensors/lidar/registered",
                  "true or false");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "frame", str("a/b") } }) } })), "~sensors/lidar/frame", "URDF link");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "cluster_tolerance", 0.0 } }) } }) } })),
                  "~sensors/lidar/clustering", "cluster_tolerance");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "cluster_tolerance", -1 } }) } }) } })),
                  "~sensors/lidar/clustering", "cluster_tolerance");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "tolerance", 0.5 } }) } }) } })),
                  "~sensors/lidar/clustering/tolerance", "not a known key");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "min_points", 0 } }) } }) } })),
                  "~sensors/lidar/clustering/min_points");
  EXPECT_MENTIONS(
      error(map({ { "lidar", map({ { "clustering", map({ { "min_points", 10 }, { "max_points", 5 } }) } }) } })),
      "~sensors/lidar/clustering", "max_points");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "ground_clearance", -0.1 } }) } }) } })),
                  "~sensors/lidar/clustering", "ground_clearance");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "use_height", 1 } }) } }) } })),
                  "~sensors/lidar/clustering/use_height", "true or false");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "ring_link_angle_deg", 0.0 } }) } }) } })),
                  "~sensors/lidar/clustering/ring_link_angle_deg", "(0, 90]");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "ring_link_angle_deg", 95.0 } }) } }) } })),
                  "~sensors/lidar/clustering/ring_link_angle_deg", "(0, 90]");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", map({ { "ring_link_gap", -1.0 } }) } }) } })),
                  "~sensors/lidar/clustering", "ring_link_gap");
  EXPECT_MENTIONS(error(map({ { "lidar", map({ { "clustering", 0.5 } }) } })), "~sensors/lidar/clustering",
                  "must be a map");
  EXPECT_MENTIONS(error(map({ { "radar", map({ { "max_range", -5.0 } }) } })), "~sensors/radar", "max_range");
  EXPECT_MENTIONS(error(map({ { "radar", map({ { "rate", 0 } }) } })), "~sensors/radar", "rate");
  EXPECT_MENTIONS(error(map({ { "radar", map({ { "cluster_min_points", 0 } }) } })),
                  "~sensors/radar/cluster_min_points");
  EXPECT_MENTIONS(error(map({ { "gps", map({ { "rate", str("fast") } }) } })), "~sensors/gps/rate", "must be a number");
  EXPECT_MENTIONS(error(map({ { "gps", map({ { "horizontal_noise", -1.0 } }) } })), "~sensors/gps", "horizontal_noise");
  EXPECT_MENTIONS(error(map({ { "imu", map({ { "rate", 0.0 } }) } })), "~sensors/imu", "rate");
  EXPECT_MENTIONS(error(map({ { "magnetometer", map({ { "model", str("fixed") },
                                                      { "intensity", 5e-5 },
                                                      { "inclination_deg", 95 },
                                                      { "declination_deg", 0 } }) } })),
                  "~sensors/magnetometer", "inclination_deg");
  EXPECT_MENTIONS(error(map({ { "magnetometer", map({ { "model", str("fixed") }, { "intensity", 5e-5 } }) } })),
                  "~sensors/magnetometer/inclination_deg", "required with model 'fixed'");
  EXPECT_MENTIONS(error(map({ { "magnetometer", map({ { "declination_deg", 7.7 } }) } })),
                  "~sensors/magnetometer/declination_deg", "only read with model 'fixed'", "'wmm2025'");
  EXPECT_MENTIONS(error(map({ { "magnetometer", map({ { "model", str("wmm2099") } }) } })),
                  "~sensors/magnetometer/model = 'wmm2099'", "magnetic model file", "wmm2099.wmm");
  EXPECT_MENTIONS(error(map({ { "magnetometer", map({ { "model", str("/nonexistent/site.wmm") } }) } })),
                  "~sensors/magnetometer/model", "magnetic model file /nonexistent/site.wmm");
  EXPECT_MENTIONS(error(map({ { "magnetometer", map({ { "model", 2025 } }) } })), "~sensors/magnetometer/model",
                  "must be a string");
  EXPECT_MENTIONS(error(map({ { "ultrasonic", list({ map({ { "x", 1.0 } }) }) } })), "~sensors/ultrasonic[0]/name",
                  "required");
  EXPECT_MENTIONS(
      error(map({ { "ultrasonic", list({ map({ { "name", str("a") } }), map({ { "name", str("a") } }) }) } })),
      "~sensors/ultrasonic[1]/name", "used twice");
  EXPECT_MENTIONS(error(map({ { "ultrasonic", list({ map({ { "name", str("a") }, { "max_range", 0.01 } }) }) } })),
                  "~sensors/ultrasonic[0]", "max_range");
  EXPECT_MENTIONS(error(map({ { "ultrasonic", map({ { "name", str("a") } }) } })), "~sensors/ultrasonic",
                  "must be a list");
  EXPECT_MENTIONS(
      error(map({ { "lidar", map({ { "enabled", false } }) }, { "occupancy", map({ { "enabled", true } }) } })),
      "~sensors/occupancy/enabled", "needs a lidar");
  EXPECT_MENTIONS(error(map({ { "occupancy", map({ { "resolution", 0.0 } }) } })), "~sensors/occupancy", "resolution");
  EXPECT_MENTIONS(error(map({ { "occupancy", map({ { "obstacle_height", 5.0 } }) } })), "~sensors/occupancy",
                  "max_height");
  EXPECT_MENTIONS(error(map({ { "sonar", map({}) } })), "~sensors/sonar", "not a known key");
  EXPECT_MENTIONS(error(map({ { "lidar", 3 } })), "~sensors/lidar", "must be a map");
  // The vehicle's own section is named as such.
  const XmlRpcValue own = map({ { "imu", map({ { "gravity", -1.0 } }) } });
  EXPECT_MENTIONS(error(map({}), &own), "~vehicle_sensors/ego/imu", "gravity");
}

TEST(SensorParams, CamerasParseWithTheirMountOutputsAndStereoPairs)
{
  const XmlRpcValue common =
      map({ { "cameras",
              list({ map({ { "name", str("front") },
                           { "width", 320 },
                           { "height", 200 },
                           { "hfov_deg", 60.0 },
                           { "rate", 3 },
                           { "x", 1.5 },
                           { "z", 1.2 },
                           { "yaw", 0.5 },
                           { "outputs", list({ str("depth"), str("thermal") }) } }),
                     map({ { "name", str("stereo") }, { "stereo_baseline", 0.4 }, { "y", 0.2 } }),
                     map({ { "name", str("fish") }, { "projection", str("fisheye") }, { "hfov_deg", 190 } }) }) } });
  const SensorsSpec s = parseSensors(nullptr, "~vehicle_sensors/ego", &common, "~sensors");
  ASSERT_EQ(s.cameras.size(), 4u);
  const CameraConfig& f = s.cameras[0];
  EXPECT_EQ(f.name, "front");
  EXPECT_EQ(f.width, 320);
  EXPECT_EQ(f.height, 200);
  EXPECT_NEAR(f.hfov, M_PI / 3, 1e-12);
  EXPECT_DOUBLE_EQ(f.rate, 3.0);
  EXPECT_TRUE(f.mount.translation().isApprox(Eigen::Vector3d(1.5, 0, 1.2)));
  EXPECT_TRUE((f.mount.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d(std::cos(0.5), std::sin(0.5), 0)));
  EXPECT_FALSE(f.rgb || f.semantic);
  EXPECT_TRUE(f.depth && f.thermal);
  // The pair: left at the mount, right 0.4 m to its right, P's Tx = -B.
  EXPECT_EQ(s.cameras[1].name, "stereo/left");
  EXPECT_EQ(s.cameras[2].name, "stereo/right");
  EXPECT_TRUE(s.cameras[1].mount.translation().isApprox(Eigen::Vector3d(0, 0.2, 0)));
  EXPECT_TRUE(s.cameras[2].mount.translation().isApprox(Eigen::Vector3d(0, -0.2, 0)));
  EXPECT_DOUBLE_EQ(s.cameras[1].stereo_tx, 0.0);
  EXPECT_DOUBLE_EQ(s.cameras[2].stereo_tx, -0.4);
  EXPECT_EQ(s.cameras[3].projection, CameraProjection::kFisheye);
  // Defaults: rgb, depth, semantic; no cameras without the section.
  EXPECT_TRUE(s.cameras[1].rgb && s.cameras[1].depth && s.cameras[1].semantic && !s.cameras[1].thermal);
  EXPECT_TRUE(parseSensors(nullptr, "", nullptr, "~sensors").cameras.empty());
  // Malformed cameras, each named.
  EXPECT_MENTIONS(error(map({ { "cameras", list({ map({ { "width", 64 } }) }) } })), "~sensors/cameras[0]/name",
                  "required");
  EXPECT_MENTIONS(error(map({ { "cameras", list({ map({ { "name", str("a") }, { "width", 0 } }) }) } })),
                  "~sensors/cameras[0]/width");
  EXPECT_MENTIONS(error(map({ { "cameras", list({ map({ { "name", str("a") }, { "rate", -1.0 } }) }) } })),
                  "~sensors/cameras[0]", "rate");
  EXPECT_MENTIONS(
      error(map({ { "cameras", list({ map({ { "name", str("a") }, { "projection", str("orthographic") } }) }) } })),
      "~sensors/cameras[0]/projection");
  EXPECT_MENTIONS(
      error(map({ { "cameras", list({ map({ { "name", str("a") }, { "outputs", list({ str("lidar") }) } }) }) } })),
      "~sensors/cameras[0]/outputs");
  EXPECT_MENTIONS(
      error(map({ { "cameras", list({ map({ { "name", str("a") }, { "distortion", list({ 0.1, 0.2 }) } }) }) } })),
      "~sensors/cameras[0]/distortion", "5 numbers");
  EXPECT_MENTIONS(error(map({ { "cameras", list({ map({ { "name", str("a") } }), map({ { "name", str("a") } }) }) } })),
                  "~sensors/cameras[1]/name", "used twice");
  EXPECT_MENTIONS(error(map({ { "cameras", list({ map({ { "name", str("a") }, { "stereo_baseline", -0.1 } }) }) } })),
                  "~sensors/cameras[0]/stereo_baseline");
  EXPECT_MENTIONS(error(map({ { "cameras", map({ { "name", str("a") } }) } })), "~sensors/cameras", "must be a list");
}

TEST(Conversions, CameraImagesInfoAndEnvironment)
{
  CameraConfig c;
  c.width = 4;
  c.height = 3;
  c.thermal = true;
  const Camera cam(c);
  CameraFrame f;
  f.width = 4;
  f.height = 3;
  f.rgb.assign(36, 7);
  f.depth.assign(12, 2.5f);
  f.semantic.assign(12, 9);
  f.thermal.assign(12, 200);
  std_msgs::Header h;
  h.frame_id = "ego/front_optical";
  const sensor_msgs::Image rgb = toImage(f, ImageKind::kRgb, h), depth = toImage(f, ImageKind::kDepth, h);
  EXPECT_EQ(rgb.encoding, "rgb8");
  EXPECT_EQ(rgb.step, 12u);
  EXPECT_EQ(rgb.data.size(), 36u);
  EXPECT_EQ(depth.encoding, "32FC1");
  EXPECT_EQ(depth.step, 16u);
  float d;
  std::memcpy(&d, &depth.data[4 * 5], 4);
  EXPECT_EQ(d, 2.5f);
  EXPECT_EQ(toImage(f, ImageKind::kSemantic, h).data[3], 9);
  EXPECT_EQ(toImage(f, ImageKind::kThermal, h).encoding, "mono8");
  const sensor_msgs::CameraInfo ci = toCameraInfo(cam.intrinsics(), h);
  EXPECT_EQ(ci.width, 4u);
  EXPECT_DOUBLE_EQ(ci.K[0], cam.intrinsics().fx);
  EXPECT_DOUBLE_EQ(ci.P[0], cam.intrinsics().fx);
  EXPECT_EQ(ci.D.size(), 5u);
  EXPECT_EQ(ci.header.frame_id, "ego/front_optical");
  // Environment: zero directions keep the last sky; season from the UTC month and latitude.
  CameraEnvironment env;
  const Eigen::Vector3d sun_before = env.sun_direction;
  avsp_msgs::Environment m;
  m.fog_visibility = 200.0;
  m.air_temperature = 265.0;
  m.utc = ros::Time(1700000000);  // 2023-11-14: fall in the north
  Weather w;
  w.fog_visibility = 200.0;
  w.snow_rate = 1.0;
  std::string why;
  ASSERT_TRUE(cameraEnvironmentFromMessage(m, w, 40.0, env, why)) << why;
  EXPECT_TRUE(env.sun_direction.isApprox(sun_before));
  EXPECT_EQ(env.season, Season::kFall);
  EXPECT_DOUBLE_EQ(env.air_temperature, 265.0);
  EXPECT_DOUBLE_EQ(env.snow_cover, 1.0);  // snowing below 0 deg C
  EXPECT_DOUBLE_EQ(env.weather.fog_visibility, 200.0);
  m.sun_direction.z = 1.0;
  m.sun_elevation = M_PI / 2;
  ASSERT_TRUE(cameraEnvironmentFromMessage(m, w, -40.0, env, why)) << why;
  EXPECT_TRUE(env.sun_direction.isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_EQ(env.season, Season::kSpring);
  m.sun_direction.z = 2.0;  // not a unit vector: refused, env unchanged
  EXPECT_FALSE(cameraEnvironmentFromMessage(m, w, 40.0, env, why));
  EXPECT_NE(why.find("sun_direction"), std::string::npos);
  EXPECT_TRUE(env.sun_direction.isApprox(Eigen::Vector3d::UnitZ()));
}

TEST(SensorParams, VehicleListIsCheckedEntryByEntry)
{
  const auto fails = [](const XmlRpcValue& v) {
    try
    {
      parseVehicles(v);
    }
    catch (const avsp::node::StartupError& e)
    {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::vector<VehicleEntry> ok =
      parseVehicles(list({ map({ { "name", str("a") }, { "model", str("fed_alpha") }, { "x", 3.0 } }),
                           map({ { "name", str("b") }, { "model", str("mrzr") } }) }));
  ASSERT_EQ(ok.size(), 2u);
  EXPECT_EQ(ok[1].model, "mrzr");
  EXPECT_MENTIONS(fails(XmlRpcValue(3)), "~vehicles", "non-empty list");
  EXPECT_MENTIONS(fails(list({ map({ { "name", str("a") } }) })), "~vehicles[0]", "'model'");
  EXPECT_MENTIONS(fails(list({ map({ { "name", str("a") }, { "model", str("m") } }),
                               map({ { "name", str("a") }, { "model", str("m") } }) })),
                  "~vehicles[1].name", "listed twice");
  EXPECT_MENTIONS(fails(list({ map({ { "name", str("a/b") }, { "model", str("m") } }) })), "~vehicles[0].name",
                  "without '/'");
  EXPECT_MENTIONS(fails(list({ map({ { "name", str("a") }, { "model", str("m") }, { "colour", str("red") } }) })),
                  "~vehicles[0].colour", "unknown key");
}

TEST(VehicleFrames, ReferenceVehiclesHaveTheSensorLinksAndCollisionBoxes)
{
  for (const char* model : { "fed_alpha", "m113", "mrzr", "tracer_x" })
  {
    const VehicleFrames f = loadVehicleFrames(std::string(AVSP_CONFIG_DIR) + "/vehicles/" + model + ".yaml");
    EXPECT_EQ(f.root_link, "base_link") << model;
    for (const char* link : { "lidar", "radar", "gps", "imu" })
      EXPECT_TRUE(f.hasLink(link)) << model << " " << link;
    EXPECT_FALSE(f.boxes.empty()) << model;
  }
  const VehicleFrames f = loadVehicleFrames(std::string(AVSP_CONFIG_DIR) + "/vehicles/fed_alpha.yaml");
  // urdf/fed_alpha.urdf: lidar_mount xyz="1 0 1.4".
  EXPECT_NEAR((f.link("lidar").translation() - Eigen::Vector3d(1.0, 0.0, 1.4)).norm(), 0.0, 1e-12);
  EXPECT_THROW(f.link("sonar"), std::invalid_argument);
}

namespace
{
LidarPoint lidarPoint(float x, float y, float z, float intensity, std::uint16_t ring, float time)
{
  LidarPoint p;
  p.x = x;
  p.y = y;
  p.z = z;
  p.intensity = intensity;
  p.ring = ring;
  p.time = time;
  return p;
}

void addField(sensor_msgs::PointCloud2& cloud, const std::string& name, std::uint32_t offset, std::uint8_t type)
{
  sensor_msgs::PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = type;
  f.count = 1;
  cloud.fields.push_back(f);
}

template <typename T>
void put(std::uint8_t* at, T value)
{
  std::memcpy(at, &value, sizeof(T));
}

/// The lidar cloud as sensors_node packed it by hand before PCL (the published contract): the
/// oracle the PCL conversion must equal byte for byte.
sensor_msgs::PointCloud2 handPackedLidar(const LidarScan& scan, const std_msgs::Header& header)
{
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  cloud.height = 1;
  cloud.width = static_cast<std::uint32_t>(scan.points.size());
  addField(cloud, "x", 0, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "y", 4, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "z", 8, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "intensity", 12, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "ring", 16, sensor_msgs::PointField::UINT16);
  addField(cloud, "time", 20, sensor_msgs::PointField::FLOAT32);
  cloud.is_bigendian = false;
  cloud.point_step = 24;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_dense = true;
  cloud.data.assign(static_cast<std::size_t>(cloud.row_step), 0);
  std::uint8_t* out = cloud.data.data();
  for (const LidarPoint& p : scan.points)
  {
    put(out + 0, p.x);
    put(out + 4, p.y);
    put(out + 8, p.z);
    put(out + 12, p.intensity);
    put(out + 16, p.ring);
    put(out + 20, p.time);
    out += 24;
  }
  return cloud;
}

/// The radar detections as packed by hand before PCL.
sensor_msgs::PointCloud2 handPackedRadar(const RadarScan& scan, const std_msgs::Header& header)
{
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  cloud.height = 1;
  cloud.width = static_cast<std::uint32_t>(scan.detections.size());
  addField(cloud, "x", 0, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "y", 4, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "z", 8, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "range_rate", 12, sensor_msgs::PointField::FLOAT32);
  addField(cloud, "cluster", 16, sensor_msgs::PointField::INT32);
  cloud.is_bigendian = false;
  cloud.point_step = 20;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_dense = true;
  cloud.data.assign(static_cast<std::size_t>(cloud.row_step), 0);
  std::uint8_t* out = cloud.data.data();
  for (std::size_t k = 0; k < scan.detections.size(); ++k)
  {
    const RadarDetection& d = scan.detections[k];
    put(out + 0, static_cast<float>(d.position.x()));
    put(out + 4, static_cast<float>(d.position.y()));
    put(out + 8, static_cast<float>(d.position.z()));
    put(out + 12, static_cast<float>(d.range_rate));
    put(out + 16, static_cast<std::int32_t>(k < scan.clusters.labels.size() ? scan.clusters.labels[k] : -1));
    out += 20;
  }
  return cloud;
}

/// Every field of two PointCloud2 messages, the bytes included.
void expectSameCloud(const sensor_msgs::PointCloud2& got, const sensor_msgs::PointCloud2& want)
{
  EXPECT_EQ(got.header.frame_id, want.header.frame_id);
  EXPECT_EQ(got.header.stamp, want.header.stamp);
  EXPECT_EQ(got.height, want.height);
  EXPECT_EQ(got.width, want.width);
  ASSERT_EQ(got.fields.size(), want.fields.size());
  for (std::size_t k = 0; k < want.fields.size(); ++k)
  {
    EXPECT_EQ(got.fields[k].name, want.fields[k].name) << k;
    EXPECT_EQ(got.fields[k].offset, want.fields[k].offset) << k;
    EXPECT_EQ(got.fields[k].datatype, want.fields[k].datatype) << k;
    EXPECT_EQ(got.fields[k].count, want.fields[k].count) << k;
  }
  EXPECT_EQ(got.is_bigendian, want.is_bigendian);
  EXPECT_EQ(got.point_step, want.point_step);
  EXPECT_EQ(got.row_step, want.row_step);
  EXPECT_EQ(got.is_dense, want.is_dense);
  EXPECT_TRUE(got.data == want.data) << "data bytes differ";
}
}  // namespace

TEST(Conversions, PclLidarCloudEqualsTheHandPackedLayoutByteForByte)
{
  // A real sweep (a VLP-16 over flat ground and a wall: ~14 000 points, every ring) through
  // pcl::toROSMsg against the hand packing the node published before PCL.
  const std::size_t n = 201;
  Scene scene(HeightField(-50.0, -50.0, 0.5, 0.5, n, n, std::vector<float>(n * n, 0.f)));
  Primitive wall;
  wall.centre = Eigen::Vector3d(8.0, 0.0, 1.5);
  wall.half_extents = Eigen::Vector3d(0.2, 4.0, 1.5);
  scene.setStaticPrimitives({ wall });
  const Lidar lidar(lidarPreset("VLP-16"), 5);
  LidarScanRequest req;
  req.motion.pose.translation() = Eigen::Vector3d(0.0, 0.0, 1.8);
  const LidarScan scan = lidar.scan(scene, req);
  ASSERT_GT(scan.points.size(), 10000u);
  std_msgs::Header h;
  h.frame_id = "odom";
  h.stamp = ros::Time(12, 345678000);
  expectSameCloud(toPointCloud2(scan, h), handPackedLidar(scan, h));
  // An empty sweep too.
  expectSameCloud(toPointCloud2(LidarScan(), h), handPackedLidar(LidarScan(), h));
}

TEST(Conversions, PclRadarCloudEqualsTheHandPackedLayoutByteForByte)
{
  RadarScan scan;
  for (int k = 0; k < 7; ++k)
  {
    RadarDetection d;
    d.position = Eigen::Vector3d(10.0 + 0.37 * k, -1.0 + 0.11 * k, 0.05 * k);
    d.range_rate = -2.0 + 0.7 * k;
    scan.detections.push_back(d);
  }
  scan.clusters.labels = { 0, 0, -1, 1, 1, 1, -1 };
  std_msgs::Header h;
  h.frame_id = "ego/radar";
  h.stamp = ros::Time(3, 100000000);
  expectSameCloud(radarPoints(scan, h), handPackedRadar(scan, h));
}

TEST(Conversions, LidarCloudHasTheContractLayout)
{
  LidarScan scan;
  scan.points.push_back(lidarPoint(1.5f, -2.0f, 0.25f, 42.0f, 7, 0.05f));
  scan.points.push_back(lidarPoint(3.0f, 4.0f, 5.0f, 1.0f, 15, 0.09f));
  std_msgs::Header h;
  h.frame_id = "odom";
  const sensor_msgs::PointCloud2 c = toPointCloud2(scan, h);
  ASSERT_EQ(c.fields.size(), 6u);
  const char* names[] = { "x", "y", "z", "intensity", "ring", "time" };
  const std::uint32_t offsets[] = { 0, 4, 8, 12, 16, 20 };
  for (int k = 0; k < 6; ++k)
  {
    EXPECT_EQ(c.fields[k].name, names[k]);
    EXPECT_EQ(c.fields[k].offset, offsets[k]);
    EXPECT_EQ(c.fields[k].count, 1u);
  }
  EXPECT_EQ(c.fields[4].datatype, sensor_msgs::PointField::UINT16);
  EXPECT_EQ(c.fields[5].datatype, sensor_msgs::PointField::FLOAT32);
  EXPECT_EQ(c.point_step, 24u);
  EXPECT_EQ(c.width, 2u);
  EXPECT_EQ(c.row_step, 48u);
  EXPECT_EQ(c.data.size(), 48u);
  EXPECT_FALSE(c.is_bigendian);
  float y, t;
  std::uint16_t ring;
  std::memcpy(&y, &c.data[24 + 4], 4);
  std::memcpy(&ring, &c.data[24 + 16], 2);
  std::memcpy(&t, &c.data[24 + 20], 4);
  EXPECT_EQ(y, 4.0f);
  EXPECT_EQ(ring, 15);
  EXPECT_EQ(t, 0.09f);
  EXPECT_EQ(c.data[18], 0);  // padding zeroed
  EXPECT_EQ(c.data[19], 0);
}

TEST(Conversions, StampsLandOnTheMicrosecondAndOdometryTwistIsRotatedIntoTheMap)
{
  EXPECT_EQ(stampSeconds(ros::Time(0, 99999999)), 0.1);
  EXPECT_EQ(stampSeconds(ros::Time(12, 300000400)), 12.3);
  EXPECT_EQ(toStamp(12.3).nsec, 300000000u);
  EXPECT_EQ(toStamp(12.3).sec, 12u);

  nav_msgs::Odometry o;
  o.header.frame_id = "odom";
  o.header.stamp = ros::Time(2, 500000000);
  o.child_frame_id = "ego/base_link";
  o.pose.pose.position.x = 10.0;
  o.pose.pose.orientation.w = std::cos(M_PI / 4);  // yaw 90 deg: facing north
  o.pose.pose.orientation.z = std::sin(M_PI / 4);
  o.twist.twist.linear.x = 3.0;  // forward, in base_link
  o.twist.twist.angular.z = 0.2;
  VehicleState s;
  std::string why;
  ASSERT_TRUE(stateFromOdometry(o, "odom", "ego/base_link", s, why)) << why;
  EXPECT_EQ(s.time, 2.5);
  EXPECT_NEAR((s.linear_velocity - Eigen::Vector3d(0.0, 3.0, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((s.angular_velocity - Eigen::Vector3d(0.0, 0.0, 0.2)).norm(), 0.0, 1e-12);
  EXPECT_FALSE(stateFromOdometry(o, "map", "ego/base_link", s, why));
  EXPECT_NE(why.find("frame_id"), std::string::npos);
  EXPECT_FALSE(stateFromOdometry(o, "odom", "car/base_link", s, why));
  EXPECT_NE(why.find("child_frame_id"), std::string::npos);
  o.pose.pose.orientation.w = 0.5;
  EXPECT_FALSE(stateFromOdometry(o, "odom", "ego/base_link", s, why));
  EXPECT_NE(why.find("unit quaternion"), std::string::npos);
  o.pose.pose.orientation.w = std::cos(M_PI / 4);
  o.twist.twist.linear.y = std::nan("");
  EXPECT_FALSE(stateFromOdometry(o, "odom", "ego/base_link", s, why));
  EXPECT_NE(why.find("twist"), std::string::npos);

  avsp_msgs::Environment env;
  env.fog_visibility = std::numeric_limits<double>::infinity();
  env.snow_rate_mm_h = 2.0;
  env.air_temperature = 268.0;
  Weather w;
  ASSERT_TRUE(weatherFromEnvironment(env, w, why)) << why;
  EXPECT_EQ(w.snow_rate, 2.0);
  EXPECT_FALSE(w.wet_snow);
  env.fog_visibility = -3.0;
  EXPECT_FALSE(weatherFromEnvironment(env, w, why));
  EXPECT_NE(why.find("fog_visibility"), std::string::npos);
  EXPECT_EQ(w.snow_rate, 2.0);  // unchanged
}

TEST(Conversions, RadarOccupancyAndSampledSensorsFillTheirMessages)
{
  RadarScan scan;
  RadarDetection d;
  d.position = Eigen::Vector3d(10, 1, 0);
  d.range_rate = -2.0;
  scan.detections = { d, d };
  scan.clusters.labels = { 0, -1 };
  RadarTarget t;
  t.centroid = Eigen::Vector3d(10, 1, 0);
  t.range = std::hypot(10.0, 1.0);
  t.range_rate = -2.0;
  t.point_count = 1;
  t.extent = Eigen::Vector3d(0.1, 0.0, 0.0);
  scan.targets = { t };
  std_msgs::Header h;
  h.frame_id = "ego/radar";
  const avsp_msgs::RadarTargetArray a = radarTargets(scan, h);
  ASSERT_EQ(a.targets.size(), 1u);
  EXPECT_EQ(a.header.frame_id, "ego/radar");
  EXPECT_EQ(a.targets[0].range_rate, -2.0);
  const sensor_msgs::PointCloud2 p = radarPoints(scan, h);
  EXPECT_EQ(p.width, 2u);
  EXPECT_EQ(p.point_step, 20u);
  std::int32_t label;
  std::memcpy(&label, &p.data[20 + 16], 4);
  EXPECT_EQ(label, -1);
  const visualization_msgs::MarkerArray m = radarMarkers(scan, h);
  ASSERT_EQ(m.markers.size(), 3u);
  EXPECT_EQ(m.markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(m.markers[1].scale.x, 0.2);

  const std::vector<OccupiedCell> cells{ { Eigen::Vector3d(1, 2, 3), 0.2, 0.9 },
                                         { Eigen::Vector3d(0, 0, 0), 0.4, 0.8 },
                                         { Eigen::Vector3d(1, 1, 1), 0.2, 0.7 } };
  const visualization_msgs::MarkerArray cm = occupiedCellMarkers(cells, h, 0.0, 3.0);
  ASSERT_EQ(cm.markers.size(), 3u);  // DELETEALL + one list per size
  EXPECT_EQ(cm.markers[1].points.size(), 2u);
  EXPECT_EQ(cm.markers[1].scale.x, 0.2);
  EXPECT_EQ(cm.markers[2].points.size(), 1u);

  OccupancyGrid2D g;
  g.width = 2;
  g.height = 1;
  g.resolution = 0.2;
  g.origin_x = -1.0;
  g.data = { 100, -1 };
  const nav_msgs::OccupancyGrid og = toOccupancyGrid(g, h);
  EXPECT_EQ(og.info.width, 2u);
  EXPECT_FLOAT_EQ(og.info.resolution, 0.2f);
  EXPECT_EQ(og.data[0], 100);

  UltrasonicReading r;
  r.range = std::numeric_limits<double>::infinity();
  r.max_range = 4.0;
  const sensor_msgs::Range range = toRange(r, h);
  EXPECT_EQ(range.radiation_type, sensor_msgs::Range::ULTRASOUND);
  EXPECT_TRUE(std::isinf(range.range));

  GpsFix fix;
  fix.position = { 42.0, -83.0, 180.0 };
  fix.covariance = Eigen::Vector3d(1, 2, 3).asDiagonal();
  const sensor_msgs::NavSatFix nf = toNavSatFix(fix, h);
  EXPECT_EQ(nf.latitude, 42.0);
  EXPECT_EQ(nf.position_covariance[4], 2.0);
  EXPECT_EQ(nf.position_covariance_type, sensor_msgs::NavSatFix::COVARIANCE_TYPE_DIAGONAL_KNOWN);
}

namespace
{
/// The StartupError message of placeMagnetometers() for the default sensors, or "(no error)".
std::string placeError(const std::optional<EnuFrame>& origin, const std::string& date)
{
  std::vector<SensorsSpec> specs{ parseSensors(nullptr, "~vehicle_sensors/ego", nullptr, "~sensors") };
  try
  {
    placeMagnetometers(specs, origin, date);
  }
  catch (const avsp::node::StartupError& e)
  {
    return e.what();
  }
  return "(no error)";
}
}  // namespace

TEST(SensorParams, MagnetometerGetsTheModelOnTheRunsDateAtTheOrigin)
{
  const EnuFrame origin({ 39.7425, -105.1786, 1829.0 });
  std::vector<SensorsSpec> specs{ parseSensors(nullptr, "~vehicle_sensors/ego", nullptr, "~sensors") };
  const std::string summary = placeMagnetometers(specs, origin, "2025-10-15");
  ASSERT_TRUE(specs[0].suite.magnetometer->model);
  EXPECT_DOUBLE_EQ(specs[0].suite.magnetometer->model->year(), 2025.0 + 287.0 / 365.0);
  // D 7.67 deg east at the default site (test_magnetometer: the MagneticField tool's figures).
  EXPECT_MENTIONS(summary, "World Magnetic Model 2025 on 2025-10-15 (2025.786)", "F 51.06 uT", "I 65.86 deg",
                  "D 7.67 deg");
  // A fixed field needs neither the date nor the origin.
  const XmlRpcValue fixed = map({ { "magnetometer", map({ { "model", str("fixed") },
                                                          { "intensity", 5e-5 },
                                                          { "inclination_deg", 60 },
                                                          { "declination_deg", 0 } }) } });
  std::vector<SensorsSpec> fixed_specs{ parseSensors(nullptr, "", &fixed, "~sensors") };
  EXPECT_EQ(placeMagnetometers(fixed_specs, std::nullopt, ""), "");
  EXPECT_FALSE(fixed_specs[0].suite.magnetometer->model);
}

TEST(SensorParams, MagnetometerDateAndSiteOutsideTheModelAreNamed)
{
  const EnuFrame origin({ 39.7425, -105.1786, 1829.0 });
  EXPECT_MENTIONS(placeError(origin, ""), "parameter ~date", "required by ~sensors/magnetometer/model 'wmm2025'",
                  "model: fixed");
  EXPECT_MENTIONS(placeError(origin, "2025-13-01"), "parameter ~date '2025-13-01'");
  EXPECT_MENTIONS(placeError(origin, "2031-01-01"), "~sensors/magnetometer/model 'wmm2025' on ~date '2031-01-01'",
                  "valid for decimal years 2025.0 to 2030.0", "the date is 2031.000");
  EXPECT_MENTIONS(placeError(origin, "2024-12-31"), "the date is 2024.997");
  EXPECT_MENTIONS(placeError(EnuFrame({ 39.7, -105.2, -5000.0 }), "2026-01-01"), "~altitude",
                  "the point is at -5000.0 m");
  EXPECT_MENTIONS(placeError(std::nullopt, "2026-01-01"), "~latitude and ~longitude",
                  "~sensors/magnetometer/model 'wmm2025'");
}

TEST(SensorParams, LidarClusteringDefaultsOnAndReadsItsKeys)
{
  const SensorsSpec d = parseSensors(nullptr, "~vehicle_sensors/ego", nullptr, "~sensors");
  ASSERT_TRUE(d.suite.lidar && d.suite.lidar->clustering);
  const LidarClusterConfig defaults;
  EXPECT_EQ(d.suite.lidar->clustering->cluster_tolerance, defaults.cluster_tolerance);
  EXPECT_EQ(d.suite.lidar->clustering->ground_clearance, defaults.ground_clearance);
  const XmlRpcValue common = map({ { "lidar", map({ { "clustering", map({ { "cluster_tolerance", 0.8 },
                                                                          { "min_points", 3 },
                                                                          { "max_points", 900 },
                                                                          { "ground_clearance", 0.5 },
                                                                          { "use_height", true },
                                                                          { "ring_link_angle_deg", 20.0 },
                                                                          { "ring_link_gap", 0.7 } }) } }) } });
  const SensorsSpec s = parseSensors(nullptr, "~vehicle_sensors/ego", &common, "~sensors");
  ASSERT_TRUE(s.suite.lidar->clustering);
  EXPECT_EQ(s.suite.lidar->clustering->cluster_tolerance, 0.8);
  EXPECT_EQ(s.suite.lidar->clustering->min_points, 3u);
  EXPECT_EQ(s.suite.lidar->clustering->max_points, 900u);
  EXPECT_EQ(s.suite.lidar->clustering->ground_clearance, 0.5);
  EXPECT_TRUE(s.suite.lidar->clustering->use_height);
  EXPECT_NEAR(s.suite.lidar->clustering->ring_link_angle, 20.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(d.suite.lidar->clustering->ring_link_angle, defaults.ring_link_angle, 1e-12);
  EXPECT_EQ(s.suite.lidar->clustering->ring_link_gap, 0.7);
  EXPECT_EQ(d.suite.lidar->clustering->ring_link_gap, defaults.ring_link_gap);
  const XmlRpcValue ninety = map({ { "lidar", map({ { "clustering", map({ { "ring_link_angle_deg", 90 } }) } }) } });
  EXPECT_EQ(parseSensors(nullptr, "~vehicle_sensors/ego", &ninety, "~sensors").suite.lidar->clustering->ring_link_angle,
            0.5 * M_PI);  // no links
  const XmlRpcValue off = map({ { "lidar", map({ { "clustering", map({ { "enabled", false } }) } }) } });
  const SensorsSpec o = parseSensors(nullptr, "~vehicle_sensors/ego", &off, "~sensors");
  ASSERT_TRUE(o.suite.lidar);
  EXPECT_FALSE(o.suite.lidar->clustering);
}

TEST(Conversions, LidarClustersAndTheirMarkers)
{
  LidarClustering r;
  LidarCluster c;
  c.indices = { 3, 4, 9 };
  c.centroid = Eigen::Vector3d(10.0, 2.0, 1.0);
  c.min = Eigen::Vector3d(9.5, 1.5, 0.3);
  c.max = Eigen::Vector3d(10.5, 2.5, 1.9);
  c.range = std::hypot(10.0, 2.0);
  r.clusters = { c, c };
  r.clusters[1].max = r.clusters[1].min;  // a single point: the marker keeps a visible size
  std_msgs::Header h;
  h.frame_id = "odom";
  h.stamp = ros::Time(4, 0);
  const avsp_msgs::LidarClusterArray a = lidarClusters(r, h);
  EXPECT_EQ(a.header.frame_id, "odom");
  ASSERT_EQ(a.clusters.size(), 2u);
  EXPECT_EQ(a.clusters[0].centroid.x, 10.0);
  EXPECT_EQ(a.clusters[0].min.z, 0.3);
  EXPECT_EQ(a.clusters[0].max.z, 1.9);
  EXPECT_NEAR(a.clusters[0].extent.z, 1.6, 1e-12);
  EXPECT_EQ(a.clusters[0].range, c.range);
  EXPECT_EQ(a.clusters[0].point_count, 3u);
  const visualization_msgs::MarkerArray m = lidarClusterMarkers(r, h);
  ASSERT_EQ(m.markers.size(), 5u);  // DELETEALL, then a box and a label per cluster
  EXPECT_EQ(m.markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(m.markers[1].type, visualization_msgs::Marker::CUBE);
  EXPECT_NEAR(m.markers[1].pose.position.z, 1.1, 1e-12);  // the box's middle, not the centroid
  EXPECT_NEAR(m.markers[1].scale.y, 1.0, 1e-12);
  EXPECT_EQ(m.markers[3].scale.x, 0.1);
  EXPECT_EQ(m.markers[2].type, visualization_msgs::Marker::TEXT_VIEW_FACING);
}
