#pragma once
/**
 * @file ultrasonic.hpp
 * @brief Ultrasonic range finder (docs/MODELS.md section 4: short range, like radar in a narrow
 *        cone): the cone is sampled by a few rays cast through the Scene; the nearest hit is the
 *        range, with sensor_msgs/Range semantics (REP 117: +inf when nothing is within
 *        max_range, -inf when something is nearer than min_range). No ROS types.
 */
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/noise.hpp"
#include "avsp_sensors/primitives.hpp"

namespace avsp
{
namespace sensors
{
class Scene;

/**
 * @brief Ultrasonic sensor parameters. Sensor frame: x along the cone's axis (REP 103).
 *
 * Defaults: the HC-SR04 module's data sheet (2 cm - 4 m, 15 deg measuring angle, a measurement
 * cycle of at least 60 ms); 10 Hz and the 1 cm noise are assumptions.
 */
struct UltrasonicConfig
{
  double rate = 10.0;                         ///< Hz, > 0
  double field_of_view = 0.2617993877991494;  ///< rad, full cone angle (15 deg), (0, pi)
  double min_range = 0.02;                    ///< m, >= 0
  double max_range = 4.0;                     ///< m, > min_range
  double noise = 0.01;                        ///< m, range noise (1 sigma), >= 0
  std::size_t rings = 2;                      ///< rings of rays around the axis (the last on the cone's edge), >= 1
  std::size_t rays_per_ring = 8;              ///< rays on each ring, >= 3
};

/// @throw std::invalid_argument naming the field ("UltrasonicConfig: max_range must be ...")
void validateUltrasonicConfig(const UltrasonicConfig& config);

/// One reading, what sensor_msgs/Range carries (radiation_type ULTRASOUND).
struct UltrasonicReading
{
  double time = 0.0;           ///< s
  double range = 0.0;          ///< m; +inf: nothing within max_range; -inf: nearer than min_range
  double field_of_view = 0.0;  ///< rad
  double min_range = 0.0;      ///< m
  double max_range = 0.0;      ///< m
  bool detected = false;       ///< a finite range in [min_range, max_range]
};

/**
 * @brief A cone-shaped range finder. Rays: the axis, then `rings` rings at half-angles
 *        k/rings * fov/2 (k = 1..rings), `rays_per_ring` rays each (successive rings rotated by
 *        half a step). The nearest hit's range plus Gaussian noise (clamped to [min, max]) is
 *        reported.
 */
class Ultrasonic
{
public:
  /// @throw std::invalid_argument (validateUltrasonicConfig)
  Ultrasonic(UltrasonicConfig config, std::uint64_t seed);

  const UltrasonicConfig& config() const { return config_; }
  /// Ray directions in the sensor frame (unit vectors; the first is the axis +x).
  const std::vector<Eigen::Vector3d>& rayDirections() const { return directions_; }

  bool due(double t) const { return clock_.due(t); }

  /**
   * @brief One reading at time t (s) from the sensor's pose (sensor frame -> map).
   * @param ignore_body the body carrying the sensor, not to be seen
   * @throw std::invalid_argument for a non-finite time or pose, a rotation that is not
   *        orthonormal, or a time earlier than the last reading
   */
  UltrasonicReading measure(const Scene& scene, double t, const Eigen::Isometry3d& sensor_pose,
                            std::uint32_t ignore_body = PrimitiveBvh::kNoId);

private:
  UltrasonicConfig config_;
  std::vector<Eigen::Vector3d> directions_;
  NormalSource normal_;
  SampleClock clock_;
  bool started_ = false;
  double last_time_ = 0.0;
};

}  // namespace sensors
}  // namespace avsp
