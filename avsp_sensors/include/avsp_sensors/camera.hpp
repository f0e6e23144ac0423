#pragma once
/**
 * @file camera.hpp
 * @brief Ray-traced cameras over the sensors' Scene: per pixel one ray through the same ray
 *        caster the lidar uses gives depth (along the optical axis), a semantic class id, an RGB
 *        value lit by the sun (hard shadow ray), the sky and the moon, fogged toward the sky
 *        with the lidar's visibility, and a surface temperature (thermal mode). Pinhole
 *        (sensor_msgs/CameraInfo plumb_bob) and equidistant fisheye projections; optical frame
 *        z forward, x right, y down (REP 103). Formulas: README.md, "Cameras".
 */
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/scene.hpp"
#include "avsp_sensors/weather.hpp"

namespace avsp
{
namespace terrain
{
class ObjectSet;
}

namespace sensors
{
/// How pixels map to rays.
enum class CameraProjection : std::uint8_t
{
  kPinhole,  ///< x = fx X/Z + cx (plumb_bob distortion applied when given)
  kFisheye,  ///< equidistant: r = f theta (theta from the optical axis), ROS "equidistant", D = 0
};

/// Fixed semantic class ids (uint8 per pixel). Terrain of soil palette index k is kSoilBase + k
/// (except asphalt, which is kRoad). The table with names: classTable().
enum SemanticClass : std::uint8_t
{
  kClassNone = 0,        ///< nothing within max_range (sky)
  kClassTerrain = 1,     ///< terrain of an unknown soil
  kClassRoad = 2,        ///< asphalt
  kClassVegetation = 3,  ///< tree, shrub, grass
  kClassRock = 4,
  kClassBuilding = 5,
  kClassBarrier = 6,
  kClassFence = 7,
  kClassVehicle = 8,
  kClassPerson = 9,
  kClassAnimal = 10,
  kClassPole = 11,
  kClassSoilBase = 32,  ///< terrain of soil k: 32 + k (k < 200)
  kClassUnknown = 255,  ///< an object or body id the materials do not know
};

/// One row of the class table.
struct ClassEntry
{
  std::uint8_t id = 0;
  std::string name;  ///< e.g. "vehicle", "terrain/sandy_loam"
};

/// Seasons change vegetation colour (README, "Cameras").
enum class Season : std::uint8_t
{
  kSpring,
  kSummer,
  kFall,
  kWinter,
};

/// Season of a UTC month (1-12) at a latitude (deg): meteorological seasons, flipped south.
Season seasonOf(int month, double latitude_deg);

/// What a terrain soil looks like.
struct SoilLook
{
  std::string name = "soil";                      ///< soil name (class "terrain/<name>", asphalt = road)
  Eigen::Vector3f albedo{ 0.30f, 0.27f, 0.22f };  ///< linear RGB diffuse reflectance when dry
  float wetness = 0.f;                            ///< moisture / saturated moisture, [0, 1]
};

/**
 * @brief Visible albedo of a soil by its name (soils.yaml's names; others get a generic brown).
 *        Representative round values (README), not measurements.
 */
Eigen::Vector3f soilAlbedo(const std::string& name);

/**
 * @brief What the camera needs beyond geometry: the soil of each terrain grid point, the type
 *        of each terrain object, the class and temperature of each body.
 */
class CameraMaterials
{
public:
  /// One generic soil everywhere, no objects, every body a vehicle.
  CameraMaterials();

  /**
   * @brief Soils per grid point (the terrain's palette and soil map; an empty map: soil 0
   *        everywhere). The map must match the lattice of the Scene's HeightField at render time.
   * @throw std::invalid_argument naming the field: empty palette or more than 200 soils,
   *        wetness outside [0, 1], albedo outside [0, 1], a map index not in the palette
   */
  void setSoils(std::vector<SoilLook> palette, std::vector<std::uint8_t> soil_map);
  /// Object id -> type, from the terrain's objects (call again when the set changes ids).
  void setObjects(const terrain::ObjectSet& objects);
  /**
   * @brief Class (kClassVehicle, kClassPerson, kClassAnimal, ...) and surface temperature of a
   *        body id. Bodies not set are vehicles at air temperature + vehicle_warmth.
   * @param temperature K, > 0, or NaN for the class's default (README)
   */
  void setBody(std::uint32_t id, std::uint8_t semantic_class,
               double temperature = std::numeric_limits<double>::quiet_NaN());

