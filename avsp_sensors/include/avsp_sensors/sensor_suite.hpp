#pragma once
/**
 * @file sensor_suite.hpp
 * @brief One vehicle's sensors driven by its states in sim time (what sensors_node runs per
 *        vehicle, without ROS): lidar sweeps, radar scans, GPS, IMU, magnetometer and ultrasonic
 *        samples, each on its own fixed grid of sim times, and the vehicle's OctoMap fed with every
 *        sweep. Also the moving bodies a vehicle puts into the scene (its collision boxes) and the
 *        merge of several vehicles' state streams into one deterministic order of times.
 *
 * Time: every sensor samples on the absolute grid k / rate of sim time (k integer), at the first
 * vehicle state at or after each grid time (states come from the odometry, typically 100 Hz: a
 * sensor faster than the states is sampled at every state). A lidar sweep starts at a state on
 * its grid and is cast when the state one period later arrives, from the pose at its start with
 * the constant twist that carries the sensor to its pose at the end (both poses exact).
 */
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "avsp_sensors/geodetic.hpp"
#include "avsp_sensors/gps.hpp"
#include "avsp_sensors/imu.hpp"
#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/lidar_clustering.hpp"
#include "avsp_sensors/magnetometer.hpp"
#include "avsp_sensors/occupancy.hpp"
#include "avsp_sensors/radar.hpp"
#include "avsp_sensors/scene.hpp"
#include "avsp_sensors/ultrasonic.hpp"
#include "avsp_sensors/weather.hpp"

namespace avsp
{
namespace sensors
{
/// A vehicle's state at one sim time, as the odometry gives it (map = odom frame, ENU).
struct VehicleState
{
  double time = 0.0;                                           ///< s, sim time
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();      ///< base_link -> map
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< m/s, map, of the base_link origin
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, map
};

/// @throw std::invalid_argument naming `context` and the field: a non-finite value or a pose
///        whose rotation is not orthonormal (to 1e-6)
void validateState(const VehicleState& state, const char* context);

/**
 * @brief Fixed-rate trigger on the absolute grid k / rate of sim time: due at the first time at
 *        or after each grid time. Times within 1e-9 of a period before a grid time count as on it.
 */
class GridClock
{
public:
  /// @param rate Hz, finite and > 0 (the callers' configs check it)
  explicit GridClock(double rate);
  /// True when a sample is due at t (s): t reached the next grid time (the first: the first grid
  /// time at or after the first t seen).
  bool due(double t);
  /// Records a sample at t: the next one is due at the first grid time after t.
  void taken(double t);
  double period() const { return period_; }
  /// Grid index of the grid time t is on (rounded).
  std::uint64_t index(double t) const;

private:
  double period_;
  bool started_ = false;
  double next_ = 0.0;
};

/// A box of a vehicle's body (its URDF collision box) in base_link.
struct BodyBox
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< box centre and axes in base_link
  Eigen::Vector3d size = Eigen::Vector3d::Ones();          ///< m, full edges along the box's x, y, z, > 0
};

/**
 * @brief The vehicle's boxes at its state as scene bodies, each with the rigid-body velocity of
 *        its centre (v + w x (c - p)) for the radar's Doppler.
 * @param id the body id of every box (Ray::ignore_body = id hides the whole vehicle)
 */
std::vector<Body> vehicleBodies(const std::vector<BodyBox>& boxes, const VehicleState& state, std::uint32_t id,
                                float reflectivity);

/// Lidar of a suite. Mount: sensor frame -> base_link.
struct LidarSetup
{
  LidarConfig config;
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  bool registered = true;  ///< points in the map (each at its firing pose) or in the sensor frame
  /// Objects in each sweep (lidar_clustering.hpp), on request (VehicleSensors::clusterSweep);
  /// nullopt: none.
  std::optional<LidarClusterConfig> clustering;
};

/// Radar of a suite.
struct RadarSetup
{
  RadarConfig config;
  double rate = 10.0;  ///< Hz, scans per second, > 0
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
};

/// GPS of a suite: the antenna at the mount's origin.
struct GpsSetup
{
  GpsConfig config;
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
};

/// One ultrasonic range finder of a suite.
struct UltrasonicSetup
{
  std::string name;  ///< unique within the suite
  UltrasonicConfig config;
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
};

/// The vehicle's OctoMap, fed with every lidar sweep; its products are published at a rate.
struct OccupancySetup
{
  OccupancyConfig config;
  std::size_t slices = 4;     ///< time slices per sweep (insert(scan, motion, slices)), >= 1
  double publish_rate = 1.0;  ///< Hz, occupied cells and 2-D grid, > 0
  double grid_size = 60.0;    ///< m, side of the square 2-D grid centred on the vehicle, > 0
  /// Thresholds and cell size of the 2-D grid (its window is set around the vehicle).
  GridProjection projection;
};

/// Everything one vehicle carries. Absent sensors are not simulated.
struct SuiteConfig
{
  std::optional<LidarSetup> lidar;
  std::optional<RadarSetup> radar;
  std::optional<GpsSetup> gps;
  std::optional<ImuConfig> imu;                    ///< mount inside (ImuConfig::mount)
  std::optional<MagnetometerConfig> magnetometer;  ///< mount inside
  std::vector<UltrasonicSetup> ultrasonics;
  std::optional<OccupancySetup> occupancy;  ///< requires a lidar
  std::uint64_t seed = 0;                   ///< every sensor's seed derives from it
};

/**
 * @brief Checks a suite: each sensor's own config (the core's validate functions), rates,
 *        unique ultrasonic names, occupancy only with a lidar, finite mounts.
 * @throw std::invalid_argument naming the sensor and the field
 */
void validateSuiteConfig(const SuiteConfig& config);

/// A lidar sweep ready to publish.
struct LidarSweep
{
  LidarScan scan;
  SensorMotion motion;  ///< sensor frame -> map at the sweep start and its twist
  double start = 0.0;   ///< s, sim time of the sweep start (points' time is relative to it)
};

/// A radar scan ready to publish.
struct RadarOutput
{
  RadarScan scan;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< radar frame -> map
};

/// What one update produced (each field only when that sensor was due).
struct SuiteOutput
{
  double time = 0.0;  ///< s, the state's time: the stamp of everything but the lidar sweep
  std::optional<LidarSweep> lidar;
  std::optional<RadarOutput> radar;
  std::optional<GpsFix> gps;
  std::optional<ImuSample> imu;
  std::optional<MagSample> magnetometer;
  /// (index into SuiteConfig::ultrasonics, reading) of the due ones, in config order.
  std::vector<std::pair<std::size_t, UltrasonicReading>> ultrasonics;
  bool occupancy_due = false;  ///< time to publish the occupancy products

