#pragma once
/**
 * @file lidar.hpp
 * @brief Rotating multi-channel lidar (docs/MODELS.md section 4): presets with the published channel
 *        angles and firing rates of the Velodyne VLP-16, HDL-32E, HDL-64E and Ouster OS1-64, or a
 *        custom configuration; per-point firing time and the vehicle's motion during the
 *        sweep; beam divergence as N sub-rays per pulse whose returns are summed into echoes
 *        (strongest or last); intensity from reflectivity and incidence angle; range noise,
 *        dropout, a detection threshold, and weather (fog/rain/snow extinction, false returns
 *        from falling precipitation). Points are x, y, z, intensity, ring, time, in a
 *        pcl::PointCloud (LidarPoint, point_types.hpp).
 */
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/point_types.hpp"
#include "avsp_sensors/primitives.hpp"
#include "avsp_sensors/weather.hpp"

namespace avsp
{
namespace sensors
{
class Scene;

/// Which echo of a pulse becomes the point.
enum class ReturnMode : std::uint8_t
{
  kStrongest,  ///< the echo with the most received power
  kLast,       ///< the farthest detected echo (sees through rain, snow and foliage edges)
};

/// One laser (channel) of the sensor.
struct LidarChannel
{
  double elevation = 0.0;       ///< rad, above the sensor's x-y plane
  double azimuth_offset = 0.0;  ///< rad, added to the column's azimuth (counter-clockwise)
  double time_offset = 0.0;     ///< s after the column's firing time
};

/**
 * @brief A lidar's configuration. Angles in rad, times in s, lengths in m.
 *
 * Sensor frame: x forward, y left, z up (REP 103). Column c fires at t_c = c / (rate columns)
 * after the sweep start; channel k at t_c + time_offset_k, along azimuth
 * start_azimuth -/+ 2 pi rate t (clockwise/counter-clockwise) + azimuth_offset_k.
 */
struct LidarConfig
{
  std::string name = "custom";
  std::vector<LidarChannel> channels;  ///< in firing order; ring = rank by elevation (0 = lowest)
  double rotation_rate = 10.0;         ///< revolutions per second, > 0
  std::size_t columns = 1024;          ///< firings (azimuth steps) per revolution, >= 1
  bool clockwise = true;               ///< spin seen from above (Velodyne and Ouster: clockwise)
  double start_azimuth = 0.0;          ///< rad, azimuth of column 0
  double min_range = 0.5;              ///< m, echoes nearer than this are not reported, >= 0
  double max_range = 100.0;            ///< m, rays are cast this far (the range gate), > min_range
  /// Detection threshold: a target of reference_reflectivity at normal incidence in clear air
  /// is detected out to reference_range; received power scales as rho cos(i) T^2 / R^2.
  double reference_range = 100.0;         ///< m, > 0
  double reference_reflectivity = 0.8;    ///< (0, 1]
  double range_noise = 0.02;              ///< m, standard deviation of the range, >= 0
  double dropout = 0.0;                   ///< probability a pulse returns nothing, [0, 1]
  double divergence_horizontal = 3.0e-3;  ///< rad, full angle along the scan, >= 0
  double divergence_vertical = 1.5e-3;    ///< rad, full angle across the scan, >= 0
  double aperture_radius = 0.005;         ///< m, r of docs/MODELS.md 4, >= 0
  double target_scale = 0.1;              ///< m, x of docs/MODELS.md 4 (scale of the scene's detail), > 0
  std::size_t sub_rays = 0;               ///< 0: N from docs/MODELS.md 4's formula; else exactly this many
  ReturnMode return_mode = ReturnMode::kStrongest;
  double echo_separation = 1.0;       ///< m, sub-ray hits closer in range merge into one echo, >= 0
  double wavelength = 905e-9;         ///< m, for the fog law
  double clutter_max_range = 10.0;    ///< m, falling particles farther than this are too faint, >= 0
  double clutter_efficiency = 1.0;    ///< share of particle interceptions that echo, [0, 1]
  float clutter_reflectivity = 0.1f;  ///< apparent reflectivity of a particle echo, [0, 1]
};

/// Names lidarPreset() knows: "VLP-16", "HDL-32E", "HDL-64E", "OS1-64".
std::vector<std::string> lidarPresetNames();

/**
 * @brief A published sensor's configuration (sources in README.md, "Lidar presets").
 * @throw std::invalid_argument naming the preset and listing the known names when unknown
 */
LidarConfig lidarPreset(const std::string& name);

/// @throw std::invalid_argument naming the field (channels empty, a value out of range or NaN)
void validateLidarConfig(const LidarConfig& config);

/**
 * @brief Sub-rays per pulse: config.sub_rays if set, else docs/MODELS.md 4's
 *        N = ceil(2 [r + R_max tan(theta / 2)] / x), theta the larger divergence, at least 1.
 */
std::size_t subRayCount(const LidarConfig& config);

/**
 * @brief The sensor's motion during a sweep: pose at the sweep start and a constant twist.
 *        pose(t): rotation exp([w] t) R0, position p0 + v t.
 */
struct SensorMotion
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();      ///< sensor frame -> map at t = 0
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< m/s, map, of the sensor origin
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, map