  /// The class of a hit (kClassNone for a miss). `terrain` locates the soil of a ground hit.
  std::uint8_t classOf(const RayHit& hit, const HeightField& terrain) const;
  /// Soil palette index at map (x, y) (nearest grid point; 0 without a map).
  std::size_t soilAt(const HeightField& terrain, double x, double y) const;

  /// The class table: fixed classes + one per soil.
  std::vector<ClassEntry> classTable() const;

  const std::vector<SoilLook>& soils() const { return soils_; }
  /// Body temperature, K (NaN: the class default).
  double bodyTemperature(std::uint32_t id) const;

private:
  std::vector<SoilLook> soils_;
  std::vector<std::uint8_t> soil_map_;
  std::vector<std::uint8_t> soil_class_;
  std::unordered_map<std::uint32_t, std::uint8_t> object_class_;
  struct BodyLook
  {
    std::uint8_t cls = kClassVehicle;
    double temperature = std::numeric_limits<double>::quiet_NaN();
  };
  std::unordered_map<std::uint32_t, BodyLook> bodies_;
};

/// The sky and weather a camera sees (from avsp_msgs/Environment).
struct CameraEnvironment
{
  Eigen::Vector3d sun_direction{ 0.5403023058681398, 0.0, 0.8414709848078965 };  ///< unit, map (ENU), toward the sun
  double sun_elevation = 1.0;                                  ///< rad (the default: 57 deg, from the east)
  Eigen::Vector3d moon_direction = -Eigen::Vector3d::UnitZ();  ///< unit, map
  double moon_elevation = -1.0;                                ///< rad
  double moon_illumination = 0.0;                              ///< [0, 1]
  double air_temperature = 288.15;                             ///< K
  Weather weather;                                             ///< fog visibility, rain, snow
  Season season = Season::kSummer;
  double snow_cover = 0.0;       ///< [0, 1], fraction of upward surfaces under snow
  double surface_wetness = 0.0;  ///< [0, 1], added to every soil's own wetness (rain)
};

/// @throw std::invalid_argument naming the field (non-unit directions, NaN, ranges)
void validateCameraEnvironment(const CameraEnvironment& env);

/// Light the sky gives, lx (derived from the sun and moon elevation; README "Cameras").
struct SkyLight
{
  double sun_normal = 0.0;                       ///< lx on a surface facing the sun (direct beam)
  double sky_horizontal = 0.0;                   ///< lx, diffuse sky (and twilight, starlight) on a horizontal surface
  double moon_normal = 0.0;                      ///< lx on a surface facing the moon
  double horizontal_total = 0.0;                 ///< lx, everything on a horizontal surface
  Eigen::Vector3f sky_zenith{ 1.f, 1.f, 1.f };   ///< relative colour, luminance 1
  Eigen::Vector3f sky_horizon{ 1.f, 1.f, 1.f };  ///< relative colour, luminance 1
};

/// The sky's light for an environment.
SkyLight skyLight(const CameraEnvironment& env);

/// One camera.
struct CameraConfig
{
  std::string name = "camera";
  CameraProjection projection = CameraProjection::kPinhole;
  int width = 640, height = 480;     ///< pixels, 1..8192
  double hfov = 1.5707963267948966;  ///< rad, horizontal field of view (fisheye: up to 2 pi)
  double rate = 10.0;                ///< Hz, frames per second (sim time)
  /// plumb_bob k1, k2, p1, p2, k3 (pinhole only); all zero = no distortion.
  std::array<double, 5> distortion{ { 0.0, 0.0, 0.0, 0.0, 0.0 } };
  double stereo_tx = 0.0;     ///< m, P's Tx / fx: -baseline for the right camera of a pair
  double max_range = 1000.0;  ///< m, rays end here (sky beyond)
  bool rgb = true, depth = true, semantic = true, thermal = false;  ///< outputs
  bool shadows = true;                                              ///< a shadow ray toward the sun per lit pixel
  double shadow_range = 300.0;                                      ///< m, length of the shadow rays
  double min_exposure_lux = 50.0;                     ///< lx: auto-exposure's limit (the sensor's highest gain)
  double sky_gain = 2.0;                              ///< sky radiance / (horizontal sky illuminance / pi)
  double fog_contrast_threshold = 0.02;               ///< epsilon of the visibility definition: alpha = -ln(eps) / V
  double thermal_min = 253.15, thermal_max = 323.15;  ///< K, mono8 thermal image range
  bool precipitation = true;                          ///< draw seeded rain streaks and snowflakes on the RGB image
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();  ///< camera body (x fwd, y left, z up) in base_link
};

/// @throw std::invalid_argument "CameraConfig '<name>': <field> ..." for a bad field
void validateCameraConfig(const CameraConfig& config);

/// sensor_msgs/CameraInfo content.
struct CameraIntrinsics
{
  int width = 0, height = 0;
  std::string distortion_model;  ///< "plumb_bob" or "equidistant"
  std::vector<double> D;         ///< 5 (plumb_bob) or 4 (equidistant)
  std::array<double, 9> K{};     ///< row-major
  std::array<double, 9> R{};     ///< identity (monocular)
  std::array<double, 12> P{};    ///< row-major, P[3] = fx * stereo_tx
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

/// The intrinsics: fx = fy = (width / 2) / tan(hfov / 2) (fisheye: (width / 2) / (hfov / 2)),
/// cx = (width - 1) / 2, cy = (height - 1) / 2 (pixel centres at integer coordinates).
CameraIntrinsics cameraIntrinsics(const CameraConfig& config);

/// Optical frame in the camera body frame: z forward (= body x), x right (= -body y), y down.
Eigen::Matrix3d opticalFromBody();

/// One rendered frame; empty vectors for outputs not asked for.
struct CameraFrame
{
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;       ///< rgb8, sRGB-encoded, row-major, 3 per pixel
  std::vector<float> radiance;         ///< linear RGB before encoding (1 = white in the open), 3 per pixel (with rgb)
  std::vector<float> depth;            ///< 32FC1, m along the optical axis; +inf: nothing within max_range
  std::vector<std::uint8_t> semantic;  ///< class ids
  std::vector<float> temperature;      ///< K (thermal)
  std::vector<std::uint8_t> thermal;   ///< mono8 of temperature over [thermal_min, thermal_max]
  double exposure_lux = 0.0;           ///< lx that map to radiance 1
};

/// A camera: fixed per-pixel rays, rendered from a pose.
class Camera
{
public:
  /// @throw std::invalid_argument (validateCameraConfig)
  explicit Camera(CameraConfig config);