  /// Wall time this update spent, s (for the node's cost report; not simulation data).
  struct Cost
  {
    double lidar = 0.0;      ///< casting the sweep
    double occupancy = 0.0;  ///< inserting it into the OctoMap
    double radar = 0.0;      ///< casting and clustering the radar scan
    double other = 0.0;      ///< GPS, IMU, magnetometer, ultrasonics
  } cost;
};

/**
 * @brief One vehicle's sensors. update() is called with every state of the vehicle in time
 *        order; each sensor due at that state is sampled.
 *
 * IMU accelerations are the backward differences of successive states' velocities (the
 * odometry's rate, whatever the IMU's), zero at the first state. Random draws come from seeds
 * derived from SuiteConfig::seed, and scan numbers are grid indices of sim time, so a run
 * depends on the states only (not on when updates were called or on the thread count).
 */
class VehicleSensors
{
public:
  /**
   * @param origin the scenario's geodetic reference (required with a GPS)
   * @param body_id the vehicle's body id in the scene (its own sensors ignore it)
   * @throw std::invalid_argument (validateSuiteConfig), or a GPS without an origin
   */
  VehicleSensors(SuiteConfig config, std::optional<EnuFrame> origin, std::uint32_t body_id);
  ~VehicleSensors();
  VehicleSensors(VehicleSensors&&) noexcept;
  VehicleSensors& operator=(VehicleSensors&&) noexcept;

  const SuiteConfig& config() const { return config_; }
  std::uint32_t bodyId() const { return body_id_; }

  /**
   * @brief Samples every sensor due at state.time.
   * @param scene the world now (the caller puts every vehicle's bodies in it)
   * @param threads ray-casting threads (0 = all cores); results do not depend on it
   * @throw std::invalid_argument for a bad state (validateState) or a time earlier than the last
   */
  SuiteOutput update(const VehicleState& state, const Scene& scene, const Weather& weather, unsigned threads);

  /// True when the lidar has a clustering configuration (LidarSetup::clustering).
  bool clusters() const { return clusterer_ != nullptr; }

  /**
   * @brief The objects of a sweep this suite produced: ground removal against `terrain` and
   *        Euclidean clustering (LidarClusterer), in the map frame. Not part of update(): a node
   *        calls it only when someone reads the clusters.
   * @throw std::logic_error without a clustering configuration
   */
  LidarClustering clusterSweep(const LidarSweep& sweep, const HeightField& terrain) const;

  /// The OctoMap (nullptr without occupancy).
  const OccupancyMap* occupancy() const { return occupancy_.get(); }

