// sensors_node's class (the node's main is ../sensors_node.cpp): the sensors of one or more
// vehicles over the shared terrain. Per vehicle, from
// its odometry: lidar sweeps (avt_341/points), radar targets and points, GPS fixes, IMU and
// magnetometer samples, ultrasonic ranges, and its OctoMap (octomap/occupied_cells,
// occupancy/grid, ~<vehicle>/save_map; never avt_341/occupancy_grid: that topic is the AVT-341
// stack's perception output, which its planners read). The ray-cast scene is kept current from
// /terrain/ruts, /terrain/toppled and the other vehicles' poses; the lidar's weather from
// /environment.
//
// Thin: the sensors, their schedules and the merge of the vehicles' odometry streams are
// avsp_sensors_core (sensor_suite.hpp); parameters and messages are converted in src/ros/.
// Parameters and topics: README.md, "sensors_node".
//
// Time. Everything runs on the odometry's stamps (sim time): each sensor samples on its own
// grid of sim times at the first odometry at or after each grid time, so a run depends on the
// odometry only, not on when messages arrive. The vehicles' streams are merged in stamp order
// (StateSynchronizer) so that every vehicle's sensors see the others at the same time; the
// callbacks only queue states, the main loop senses the times that are complete.
#include "avsp_sensors/ros/sensors_node.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <avsp_msgs/AddSensedVehicle.h>
#include <avsp_msgs/Environment.h>
#include <avsp_msgs/LidarClusterArray.h>
#include <avsp_msgs/ObjectToppled.h>
#include <avsp_msgs/RemoveSensedVehicle.h>
#include <avsp_msgs/SaveMap.h>
#include <avsp_msgs/StepDone.h>
#include <avsp_msgs/TerrainPatch.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_transport/image_transport.h>
#include <ros/callback_queue.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <avsp_terrain/geodetic_reference.hpp>
#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/agent_params.hpp>
#include <avsp_terrain/ros/conversions.hpp>
#include <avsp_terrain/ros/input_diagnostics.hpp>
#include <avsp_terrain/ros/output_folder_params.hpp>
#include <avsp_terrain/soil.hpp>
#include <avsp_terrain/ros/terrain_source_params.hpp>

#include "avsp_sensors/camera_rig.hpp"
#include "avsp_sensors/parallel.hpp"
#include "avsp_sensors/agent_bodies.hpp"
#include "avsp_sensors/random.hpp"
#include "avsp_sensors/ros/camera_conversions.hpp"
#include "avsp_sensors/ros/conversions.hpp"
#include "avsp_sensors/ros/sensor_params.hpp"
#include "avsp_sensors/ros/vehicle_frames.hpp"
#include "avsp_sensors/sensor_suite.hpp"
#include "avsp_sensors/terrain_patch.hpp"

namespace avsp
{
namespace sensors
{
namespace node
{
namespace as = avsp::sensors;
namespace asn = avsp::sensors::node;
namespace at = avsp::terrain;

namespace
{
using avsp::node::boundedIntParam;
using avsp::node::boundedParam;
using avsp::node::StartupError;

/// FNV-1a of a vehicle name: its sensors' seeds do not depend on its place in ~vehicles.
std::uint64_t nameHash(const std::string& s)
{
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s)
    h = (h ^ c) * 1099511628211ull;
  return h;
}

/**
 * @brief A warning at most once per `period` s of wall time per call site and subject (the
 *        format string with its first argument, e.g. the topic), the first one always; the
 *        repeats it swallowed are counted in the next one. ROS_WARN_THROTTLE counts sim time and
 *        drops everything in the first period after time 0 (its last-hit time starts at 0).
 */
void warnThrottled(double period, const char* format, ...) __attribute__((format(printf, 2, 3)));
void warnThrottled(double period, const char* format, ...)
{
  char text[2048];
  va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof(text), format, args);
  va_end(args);
  struct Seen
  {
    ros::WallTime last;
    unsigned swallowed = 0;
  };
  static std::map<std::string, Seen> seen;
  // The subject: the format and the text up to its first ':' (the topic or vehicle).
  const std::string message(text);
  Seen& s = seen[std::string(format) + "|" + message.substr(0, message.find(':', 14))];
  const ros::WallTime now = ros::WallTime::now();
  if (!s.last.isZero() && (now - s.last).toSec() < period)
  {
    ++s.swallowed;
    return;
  }
  if (s.swallowed > 0)
    ROS_WARN("%s (and %u more like it since the last report)", text, s.swallowed);
  else
    ROS_WARN("%s", text);
  s.last = now;
  s.swallowed = 0;
}

/// One vehicle's ROS side.
struct VehicleIo
{
  std::string name;
  std::size_t index = 0;
  std::unique_ptr<as::VehicleSensors> sensors;
  std::vector<as::BodyBox> boxes;
  std::string odom_topic, base_frame;
  /// Frame of its odometry, registered clouds, clusters and maps: ~world_frame, or <v>/odom with
  /// ~per_vehicle_odom_frames (each an identity child of map).
  std::string world_frame;
  double last_stamp = -1.0;  ///< s, the last state queued (an equal stamp is a re-send)
  double sensed = 0.0;       ///< s, the time of the last state sensed (/diagnostics' lag)
  std::uint64_t states_sensed = 0;
  std::uint64_t odometry_ignored = 0;  ///< bad, repeated-back or late odometry messages
  std::uint64_t ignored_reported = 0;  ///< `odometry_ignored` at the last diagnostics publication
  std::uint64_t waited_out = 0;        ///< times the others went on without it (~odometry_timeout)
  bool removing = false;               ///< ~remove_vehicle came: sensed up to its last state, then closed
  bool removed = false;                ///< closed: no subscriber, no publisher
  std::string lidar_frame, radar_frame, gps_frame, imu_frame, mag_frame;
  std::vector<std::string> range_frames;
  ros::Subscriber odom_sub;
  ros::Publisher points_pub, targets_pub, radar_points_pub, radar_markers_pub, gps_pub, imu_pub, mag_pub;
  ros::Publisher cells_pub, grid_pub;
  ros::Publisher clusters_pub, cluster_markers_pub;  ///< lidar/clusters, lidar/cluster_markers
  std::vector<ros::Publisher> range_pubs;
  ros::ServiceServer save_service;

  /// Wall time spent, s, and counts, for the cost report at shutdown.
  struct Costs
  {
    std::size_t sweeps = 0, radar_scans = 0, states = 0, maps = 0;
    double lidar = 0.0, occupancy = 0.0, cloud = 0.0, radar = 0.0, other = 0.0, map_products = 0.0;
    std::size_t clusterings = 0;
    double clustering = 0.0;  ///< ground removal + clustering + messages, per clustered sweep
  } costs;

