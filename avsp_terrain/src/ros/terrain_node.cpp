// terrain_node's class (the node's main is ../terrain_node.cpp): holds the terrain (default
// course, a DEM raster or a saved terrain), shows it in RViz (/terrain/mesh,
// /terrain/rut_markers, /terrain/objects), applies the ruts other processes publish on
// /terrain/ruts, tracks soil moisture and snow from /environment, and saves the terrain on
// request (~save_map).
//
// Thin: loading, meshing, patch application and moisture live in avsp_terrain_core; this
// file converts parameters and messages. Parameters and topics: avsp_terrain/README.md.
#include "avsp_terrain/ros/terrain_node.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <avsp_msgs/Environment.h>
#include <avsp_msgs/SaveMap.h>
#include <avsp_msgs/ObjectToppled.h>
#include <avsp_msgs/TerrainPatch.h>
#include <avsp_terrain/ros/node_params.hpp>
#include <ros/package.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include "avsp_terrain/default_course.hpp"
#include "avsp_terrain/dem_io.hpp"
#include "avsp_terrain/dynamic_soil.hpp"
#include "avsp_terrain/height_patch.hpp"
#include "avsp_terrain/ros/conversions.hpp"
#include "avsp_terrain/ros/input_diagnostics.hpp"
#include "avsp_terrain/ros/output_folder_params.hpp"
#include "avsp_terrain/terrain_file.hpp"
#include "avsp_terrain/ros/terrain_source_params.hpp"
#include "avsp_terrain/terrain_mesh.hpp"

namespace avsp
{
namespace terrain
{
namespace node
{
namespace at = avsp::terrain;

namespace
{
using avsp::node::StartupError;

double finiteParam(const ros::NodeHandle& pnh, const std::string& key, double fallback, double min_exclusive)
{
  const double value = avsp::node::numberParam(pnh, key, fallback);
  if (!std::isfinite(value) || value <= min_exclusive)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be finite and > " +
                       std::to_string(min_exclusive));
  return value;
}

/// Soil colours for RViz (RGB); unknown soils are magenta so they stand out.
std::array<float, 3> soilColour(const std::string& soil)
{
  if (soil == "asphalt")
    return { 0.25f, 0.25f, 0.27f };
  if (soil == "gravel")
    return { 0.58f, 0.55f, 0.50f };
  if (soil == "dry_sand")
    return { 0.86f, 0.78f, 0.55f };
  if (soil == "sandy_loam")
    return { 0.60f, 0.48f, 0.33f };
  if (soil == "clay")
    return { 0.66f, 0.42f, 0.28f };
  if (soil == "mud")
    return { 0.36f, 0.28f, 0.20f };
  if (soil == "snow")
    return { 0.95f, 0.95f, 0.97f };
  if (soil == "grass_over_loam")
    return { 0.36f, 0.55f, 0.25f };
  return { 0.8f, 0.2f, 0.8f };
}

std::array<float, 4> objectColour(at::ObjectType type)
{
  switch (type)
  {
    case at::ObjectType::kTree:
      return { 0.13f, 0.40f, 0.13f, 1.f };
    case at::ObjectType::kShrub:
      return { 0.25f, 0.50f, 0.18f, 1.f };
    case at::ObjectType::kGrass:
      return { 0.45f, 0.70f, 0.30f, 0.6f };
    case at::ObjectType::kRock:
      return { 0.50f, 0.50f, 0.48f, 1.f };
    case at::ObjectType::kPole:
      return { 0.45f, 0.35f, 0.25f, 1.f };
    case at::ObjectType::kFence:
      return { 0.70f, 0.72f, 0.75f, 0.5f };
    case at::ObjectType::kBarrier:
      return { 0.80f, 0.80f, 0.78f, 1.f };
    case at::ObjectType::kBuilding:
      return { 0.60f, 0.45f, 0.40f, 1.f };
  }
  return { 1.f, 0.f, 1.f, 1.f };
}

}  // namespace

class TerrainNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh) : nh_(nh), pnh_(pnh), soils_(at::SoilLibrary::load(soilsFile(pnh)))
  {
    frame_id_ = avsp::node::stringParam(pnh_, "frame_id", "map");
    if (frame_id_.empty())
      throw StartupError("parameter ~frame_id must not be empty");
    loadTerrain();

