#include "avsp_sensors/ros/sensor_params.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <stdexcept>

#include <avsp_terrain/ros/node_params.hpp>
#include <ros/names.h>
#include <ros/package.h>

namespace avsp
{
namespace sensors
{
namespace node
{
namespace
{
using avsp::node::StartupError;
using XmlRpc::XmlRpcValue;

const char* typeName(const XmlRpcValue& v)
{
  switch (v.getType())
  {
    case XmlRpcValue::TypeBoolean:
      return "a boolean";
    case XmlRpcValue::TypeInt:
      return "an integer";
    case XmlRpcValue::TypeDouble:
      return "a number";
    case XmlRpcValue::TypeString:
      return "a string";
    case XmlRpcValue::TypeArray:
      return "a list";
    case XmlRpcValue::TypeStruct:
      return "a map";
    default:
      return "an unsupported value";
  }
}

/// A YAML map of parameters (or an absent one: every key takes its default), with typed reads
/// whose errors name the full key.
class Section
{
public:
  Section(const XmlRpcValue* value, std::string path) : path_(std::move(path))
  {
    if (value == nullptr)
      return;
    if (value->getType() != XmlRpcValue::TypeStruct)
      throw StartupError("parameter " + path_ + " must be a map (got " + typeName(*value) + ")");
    value_ = *value;
    present_ = true;
  }

  bool present() const { return present_; }
  const std::string& path() const { return path_; }
  std::string key(const std::string& k) const { return path_ + "/" + k; }
  bool has(const std::string& k) const { return present_ && value_.hasMember(k); }

  /// The raw value of a key that has() says is there.
  XmlRpcValue get(const std::string& k) const { return value_[k]; }

  void allowOnly(const std::vector<std::string>& keys) const
  {
    if (!present_)
      return;
    for (auto it = value_.begin(); it != value_.end(); ++it)
      if (std::find(keys.begin(), keys.end(), it->first) == keys.end())
      {
        std::string known;
        for (const std::string& k : keys)
          known += (known.empty() ? "" : ", ") + k;
        throw StartupError("parameter " + key(it->first) + " is not a known key (known: " + known + ")");
      }
  }

  double number(const std::string& k, double fallback) const
  {
    const std::optional<double> v = optionalNumber(k);
    return v ? *v : fallback;
  }

  std::optional<double> optionalNumber(const std::string& k) const
  {
    if (!has(k))
      return std::nullopt;
    XmlRpcValue v = get(k);
    double value;
    if (v.getType() == XmlRpcValue::TypeInt)
      value = static_cast<int>(v);
    else if (v.getType() == XmlRpcValue::TypeDouble)
      value = static_cast<double>(v);
    else
      throw StartupError("parameter " + key(k) + " must be a number (got " + typeName(v) + ")");
    if (std::isnan(value))
      throw StartupError("parameter " + key(k) + " must not be NaN");
    return value;
  }

  std::size_t count(const std::string& k, std::size_t fallback, std::size_t min, std::size_t max = 1000000) const
  {
    if (!has(k))
      return fallback;
    XmlRpcValue v = get(k);
    if (v.getType() != XmlRpcValue::TypeInt)
      throw StartupError("parameter " + key(k) + " must be an integer (got " + typeName(v) + ")");
    const int value = static_cast<int>(v);
    if (value < 0 || static_cast<std::size_t>(value) < min || static_cast<std::size_t>(value) > max)
      throw StartupError("parameter " + key(k) + " = " + std::to_string(value) + " must be in [" + std::to_string(min) +
                         ", " + std::to_string(max) + "]");
    return static_cast<std::size_t>(value);
  }

  bool flag(const std::string& k, bool fallback) const
  {
    if (!has(k))
      return fallback;
    XmlRpcValue v = get(k);
    if (v.getType() != XmlRpcValue::TypeBoolean)
      throw StartupError("parameter " + key(k) + " must be true or false (got " + typeName(v) + ")");
    return static_cast<bool>(v);
  }

  std::string text(const std::string& k, const std::string& fallback) const
  {
    if (!has(k))
      return fallback;
    XmlRpcValue v = get(k);
    if (v.getType() != XmlRpcValue::TypeString)
      throw StartupError("parameter " + key(k) + " must be a string (got " + typeName(v) + ")");
    return static_cast<std::string>(v);
  }