  // Cameras (README, "Cameras"): the rig, and per camera its publishers and optical frame.
  struct CameraIo
  {
    std::string frame;  ///< <vehicle>/<camera>_optical (a stereo half: <vehicle>/<pair>_left_optical)
    image_transport::Publisher rgb, depth, semantic, thermal;
    ros::Publisher info;
  };
  std::unique_ptr<as::CameraRig> camera_rig;
  std::unique_ptr<image_transport::ImageTransport> image_transport;
  std::vector<CameraIo> camera_io;
  ros::Publisher classes_pub;
  std::size_t camera_frames = 0;
  double camera_cost = 0.0;  ///< wall s rendering + converting
};

}  // namespace

class SensorsNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh) : nh_(nh), pnh_(pnh)
  {
    XmlRpc::XmlRpcValue list;
    if (!avsp::node::structuredParam(pnh_, "vehicles", list))
      throw StartupError("parameter ~vehicles must be a non-empty list of {name, model}");
    const std::vector<asn::VehicleEntry> entries = asn::parseVehicles(list);
    std::vector<asn::SensorsSpec> specs = readSensorSpecs(entries);

    world_frame_ = avsp::node::stringParam(pnh_, "world_frame", "odom");
    if (world_frame_.empty())
      throw StartupError("parameter ~world_frame must not be empty");
    per_vehicle_odom_frames_ = avsp::node::boolParam(pnh_, "per_vehicle_odom_frames", false);
    if (per_vehicle_odom_frames_ && pnh_.hasParam("world_frame"))
      throw StartupError(
          "parameters ~world_frame and ~per_vehicle_odom_frames exclude each other (the latter puts "
          "each vehicle in <v>/odom)");
    const int seed = avsp::node::runIntParam(pnh_, avsp::terrain::kRunSeed);
    threads_ = static_cast<unsigned>(boundedIntParam(pnh_, "threads", 0, 0, 256));
    const double timeout = boundedParam(pnh_, "odometry_timeout", 1.0, 0.0, 3600.0);
    max_lag_ = boundedParam(pnh_, "max_lag", 1.0, 0.0, 3600.0);
    // Validated here; diagnostic_updater reads the same parameter itself.
    boundedParam(pnh_, "diagnostic_period", 1.0, 0.01, 3600.0);
    const float body_reflectivity = static_cast<float>(boundedParam(pnh_, "body_reflectivity", 0.5, 0.0, 1.0));
    body_reflectivity_ = body_reflectivity;
    const std::optional<as::EnuFrame> origin = readOrigin(asn::needsOrigin(specs));
    date_ = avsp::node::stringParam(pnh_, "date", "");
    const std::string magnetic = asn::placeMagnetometers(specs, origin, date_);
    if (!magnetic.empty())
      ROS_INFO("sensors_node: magnetometer field: %s", magnetic.c_str());

    const std::string config_dir =
        avsp::node::stringParam(pnh_, "config_dir", ros::package::getPath("avsp") + "/config/vehicles");
    const std::string soils_file =
        avsp::node::stringParam(pnh_, "soils_file", ros::package::getPath("avsp") + "/config/soils.yaml");

    origin_ = origin;
    config_dir_ = config_dir;
    seed_ = static_cast<std::uint64_t>(seed);
    // Vehicles: their descriptions give the mounts and the bodies others see.
    for (std::size_t k = 0; k < entries.size(); ++k)
      vehicles_.push_back(makeVehicle(entries[k], specs[k], k, config_dir, origin, static_cast<std::uint64_t>(seed)));

    loadScene(soils_file);
    sync_ = std::make_unique<as::StateSynchronizer>(vehicles_.size(), timeout);
    advertise();
    setUpDiagnostics();
    add_service_ = pnh_.advertiseService("add_vehicle", &Impl::onAddVehicle, this);
    remove_service_ = pnh_.advertiseService("remove_vehicle", &Impl::onRemoveVehicle, this);
    ruts_sub_ = nh_.subscribe("/terrain/ruts", 100, &Impl::onPatch, this);
    toppled_sub_ = nh_.subscribe("/terrain/toppled", 100, &Impl::onToppled, this);
    // Every message is kept (a weather change must not be dropped by a full queue).
    environment_sub_ = nh_.subscribe("/environment", 1000, &Impl::onEnvironment, this);
    // In the lockstep environment_node publishes at every multiple of its period; a time is
    // sensed only once its message has come (worldKnownAt).
    environment_period_ = boundedParam(pnh_, "environment_period", 0.0, 0.0, 3600.0);
    // The same for the ruts: dynamics_node marks the end of each rut instant (1 / its ~ruts_rate).
    ruts_period_ = boundedParam(pnh_, "ruts_period", 0.0, 0.0, 3600.0);
    // Lockstep with a partitioned run: report each clock interval sensed, so lockstep_clock
    // waits for the sensors as for the dynamics partitions (the sensors never fall behind by
    // more than one interval, however costly a sweep or frame).
    output_ = at::node::outputFolderFromParams(pnh_);
    lockstep_partition_ = avsp::node::stringParam(pnh_, "lockstep_partition", "");
    if (!lockstep_partition_.empty())
    {
      std::string why;
      if (!ros::names::validate(lockstep_partition_, why) || lockstep_partition_.find('/') != std::string::npos)
        throw StartupError("parameter ~lockstep_partition '" + lockstep_partition_ + "' must be a plain name (no '/')");
      lockstep_interval_ = boundedParam(pnh_, "lockstep_interval", 0.01, 1e-4, 10.0);
      done_pub_ = nh_.advertise<avsp_msgs::StepDone>("/lockstep/done", 10);
      tick_sub_ = nh_.subscribe("/clock", 100, &Impl::onTick, this, ros::TransportHints().tcpNoDelay());
    }
    ROS_INFO(
        "sensors_node: %zu vehicle(s) and %zu agent(s) on %s (%zu objects), world frame '%s', %u ray-casting "
        "thread(s)%s",
        vehicles_.size(), agents_.size(), source_.c_str(), objects_.size(),
        per_vehicle_odom_frames_ ? "<v>/odom" : world_frame_.c_str(), threads_,
        threads_ == 0 ? " (0 = all cores)" : "");
  }

  /// One line per vehicle on stdout: wall time per sweep, scan, state and map publication.
  void reportCosts() const
  {
    for (const auto& v : vehicles_)
    {
      const VehicleIo::Costs& c = v->costs;
      auto per = [](double total, std::size_t n) { return n > 0 ? 1e3 * total / static_cast<double>(n) : 0.0; };
      std::printf(
          "sensors_node: %s cost (wall ms): lidar %.1f per sweep + OctoMap insertion %.1f + PointCloud2 %.1f "
          "(%zu sweeps); radar %.2f per scan (%zu); GPS/IMU/mag/ultrasonic %.3f per state (%zu); occupied "
          "cells + 2-D grid %.1f per publication (%zu)\n",
          v->name.c_str(), per(c.lidar, c.sweeps), per(c.occupancy, c.sweeps), per(c.cloud, c.sweeps), c.sweeps,
          per(c.radar, c.radar_scans), c.radar_scans, per(c.other, c.states), c.states, per(c.map_products, c.maps),
          c.maps);
      if (c.clusterings > 0)
        std::printf("sensors_node: %s lidar clustering (wall ms): %.2f per sweep (%zu sweeps)\n", v->name.c_str(),
                    per(c.clustering, c.clusterings), c.clusterings);
      if (v->camera_rig)
        std::printf("sensors_node: %s cameras (wall ms): %.1f per frame (%zu frames)\n", v->name.c_str(),
                    per(v->camera_cost, v->camera_frames), v->camera_frames);
    }
    std::fflush(stdout);
  }