    const double mesh_resolution = finiteParam(pnh_, "mesh_resolution", 2.0, 0.0);
    const double chunk_size = finiteParam(pnh_, "mesh_chunk_size", 50.0, 0.0);
    const double dx = terrain_->base().dx();
    const std::size_t step = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(mesh_resolution / dx)));
    const std::size_t chunk_cells =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(chunk_size / (step * dx)))) * step;
    mesher_ =
        std::make_unique<at::TerrainMesher>(terrain_->base().columns(), terrain_->base().rows(), step, chunk_cells);
    rut_lift_ = static_cast<float>(finiteParam(pnh_, "rut_marker_lift", 0.02, -1.0));
    mesh_refresh_period_ = finiteParam(pnh_, "mesh_refresh_period", 10.0, 0.0);

    setUpWeather();
    output_ = at::node::outputFolderFromParams(pnh_);

    // Mesh and rut markers go out as changed chunks; a new subscriber first gets every chunk
    // (a latched topic would only replay the last change).
    mesh_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("/terrain/mesh", 10,
                                                               [this](const ros::SingleSubscriberPublisher& sub) {
                                                                 visualization_msgs::MarkerArray all;
                                                                 all.markers = mesh_markers_;
                                                                 sub.publish(all);
                                                               });
    rut_markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>(
        "/terrain/rut_markers", 10, [this](const ros::SingleSubscriberPublisher& sub) {
          if (rut_markers_.empty())
            return;
          visualization_msgs::MarkerArray all;
          for (const auto& entry : rut_markers_)
            all.markers.push_back(entry.second);
          sub.publish(all);
        });
    objects_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("/terrain/objects", 1, true);
    ruts_pub_ = nh_.advertise<avsp_msgs::TerrainPatch>("/terrain/ruts", 1, true);
    ruts_sub_ = nh_.subscribe("/terrain/ruts", 100, &Impl::onPatch, this);
    environment_sub_ = nh_.subscribe("/environment", 10, &Impl::onEnvironment, this);
    toppled_sub_ = nh_.subscribe("/terrain/toppled", 100, &Impl::onToppled, this);
    save_service_ = pnh_.advertiseService("save_map", &Impl::onSaveMap, this);
    setUpDiagnostics();

    publishObjects();
    mesh_markers_.resize(mesher_->chunkCount());
    for (std::size_t id = 0; id < mesher_->chunkCount(); ++id)
      dirty_chunks_.insert(id);
    publishDirtyChunks();
    publishLoadedRuts();
    ROS_INFO("terrain_node: %zu x %zu points at %.3f m from %s, %zu objects, mesh %zu chunks at %.2f m",
             terrain_->base().columns(), terrain_->base().rows(), dx, source_.c_str(), objects_.size(),
             mesher_->chunkCount(), step * dx);
  }

  /// Publishes the chunks changed since the last call (called from the spin loop, so a burst
  /// of patches becomes one publication).
  void publishDirtyChunks()
  {
    if (dirty_chunks_.empty())
      return;
    visualization_msgs::MarkerArray mesh, ruts;
    for (std::size_t id : dirty_chunks_)
    {
      mesh_markers_[id] = toMarker(mesher_->build(id, *terrain_, colour_), "terrain_mesh");
      mesh.markers.push_back(mesh_markers_[id]);
      const at::MeshChunk deformed = mesher_->buildDeformed(id, *terrain_, rut_colour_, rut_lift_);
      if (deformed.vertices.empty() && !rut_markers_.count(id))
        continue;
      ruts.markers.push_back(toMarker(deformed, "terrain_ruts"));
      if (deformed.vertices.empty())
        rut_markers_.erase(id);  // the DELETE goes out once; new subscribers never see the chunk
      else
        rut_markers_[id] = ruts.markers.back();
    }
    dirty_chunks_.clear();
    mesh_pub_.publish(mesh);
    if (!ruts.markers.empty())
      rut_markers_pub_.publish(ruts);
  }

