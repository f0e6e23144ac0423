#pragma once
/**
 * @file vehicle_record.hpp
 * @brief What the run recorder keeps of one vehicle (no ROS), in constant memory however long
 *        the run: from its odometry the first and latest sample, the count, the distance driven,
 *        the top speed and the box it covered; from its telemetry the largest driven slip, the
 *        time stuck and the collision count. The samples themselves stream to disk
 *        (output.hpp, TrajectoryTable) and to the gap trackers (gap.hpp).
 */
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace avsp
{
namespace results
{
/// A vehicle of the run and the vehicle it follows ("" = none).
struct VehicleSpec
{
  std::string name;
  std::string leader;
  /// From the model, for the anomaly counts (anomaly_monitor.hpp); all 0 = not judged.
  double max_speed = 0.0, rest_height = 0.0, wheel_radius = 0.0;
};

/**
 * @brief Checks a run's vehicle list: at least one vehicle, names non-empty and unique, every
 *        leader one of the listed vehicles and not the vehicle itself.
 * @throw std::invalid_argument naming the entry, e.g. "vehicles[2].leader 'delta' is not a listed vehicle"
 */
void validateVehicles(const std::vector<VehicleSpec>& vehicles);

/// One odometry sample: sim time, base_link position (map = odom), speed, distance so far.
struct OdometrySample
{
  double t = 0.0;         ///< s, sim time (the message's stamp)
  double x = 0.0;         ///< m, map
  double y = 0.0;         ///< m, map
  double z = 0.0;         ///< m, map
  double speed = 0.0;     ///< m/s, magnitude of the base_link linear velocity
  double distance = 0.0;  ///< m, driven from the first sample to this one
};

/// Picks a time series' first sample and then its first at or after each multiple of `period`
/// (s): the rows of trajectories.csv and the gap samples.
class PeriodicPick
{
public:
  explicit PeriodicPick(double period) : period_(period) {}
  /// True when the sample at `t` (times in order) is picked.
  bool take(double t)
  {
    if (t < next_ - 1e-9)
      return false;
    next_ = (std::floor(t / period_ + 1e-9) + 1.0) * period_;
    return true;
  }

private:
  double period_;
  double next_ = -std::numeric_limits<double>::infinity();
};

/// One wheel's or track segment's contact as telemetry reports it (avsp_msgs/WheelContact).
struct ContactSlip
{
  double slip = 0.0;          ///< longitudinal slip, + = driving
  double normal_force = 0.0;  ///< N
  bool driven = false;
};

/**
 * @brief The largest slip of the driven wheels or track segments that touch the ground
 *        (normal force > 0): a wheel in the air spins freely and an undriven one only skids.
 * @return nullopt when no driven contact touches the ground or a slip is not finite
 */
std::optional<double> maxDrivenSlip(const std::vector<ContactSlip>& contacts);

/// What VehicleRecord::addOdometry did with a message.
enum class OdometryAdded
{
  kSample,   ///< a new sample
  kRepeat,   ///< the instant of the last sample again: not a new sample (dynamics_node repeats time 0)
  kRefused,  ///< a value not finite, or earlier than the last sample (out of order): ignored
};

/// The record of one vehicle over the run.
class VehicleRecord
{
public:
  /**
   * @brief Adds an odometry sample. The distance grows by the straight 3-D distance from the
   *        previous sample (at 100 Hz the chord of any path a vehicle can drive). A message
   *        stamped with the last sample's time is a repeat (dynamics_node sends the odometry
   *        of time 0 again until its lockstep controllers answer, as often as start-up takes):
   *        counting it would make the sample count depend on wall-clock timing.
   * @param t s, sim time; speed m/s (>= 0)
   */
  OdometryAdded addOdometry(double t, double x, double y, double z, double speed);

  /**
   * @brief Adds a telemetry message. Time stuck grows by the time from the previous message
   *        when that one had the stuck flag (the flag holds until the next message says otherwise).
   * @param max_slip the message's maxDrivenSlip() (nullopt: none in contact)
   * @param collisions the message's cumulative collision count
   * @return false, and the message is ignored, when t is not finite or earlier than the previous one's
   */
  bool addTelemetry(double t, std::optional<double> max_slip, bool stuck, std::uint32_t collisions);

  /// Accepted odometry samples so far.
  std::size_t sampleCount() const { return count_; }
  /// The first and the latest accepted sample; nullopt before any.
  std::optional<OdometrySample> first() const;
  std::optional<OdometrySample> last() const;
  /// m, driven so far (0 before two samples).
  double distance() const { return count_ ? last_.distance : 0.0; }
  /// m/s, of the latest sample (0 before any).
  double speed() const { return count_ ? last_.speed : 0.0; }
  /// m/s, the largest sample speed (0 before any).
  double maxSpeed() const { return max_speed_; }
  /// m/s, distance / time from the first to the latest sample; nullopt before that time is > 0.
  std::optional<double> meanSpeed() const;
  /// The map-plane box of every accepted sample: min_x, min_y, max_x, max_y (m); nullopt before any.
  std::optional<std::array<double, 4>> bounds() const;

  std::size_t telemetryCount() const { return telemetry_count_; }
  /// Largest driven slip reported; nullopt if no telemetry had a driven contact on the ground.
  std::optional<double> maxSlip() const { return max_slip_; }
  /// s with the stuck flag (0 without telemetry).
  double timeStuck() const { return time_stuck_; }
  /// The latest cumulative collision count; nullopt without telemetry.
  std::optional<std::uint32_t> collisions() const;

private:
  std::size_t count_ = 0;
  OdometrySample first_, last_;
  std::array<double, 4> bounds_{};
  double max_speed_ = 0.0;
  std::size_t telemetry_count_ = 0;
  std::optional<double> max_slip_;
  double time_stuck_ = 0.0;
  double last_telemetry_t_ = 0.0;
  bool last_stuck_ = false;
  std::uint32_t collisions_ = 0;
};

}  // namespace results
}  // namespace avsp