  /// A URDF link name (no '/', not empty).
  std::string link(const std::string& k, const std::string& fallback) const
  {
    const std::string s = text(k, fallback);
    std::string error;
    if (s.empty() || s.find('/') != std::string::npos || !ros::names::validate(s, error))
      throw StartupError("parameter " + key(k) + " = '" + s + "' must be a URDF link name (a ROS name without '/')");
    return s;
  }

private:
  mutable XmlRpcValue value_;
  std::string path_;
  bool present_ = false;
};

/// Runs a core validation and names the section when it throws.
template <typename F>
void checked(const Section& s, F&& validate)
{
  try
  {
    validate();
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError("parameter " + s.path() + ": " + e.what());
  }
}

/// The section `name` of the vehicle's map if it has it, else of the common map.
Section pick(const Section& vehicle, const Section& common, const std::string& name)
{
  for (const Section* s : { &vehicle, &common })
    if (s->has(name))
    {
      const XmlRpcValue v = s->get(name);
      return Section(&v, s->key(name));
    }
  return Section(nullptr, common.key(name));
}

/// The lidar's `clustering` map (lidar_clustering.hpp): on by default, `enabled: false` removes it.
std::optional<LidarClusterConfig> parseLidarClustering(const Section& lidar)
{
  std::optional<XmlRpcValue> value;
  if (lidar.has("clustering"))
    value = lidar.get("clustering");
  const Section s(value ? &*value : nullptr, lidar.key("clustering"));
  s.allowOnly({ "enabled", "cluster_tolerance", "min_points", "max_points", "ground_clearance", "use_height",
                "cell_size", "ring_link_angle_deg", "ring_link_gap" });
  if (!s.flag("enabled", true))
    return std::nullopt;
  LidarClusterConfig c;
  c.cluster_tolerance = s.number("cluster_tolerance", c.cluster_tolerance);
  c.min_points = s.count("min_points", c.min_points, 1, 100000000);
  c.max_points = s.count("max_points", c.max_points, 1, 100000000);
  c.ground_clearance = s.number("ground_clearance", c.ground_clearance);
  c.use_height = s.flag("use_height", c.use_height);
  c.cell_size = s.number("cell_size", c.cell_size);
  const double link_deg = s.number("ring_link_angle_deg", c.ring_link_angle * 180.0 / M_PI);
  if (!(link_deg > 0.0 && link_deg <= 90.0))
    throw StartupError("parameter " + s.key("ring_link_angle_deg") +
                       " must be in (0, 90] deg (90: no ring links), got " + std::to_string(link_deg));
  c.ring_link_angle = link_deg == 90.0 ? 0.5 * M_PI : link_deg * M_PI / 180.0;
  c.ring_link_gap = s.number("ring_link_gap", c.ring_link_gap);
  checked(s, [&] { validateLidarClusterConfig(c); });
  return c;
}

std::optional<LidarSetup> parseLidar(const Section& s)
{
  s.allowOnly({ "enabled",
                "preset",
                "frame",
                "registered",
                "channels",
                "rotation_rate",
                "columns",
                "clockwise",
                "start_azimuth",
                "min_range",
                "max_range",
                "reference_range",
                "reference_reflectivity",
                "range_noise",
                "dropout",
                "divergence_horizontal",
                "divergence_vertical",
                "aperture_radius",
                "target_scale",
                "sub_rays",
                "return_mode",
                "echo_separation",
                "wavelength",
                "clutter_max_range",
                "clutter_efficiency",
                "clutter_reflectivity",
                "clustering" });
  if (!s.flag("enabled", true))
    return std::nullopt;
  LidarSetup setup;
  LidarConfig& c = setup.config;
  const std::string preset = s.text("preset", "VLP-16");
  if (preset == "custom")
  {
    if (!s.has("channels"))
      throw StartupError("parameter " + s.key("channels") + " is required with preset 'custom'");
  }
  else
  {
    if (s.has("channels"))
      throw StartupError("parameter " + s.key("channels") + " is only for preset 'custom' (preset is '" + preset +
                         "')");
    try
    {
      c = lidarPreset(preset);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError("parameter " + s.key("preset") + ": " + e.what());
    }
  }
  if (s.has("channels"))
  {
    XmlRpcValue list = s.get("channels");
    if (list.getType() != XmlRpcValue::TypeArray || list.size() == 0)
      throw StartupError("parameter " + s.key("channels") +
                         " must be a non-empty list of {elevation, azimuth_offset, time_offset}");
    for (int k = 0; k < list.size(); ++k)
    {
      const Section ch(&list[k], s.key("channels") + "[" + std::to_string(k) + "]");
      ch.allowOnly({ "elevation", "azimuth_offset", "time_offset" });
      if (!ch.has("elevation"))
        throw StartupError("parameter " + ch.key("elevation") + " is required (rad)");
      c.channels.push_back(
          { ch.number("elevation", 0.0), ch.number("azimuth_offset", 0.0), ch.number("time_offset", 0.0) });
    }
  }
  setup.registered = s.flag("registered", true);
  c.rotation_rate = s.number("rotation_rate", c.rotation_rate);
  c.columns = s.count("columns", c.columns, 1);
  c.clockwise = s.flag("clockwise", c.clockwise);
  c.start_azimuth = s.number("start_azimuth", c.start_azimuth);
  c.min_range = s.number("min_range", c.min_range);
  c.max_range = s.number("max_range", c.max_range);
  c.reference_range = s.number("reference_range", c.reference_range);
  c.reference_reflectivity = s.number("reference_reflectivity", c.reference_reflectivity);
  c.range_noise = s.number("range_noise", c.range_noise);
  c.dropout = s.number("dropout", c.dropout);
  c.divergence_horizontal = s.number("divergence_horizontal", c.divergence_horizontal);
  c.divergence_vertical = s.number("divergence_vertical", c.divergence_vertical);
  c.aperture_radius = s.number("aperture_radius", c.aperture_radius);
  c.target_scale = s.number("target_scale", c.target_scale);
  c.sub_rays = s.count("sub_rays", c.sub_rays, 0, 1024);
  const std::string mode = s.text("return_mode", c.return_mode == ReturnMode::kLast ? "last" : "strongest");
  if (mode == "strongest")
    c.return_mode = ReturnMode::kStrongest;
  else if (mode == "last")
    c.return_mode = ReturnMode::kLast;
  else
    throw StartupError("parameter " + s.key("return_mode") + " = '" + mode + "' must be 'strongest' or 'last'");
  c.echo_separation = s.number("echo_separation", c.echo_separation);
  c.wavelength = s.number("wavelength", c.wavelength);
  c.clutter_max_range = s.number("clutter_max_range", c.clutter_max_range);
  c.clutter_efficiency = s.number("clutter_efficiency", c.clutter_efficiency);
  c.clutter_reflectivity = static_cast<float>(s.number("clutter_reflectivity", c.clutter_reflectivity));
  checked(s, [&] { validateLidarConfig(c); });
  setup.clustering = parseLidarClustering(s);
  // A sweep's rays are cast at once: bound the work of one sweep (HDL-64E: 133,312 pulses).
  if (static_cast<double>(c.columns) * static_cast<double>(c.channels.size()) > 4e6)
    throw StartupError("parameter " + s.key("columns") + ": columns x channels must be <= 4,000,000 pulses per sweep");
  return setup;
}

std::optional<RadarSetup> parseRadar(const Section& s)
{
  s.allowOnly({ "enabled", "frame", "rate", "horizontal_fov", "vertical_fov", "azimuth_rays", "elevation_rays",
                "min_range", "max_range", "range_noise", "range_rate_noise", "terrain_returns", "cluster_eps",
                "cluster_min_points" });
  if (!s.flag("enabled", true))
    return std::nullopt;
  RadarSetup setup;
  RadarConfig& c = setup.config;
  setup.rate = s.number("rate", setup.rate);
  c.horizontal_fov = s.number("horizontal_fov", c.horizontal_fov);
  c.vertical_fov = s.number("vertical_fov", c.vertical_fov);
  c.azimuth_rays = s.count("azimuth_rays", c.azimuth_rays, 1, 100000);
  c.elevation_rays = s.count("elevation_rays", c.elevation_rays, 1, 100000);
  c.min_range = s.number("min_range", c.min_range);
  c.max_range = s.number("max_range", c.max_range);
  c.range_noise = s.number("range_noise", c.range_noise);
  c.range_rate_noise = s.number("range_rate_noise", c.range_rate_noise);
  c.terrain_returns = s.flag("terrain_returns", c.terrain_returns);
  c.cluster_eps = s.number("cluster_eps", c.cluster_eps);
  c.cluster_min_points = s.count("cluster_min_points", c.cluster_min_points, 1);
  checked(s, [&] {
    validateRadarConfig(c);
    check::positive("RadarSetup", "rate", setup.rate);
  });
  if (c.azimuth_rays * c.elevation_rays > 1000000)
    throw StartupError("parameter " + s.key("azimuth_rays") + ": azimuth_rays x elevation_rays must be <= 1,000,000");
  return setup;
}

std::optional<GpsSetup> parseGps(const Section& s)
{
  s.allowOnly({ "enabled", "frame", "rate", "horizontal_noise", "vertical_noise", "horizontal_bias_sigma",
                "vertical_bias_sigma", "bias_time_constant" });
  if (!s.flag("enabled", true))
    return std::nullopt;
  GpsSetup setup;
  GpsConfig& c = setup.config;
  c.rate = s.number("rate", c.rate);
  c.horizontal_noise = s.number("horizontal_noise", c.horizontal_noise);
  c.vertical_noise = s.number("vertical_noise", c.vertical_noise);
  c.horizontal_bias_sigma = s.number("horizontal_bias_sigma", c.horizontal_bias_sigma);
  c.vertical_bias_sigma = s.number("vertical_bias_sigma", c.vertical_bias_sigma);
  c.bias_time_constant = s.number("bias_time_constant", c.bias_time_constant);
  checked(s, [&] { validateGpsConfig(c); });
  return setup;
}

std::optional<ImuConfig> parseImu(const Section& s)
{
  s.allowOnly({ "enabled", "frame", "rate", "gyro_noise_density", "gyro_random_walk", "accel_noise_density",
                "accel_random_walk", "gyro_turn_on_bias", "accel_turn_on_bias", "orientation_noise", "gravity" });
  if (!s.flag("enabled", true))
    return std::nullopt;
  ImuConfig c;
  c.rate = s.number("rate", c.rate);
  c.gyro_noise_density = s.number("gyro_noise_density", c.gyro_noise_density);
  c.gyro_random_walk = s.number("gyro_random_walk", c.gyro_random_walk);
  c.accel_noise_density = s.number("accel_noise_density", c.accel_noise_density);
  c.accel_random_walk = s.number("accel_random_walk", c.accel_random_walk);
  c.gyro_turn_on_bias = s.number("gyro_turn_on_bias", c.gyro_turn_on_bias);
  c.accel_turn_on_bias = s.number("accel_turn_on_bias", c.accel_turn_on_bias);
  c.orientation_noise = s.number("orientation_noise", c.orientation_noise);
  c.gravity = s.number("gravity", c.gravity);
  checked(s, [&] { validateImuConfig(c); });
  return c;
}

/// The file of a magnetometer's `model`: a name in avsp_sensors/data/magnetic/, or a path.
std::string magneticModelFile(const Section& s, const std::string& model)
{
  if (model.find('/') != std::string::npos)
    return model;
  const std::string package = ros::package::getPath("avsp_sensors");
  if (package.empty())
    throw StartupError("parameter " + s.key("model") + " = '" + model +
                       "': rospack does not find the package avsp_sensors (ROS_PACKAGE_PATH) whose data/magnetic/ "
                       "holds the named models; give the path of the .wmm file");
  return package + "/data/magnetic/" + model + ".wmm";
}

std::optional<MagnetometerConfig> parseMagnetometer(const Section& s, SensorsSpec& spec)
{
  s.allowOnly({ "enabled", "frame", "rate", "model", "intensity", "inclination_deg", "declination_deg", "noise" });
  if (!s.flag("enabled", true))
    return std::nullopt;
  MagnetometerConfig c;
  c.rate = s.number("rate", c.rate);
  c.noise = s.number("noise", c.noise);
  const std::string model = s.text("model", "wmm2025");
  const char* elements[] = { "intensity", "inclination_deg", "declination_deg" };
  if (model == "fixed")
  {
    // A fixed field is the user's statement of the site's field: all three elements, no defaults.
    for (const char* k : elements)
      if (!s.has(k))
        throw StartupError("parameter " + s.key(k) +
                           " is required with model 'fixed' (the site's field: intensity T, "
                           "inclination_deg and declination_deg deg)");
    c.field.intensity = s.number("intensity", 0.0);
    c.field.inclination_deg = s.number("inclination_deg", 0.0);
    c.field.declination_deg = s.number("declination_deg", 0.0);
  }
  else
  {
    for (const char* k : elements)
      if (s.has(k))
        throw StartupError("parameter " + s.key(k) + " is only read with model 'fixed' (model '" + model +
                           "' gives the field)");
    if (model.empty())
      throw StartupError("parameter " + s.key("model") +
                         " must be 'fixed', a model name in avsp_sensors/data/magnetic (wmm2025) or a .wmm file");
    try
    {
      spec.magnetometer_model.emplace(magneticModelFile(s, model));
    }
    catch (const GeomagneticModelError& e)
    {
      throw StartupError("parameter " + s.key("model") + " = '" + model + "': " + e.what());
    }
  }
  checked(s, [&] { validateMagnetometerConfig(c); });
  return c;
}

void parseUltrasonics(const Section& parent, const std::string& name, SensorsSpec& spec)
{
  if (!parent.has(name))
    return;
  XmlRpcValue list = parent.get(name);
  const std::string path = parent.key(name);
  if (list.getType() != XmlRpcValue::TypeArray)
    throw StartupError("parameter " + path + " must be a list of {name, ...} (got " + typeName(list) + ")");
  std::set<std::string> names;
  for (int k = 0; k < list.size(); ++k)
  {
    const Section s(&list[k], path + "[" + std::to_string(k) + "]");
    s.allowOnly({ "name", "x", "y", "z", "roll", "pitch", "yaw", "rate", "field_of_view", "min_range", "max_range",
                  "noise", "rings", "rays_per_ring" });
    if (!s.has("name"))
      throw StartupError("parameter " + s.key("name") + " is required (the sensor's frame is <vehicle>/<name>)");
    UltrasonicSetup u;
    u.name = s.link("name", "");
    if (!names.insert(u.name).second)
      throw StartupError("parameter " + s.key("name") + " = '" + u.name + "' is used twice");
    UltrasonicConfig& c = u.config;
    c.rate = s.number("rate", c.rate);
    c.field_of_view = s.number("field_of_view", c.field_of_view);
    c.min_range = s.number("min_range", c.min_range);
    c.max_range = s.number("max_range", c.max_range);
    c.noise = s.number("noise", c.noise);
    c.rings = s.count("rings", c.rings, 1, 1000);
    c.rays_per_ring = s.count("rays_per_ring", c.rays_per_ring, 3, 1000);
    checked(s, [&] { validateUltrasonicConfig(c); });
    UltrasonicMount mount;
    bool posed = false;
    for (const char* key : { "x", "y", "z", "roll", "pitch", "yaw" })
      posed = posed || s.has(key);
    if (posed)
    {
      const Eigen::Vector3d xyz(s.number("x", 0.0), s.number("y", 0.0), s.number("z", 0.0));
      const double roll = s.number("roll", 0.0), pitch = s.number("pitch", 0.0), yaw = s.number("yaw", 0.0);
      for (double value : { xyz.x(), xyz.y(), xyz.z(), roll, pitch, yaw })
        if (!std::isfinite(value))
          throw StartupError("parameter " + s.path() + ": x, y, z, roll, pitch, yaw must be finite");
      // URDF's rpy: fixed-axis roll about x, then pitch about y, then yaw about z.
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() = xyz;
      pose.linear() =
          (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
              .toRotationMatrix();
      mount.pose = pose;
    }
    spec.suite.ultrasonics.push_back(u);
    spec.ultrasonic_mounts.push_back(mount);
  }
}

/// The `cameras` list: one CameraConfig per entry (two for a stereo pair).
/// cameras[k].outputs: which images the camera makes (all when absent).
void parseCameraOutputs(const Section& s, CameraConfig& c)
{
  if (!s.has("outputs"))
    return;
  XmlRpcValue outputs = s.get("outputs");
  if (outputs.getType() != XmlRpcValue::TypeArray || outputs.size() == 0)
    throw StartupError("parameter " + s.key("outputs") + " must be a non-empty list of rgb, depth, semantic, thermal");
  c.rgb = c.depth = c.semantic = c.thermal = false;
  for (int o = 0; o < outputs.size(); ++o)
  {
    const std::string out = outputs[o].getType() == XmlRpcValue::TypeString ? static_cast<std::string>(outputs[o]) : "";
    if (out == "rgb")
      c.rgb = true;
    else if (out == "depth")
      c.depth = true;
    else if (out == "semantic")
      c.semantic = true;
    else if (out == "thermal")
      c.thermal = true;
    else
      throw StartupError("parameter " + s.key("outputs") + "[" + std::to_string(o) +
                         "] must be one of rgb, depth, "
                         "semantic, thermal");
  }
}

/// cameras[k].distortion: plumb_bob k1, k2, p1, p2, k3 (none when absent).
void parseCameraDistortion(const Section& s, CameraConfig& c)
{
  if (!s.has("distortion"))
    return;
  XmlRpcValue d = s.get("distortion");
  if (d.getType() != XmlRpcValue::TypeArray || d.size() != 5)
    throw StartupError("parameter " + s.key("distortion") +
                       " must be a list of 5 numbers (plumb_bob k1, k2, p1, "
                       "p2, k3)");
  for (int i = 0; i < 5; ++i)
  {
    if (d[i].getType() == XmlRpcValue::TypeInt)
      c.distortion[i] = static_cast<int>(d[i]);
    else if (d[i].getType() == XmlRpcValue::TypeDouble)
      c.distortion[i] = static_cast<double>(d[i]);
    else
      throw StartupError("parameter " + s.key("distortion") + "[" + std::to_string(i) + "] must be a number");
  }
}

/// cameras[k].x, y, z, roll, pitch, yaw: the mount on the vehicle (URDF's rpy).
Eigen::Isometry3d parseCameraMount(const Section& s)
{
  const Eigen::Vector3d xyz(s.number("x", 0.0), s.number("y", 0.0), s.number("z", 0.0));
  const double roll = s.number("roll", 0.0), pitch = s.number("pitch", 0.0), yaw = s.number("yaw", 0.0);
  for (double value : { xyz.x(), xyz.y(), xyz.z(), roll, pitch, yaw })
    if (!std::isfinite(value))
      throw StartupError("parameter " + s.path() + ": x, y, z, roll, pitch, yaw must be finite");
  // URDF's rpy: fixed-axis roll about x, then pitch about y, then yaw about z.
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.translation() = xyz;
  mount.linear() =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  return mount;
}

/// One entry of a cameras list (a stereo pair still as one camera).
CameraConfig parseCamera(const Section& s)
{
  s.allowOnly({ "name",
                "projection",
                "width",
                "height",
                "hfov_deg",
                "rate",
                "x",
                "y",
                "z",
                "roll",
                "pitch",
                "yaw",
                "outputs",
                "distortion",
                "stereo_baseline",
                "max_range",
                "shadows",
                "shadow_range",
                "min_exposure_lux",
                "sky_gain",
                "fog_contrast_threshold",
                "thermal_min",
                "thermal_max",
                "precipitation" });
  if (!s.has("name"))
    throw StartupError("parameter " + s.key("name") +
                       " is required (topics <vehicle>/<name>/..., frame "
                       "<vehicle>/<name>_optical)");
  CameraConfig c;
  c.name = s.link("name", "");
  const std::string projection = s.text("projection", "pinhole");
  if (projection == "pinhole")
    c.projection = CameraProjection::kPinhole;
  else if (projection == "fisheye")
    c.projection = CameraProjection::kFisheye;
  else
    throw StartupError("parameter " + s.key("projection") + " = '" + projection +
                       "' must be 'pinhole' or 'fisheye' (equidistant)");
  c.width = static_cast<int>(s.count("width", static_cast<std::size_t>(c.width), 1, 8192));
  c.height = static_cast<int>(s.count("height", static_cast<std::size_t>(c.height), 1, 8192));
  c.hfov = s.number("hfov_deg", c.hfov * 180.0 / M_PI) * M_PI / 180.0;
  c.rate = s.number("rate", c.rate);
  c.max_range = s.number("max_range", c.max_range);
  c.shadows = s.flag("shadows", c.shadows);
  c.shadow_range = s.number("shadow_range", c.shadow_range);
  c.min_exposure_lux = s.number("min_exposure_lux", c.min_exposure_lux);
  c.sky_gain = s.number("sky_gain", c.sky_gain);
  c.fog_contrast_threshold = s.number("fog_contrast_threshold", c.fog_contrast_threshold);
  c.thermal_min = s.number("thermal_min", c.thermal_min);
  c.thermal_max = s.number("thermal_max", c.thermal_max);
  c.precipitation = s.flag("precipitation", c.precipitation);
  parseCameraOutputs(s, c);
  parseCameraDistortion(s, c);
  c.mount = parseCameraMount(s);
  return c;
}

void parseCameras(const Section& parent, const std::string& name, SensorsSpec& spec)
{
  if (!parent.has(name))
    return;
  XmlRpcValue list = parent.get(name);
  const std::string path = parent.key(name);
  if (list.getType() != XmlRpcValue::TypeArray)
    throw StartupError("parameter " + path + " must be a list of {name, ...} (got " + typeName(list) + ")");
  std::set<std::string> names;
  for (int k = 0; k < list.size(); ++k)
  {
    const Section s(&list[k], path + "[" + std::to_string(k) + "]");
    CameraConfig c = parseCamera(s);
    const double baseline = s.number("stereo_baseline", 0.0);
    if (!(baseline >= 0.0 && std::isfinite(baseline)))
      throw StartupError("parameter " + s.key("stereo_baseline") + " must be finite and >= 0 m (0: monocular)");
    std::vector<CameraConfig> made;
    if (baseline > 0.0)
    {
      // A pair: <name>/left at the mount, <name>/right baseline to its right (camera -y); the
      // topics <name>/left/image_raw ... are what stereo_image_proc in namespace <name> reads.
      CameraConfig left = c, right = c;
      left.name = c.name + "/left";
      right.name = c.name + "/right";
      right.mount.translation() = c.mount * Eigen::Vector3d(0.0, -baseline, 0.0);
      right.stereo_tx = -baseline;
      made = { left, right };
    }
    else
      made = { c };
    for (const CameraConfig& m : made)
    {
      if (!names.insert(m.name).second)
        throw StartupError("parameter " + s.key("name") + " = '" + m.name + "' is used twice");
      checked(s, [&] { validateCameraConfig(m); });
      spec.cameras.push_back(m);
    }
  }
}

std::optional<OccupancySetup> parseOccupancy(const Section& s, bool has_lidar)
{
  s.allowOnly({ "enabled", "resolution", "max_range", "prob_hit", "prob_miss", "clamping_min", "clamping_max",
                "occupancy_threshold", "discretize", "voxel_filter", "slices", "publish_rate", "grid_size",
                "grid_resolution", "obstacle_height", "max_height", "min_height", "free_max_height" });
  // Without a lidar there is nothing to build the map from: off unless asked for explicitly.
  if (!s.flag("enabled", has_lidar))
    return std::nullopt;
  if (!has_lidar)
    throw StartupError("parameter " + s.key("enabled") + ": the occupancy map needs a lidar (lidar is disabled)");
  OccupancySetup o;
  OccupancyConfig& c = o.config;
  c.resolution = s.number("resolution", c.resolution);
  c.max_range = s.number("max_range", c.max_range);
  c.prob_hit = s.number("prob_hit", c.prob_hit);
  c.prob_miss = s.number("prob_miss", c.prob_miss);
  c.clamping_min = s.number("clamping_min", c.clamping_min);
  c.clamping_max = s.number("clamping_max", c.clamping_max);
  c.occupancy_threshold = s.number("occupancy_threshold", c.occupancy_threshold);
  c.discretize = s.flag("discretize", c.discretize);
  c.voxel_filter = s.flag("voxel_filter", c.voxel_filter);
  o.slices = s.count("slices", o.slices, 1, 1000);
  o.publish_rate = s.number("publish_rate", o.publish_rate);
  o.grid_size = s.number("grid_size", o.grid_size);
  GridProjection& g = o.projection;
  g.resolution = s.number("grid_resolution", 0.0);
  g.obstacle_height = s.number("obstacle_height", g.obstacle_height);
  g.max_height = s.number("max_height", g.max_height);
  g.min_height = s.number("min_height", g.min_height);
  g.free_max_height = s.number("free_max_height", g.free_max_height);
  checked(s, [&] {
    validateOccupancyConfig(c);
    SuiteConfig probe;  // the suite's own checks of the occupancy section
    probe.lidar.emplace();
    probe.lidar->config = lidarPreset("VLP-16");
    probe.occupancy = o;
    validateSuiteConfig(probe);
  });
  return o;
}
}  // namespace

std::vector<VehicleEntry> parseVehicles(const XmlRpc::XmlRpcValue& list)
{
  int offset = 0;
  XmlRpcValue tree("<value><struct></struct></value>", &offset);
  tree["vehicles"] = list;
  std::vector<VehicleEntry> out;
  for (const avsp::node::VehicleListEntry& e : avsp::node::vehicleListParam(
           avsp::node::ParamSource(tree), true, { "name", "model", "x", "y", "yaw" }, "{name, model}"))
    out.push_back({ e.name, e.model });
  return out;
}

SensorsSpec parseSensors(const XmlRpc::XmlRpcValue* vehicle, const std::string& vehicle_path,
                         const XmlRpc::XmlRpcValue* common, const std::string& common_path)
{
  const Section v(vehicle, vehicle_path), c(common, common_path);
  const std::vector<std::string> sections{ "lidar",        "radar",      "gps",       "imu",
                                           "magnetometer", "ultrasonic", "occupancy", "cameras" };
  v.allowOnly(sections);
  c.allowOnly(sections);

  SensorsSpec spec;
  const Section lidar = pick(v, c, "lidar");
  for (const std::string& name : sections)
    spec.keys[name] = (v.has(name) ? v : c).key(name);
  spec.suite.lidar = parseLidar(lidar);
  spec.lidar_link = lidar.link("frame", spec.lidar_link);
  const Section radar = pick(v, c, "radar");
  spec.suite.radar = parseRadar(radar);
  spec.radar_link = radar.link("frame", spec.radar_link);
  const Section gps = pick(v, c, "gps");
  spec.suite.gps = parseGps(gps);
  spec.gps_link = gps.link("frame", spec.gps_link);
  const Section imu = pick(v, c, "imu");
  spec.suite.imu = parseImu(imu);
  spec.imu_link = imu.link("frame", spec.imu_link);
  const Section mag = pick(v, c, "magnetometer");
  spec.suite.magnetometer = parseMagnetometer(mag, spec);
  spec.magnetometer_link = mag.link("frame", spec.magnetometer_link);
  parseUltrasonics(v.has("ultrasonic") ? v : c, "ultrasonic", spec);
  parseCameras(v.has("cameras") ? v : c, "cameras", spec);
  spec.suite.occupancy = parseOccupancy(pick(v, c, "occupancy"), spec.suite.lidar.has_value());
  return spec;
}

bool needsOrigin(const std::vector<SensorsSpec>& specs)
{
  for (const SensorsSpec& s : specs)
    if (s.suite.gps || (s.suite.magnetometer && s.magnetometer_model))
      return true;
  return false;
}

std::string placeMagnetometers(std::vector<SensorsSpec>& specs, const std::optional<EnuFrame>& origin,
                               const std::string& date)
{
  std::string summary;
  std::optional<double> year;
  for (SensorsSpec& spec : specs)
  {
    if (!spec.suite.magnetometer || !spec.magnetometer_model)
      continue;
    const std::string model_key = spec.keys.at("magnetometer") + "/model";
    const std::string name = spec.magnetometer_model->name();
    if (!origin)
      throw StartupError("parameters ~latitude and ~longitude are required by " + model_key + " '" + name + "'");
    if (!year)
    {
      if (date.empty())
        throw StartupError("parameter ~date (the run's date, YYYY-MM-DD, or a decimal year) is required by " +
                           model_key + " '" + name + "' (or set model: fixed with the site's field)");
      try
      {
        year = decimalYear(date);
      }
      catch (const GeomagneticModelError& e)
      {
        throw StartupError("parameter ~" + std::string(e.what()));
      }
    }
    try
    {
      spec.suite.magnetometer->model.emplace(*spec.magnetometer_model, *origin, *year);
    }
    catch (const GeomagneticModelError& e)
    {
      throw StartupError(model_key + " '" + name + "' on ~date '" + date + "' at the map origin (~latitude, " +
                         "~longitude, ~altitude): " + e.what());
    }
    if (summary.empty())
    {
      const EarthField f = earthFieldFromEnu(spec.suite.magnetometer->model->at(Eigen::Vector3d::Zero()));
      char text[200];
      std::snprintf(text, sizeof text, "%s on %s (%.3f) at the map origin: F %.2f uT, I %.2f deg, D %.2f deg",
                    spec.magnetometer_model->description().c_str(), date.c_str(), *year, f.intensity * 1e6,
                    f.inclination_deg, f.declination_deg);
      summary = text;
    }
  }
  return summary;
}

void mountSensors(SensorsSpec& spec, const VehicleFrames& frames, const std::string& where)
{
  auto mount = [&](const std::string& link, const std::string& key) {
    if (!frames.hasLink(link))
      throw StartupError(where + ": parameter " + key + " = '" + link + "' is not a link of " + frames.urdf_path);
    return frames.link(link);
  };
  SuiteConfig& suite = spec.suite;
  if (suite.lidar)
    suite.lidar->mount = mount(spec.lidar_link, spec.keys.at("lidar") + "/frame");
  if (suite.radar)
    suite.radar->mount = mount(spec.radar_link, spec.keys.at("radar") + "/frame");
  if (suite.gps)
    suite.gps->mount = mount(spec.gps_link, spec.keys.at("gps") + "/frame");
  if (suite.imu)
    suite.imu->mount = mount(spec.imu_link, spec.keys.at("imu") + "/frame");
  if (suite.magnetometer)
    suite.magnetometer->mount = mount(spec.magnetometer_link, spec.keys.at("magnetometer") + "/frame");
  for (std::size_t k = 0; k < suite.ultrasonics.size(); ++k)
  {
    const std::string& name = suite.ultrasonics[k].name;
    const std::optional<Eigen::Isometry3d>& pose = spec.ultrasonic_mounts[k].pose;
    if (pose && frames.hasLink(name))
      throw StartupError(where + ": ultrasonic '" + name + "' has x/y/z/roll/pitch/yaw but " + frames.urdf_path +
                         " has a link '" + name + "' already: use one or the other");
    if (!pose && !frames.hasLink(name))
      throw StartupError(where + ": ultrasonic '" + name + "': " + frames.urdf_path + " has no link '" + name +
                         "'; give its x, y, z, roll, pitch, yaw in base_link");
    suite.ultrasonics[k].mount = pose ? *pose : frames.link(name);
  }
}

}  // namespace node
}  // namespace sensors
}  // namespace avsp