private:
  // ---- start-up ---------------------------------------------------------------------------
  std::vector<asn::SensorsSpec> readSensorSpecs(const std::vector<asn::VehicleEntry>& entries)
  {
    XmlRpc::XmlRpcValue common, per_vehicle;
    const bool has_common = avsp::node::structuredParam(pnh_, "sensors", common);
    if (has_common)
      common_sensors_ = common;  // a spawned vehicle's (~add_vehicle)
    const bool has_per_vehicle = avsp::node::structuredParam(pnh_, "vehicle_sensors", per_vehicle);
    if (has_per_vehicle)
    {
      if (per_vehicle.getType() != XmlRpc::XmlRpcValue::TypeStruct)
        throw StartupError("parameter ~vehicle_sensors must be a map of <vehicle name>: {sensor sections}");
      for (auto it = per_vehicle.begin(); it != per_vehicle.end(); ++it)
      {
        bool known = false;
        for (const auto& e : entries)
          known = known || e.name == it->first;
        if (!known)
          throw StartupError("parameter ~vehicle_sensors/" + it->first + ": there is no vehicle '" + it->first +
                             "' in ~vehicles");
      }
    }
    std::vector<asn::SensorsSpec> specs;
    for (const auto& e : entries)
    {
      XmlRpc::XmlRpcValue* own = has_per_vehicle && per_vehicle.hasMember(e.name) ? &per_vehicle[e.name] : nullptr;
      specs.push_back(asn::parseSensors(own, "~vehicle_sensors/" + e.name, has_common ? &common : nullptr, "~sensors"));
    }
    return specs;
  }

  std::optional<as::EnuFrame> readOrigin(bool required)
  {
    const bool given = pnh_.hasParam("latitude") || pnh_.hasParam("longitude");
    if (!required && !given)
      return std::nullopt;
    if (!pnh_.hasParam("latitude") || !pnh_.hasParam("longitude"))
      throw StartupError(
          "parameters ~latitude and ~longitude (deg, the map origin's WGS-84 position) are required "
          "with a GPS or a magnetometer on a geomagnetic model (magnetometer/model other than fixed)");
    double value[3];
    for (std::size_t k = 0; k < 3; ++k)
    {
      const avsp::terrain::GeodeticNumber& n = avsp::terrain::geodeticReferenceNumbers()[k];
      value[k] = boundedParam(pnh_, n.key, n.fallback, n.min, n.max);
    }
    return as::EnuFrame(as::Geodetic{ value[0], value[1], value[2] });
  }

  std::unique_ptr<VehicleIo> makeVehicle(const asn::VehicleEntry& entry, asn::SensorsSpec spec, std::size_t index,
                                         const std::string& config_dir, const std::optional<as::EnuFrame>& origin,
                                         std::uint64_t seed)
  {
    auto v = std::make_unique<VehicleIo>();
    v->name = entry.name;
    v->index = index;
    const std::string where =
        "vehicle '" + entry.name + "' (model '" + entry.model + "', ~config_dir " + config_dir + ")";
    asn::VehicleFrames frames;
    try
    {
      frames = asn::loadVehicleFrames(config_dir + "/" + entry.model + ".yaml");
    }
    catch (const std::exception& e)
    {
      throw StartupError(where + ": " + e.what());
    }
    v->boxes = frames.boxes;
    v->base_frame = entry.name + "/" + frames.root_link;
    v->world_frame = per_vehicle_odom_frames_ ? entry.name + "/odom" : world_frame_;
    asn::mountSensors(spec, frames, where);
    as::SuiteConfig& suite = spec.suite;
    if (suite.lidar)
      v->lidar_frame = suite.lidar->registered ? v->world_frame : entry.name + "/" + spec.lidar_link;
    if (suite.radar)
      v->radar_frame = entry.name + "/" + spec.radar_link;
    if (suite.gps)
      v->gps_frame = entry.name + "/" + spec.gps_link;
    if (suite.imu)
      v->imu_frame = entry.name + "/" + spec.imu_link;
    if (suite.magnetometer)
      v->mag_frame = entry.name + "/" + spec.magnetometer_link;
    for (std::size_t k = 0; k < suite.ultrasonics.size(); ++k)
    {
      v->range_frames.push_back(entry.name + "/" + suite.ultrasonics[k].name);
      if (spec.ultrasonic_mounts[k].pose)
        staticFrame(v->base_frame, v->range_frames.back(), *spec.ultrasonic_mounts[k].pose);
    }
    setupCameras(*v, spec.cameras, where, as::streamKey(seed, nameHash(entry.name), 1));
    if (suite.occupancy)
      suite.occupancy->config.threads = threads_;
    suite.seed = as::streamKey(seed, nameHash(entry.name), 0);
    try
    {
      v->sensors = std::make_unique<as::VehicleSensors>(suite, origin, static_cast<std::uint32_t>(index));
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError(where + ": " + e.what());
    }
    return v;
  }

  void staticFrame(const std::string& parent, const std::string& child, const Eigen::Isometry3d& pose)
  {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = parent;
    t.child_frame_id = child;
    t.transform.translation.x = pose.translation().x();
    t.transform.translation.y = pose.translation().y();
    t.transform.translation.z = pose.translation().z();
    const Eigen::Quaterniond q(pose.linear());
    t.transform.rotation.w = q.w();
    t.transform.rotation.x = q.x();
    t.transform.rotation.y = q.y();
    t.transform.rotation.z = q.z();
    static_frames_.push_back(t);
  }

  /// The vehicle's cameras: the rig (validated) and each camera's static optical frame.
  void setupCameras(VehicleIo& v, const std::vector<as::CameraConfig>& cameras, const std::string& where,
                    std::uint64_t seed)
  {
    if (cameras.empty())
      return;
    try
    {
      v.camera_rig = std::make_unique<as::CameraRig>(cameras, static_cast<std::uint32_t>(v.index), seed);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError(where + ": " + e.what());
    }
    for (std::size_t k = 0; k < cameras.size(); ++k)
    {
      VehicleIo::CameraIo io;
      // A stereo half's name is <pair>/left: its frame <v>/<pair>_left_optical (one level).
      std::string flat = cameras[k].name;
      std::replace(flat.begin(), flat.end(), '/', '_');
      io.frame = v.name + "/" + flat + "_optical";
      staticFrame(v.base_frame, io.frame, v.camera_rig->opticalMount(k));
      v.camera_io.push_back(io);
    }
  }

  /// What the cameras need beyond geometry: the soil of each grid point (the terrain's palette
  /// and map, wetness at the soils' initial moisture) and the objects' types.
  void loadCameraMaterials(const at::DeformableTerrain& terrain)
  {
    std::vector<as::SoilLook> palette;
    for (const at::SoilParameters& soil : terrain.palette())
    {
      const double wet = soil.moisture.saturated > 0.0 ? soil.moisture.initial / soil.moisture.saturated : 0.0;
      palette.push_back(
          { soil.name, as::soilAlbedo(soil.name), static_cast<float>(std::min(1.0, std::max(0.0, wet))) });
    }
    std::vector<std::uint8_t> soil_map;
    if (palette.size() > 1)
    {
      const std::size_t nx = scene_->terrain().columns(), ny = scene_->terrain().rows();
      soil_map.resize(nx * ny);
      for (std::size_t j = 0; j < ny; ++j)
        for (std::size_t i = 0; i < nx; ++i)
          soil_map[j * nx + i] = terrain.soilIndex(i, j);
    }
    camera_materials_.setSoils(std::move(palette), std::move(soil_map));
    camera_materials_.setObjects(objects_);
    // Agents' bodies follow the vehicles' ids (appendAgentBodies): label and warm them by type.
    for (std::size_t k = 0; k < agents_.size(); ++k)
    {
      const at::AgentType type = agents_[k].spec().type;
      camera_materials_.setBody(static_cast<std::uint32_t>(vehicles_.size() + k),
                                type == at::AgentType::kDeer         ? as::kClassAnimal
                                : type == at::AgentType::kPedestrian ? as::kClassPerson
                                                                     : as::kClassVehicle);
    }
  }

  void loadScene(const std::string& soils_file)
  {
    std::unique_ptr<at::SoilLibrary> soils;
    try
    {
      soils = std::make_unique<at::SoilLibrary>(at::SoilLibrary::load(soils_file));
    }
    catch (const std::exception& e)
    {
      throw StartupError("parameter ~soils_file: " + std::string(e.what()));
    }
    at::LoadedSource loaded = at::node::loadTerrainFromParams(pnh_, *soils);
    if (loaded.filled_no_data > 0)
      ROS_WARN("sensors_node: %s: %zu no-data points filled from their nearest valid neighbours",
               loaded.description.c_str(), loaded.filled_no_data);
    source_ = loaded.description;
    objects_ = std::move(loaded.objects);
    loadAgents(loaded.terrain->base());
    // The sensors keep the heights only (ruts arrive as heights); the soil state is dropped.
    scene_ = std::make_unique<as::Scene>(as::HeightField::fromTerrain(*loaded.terrain));
    for (const auto& v : vehicles_)
      if (v->camera_rig)
      {
        loadCameraMaterials(*loaded.terrain);
        break;
      }
    loaded.terrain.reset();
    scene_->setObjects(objects_);
  }

  /// ~agents (heights from the terrain's base grid, as agents_node and dynamics_node take them)
  /// and their reflectivities.
  void loadAgents(const at::ElevationGrid& ground)
  {
    agents_ = at::node::agentsFromParams(pnh_, ground);
    for (at::AgentType t : { at::AgentType::kDeer, at::AgentType::kPedestrian, at::AgentType::kTruck })
    {
      float& r = agent_reflectivities_.types[static_cast<std::size_t>(t)];
      r = static_cast<float>(boundedParam(pnh_, std::string("agent_reflectivity/") + at::toString(t), r, 0.0, 1.0));
    }
  }

  /// The agents' boxes at sim time t, after the vehicles' bodies (their ids follow the vehicles').
  void appendAgentBodies(std::vector<as::Body>& bodies, double t) const
  {
    for (std::size_t k = 0; k < agents_.size(); ++k)
    {
      const std::vector<as::Body> b =
          as::agentBodies(agents_[k], t, static_cast<std::uint32_t>(vehicles_.size() + k), agent_reflectivities_);
      bodies.insert(bodies.end(), b.begin(), b.end());
    }
  }

  void advertise()
  {
    // Seasons flip south of the equator; without ~latitude the north's are used.
    const avsp::terrain::GeodeticNumber& latitude = avsp::terrain::geodeticReferenceNumbers()[0];
    camera_latitude_ = boundedParam(pnh_, latitude.key, latitude.fallback, latitude.min, latitude.max);
    for (auto& v : vehicles_)
      advertiseVehicle(*v);
    if (!static_frames_.empty())
      static_broadcaster_.sendTransform(static_frames_);
  }

  /// A vehicle's odometry subscriber and the publishers and services of its sensors.
  void advertiseVehicle(VehicleIo& v)
  {
    ros::NodeHandle vnh(nh_, v.name);
    const as::SuiteConfig& c = v.sensors->config();
    v.odom_topic = vnh.resolveName("avt_341/odometry");
    VehicleIo* raw = &v;
    // A deep queue: a burst of odometry (a fast clock) must not lose states (they fix the
    // sampling times); the callback only queues them.
    v.odom_sub = vnh.subscribe<nav_msgs::Odometry>(
        "avt_341/odometry", 2000, [this, raw](const nav_msgs::Odometry::ConstPtr& m) { onOdometry(*raw, *m); });
    if (c.lidar)
      v.points_pub = vnh.advertise<sensor_msgs::PointCloud2>("avt_341/points", 5);
    advertiseClusters(v, vnh);
    if (c.radar)
    {
      v.targets_pub = vnh.advertise<avsp_msgs::RadarTargetArray>("radar/targets", 10);
      v.radar_points_pub = vnh.advertise<sensor_msgs::PointCloud2>("radar/points", 10);
      v.radar_markers_pub = vnh.advertise<visualization_msgs::MarkerArray>("radar/markers", 10);
    }
    if (c.gps)
      v.gps_pub = vnh.advertise<sensor_msgs::NavSatFix>("gps/fix", 20);
    if (c.imu)
      v.imu_pub = vnh.advertise<sensor_msgs::Imu>("imu/data", 200);
    if (c.magnetometer)
      v.mag_pub = vnh.advertise<sensor_msgs::MagneticField>("mag", 50);
    for (const as::UltrasonicSetup& u : c.ultrasonics)
      v.range_pubs.push_back(vnh.advertise<sensor_msgs::Range>("ultrasonic/" + u.name, 20));
    if (c.occupancy)
    {
      v.cells_pub = vnh.advertise<visualization_msgs::MarkerArray>("octomap/occupied_cells", 2);
      v.grid_pub = vnh.advertise<nav_msgs::OccupancyGrid>("occupancy/grid", 2);
      v.save_service = pnh_.advertiseService<avsp_msgs::SaveMap::Request, avsp_msgs::SaveMap::Response>(
          v.name + "/save_map", [this, raw](avsp_msgs::SaveMap::Request& req, avsp_msgs::SaveMap::Response& res) {
            return onSaveMap(*raw, req, res);
          });
    }
    advertiseCameras(v);
  }

  /// Per camera: <camera>/image_raw (rgb8), depth/image_raw (32FC1), semantic/image_raw and
  /// thermal/image_raw (mono8) through image_transport, camera_info; per vehicle the latched
  /// class table semantic_classes.
  void advertiseCameras(VehicleIo& v)
  {
    if (!v.camera_rig)
      return;
    ros::NodeHandle vnh(nh_, v.name);
    v.image_transport = std::make_unique<image_transport::ImageTransport>(vnh);
    for (std::size_t k = 0; k < v.camera_io.size(); ++k)
    {
      const as::CameraConfig& c = v.camera_rig->cameras()[k].config();
      VehicleIo::CameraIo& io = v.camera_io[k];
      if (c.rgb)
        io.rgb = v.image_transport->advertise(c.name + "/image_raw", 2);
      if (c.depth)
        io.depth = v.image_transport->advertise(c.name + "/depth/image_raw", 2);
      if (c.semantic)
        io.semantic = v.image_transport->advertise(c.name + "/semantic/image_raw", 2);
      if (c.thermal)
        io.thermal = v.image_transport->advertise(c.name + "/thermal/image_raw", 2);
      io.info = vnh.advertise<sensor_msgs::CameraInfo>(c.name + "/camera_info", 10);
    }
    v.classes_pub = vnh.advertise<avsp_msgs::ClassTable>("semantic_classes", 1, true);
    v.classes_pub.publish(asn::toClassTable(camera_materials_.classTable(), std_msgs::Header()));
  }

  // ---- vehicles joining and leaving (dynamics_node ~spawn_vehicle / ~remove_vehicle) -----
  // dynamics_node calls these between its steps, before the vehicle's first odometry and after
  // its last: the synchronizer waits for it exactly from its first state to its last, so the
  // sensed times and the scene do not depend on when the calls' messages arrived.

  bool onAddVehicle(avsp_msgs::AddSensedVehicle::Request& req, avsp_msgs::AddSensedVehicle::Response& res)
  {
    res.success = false;
    std::string why;
    const bool used = std::any_of(vehicles_.begin(), vehicles_.end(),
                                  [&](const auto& v) { return !v->removed && v->name == req.name; });
    if (req.name.empty() || req.name.find('/') != std::string::npos || !ros::names::validate(req.name, why))
      res.message = "refused: name '" + req.name + "' must be a valid ROS name without '/'";
    else if (used)
      res.message = "refused: there is already a vehicle '" + req.name + "'";
    else if (req.model.empty() || req.model.find('/') != std::string::npos)
      res.message = "refused: model '" + req.model + "' must be a model name (config_dir/<model>.yaml)";
    else if (!std::isfinite(req.first_time))
      res.message = "refused: first_time must be finite";
    else
    {
      const std::size_t frames_before = static_frames_.size();
      try
      {
        std::vector<asn::SensorsSpec> specs{ asn::parseSensors(
            nullptr, "~vehicle_sensors/" + req.name, common_sensors_ ? &*common_sensors_ : nullptr, "~sensors") };
        if (asn::needsOrigin(specs) && !origin_)
          throw std::invalid_argument(
              "its sensors (~sensors) need ~latitude and ~longitude, which this node was not given");
        asn::placeMagnetometers(specs, origin_, date_);
        std::unique_ptr<VehicleIo> v = makeVehicle(asn::VehicleEntry{ req.name, req.model }, specs[0], vehicles_.size(),
                                                   config_dir_, origin_, seed_);
        if (sync_->addVehicle(req.first_time) != v->index)
          throw std::logic_error("the synchronizer's index differs from the vehicle's");
        advertiseVehicle(*v);
        static_broadcaster_.sendTransform(static_frames_);
        VehicleIo* raw = v.get();
        diagnostics_->add(v->name,
                          [this, raw](diagnostic_updater::DiagnosticStatusWrapper& st) { vehicleStatus(*raw, st); });
        const as::SuiteConfig& c = v->sensors->config();
        res.message = "'" + req.name + "' (" + req.model + ") sensed from " + std::to_string(req.first_time) +
                      " s:" + (c.lidar ? " lidar" : "") + (c.radar ? " radar" : "") + (c.gps ? " gps" : "") +
                      (c.imu ? " imu" : "") + (c.magnetometer ? " magnetometer" : "") +
                      (v->camera_rig ? " cameras" : "") + (c.occupancy ? " octomap" : "");
        vehicles_.push_back(std::move(v));
        res.success = true;
      }
      catch (const std::exception& e)
      {
        static_frames_.resize(frames_before);
        res.message = std::string("refused: ") + e.what();
      }
    }
    if (res.success)
      ROS_INFO("sensors_node: ~add_vehicle: %s", res.message.c_str());
    else
      ROS_WARN("sensors_node: ~add_vehicle: %s (nothing changed)", res.message.c_str());
    return true;
  }

  bool onRemoveVehicle(avsp_msgs::RemoveSensedVehicle::Request& req, avsp_msgs::RemoveSensedVehicle::Response& res)
  {
    res.success = false;
    const auto it = std::find_if(vehicles_.begin(), vehicles_.end(),
                                 [&](const auto& v) { return !v->removing && v->name == req.name; });
    if (it == vehicles_.end())
      res.message = "refused: no vehicle '" + req.name + "'";
    else if (!std::isfinite(req.last_time))
      res.message = "refused: last_time must be finite";
    else
    {
      VehicleIo& v = **it;
      sync_->removeVehicle(v.index, req.last_time);
      v.removing = true;
      diagnostics_->removeByName(v.name);
      closeRemoved();
      res.success = true;
      res.message = "'" + req.name + "' sensed up to " + std::to_string(req.last_time) + " s";
    }
    if (res.success)
      ROS_INFO("sensors_node: ~remove_vehicle: %s", res.message.c_str());
    else
      ROS_WARN("sensors_node: ~remove_vehicle: %s (nothing changed)", res.message.c_str());
    return true;
  }

  /// Closes every removed vehicle whose last state is sensed: its subscriber, publishers and
  /// services go (until then its queued states still need them).
  void closeRemoved()
  {
    for (auto& vp : vehicles_)
    {
      VehicleIo& v = *vp;
      if (!v.removing || v.removed || !sync_->gone(v.index))
        continue;
      v.odom_sub.shutdown();
      for (ros::Publisher* p :
           { &v.points_pub, &v.targets_pub, &v.radar_points_pub, &v.radar_markers_pub, &v.gps_pub, &v.imu_pub,
             &v.mag_pub, &v.cells_pub, &v.grid_pub, &v.clusters_pub, &v.cluster_markers_pub, &v.classes_pub })
        p->shutdown();
      for (ros::Publisher& p : v.range_pubs)
        p.shutdown();
      for (VehicleIo::CameraIo& c : v.camera_io)
      {
        for (image_transport::Publisher* p : { &c.rgb, &c.depth, &c.semantic, &c.thermal })
          p->shutdown();
        c.info.shutdown();
      }
      v.save_service.shutdown();
      v.removed = true;
    }
  }

  // ---- inputs ----------------------------------------------------------------------------
  void onOdometry(VehicleIo& v, const nav_msgs::Odometry& msg)
  {
    as::VehicleState state;
    std::string why;
    if (!asn::stateFromOdometry(msg, v.world_frame, v.base_frame, state, why))
    {
      ++v.odometry_ignored;
      warnThrottled(2.0, "sensors_node: %s ignored: %s; the vehicle keeps its last good state", v.odom_topic.c_str(),
                    why.c_str());
      return;
    }
    if (state.time == v.last_stamp)
      return;  // sent again (dynamics_node re-sends time 0 until its lockstep peers answer)
    switch (sync_->push(v.index, state))
    {
      case as::StateSynchronizer::Push::kQueued:
        v.last_stamp = state.time;
        break;
      case as::StateSynchronizer::Push::kNotAfterLast:
        ++v.odometry_ignored;
        warnThrottled(2.0, "sensors_node: %s ignored: stamp %.6f s is not after the previous one", v.odom_topic.c_str(),
                      state.time);
        return;
      case as::StateSynchronizer::Push::kLate:
        ++v.odometry_ignored;
        warnThrottled(2.0,
                      "sensors_node: %s ignored: stamp %.6f s arrived after the sensors moved past it "
                      "(the vehicle was silent longer than ~odometry_timeout)",
                      v.odom_topic.c_str(), state.time);
        return;
    }
  }

  /// A change of the world takes effect at the first sensor time at or after its stamp (at once
  /// when it arrives late), so that its effect does not depend on message interleaving when it
  /// is published ahead of time.
  void schedule(const ros::Time& stamp, std::function<void()> apply)
  {
    events_.emplace(asn::stampSeconds(stamp), std::move(apply));
  }

  void onPatch(const ros::MessageEvent<const avsp_msgs::TerrainPatch>& event)
  {
    const avsp_msgs::TerrainPatch::ConstPtr msg = event.getMessage();
    const std::string publisher = event.getPublisherName();
    if (at::node::isEndOfInstantMarker(*msg))
    {
      // dynamics_node's end-of-instant marker: every patch up to its stamp has come.
      ruts_reached_ = std::max(ruts_reached_, asn::stampSeconds(msg->header.stamp));
      return;
    }
    if (!msg->header.frame_id.empty() && msg->header.frame_id != "map" && msg->header.frame_id != world_frame_)
    {
      ++ignored_["/terrain/ruts"];
      warnThrottled(5.0, "sensors_node: /terrain/ruts from %s in frame '%s', expected 'map'; ignored",
                    publisher.c_str(), msg->header.frame_id.c_str());
      return;
    }
    schedule(msg->header.stamp, [this, msg, publisher] {
      try
      {
        as::applyHeightPatch(scene_->terrain(), at::node::heightPatchFromMessage(*msg));
      }
      catch (const std::invalid_argument& e)
      {
        ++ignored_["/terrain/ruts"];
        warnThrottled(5.0, "sensors_node: /terrain/ruts from %s rejected: %s", publisher.c_str(), e.what());
      }
    });
  }

  void onToppled(const avsp_msgs::ObjectToppled::ConstPtr& msg)
  {
    if (!msg->header.frame_id.empty() && msg->header.frame_id != "map" && msg->header.frame_id != world_frame_)
    {
      ++ignored_["/terrain/toppled"];
      warnThrottled(5.0, "sensors_node: /terrain/toppled ignored: frame '%s', expected 'map'",
                    msg->header.frame_id.c_str());
      return;
    }
    schedule(msg->header.stamp, [this, msg] {
      std::string why;
      if (objects_.applyToppled(msg->id, msg->fall_direction, why))
        scene_->setObjects(objects_);
      else
      {
        ++ignored_["/terrain/toppled"];
        warnThrottled(5.0, "sensors_node: /terrain/toppled ignored: %s", why.c_str());
      }
    });
  }

  void onEnvironment(const avsp_msgs::Environment::ConstPtr& msg)
  {
    // Its time has come, even when the message is refused (the lidar keeps the last good weather).
    environment_reached_ = std::max(environment_reached_, asn::stampSeconds(msg->header.stamp));
    as::Weather weather;
    std::string why;
    if (!asn::weatherFromEnvironment(*msg, weather, why))
    {
      ++ignored_["/environment"];
      warnThrottled(5.0, "sensors_node: /environment ignored: %s; the lidar keeps the last good weather", why.c_str());
      return;
    }
    schedule(msg->header.stamp, [this, weather] { weather_ = weather; });
    scheduleCameraEnvironment(msg, weather);
  }

  /// The cameras' sky (sun, moon, season, snow, wetness) from the same message, at its stamp.
  void scheduleCameraEnvironment(const avsp_msgs::Environment::ConstPtr& msg, const as::Weather& weather)
  {
    schedule(msg->header.stamp, [this, msg, weather] {
      std::string why;
      if (!asn::cameraEnvironmentFromMessage(*msg, weather, camera_latitude_, camera_env_, why))
        warnThrottled(5.0, "sensors_node: /environment ignored by the cameras: %s; they keep the last good sky",
                      why.c_str());
    });
  }

  bool onSaveMap(VehicleIo& v, avsp_msgs::SaveMap::Request& req, avsp_msgs::SaveMap::Response& res)
  {
    res.success = false;
    try
    {
      const std::string path = at::resolveOutputPath(req.path, output_);
      if (at::fileExtension(path) != ".bt")
        throw at::OutputFileError("path '" + path + "' must end in .bt (OctoMap binary)");
      const std::string bytes = v.sensors->occupancy()->binary();
      at::writeThroughTemporary(path, [&](const std::string& tmp) { at::writeBytes(tmp, bytes); });
      res.success = true;
      res.message = path;
      ROS_INFO("sensors_node: saved %s's OctoMap to %s", v.name.c_str(), path.c_str());
    }
    catch (const std::exception& e)
    {
      res.message = e.what();
      ROS_WARN("sensors_node: %s/save_map refused: %s", v.name.c_str(), res.message.c_str());
    }
    return true;
  }

  // ---- /diagnostics (diagnostic_updater) ---------------------------------------------------
  // Every ~diagnostic_period of sim time: "<node>: <vehicle>" (how far its sensing is behind
  // /clock, states sensed, odometry ignored) and "<node>: inputs" (world messages ignored).