  /// Pose at t s after the sweep start.
  Eigen::Isometry3d at(double t) const;
};

/// @throw std::invalid_argument naming the field: non-finite pose, velocity or angular velocity,
///        or a pose whose rotation is not orthonormal
void validateMotion(const SensorMotion& motion, const char* context);

/// What to scan.
struct LidarScanRequest
{
  SensorMotion motion;
  Weather weather;
  std::uint64_t sweep = 0;  ///< sweep number: with the seed, fixes every random draw
  bool registered = true;   ///< true: points in the map (each at its firing pose); false: sensor frame at firing time
  unsigned threads = 1;     ///< 0 = all cores; any count gives the same points
  std::uint32_t ignore_body = PrimitiveBvh::kNoId;  ///< the vehicle carrying the sensor
};

/// One sweep's points and counts.
struct LidarScan
{
  /// Column by column, channels in firing order; pulses without a return omitted. A PCL cloud
  /// (point_types.hpp): PCL's algorithms read it and pcl::toROSMsg publishes it as it is.
  LidarCloud points;
  std::size_t pulses = 0;   ///< channels x columns
  std::size_t rays = 0;     ///< sub-rays cast
  std::size_t dropped = 0;  ///< pulses lost to `dropout`
  std::size_t clutter = 0;  ///< points that are false returns from precipitation
  /// Per point of `points`: true for a falling particle's echo (one of the `clutter` points). A
  /// map of the solid world leaves these out (OccupancyMap::insert), as a real pipeline's
  /// weather filter would; the cloud keeps them.
  std::vector<bool> particle_echo;
  double duration = 0.0;  ///< s, one revolution
  bool registered = true;
};

namespace detail
{
struct SubHit;       ///< lidar.cpp: one sub-ray's hit as the echo builder needs it
struct PulseResult;  ///< lidar.cpp: what one pulse produced
}  // namespace detail

/**
 * @brief A lidar with a fixed configuration and random seed.
 *
 * Per pulse: N sub-rays spread over the beam's footprint (radius r + R tan(theta / 2) at range
 * R) each cast exactly; each sub-ray that hits contributes rho cos(i) T^2 / N (T^2 the two-way
 * weather transmission) to the echo of its range; sub-ray ranges closer than echo_separation
 * form one echo at their power-weighted mean range. A falling particle may add an echo nearer
 * than the first hit. Echoes whose power rho_app / R^2 falls below the reference target's
 * rho_ref / R_ref^2 are not detected; of the rest the strongest or last is reported, at the
 * echo's range (plus Gaussian noise) along the beam's axis. Each pulse draws its random numbers
 * in a fixed order from its own stream (seed, sweep, pulse), so changing the weather changes
 * no pulse's draws.
 */
class Lidar
{
public:
  /// @throw std::invalid_argument (validateLidarConfig)
  Lidar(LidarConfig config, std::uint64_t seed);

  const LidarConfig& config() const { return config_; }
  std::size_t subRays() const { return sub_offsets_.size(); }
  /// Ring of channel k (its rank by elevation, 0 = lowest).
  std::uint16_t ring(std::size_t channel) const { return rings_.at(channel); }

  /**
   * @brief One revolution.
   * @throw std::invalid_argument naming the field for a bad motion or weather
   */
  LidarScan scan(const Scene& scene, const LidarScanRequest& request) const;

private:
  struct SweepConstants;
  /// Casts pulse `channel` of column `col` into out (subs: scratch for its sub-ray echoes).
  void firePulse(const Scene& scene, const LidarScanRequest& req, const SweepConstants& k, std::size_t col,
                 std::size_t channel, std::vector<detail::SubHit>& subs, detail::PulseResult& out) const;

  LidarConfig config_;
  std::uint64_t seed_;
  std::vector<std::uint16_t> rings_;
  std::vector<Eigen::Vector2d> sub_offsets_;  ///< unit-disc positions of the sub-rays
};

}  // namespace sensors
}  // namespace avsp
