#pragma once
/**
 * @file radio.hpp
 * @brief The simulated V2V radio (docs/MODELS.md section 5), no ROS: which broadcast reaches
 *        which vehicle, and when.
 *
 * A broadcast from vehicle s at sim time t (its state's stamp) reaches vehicle r != s at
 * t + latency when all hold:
 *  - r's position is known (r has broadcast at least once; its latest broadcast position is used);
 *  - the antennas (positions + antenna_height up) are at most `range` apart (3-D distance);
 *  - with line_of_sight, the straight ray between the antennas stays above the terrain
 *    (sampled every los_step metres; points off the terrain never block);
 *  - the packet is not lost: lost when u < loss_probability, u in [0, 1) a hash of
 *    (seed, sender name, receiver name, sequence number). The draw depends on nothing else
 *    (not on arrival order nor on other vehicles), so the same broadcasts and seed give the
 *    same deliveries, run after run, and each link loses an independent fraction.
 */
#include <cstddef>
#include <cstdint>
#include <functional>
#include <queue>
#include <stdexcept>
#include <string>
#include <vector>

namespace avsp
{
namespace v2v
{
struct Vec3
{
  double x = 0.0, y = 0.0, z = 0.0;
};

/// Radio parameters (the node's private parameters of the same names).
struct RadioOptions
{
  double range = 300.0;           ///< m, maximum antenna-to-antenna distance, > 0
  double latency = 0.0;           ///< s of sim time from a state's stamp to its delivery, >= 0
  double loss_probability = 0.0;  ///< [0, 1], independent per (message, receiver)
  bool line_of_sight = false;     ///< terrain blocks the ray between antennas
  double antenna_height = 1.5;    ///< m above the broadcast position, >= 0
  double los_step = 1.0;          ///< m between terrain samples along the ray, > 0
  std::uint64_t seed = 0;         ///< loss draws
};

/// One number of RadioOptions as a parameter: the scenario's `v2v.<key>` and v2v_radio_node's
/// `~<key>` are read through this one table (its default is a default RadioOptions' value).
struct RadioNumber
{
  const char* key;
  double RadioOptions::*member;
  double min, max;   ///< inclusive
  const char* unit;  ///< for messages ("m", "s", "" for a probability)
};

/// range (m, [1e-3, 1e6]), latency (s, [0, 3600]), loss_probability ([0, 1]), antenna_height
/// (m, [0, 1000]), los_step (m, [0.01, 100]).
const std::vector<RadioNumber>& radioNumbers();

/// Terrain height (m) at map (x, y); false where there is no terrain.
using HeightFunction = std::function<bool(double x, double y, double& height)>;

/// Why a link is up or down.
enum class Link
{
  Up,          ///< in range, line of sight clear (or not checked)
  OutOfRange,  ///< farther than `range`
  Blocked,     ///< in range, the terrain blocks the ray
  Unknown      ///< one of the two has not broadcast yet
};

/// One scheduled delivery: the broadcast `message` (the caller's id) to vehicle `receiver` at `due`.
struct Delivery
{
  double due = 0.0;           ///< s, sim time
  std::size_t receiver = 0;   ///< index into the vehicle list
  std::uint64_t message = 0;  ///< the id the caller gave transmit()
};

/// Counters since construction (for diagnostics and tests).
struct RadioStats
{
  std::uint64_t broadcasts = 0;    ///< transmit() calls
  std::uint64_t delivered = 0;     ///< deliveries scheduled
  std::uint64_t lost = 0;          ///< in range and in sight, dropped by the loss draw
  std::uint64_t out_of_range = 0;  ///< (message, receiver) pairs beyond range
  std::uint64_t blocked = 0;       ///< pairs in range blocked by the terrain
  std::uint64_t unknown = 0;       ///< pairs whose receiver had no position yet
};

class Radio
{
public:
  /**
   * @param vehicles the vehicles' names (unique, non-empty)
   * @param options checked: range > 0, latency in [0, 3600], loss in [0, 1], antenna_height
   *        in [0, 1000], los_step > 0
   * @param terrain required when options.line_of_sight
   * @throw std::invalid_argument naming the option or vehicle
   */
  Radio(std::vector<std::string> vehicles, const RadioOptions& options, HeightFunction terrain = {});

  /**
   * @brief Vehicle `sender` broadcasts its state at `position` (map, m), sequence number
   *        `seq`, stamped `stamp` (s, sim time). Updates its known position first.
   * @return the deliveries this broadcast schedules (also queued inside, see due()), in
   *         receiver order
   * @throw std::out_of_range if sender is not an index of the vehicle list
   */
  std::vector<Delivery> transmit(std::size_t sender, const Vec3& position, std::uint32_t seq, double stamp,
                                 std::uint64_t message);

  /// Pops the queued deliveries due at or before `now` (within 1 ns), ordered by (due, message, receiver).
  std::vector<Delivery> due(double now);

  /// Deliveries still queued.
  std::size_t pending() const { return queue_.size(); }

  /// State of the link between two vehicles at their latest known positions.
  Link link(std::size_t a, std::size_t b) const;

  /// True when the straight segment between two antenna positions clears the terrain.
  bool lineOfSight(const Vec3& a, const Vec3& b) const;

  /// The loss draw in [0, 1) for (seed, sender, receiver, seq): the packet is lost when below the loss probability.
  static double lossDraw(std::uint64_t seed, const std::string& sender, const std::string& receiver, std::uint32_t seq);

  /// Index of a vehicle name, or vehicles().size() if unknown.
  std::size_t indexOf(const std::string& name) const;
  const std::vector<std::string>& vehicles() const { return vehicles_; }
  const RadioOptions& options() const { return options_; }
  /// Latest known antenna position of vehicle k (false if it has not broadcast).
  bool antenna(std::size_t k, Vec3& out) const;
  const RadioStats& stats() const { return stats_; }

private:
  struct Later
  {
    bool operator()(const Delivery& a, const Delivery& b) const
    {
      if (a.due != b.due)
        return a.due > b.due;
      if (a.message != b.message)
        return a.message > b.message;
      return a.receiver > b.receiver;
    }
  };

  Link linkBetween(const Vec3& antenna_a, const Vec3& antenna_b) const;

  std::vector<std::string> vehicles_;
  RadioOptions options_;
  HeightFunction terrain_;
  std::vector<Vec3> antennas_;
  std::vector<bool> known_;
  std::priority_queue<Delivery, std::vector<Delivery>, Later> queue_;
  RadioStats stats_;
};

}  // namespace v2v
}  // namespace avsp