  const CameraConfig& config() const { return config_; }
  const CameraIntrinsics& intrinsics() const { return intrinsics_; }
  /// Unit ray through the centre of pixel (u, v), optical frame.
  const Eigen::Vector3f& pixelRay(int u, int v) const { return rays_[static_cast<std::size_t>(v) * config_.width + u]; }
  /// Projects an optical-frame point to pixel coordinates (false behind the camera / outside fisheye).
  bool project(const Eigen::Vector3d& p_optical, Eigen::Vector2d& uv) const;

  /**
   * @brief Renders the scene from `optical_pose` (optical frame -> map).
   * @param ignore_body body id of the camera's own vehicle (not seen; still casts shadows)
   * @param threads 0 = all cores; output does not depend on it
   * @param noise_key seed of this frame's rain streaks and snowflakes (same key, same image)
   * @throw std::invalid_argument for a non-finite pose or a bad environment
   */
  CameraFrame render(const Scene& scene, const CameraMaterials& materials, const Eigen::Isometry3d& optical_pose,
                     const CameraEnvironment& env, unsigned threads, std::uint32_t ignore_body = PrimitiveBvh::kNoId,
                     std::uint64_t noise_key = 0) const;

private:
  CameraConfig config_;
  CameraIntrinsics intrinsics_;
  std::vector<Eigen::Vector3f> rays_;
};

/**
 * @brief Draws the frame's rain streaks and snowflakes on its linear radiance (README,
 *        "Cameras"): counts from the rain and snow rates, positions from `key` only.
 * @param light radiance of a white surface lit by the scene's horizontal light, [0, 1]
 */
void drawPrecipitation(CameraFrame& frame, const CameraEnvironment& env, float light, std::uint64_t key);

/// sRGB transfer function of a linear value (clamped to [0, 1]) to 8 bits.
std::uint8_t encodeSrgb(float linear);

}  // namespace sensors
}  // namespace avsp