private:
  static std::string soilsFile(const ros::NodeHandle& pnh)
  {
    const std::string path =
        avsp::node::stringParam(pnh, "soils_file", ros::package::getPath("avsp") + "/config/soils.yaml");
    return path;
  }

  void loadTerrain()
  {
    at::LoadedSource loaded = at::node::loadTerrainFromParams(pnh_, soils_);
    if (loaded.filled_no_data > 0)
      ROS_WARN("terrain_node: %s: %zu no-data points filled from their nearest valid neighbours",
               loaded.description.c_str(), loaded.filled_no_data);
    terrain_ = std::move(loaded.terrain);
    objects_ = std::move(loaded.objects);
    source_ = loaded.description;
  }

  void setUpWeather()
  {
    const std::string weather_soil = avsp::node::stringParam(pnh_, "weather_soil", "sandy_loam");
    if (!soils_.contains(weather_soil))
      throw StartupError("parameter ~weather_soil: no soil '" + weather_soil + "' in the soil library");
    region_size_ = finiteParam(pnh_, "weather_region_size", 25.0, 0.0);
    const at::ElevationGrid& g = terrain_->base();
    const double len_x = (g.columns() - 1) * g.dx(), len_y = (g.rows() - 1) * g.dy();
    region_columns_ = static_cast<std::size_t>(std::ceil(len_x / region_size_));
    region_rows_ = static_cast<std::size_t>(std::ceil(len_y / region_size_));
    weather_soil_ = soils_.get(weather_soil);
    weather_ = std::make_unique<at::SoilWeatherField>(g.originX(), g.originY(), region_size_,
                                                      std::max<std::size_t>(1, region_columns_),
                                                      std::max<std::size_t>(1, region_rows_), weather_soil_);
    shown_weather_ = sampleWeather();

    const double kPi = 3.14159265358979323846;
    // Fixed light from the north-west, 45 deg up: relief is visible on unlit triangle lists.
    const Eigen::Vector3d light = Eigen::Vector3d(-std::cos(kPi / 4), std::cos(kPi / 4), std::sqrt(2.0)).normalized();
    colour_ = [this, light](std::size_t i, std::size_t j) {
      const at::ElevationGrid& grid = terrain_->base();
      const double x = grid.originX() + i * grid.dx(), y = grid.originY() + j * grid.dy();
      std::array<float, 3> c = soilColour(terrain_->soil(i, j).name);
      // Central-difference normal of the deformed surface for the hillshade.
      const std::size_t i0 = i > 0 ? i - 1 : i, i1 = std::min(i + 1, grid.columns() - 1);
      const std::size_t j0 = j > 0 ? j - 1 : j, j1 = std::min(j + 1, grid.rows() - 1);
      const double gx = (terrain_->pointHeight(i1, j) - terrain_->pointHeight(i0, j)) / ((i1 - i0) * grid.dx());
      const double gy = (terrain_->pointHeight(i, j1) - terrain_->pointHeight(i, j0)) / ((j1 - j0) * grid.dy());
      const double shade = 0.55 + 0.45 * std::max(0.0, Eigen::Vector3d(-gx, -gy, 1.0).normalized().dot(light));
      // Wet soil darkens with moisture towards saturation; snow whitens over its first 0.1 m.
      const double wet = std::clamp(weather_->moistureAt(x, y) / weather_soil_.moisture.saturated, 0.0, 1.0);
      const double snow = std::clamp(weather_->snowDepthAt(x, y) / 0.1, 0.0, 1.0);
      for (float& v : c)
        v = static_cast<float>(((1 - snow) * v * (1.0 - 0.35 * wet) + snow * 0.97) * shade);
      return c;
    };
    rut_colour_ = [this](std::size_t i, std::size_t j) {
      std::array<float, 3> c = colour_(i, j);
      for (float& v : c)
        v *= 0.75f;  // ruts read darker than the surface around them
      return c;
    };
  }

  std::vector<std::pair<double, double>> sampleWeather() const
  {
    std::vector<std::pair<double, double>> out;
    const at::ElevationGrid& g = terrain_->base();
    for (std::size_t r = 0; r < std::max<std::size_t>(1, region_rows_); ++r)
      for (std::size_t c = 0; c < std::max<std::size_t>(1, region_columns_); ++c)
      {
        const double x = g.originX() + (c + 0.5) * region_size_, y = g.originY() + (r + 0.5) * region_size_;
        out.emplace_back(weather_->moistureAt(x, y), weather_->snowDepthAt(x, y));
      }
    return out;
  }

  visualization_msgs::Marker toMarker(const at::MeshChunk& chunk, const std::string& ns) const
  {
    visualization_msgs::Marker m;
    m.header.frame_id = frame_id_;
    m.header.stamp = ros::Time(0);
    m.ns = ns;
    m.id = static_cast<int>(chunk.id);
    m.type = visualization_msgs::Marker::TRIANGLE_LIST;
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = m.scale.z = 1.0;
    m.color.a = 1.0;
    if (chunk.vertices.empty())
    {
      m.action = visualization_msgs::Marker::DELETE;
      return m;
    }
    m.action = visualization_msgs::Marker::ADD;
    m.points.resize(chunk.vertices.size());
    m.colors.resize(chunk.vertices.size());
    for (std::size_t k = 0; k < chunk.vertices.size(); ++k)
    {
      m.points[k].x = chunk.vertices[k][0];
      m.points[k].y = chunk.vertices[k][1];
      m.points[k].z = chunk.vertices[k][2];
      m.colors[k].r = chunk.colours[k][0];
      m.colors[k].g = chunk.colours[k][1];
      m.colors[k].b = chunk.colours[k][2];
      m.colors[k].a = 1.0f;
    }
    return m;
  }

  void publishObjects()
  {
    visualization_msgs::MarkerArray array;
    for (const at::TerrainObject& o : objects_.all())
    {
      visualization_msgs::Marker m;
      m.header.frame_id = frame_id_;
      m.ns = at::toString(o.type);
      m.id = static_cast<int>(o.id);
      m.action = visualization_msgs::Marker::ADD;
      const bool round = o.type == at::ObjectType::kTree || o.type == at::ObjectType::kShrub ||
                         o.type == at::ObjectType::kPole || o.type == at::ObjectType::kRock;
      m.type = o.type == at::ObjectType::kRock ? visualization_msgs::Marker::SPHERE
               : round                         ? visualization_msgs::Marker::CYLINDER
                                               : visualization_msgs::Marker::CUBE;
      const auto colour = objectColour(o.type);
      m.color.r = colour[0];
      m.color.g = colour[1];
      m.color.b = colour[2];
      m.color.a = colour[3];
      const double ground = terrain_->height(o.x, o.y).value_or(0.0);
      m.scale.x = o.length;
      m.scale.y = o.width;
      m.scale.z = std::max(o.height, 0.02);
      // Standing: yaw about z, centred half its height above the ground. Toppled: lying along
      // its fall direction (a quarter turn about the horizontal axis across the fall).
      double yaw = o.yaw, pitch = 0.0;
      double cx = o.x, cy = o.y, cz = ground + 0.5 * m.scale.z;
      if (o.toppled)
      {
        yaw = o.fall_direction;
        pitch = 1.5707963267948966;
        cx += 0.5 * m.scale.z * std::cos(o.fall_direction);
        cy += 0.5 * m.scale.z * std::sin(o.fall_direction);
        cz = ground + 0.5 * std::min(o.length, o.width);
      }
      m.pose.position.x = cx;
      m.pose.position.y = cy;
      m.pose.position.z = cz;
      // q = yaw about z, then pitch about the new y axis (z-y intrinsic).
      m.pose.orientation.w = std::cos(yaw / 2) * std::cos(pitch / 2);
      m.pose.orientation.x = -std::sin(yaw / 2) * std::sin(pitch / 2);
      m.pose.orientation.y = std::cos(yaw / 2) * std::sin(pitch / 2);
      m.pose.orientation.z = std::sin(yaw / 2) * std::cos(pitch / 2);
      array.markers.push_back(m);
    }
    objects_pub_.publish(array);
  }

  void publishLoadedRuts()
  {
    const auto points = terrain_->statefulPoints();
    if (points.empty())
      return;
    // One latched patch over all loaded ruts, so a consumer that starts later still gets them.
    at::PointRange all{ terrain_->base().columns(), terrain_->base().rows(), 0, 0 };
    for (const auto& [i, j] : points)
    {
      all.i0 = std::min(all.i0, i);
      all.j0 = std::min(all.j0, j);
      all.i1 = std::max(all.i1, i);
      all.j1 = std::max(all.j1, j);
    }
    std_msgs::Header header;
    header.frame_id = frame_id_;
    header.stamp = ros::Time::now();
    const avsp_msgs::TerrainPatch msg = at::node::toTerrainPatch(at::extractPatch(*terrain_, all), header);
    ruts_pub_.publish(msg);
    ROS_INFO("terrain_node: published the loaded ruts on /terrain/ruts (%u x %u points)", msg.width, msg.height);
  }

  /// An object a vehicle pushed over (dynamics_node): it lies down in /terrain/objects and in
  /// saved maps. Bad reports (unknown id, rigid object, NaN direction, other frame) are ignored
  /// with a warning.
  void onToppled(const avsp_msgs::ObjectToppled& msg)
  {
    std::string why;
    if (!msg.header.frame_id.empty() && msg.header.frame_id != frame_id_)
      why = "frame '" + msg.header.frame_id + "', expected '" + frame_id_ + "'";
    else if (objects_.applyToppled(msg.id, msg.fall_direction, why))
    {
      ++toppled_.applied;
      publishObjects();
      return;
    }
    ++toppled_.ignored;
    ROS_WARN_THROTTLE(5.0, "terrain_node: /terrain/toppled ignored: %s", why.c_str());
  }

  void onPatch(const ros::MessageEvent<const avsp_msgs::TerrainPatch>& event)
  {
    if (event.getPublisherName() == ros::this_node::getName())
      return;  // our own publication of loaded ruts
    const avsp_msgs::TerrainPatch& msg = *event.getMessage();
    if (!msg.header.frame_id.empty() && msg.header.frame_id != frame_id_)
    {
      ++ruts_.ignored;
      ROS_WARN_THROTTLE(5.0, "terrain_node: /terrain/ruts from %s in frame '%s', expected '%s'; ignored",
                        event.getPublisherName().c_str(), msg.header.frame_id.c_str(), frame_id_.c_str());
      return;
    }
    try
    {
      const std::optional<at::PointRange> range = at::applyPatch(*terrain_, at::node::heightPatchFromMessage(msg));
      ++ruts_.applied;
      if (!range)
        return;
      for (std::size_t id : mesher_->chunksTouching(*range))
        dirty_chunks_.insert(id);
    }
    catch (const at::PatchError& e)
    {
      ++ruts_.ignored;
      ROS_WARN_THROTTLE(5.0, "terrain_node: /terrain/ruts from %s rejected: %s", event.getPublisherName().c_str(),
                        e.what());
    }
  }

  void onEnvironment(const avsp_msgs::Environment& msg)
  {
    const double rain = msg.rain_rate_mm_h, snow = msg.snow_rate_mm_h;
    if (!std::isfinite(rain) || rain < 0.0 || !std::isfinite(snow) || snow < 0.0)
    {
      ++environment_.ignored;
      ROS_WARN_THROTTLE(5.0,
                        "terrain_node: /environment rain_rate_mm_h %g / snow_rate_mm_h %g must be finite and "
                        ">= 0; message ignored, soil kept as it was",
                        rain, snow);
      return;
    }
    ++environment_.applied;
    const ros::Time stamp = msg.header.stamp;
    if (last_environment_.isZero())
    {
      last_environment_ = stamp;
      last_recolour_ = stamp;
      last_rain_ = rain;
      last_snow_ = snow;
      return;
    }
    const double dt = (stamp - last_environment_).toSec();
    if (dt < 0.0)
    {
      ROS_WARN_THROTTLE(5.0, "terrain_node: /environment stamp went back by %.3f s; restarting its clock", -dt);
      last_environment_ = stamp;
      return;
    }
    last_environment_ = stamp;
    // Rates hold from the previous message to this one.
    weather_->advance(dt, last_rain_, last_snow_);
    last_rain_ = rain;
    last_snow_ = snow;
    if ((stamp - last_recolour_).toSec() < mesh_refresh_period_)
      return;
    const auto now = sampleWeather();
    bool changed = false;
    for (std::size_t k = 0; k < now.size() && !changed; ++k)
      changed = std::abs(now[k].first - shown_weather_[k].first) > 0.01 ||
                std::abs(now[k].second - shown_weather_[k].second) > 0.005;
    if (!changed)
      return;
    shown_weather_ = now;
    last_recolour_ = stamp;
    for (std::size_t id = 0; id < mesher_->chunkCount(); ++id)
      dirty_chunks_.insert(id);
  }

  bool onSaveMap(avsp_msgs::SaveMap::Request& req, avsp_msgs::SaveMap::Response& res)
  {
    res.success = false;
    try
    {
      const std::string path = at::resolveOutputPath(req.path, output_);
      const std::string ext = at::fileExtension(path);
      if (ext == ".avspterrain")
        at::writeThroughTemporary(path, [&](const std::string& tmp) { at::saveTerrain(tmp, *terrain_, objects_); });
      else if (ext == ".asc" || ext == ".tif" || ext == ".tiff")
      {
        const at::ElevationGrid& g = terrain_->base();
        at::HeightRaster raster;
        raster.origin_x = g.originX();
        raster.origin_y = g.originY();
        raster.cell_size = g.dx();
        raster.columns = g.columns();
        raster.rows = g.rows();
        raster.heights.resize(g.columns() * g.rows());
        for (std::size_t j = 0; j < g.rows(); ++j)
          for (std::size_t i = 0; i < g.columns(); ++i)
            raster.heights[j * g.columns() + i] = static_cast<float>(terrain_->pointHeight(i, j));
        at::writeThroughTemporary(path, [&](const std::string& tmp) {
          if (ext == ".asc")
            at::writeAsciiGrid(raster, tmp);
          else
            at::writeGeoTiff(raster, tmp);
        });
      }
      else
        throw at::OutputFileError("path '" + path + "': unknown extension '" + ext +
                                  "' (.avspterrain: full state, bit-exact; .asc, .tif: deformed heights)");
      res.success = true;
      res.message = path;
      ROS_INFO("terrain_node: saved the terrain to %s", path.c_str());
    }
    catch (const std::exception& e)
    {
      res.message = e.what();
      ROS_WARN("terrain_node: ~save_map refused: %s", e.what());
    }
    return true;
  }

  ros::NodeHandle& nh_;
  ros::NodeHandle& pnh_;
  std::string frame_id_;
  std::string source_;
  at::OutputFolder output_;  // where ~save_map may write
  at::SoilLibrary soils_;
  std::unique_ptr<at::DeformableTerrain> terrain_;
  at::ObjectSet objects_;
  std::unique_ptr<at::TerrainMesher> mesher_;
  at::PointColour colour_, rut_colour_;
  float rut_lift_ = 0.02f;
  std::set<std::size_t> dirty_chunks_;
  std::vector<visualization_msgs::Marker> mesh_markers_;           ///< by chunk id, as last published
  std::map<std::size_t, visualization_msgs::Marker> rut_markers_;  ///< chunks that show ruts

  at::SoilParameters weather_soil_;
  std::unique_ptr<at::SoilWeatherField> weather_;
  double region_size_ = 25.0;
  std::size_t region_columns_ = 1, region_rows_ = 1;
  std::vector<std::pair<double, double>> shown_weather_;
  ros::Time last_environment_, last_recolour_;
  double last_rain_ = 0.0, last_snow_ = 0.0;
  double mesh_refresh_period_ = 10.0;

  ros::Publisher mesh_pub_, rut_markers_pub_, objects_pub_, ruts_pub_;
  ros::Subscriber ruts_sub_, environment_sub_, toppled_sub_;
  ros::ServiceServer save_service_;

  // ---- /diagnostics (diagnostic_updater): "<node>: inputs" every ~diagnostic_period of sim
  // time, the messages applied and ignored per input topic.
