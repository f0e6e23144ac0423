#pragma once
/**
 * @file anomaly_monitor.hpp
 * @brief Physically implausible vehicle states in a run (no ROS): run_recorder feeds each
 *        odometry sample and the ground height under it, and counts per vehicle the samples
 *        beyond what the vehicle can do, reporting the first of each kind once.
 *
 * Kinds: `overspeed` (speed above 1.5 x the governed speed), `airborne` (base_link more than
 * one wheel radius above its rest height over the undeformed ground: a jump off a ledge counts
 * too, so that a scenario that means one sees it), `non_finite` (a NaN or infinite position or
 * speed). Nothing is corrected: the counts go into summary.json so that a run that looks fine
 * in its plots cannot hide a vehicle thrown into the air.
 */
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace avsp
{
namespace results
{
/// What a vehicle can do, from its model (config/vehicles/<model>.yaml and its URDF).
struct VehicleLimits
{
  double max_speed = 0.0;     ///< m/s, governed (drivetrain.max_speed), > 0
  double rest_height = 0.0;   ///< m, base_link above the ground at rest (lowest wheel centre + its radius)
  double wheel_radius = 0.0;  ///< m, of that wheel, > 0
};

/// Factor on the governed speed above which a sample is an anomaly.
constexpr double kOverspeedFactor = 1.5;

struct AnomalyCounts
{
  std::size_t overspeed = 0, airborne = 0, non_finite = 0;
  std::size_t total() const { return overspeed + airborne + non_finite; }
};

class AnomalyMonitor
{
public:
  /// @throw std::invalid_argument naming the vehicle when a limit is not finite and > 0 (rest_height: finite)
  void addVehicle(const std::string& name, const VehicleLimits& limits);

  /**
   * @brief One odometry sample of `vehicle` at sim time t; `ground` is the undeformed terrain's
   *        height under (x, y), or nullopt off the terrain (then airborne is not judged).
   * @return the message for the first anomaly of its kind for this vehicle, or "" (log it once)
   */
  std::string sample(const std::string& vehicle, double t, double x, double y, double z, double speed,
                     std::optional<double> ground);

  const AnomalyCounts& counts(const std::string& vehicle) const;
  std::size_t total() const;

private:
  struct Entry
  {
    VehicleLimits limits;
    AnomalyCounts counts;
  };
  std::map<std::string, Entry> vehicles_;
};

}  // namespace results
}  // namespace avsp