public:
  void setUpDiagnostics()
  {
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
    diagnostics_->setHardwareID(ros::this_node::getName());
    for (const auto& v : vehicles_)
    {
      VehicleIo* raw = v.get();
      diagnostics_->add(v->name,
                        [this, raw](diagnostic_updater::DiagnosticStatusWrapper& s) { vehicleStatus(*raw, s); });
    }
    diagnostics_->add("inputs", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { inputStatus(s); });
  }

  void updateDiagnostics() { diagnostics_->update(); }

private:
  void vehicleStatus(VehicleIo& v, diagnostic_updater::DiagnosticStatusWrapper& s)
  {
    const double lag = ros::Time::now().toSec() - v.sensed;
    s.add("behind /clock (s)", lag);
    s.add("sensed up to (s)", v.sensed);
    s.add("states sensed", v.states_sensed);
    s.add("odometry ignored", v.odometry_ignored);
    s.add("times waited out", v.waited_out);
    const std::uint64_t new_ignored = v.odometry_ignored - v.ignored_reported;
    v.ignored_reported = v.odometry_ignored;
    if (lag > max_lag_)
      s.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "sensing %.2f s behind /clock (~max_lag %.2f s)", lag,
                 max_lag_);
    else if (new_ignored > 0)
      s.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%llu odometry message(s) ignored since the last report",
                 static_cast<unsigned long long>(new_ignored));
    else
      s.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "sensing %.2f s behind /clock", lag);
  }

  void inputStatus(diagnostic_updater::DiagnosticStatusWrapper& s)
  {
    std::uint64_t total = 0;
    for (const char* topic : { "/terrain/ruts", "/terrain/toppled", "/environment" })
    {
      const std::uint64_t n = ignored_[topic];
      s.add(std::string(topic) + " ignored", n);
      total += n;
    }
    s.add("world changes pending", events_.size());
    if (environment_period_ > 0.0)
      s.add("/environment reached (s)", environment_reached_);  // a held time waits for it
    if (ruts_period_ > 0.0)
      s.add("/terrain/ruts reached (s)", ruts_reached_);
    avsp::node::summarizeIgnoredInputs(s, total, ignored_reported_);
  }

  // ---- sensing ---------------------------------------------------------------------------