  /**
   * @brief The 2-D grid of the OctoMap around (x, y): OccupancySetup::grid_size square, its cell
   *        corners on multiples of the cell size (so cells do not shift as the vehicle moves).
   * @throw std::logic_error without occupancy
   */
  OccupancyGrid2D occupancyGrid(double x, double y, const HeightField& terrain) const;

private:
  /// The lidar's part of update(): a sweep (and its OctoMap insertion) when one is due.
  void sweepLidar(const VehicleState& state, const Scene& scene, const Weather& weather, unsigned threads,
                  SuiteOutput& out);

  SuiteConfig config_;
  std::uint32_t body_id_;
  std::unique_ptr<Lidar> lidar_;
  std::unique_ptr<LidarClusterer> clusterer_;
  std::unique_ptr<Radar> radar_;
  std::unique_ptr<Gps> gps_;
  std::unique_ptr<Imu> imu_;
  std::unique_ptr<Magnetometer> magnetometer_;
  std::vector<Ultrasonic> ultrasonics_;
  std::unique_ptr<OccupancyMap> occupancy_;
  std::optional<GridClock> sweep_clock_, radar_clock_, gps_clock_, imu_clock_, mag_clock_, occupancy_clock_;
  std::vector<GridClock> ultrasonic_clocks_;
  std::optional<VehicleState> sweep_start_;  ///< state at the start of the sweep in progress
  std::optional<VehicleState> last_;         ///< previous state (IMU differences)
};

/**
 * @brief Merges the state streams of several vehicles into one order of times.
 *
 * Each vehicle's states arrive in time order (one ROS topic each), but the topics interleave
 * arbitrarily. next() releases the earliest queued time only once every vehicle has a queued
 * state (none can still deliver an earlier one), with the states of all vehicles at that time:
 * the same streams give the same batches however they interleaved. A vehicle that has nothing
 * queued is waited for until another vehicle's stream has run `timeout` s of sim time beyond
 * the pending time; then it is treated as silent (its last state stays its state) until it
 * delivers again. The streams themselves are the clock: a node that lags behind the simulation
 * (its queues full) never waits a vehicle out.
 */
class StateSynchronizer
{
public:
  /// @param timeout s of sim time, >= 0 (+inf: wait for ever)
  StateSynchronizer(std::size_t vehicles, double timeout);

  /// Why push() refused a state.
  enum class Push
  {
    kQueued,
    kNotAfterLast,  ///< not later than the vehicle's previous state (duplicate or out of order)
    kLate,          ///< earlier than a time already released (the vehicle had been silent)
  };
  Push push(std::size_t vehicle, const VehicleState& state);

  /// One released time: the vehicles that have a state at exactly that time (ascending index).
  struct Batch
  {
    double time = 0.0;
    std::vector<std::size_t> vehicles;
    std::vector<VehicleState> states;
  };

  /// The next complete time, if any (see the class).
  std::optional<Batch> next();

  /**
   * @brief A vehicle that joins the run (spawned): waited for at times >= `first_time` (its
   *        first state's), not before, so the times already pending are released without it.
   * @return its index (the next one; indices are never reused)
   * @throw std::invalid_argument when `first_time` is not after the last released time
   */
  std::size_t addVehicle(double first_time);
  /**
   * @brief A vehicle that leaves the run (removed) after its state at `last_time`: its states up
   *        to then are still released; later times are released without it, its later states
   *        refused (kNotAfterLast), and from the first later time it has no latest() state.
   * @throw std::out_of_range for an unknown index
   */
  void removeVehicle(std::size_t vehicle, double last_time);
  /// Whether a vehicle was removed and every time up to its last state is released.
  bool gone(std::size_t vehicle) const { return released_ > last_.at(vehicle); }

  /// The latest released state of a vehicle (none before its first).
  const std::optional<VehicleState>& latest(std::size_t vehicle) const { return latest_.at(vehicle); }
  /// Vehicles skipped by the timeout at the last next() (ascending), for warnings.
  const std::vector<std::size_t>& waitedOut() const { return waited_out_; }
  std::size_t queued(std::size_t vehicle) const { return queues_.at(vehicle).size(); }

private:
  double timeout_;
  std::vector<std::deque<VehicleState>> queues_;
  std::vector<std::optional<VehicleState>> latest_;
  std::vector<double> last_pushed_;
  std::vector<double> first_, last_;  ///< s, the times a vehicle is waited for (addVehicle, removeVehicle)
  double newest_ = -std::numeric_limits<double>::infinity();  ///< latest time any vehicle pushed
  double released_ = -std::numeric_limits<double>::infinity();
  std::vector<std::size_t> waited_out_;
};

}  // namespace sensors
}  // namespace avsp
