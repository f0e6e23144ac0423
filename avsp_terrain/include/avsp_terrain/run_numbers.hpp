#pragma once
/**
 * @file run_numbers.hpp
 * @brief The numbers of a run that the launcher (scenario_launch, scenario_node), the scenario
 *        file and several nodes all take, with one range each, so that what the launcher or the
 *        scenario check accepts every node accepts (dynamics_node, lockstep_clock, run_recorder,
 *        sensors_node, v2v_radio_node, environment_node).
 */
namespace avsp
{
namespace terrain
{
/// A number of a run as a parameter: its key, default and inclusive range.
struct RunNumber
{
  const char* key;
  double fallback;  ///< when not given
  double min, max;  ///< inclusive
  const char* unit;
};

/// ~real_time_factor of dynamics_node, lockstep_clock and run_recorder; --real-time-factor (0:
/// as fast as the host can).
constexpr RunNumber kRealTimeFactor{ "real_time_factor", 0.0, 0.0, 1000.0, "x wall-clock pace" };
/// A run's length: the scenario's `duration`, --duration (0 there: the scenario's), run_recorder's
/// ~duration.
constexpr RunNumber kRunDuration{ "duration", 0.0, 1e-3, 1e9, "s of sim time" };
/// run_recorder's ~progress_period, --progress-period.
constexpr RunNumber kProgressPeriod{ "progress_period", 1.0, 0.01, 3600.0, "s of wall time" };
/// environment_node's ~time_acceleration, the scenario's `time.acceleration`.
constexpr RunNumber kTimeAcceleration{ "time_acceleration", 1.0, 1e-6, 1e6, "x sim time" };
/// The run's random seed (scenario `seed`; ~seed of dynamics_node, sensors_node, v2v_radio_node):
/// an XML-RPC int.
constexpr RunNumber kRunSeed{ "seed", 0.0, 0.0, 2147483647.0, "" };

/// Whether v is a value of n (finite, within its range).
constexpr bool inRange(const RunNumber& n, double v)
{
  return v >= n.min && v <= n.max;
}

}  // namespace terrain
}  // namespace avsp