public:
  /// Runs every time whose states are complete, in time order (after the callbacks that were
  /// waiting have queued their states).
  void drain()
  {
    // Stops at shutdown: behind the clock, the queue may hold seconds of sensing, and a SIGINT
    // waited for all of it (roslaunch's SIGTERM after 15 s ended some runs).
    while (ros::ok())
    {
      std::optional<as::StateSynchronizer::Batch> batch;
      if (held_)
        batch.swap(held_);
      else
      {
        batch = sync_->next();
        if (!batch)
          break;
        for (std::size_t k : sync_->waitedOut())
          ++vehicles_[k]->waited_out;
        for (std::size_t k : sync_->waitedOut())
          warnThrottled(5.0,
                        "sensors_node: %s silent while the others ran ~odometry_timeout ahead of %.3f s; going "
                        "on without it",
                        vehicles_[k]->odom_topic.c_str(), batch->time);
      }
      if (!worldKnownAt(batch->time))
      {
        held_.swap(batch);  // sensed once /environment and the ruts have reached its time
        break;
      }
      for (auto it = events_.begin(); it != events_.end() && it->first <= batch->time;)
      {
        it->second();
        it = events_.erase(it);
      }
      std::vector<as::Body> bodies;
      for (const auto& v : vehicles_)
        if (const std::optional<as::VehicleState>& s = sync_->latest(v->index))
        {
          const std::vector<as::Body> b =
              as::vehicleBodies(v->boxes, *s, static_cast<std::uint32_t>(v->index), body_reflectivity_);
          bodies.insert(bodies.end(), b.begin(), b.end());
        }
      appendAgentBodies(bodies, batch->time);
      scene_->setBodies(std::move(bodies));
      // The vehicles' sensors and cameras over the threads (each vehicle's outputs depend on its
      // own state and the scene alone, both fixed for this time: any split gives the same
      // outputs), then published in the vehicles' order from this thread.
      std::vector<Sensed> sensed(batch->vehicles.size());
      as::parallelForDynamic(batch->vehicles.size(), threads_, 1, [&](std::size_t begin, std::size_t end) {
        for (std::size_t k = begin; k < end; ++k)
          sensed[k] = compute(*vehicles_[batch->vehicles[k]], batch->states[k]);
      });
      for (std::size_t k = 0; k < batch->vehicles.size(); ++k)
      {
        VehicleIo& v = *vehicles_[batch->vehicles[k]];
        publish(v, batch->states[k], sensed[k]);
        v.sensed = batch->states[k].time;
        ++v.states_sensed;
      }
      closeRemoved();
      diagnostics_->update();
      if (!lockstep_partition_.empty())
      {
        // Every interval end up to this time is sensed.
        const double end = std::floor(batch->time / lockstep_interval_ + 1e-6) * lockstep_interval_;
        if (!reported_ || end > *reported_ + 0.5 * lockstep_interval_)
        {
          reported_ = end;
          reportDone();
        }
      }
    }
  }