public:
  void setUpDiagnostics()
  {
    // Validated here; diagnostic_updater reads the same parameter itself.
    avsp::node::boundedParam(pnh_, "diagnostic_period", 1.0, 0.01, 3600.0);
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
    diagnostics_->setHardwareID(ros::this_node::getName());
    diagnostics_->add("inputs", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { inputStatus(s); });
  }

  void updateDiagnostics() { diagnostics_->update(); }

private:
  struct InputCount
  {
    std::uint64_t applied = 0, ignored = 0;
  };

  void inputStatus(diagnostic_updater::DiagnosticStatusWrapper& s)
  {
    const std::pair<const char*, const InputCount*> inputs[] = { { "/terrain/ruts", &ruts_ },
                                                                 { "/terrain/toppled", &toppled_ },
                                                                 { "/environment", &environment_ } };
    std::uint64_t ignored = 0;
    for (const auto& [topic, count] : inputs)
    {
      s.add(std::string(topic) + " applied", count->applied);
      s.add(std::string(topic) + " ignored", count->ignored);
      ignored += count->ignored;
    }
    s.add("mesh chunks waiting", dirty_chunks_.size());
    avsp::node::summarizeIgnoredInputs(s, ignored, ignored_reported_);
  }

  InputCount ruts_, toppled_, environment_;
  std::uint64_t ignored_reported_ = 0;  ///< ignored messages at the last diagnostics publication
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
};
TerrainNode::TerrainNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

TerrainNode::~TerrainNode() = default;

void TerrainNode::publishDirtyChunks()
{
  impl_->publishDirtyChunks();
}

int TerrainNode::spin()
{
  // Spin, then publish the chunks the callbacks changed: a burst of patches is one update.
  ros::WallRate rate(20.0);
  while (ros::ok())
  {
    ros::spinOnce();
    impl_->publishDirtyChunks();
    impl_->updateDiagnostics();
    rate.sleep();
  }
  return 0;
}

}  // namespace node
}  // namespace terrain
}  // namespace avsp