private:
  /// Whether the world at `time` is known whatever the message interleaving: with
  /// ~environment_period p, the /environment message of the last multiple of p up to `time`
  /// has come; with ~ruts_period q, dynamics_node's end-of-patches marker of the last multiple
  /// of q up to `time` (from q on: there is no rut instant at 0).
  bool worldKnownAt(double time) const
  {
    const auto due = [time](double period) { return std::floor(time / period + 1e-9) * period; };
    if (environment_period_ > 0.0 && environment_reached_ < due(environment_period_) - 1e-9)
      return false;
    if (ruts_period_ > 0.0)
    {
      const double r = due(ruts_period_);
      if (r > 0.5 * ruts_period_ && ruts_reached_ < r - 1e-9)
        return false;
    }
    return true;
  }

  void reportDone()
  {
    avsp_msgs::StepDone d;
    d.header.stamp = ros::Time(*reported_);
    d.partition = lockstep_partition_;
    done_pub_.publish(d);
  }

  /// A tick the clock sends again (it is waiting): our report may have been lost.
  void onTick(const rosgraph_msgs::Clock::ConstPtr& c)
  {
    if (reported_ && c->clock.toSec() <= *reported_ + 0.5 * lockstep_interval_)
      reportDone();
  }

  /// What one vehicle's sensors and cameras made of one state (compute(), on any thread).
  struct Sensed
  {
    as::SuiteOutput out;
    std::vector<as::CameraOutput> frames;
    std::string suite_error, camera_error;  ///< the core's refusal of the state, if any
  };

  /// The vehicle's sensors and cameras at `state` (no ROS call: run on a worker thread).
  Sensed compute(VehicleIo& v, const as::VehicleState& state)
  {
    Sensed s;
    try
    {
      s.out = v.sensors->update(state, *scene_, weather_, threads_);
    }
    catch (const std::invalid_argument& e)
    {
      s.suite_error = e.what();
    }
    if (v.camera_rig)
      try
      {
        s.frames = v.camera_rig->update(state, *scene_, camera_materials_, camera_env_, threads_);
      }
      catch (const std::invalid_argument& e)
      {
        s.camera_error = e.what();
      }
    return s;
  }

  void publish(VehicleIo& v, const as::VehicleState& state, const Sensed& sensed)
  {
    if (!sensed.suite_error.empty())
    {
      warnThrottled(2.0, "sensors_node: %s at %.6f s: %s", v.name.c_str(), state.time, sensed.suite_error.c_str());
      return;
    }
    const as::SuiteOutput& out = sensed.out;
    std_msgs::Header header;
    header.stamp = asn::toStamp(out.time);
    auto with = [&header](const std::string& frame) {
      std_msgs::Header h = header;
      h.frame_id = frame;
      return h;
    };
    VehicleIo::Costs& costs = v.costs;
    ++costs.states;
    costs.other += out.cost.other;
    if (out.lidar)
    {
      const ros::WallTime start = ros::WallTime::now();
      std_msgs::Header h = with(v.lidar_frame);
      h.stamp = asn::toStamp(out.lidar->start);
      v.points_pub.publish(asn::toPointCloud2(out.lidar->scan, h));
      ++costs.sweeps;
      costs.lidar += out.cost.lidar;
      costs.occupancy += out.cost.occupancy;
      costs.cloud += (ros::WallTime::now() - start).toSec();
      ROS_DEBUG("sensors_node: %s sweep at %.3f s: %zu points, cast %.1f ms, OctoMap %.1f ms", v.name.c_str(),
                out.lidar->start, out.lidar->scan.points.size(), 1e3 * out.cost.lidar, 1e3 * out.cost.occupancy);
      publishClusters(v, *out.lidar, h.stamp);
    }
    if (out.radar)
    {
      ++costs.radar_scans;
      costs.radar += out.cost.radar;
      const std_msgs::Header h = with(v.radar_frame);
      v.targets_pub.publish(asn::radarTargets(out.radar->scan, h));
      v.radar_points_pub.publish(asn::radarPoints(out.radar->scan, h));
      if (v.radar_markers_pub.getNumSubscribers() > 0)
        v.radar_markers_pub.publish(asn::radarMarkers(out.radar->scan, h));
    }
    if (out.gps)
      v.gps_pub.publish(asn::toNavSatFix(*out.gps, with(v.gps_frame)));
    if (out.imu)
      v.imu_pub.publish(asn::toImu(*out.imu, with(v.imu_frame)));
    if (out.magnetometer)
      v.mag_pub.publish(asn::toMagneticField(*out.magnetometer, with(v.mag_frame)));
    for (const auto& [k, reading] : out.ultrasonics)
      v.range_pubs[k].publish(asn::toRange(reading, with(v.range_frames[k])));
    if (out.occupancy_due)
    {
      const ros::WallTime start = ros::WallTime::now();
      const Eigen::Vector3d p = state.pose.translation();
      if (v.cells_pub.getNumSubscribers() > 0)
        v.cells_pub.publish(asn::occupiedCellMarkers(v.sensors->occupancy()->occupiedCells(), with(v.world_frame),
                                                     p.z() - 2.0, p.z() + 4.0));
      if (v.grid_pub.getNumSubscribers() > 0)
        v.grid_pub.publish(
            asn::toOccupancyGrid(v.sensors->occupancyGrid(p.x(), p.y(), scene_->terrain()), with(v.world_frame)));
      ++costs.maps;
      costs.map_products += (ros::WallTime::now() - start).toSec();
    }
    publishCameras(v, state, sensed);
  }

  // ---- lidar clustering (issue 23) -------------------------------------------------------
  // Objects in each sweep: the core's LidarClusterer (lidar_clustering.hpp) through
  // VehicleSensors::clusterSweep, parameters `lidar/clustering/...` (README, "Lidar
  // clustering"). Clusters are in ~world_frame whatever the cloud's frame (the ground test needs
  // the terrain's frame), stamped with the sweep start like the cloud. Computed only while
  // someone listens to either topic: the clusters feed nothing else in the simulator.

  void advertiseClusters(VehicleIo& v, ros::NodeHandle& vnh)
  {
    if (!v.sensors->clusters())
      return;
    v.clusters_pub = vnh.advertise<avsp_msgs::LidarClusterArray>("lidar/clusters", 5);
    v.cluster_markers_pub = vnh.advertise<visualization_msgs::MarkerArray>("lidar/cluster_markers", 5);
  }

  void publishClusters(VehicleIo& v, const as::LidarSweep& sweep, const ros::Time& stamp)
  {
    if (!v.sensors->clusters())
      return;
    const bool markers = v.cluster_markers_pub.getNumSubscribers() > 0;
    if (v.clusters_pub.getNumSubscribers() == 0 && !markers)
      return;
    const ros::WallTime start = ros::WallTime::now();
    std_msgs::Header h;
    h.stamp = stamp;
    h.frame_id = v.world_frame;
    as::LidarClustering clustering;
    try
    {
      clustering = v.sensors->clusterSweep(sweep, scene_->terrain());
    }
    catch (const std::exception& e)
    {
      warnThrottled(2.0, "sensors_node: %s lidar clustering at %.6f s: %s", v.name.c_str(), sweep.start, e.what());
      return;
    }
    v.clusters_pub.publish(asn::lidarClusters(clustering, h));
    if (markers)
      v.cluster_markers_pub.publish(asn::lidarClusterMarkers(clustering, h));
    ++v.costs.clusterings;
    v.costs.clustering += (ros::WallTime::now() - start).toSec();
  }

  /// Publishes the camera frames rendered at this state (stamped with its time).
  void publishCameras(VehicleIo& v, const as::VehicleState& state, const Sensed& sensed)
  {
    if (!v.camera_rig)
      return;
    if (!sensed.camera_error.empty())
    {
      warnThrottled(2.0, "sensors_node: %s cameras at %.6f s: %s", v.name.c_str(), state.time,
                    sensed.camera_error.c_str());
      return;
    }
    for (const as::CameraOutput& o : sensed.frames)
    {
      const ros::WallTime start = ros::WallTime::now();
      const as::Camera& camera = v.camera_rig->cameras()[o.index];
      VehicleIo::CameraIo& io = v.camera_io[o.index];
      std_msgs::Header h;
      h.stamp = asn::toStamp(o.time);
      h.frame_id = io.frame;
      if (camera.config().rgb)
        io.rgb.publish(asn::toImage(o.frame, asn::ImageKind::kRgb, h));
      if (camera.config().depth)
        io.depth.publish(asn::toImage(o.frame, asn::ImageKind::kDepth, h));
      if (camera.config().semantic)
        io.semantic.publish(asn::toImage(o.frame, asn::ImageKind::kSemantic, h));
      if (camera.config().thermal)
        io.thermal.publish(asn::toImage(o.frame, asn::ImageKind::kThermal, h));
      io.info.publish(asn::toCameraInfo(camera.intrinsics(), h));
      ++v.camera_frames;
      v.camera_cost += o.cost + (ros::WallTime::now() - start).toSec();
    }
  }

  ros::NodeHandle& nh_;
  ros::NodeHandle& pnh_;
  std::string world_frame_ = "odom";
  bool per_vehicle_odom_frames_ = false;  ///< ~per_vehicle_odom_frames
  at::OutputFolder output_;               // where <v>/save_map may write
  unsigned threads_ = 0;
  float body_reflectivity_ = 0.5f;
  std::string source_;
  at::ObjectSet objects_;
  std::vector<at::Agent> agents_;  ///< ~agents: boxes in the scene at every sensor time
  as::AgentReflectivities agent_reflectivities_;
  std::unique_ptr<as::Scene> scene_;
  as::Weather weather_;
  as::CameraMaterials camera_materials_;
  as::CameraEnvironment camera_env_;
  double camera_latitude_ = 0.0;  ///< deg, ~latitude (seasons)
  std::vector<std::unique_ptr<VehicleIo>> vehicles_;
  std::unique_ptr<as::StateSynchronizer> sync_;
  // What ~add_vehicle gives a spawned vehicle: the defaults (~sensors) on its model.
  std::optional<XmlRpc::XmlRpcValue> common_sensors_;
  std::optional<as::EnuFrame> origin_;
  std::string config_dir_, date_;
  std::uint64_t seed_ = 0;
  ros::ServiceServer add_service_, remove_service_;
  std::multimap<double, std::function<void()>> events_;  ///< world changes by stamp, in arrival order per stamp
  std::vector<geometry_msgs::TransformStamped> static_frames_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  ros::Subscriber ruts_sub_, toppled_sub_, environment_sub_;
  double max_lag_ = 1.0;                          ///< s, ~max_lag: sensing further behind /clock is a warning
  std::map<std::string, std::uint64_t> ignored_;  ///< messages ignored per input topic
  std::uint64_t ignored_reported_ = 0;            ///< their sum at the last diagnostics publication
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  std::string lockstep_partition_;   ///< ~lockstep_partition ("" = not in the lockstep)
  double environment_period_ = 0.0;  ///< s, ~environment_period (0: sense without waiting for it)
  double environment_reached_ = -std::numeric_limits<double>::infinity();  ///< s, latest /environment stamp
  double ruts_period_ = 0.0;  ///< s, ~ruts_period (0: sense without waiting for the ruts)
  double ruts_reached_ = -std::numeric_limits<double>::infinity();  ///< s, latest end-of-ruts marker
  std::optional<as::StateSynchronizer::Batch> held_;                ///< popped, waiting for /environment or the ruts
  double lockstep_interval_ = 0.01;                                 ///< s, lockstep_clock's ~sync_interval
  std::optional<double> reported_;                                  ///< last interval end reported sensed, s
  ros::Publisher done_pub_;
  ros::Subscriber tick_sub_;
};
SensorsNode::SensorsNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

SensorsNode::~SensorsNode() = default;

void SensorsNode::drain()
{
  impl_->drain();
}

void SensorsNode::reportCosts() const
{
  impl_->reportCosts();
}

int SensorsNode::spin()
{
  ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
  while (ros::ok())
  {
    queue->callAvailable(ros::WallDuration(0.01));
    impl_->drain();
    impl_->updateDiagnostics();
  }
  impl_->reportCosts();  // after shutdown: rosconsole no longer prints, so plain stdout
  return 0;
}

}  // namespace node
}  // namespace sensors
}  // namespace avsp
