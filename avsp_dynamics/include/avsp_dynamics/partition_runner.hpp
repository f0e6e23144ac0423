#pragma once
/**
 * @file partition_runner.hpp
 * @brief The dynamics partitions' exchange protocol (issue 7), ROS-free: what one partition of
 *        a run sends its peers at the end of every interval, and what of theirs it applies
 *        before stepping the next one. dynamics_node moves the exchanges over ROS topics
 *        (avsp_dynamics/ros/exchange_transport.hpp); the tests move them in memory.
 *
 * A run's vehicles are split over partitions, each with its own World on its own copy of the
 * terrain. At the end of every interval T a partition sends its vehicles' states and the soil
 * they changed; before stepping past T it applies its peers' exchanges of T: their vehicles
 * become kinematic proxies its own collide with (one interval late at most: between exchanges a
 * proxy flies on at its last velocities) and their soil changes are copied exactly, so every
 * partition drives on the same ruts. Without contacts between partitions' vehicles, or two
 * partitions' wheels on the same soil point in one interval, any layout gives the same
 * trajectories bit for bit.
 *
 * Stepping ahead (K = PartitionOptions::step_ahead_intervals): the peers' exchange of T can
 * change this partition's interval after T only through contacts between their vehicles and
 * ours, soil under both, or objects the peers toppled. Before an interval the partition applies
 * the exchanges K or more intervals old, then the newer ones, oldest first, only as long as, by
 * the last one applied, a peer vehicle may come near one of ours before the interval's end
 * (boxes round every part, grown by the distance each can travel: partition_reach.hpp); the rest
 * wait for a later interval. The answer is the strict lockstep's (K = 0) bit for bit; what it
 * saves is the wait for the peers' latest exchanges.
 *
 * Soil held back (K > 0): an interval's soil changes go out with its exchange only when a peer
 * vehicle, as last known, could come near them before the peers apply our next exchange (K + 1
 * intervals on); otherwise they accumulate in the terrain and go out later, a point changed in
 * many intervals once. A peer never steps on soil of ours it has not applied.
 */
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/terrain_objects.hpp>

#include "avsp_dynamics/partition_reach.hpp"
#include "avsp_dynamics/vehicle_model.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

namespace avsp
{
namespace dynamics
{
/// A vehicle as its partition sends it: where it is at the exchange's time.
struct ExchangedVehicle
{
  std::string name;                                                 ///< unique in the run (its namespace)
  std::string model;                                                ///< its model's name; a peer loads it for the proxy
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               ///< m, base_link origin in map
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< base_link -> map
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();        ///< m/s, base_link origin, map axes
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();       ///< rad/s, map axes
};

/// A partition's part of one interval, field for field avsp_msgs/PartitionExchange.
struct PartitionExchange
{
  std::string partition;  ///< the sender
  double time = 0.0;      ///< s, the interval's end
  /// s, the latest of its peers' exchanges the sender had applied when it stepped to `time`:
  /// one interval before it, up to K + 1 when it stepped ahead of them (0 before the first).
  double peers_applied = 0.0;
  std::vector<ExchangedVehicle> vehicles;
  /// Soil points the sender changed since its last exchange with soil, j * columns + i of the
  /// terrain grid, and per point 3 values (plastic sinkage m, displaced soil m, largest normal
  /// stress Pa) before and after.
  std::vector<std::uint32_t> soil_points;
  std::vector<float> soil_before, soil_after;
  std::vector<std::uint32_t> toppled_ids;  ///< objects the sender's vehicles pushed over
  std::vector<double> toppled_directions;  ///< rad, the map direction each fell towards
};

/// How a partition's exchanges reach its peers (ROS topics in dynamics_node, memory in tests).
/// Exchanges from the peers go the other way: whoever receives them calls PartitionRunner::receive().
class ExchangeTransport
{
public:
  virtual ~ExchangeTransport() = default;
  /// Sends this partition's exchange to every peer: each must get every one, in order, also a
  /// peer that starts listening late.
  virtual void send(PartitionExchange exchange) = 0;
  /// Where `peer`'s exchanges come from, for messages (dynamics_node: its topic).
  virtual std::string source(const std::string& peer) const = 0;
};

/// An exchange that cannot be applied: the run cannot go on without it, nor guess it.
class ExchangeError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Configuration of one partition's side of the protocol.
struct PartitionOptions
{
  std::string partition;           ///< this partition's name
  std::vector<std::string> peers;  ///< the run's other partitions (applied in name order)
  double interval = 0.01;          ///< s, T: the exchanges' period (lockstep_clock's sync interval)
  int step_ahead_intervals = 4;    ///< K: how many of the peers' latest exchanges may wait (>= 0)
};

/// One of this partition's vehicles.
struct PartitionVehicle
{
  std::size_t id = 0;  ///< its index in the World
  std::string name;    ///< unique in the run
  std::string model;   ///< its model's name (peers load the same for the proxy)
  VehicleBox box;      ///< boundingBox() of its model
};

/**
 * @brief The objects of `standing` (ids in `objects`) that have toppled since, in their order;
 *        removed from `standing`.
 */
std::vector<std::uint32_t> takeToppled(const terrain::ObjectSet& objects, std::vector<std::uint32_t>& standing);

/**
 * @brief One partition's side of the exchange protocol: builds its exchanges, keeps its peers'
 *        until applied, applies them (proxies placed, soil copied, objects toppled) when the
 *        interval about to be stepped needs them.
 *
 * Each interval: prepare(from, to) until it returns kReady (between calls, deliver what arrived
 * through receive()), step the World to `to`, finish(to). Before the first: finish(0).
 * Deterministic: every decision depends on simulated states only, never on when exchanges arrive.
 */
class PartitionRunner
{
public:
  enum class Level
  {
    kDebug,
    kInfo,
    kWarning
  };
  /// Receives the runner's log lines (new proxies, merged soil points, toppled objects refused).
  using Log = std::function<void(Level, const std::string&)>;
  /// Loads a peer vehicle's model by its name (dynamics_node: config_dir/<model>.yaml).
  using ModelLoader = std::function<VehicleModel(const std::string& model)>;

  /// m/s^2: the most a point of a vehicle accelerates, for how far vehicles can go between
  /// exchanges: 20 g, beyond what driving or a collision between ground vehicles gives over an
  /// interval.
  static constexpr double kMaxAcceleration = 200.0;

  /**
   * @param world this partition's world; its terrain's change tracking is turned on
   * @param objects the terrain's objects the world collides with (peers' topplings applied here)
   * @param vehicles this partition's vehicles in `world`
   * @param standing ids of the toppleable objects still standing (ours to report when they fall)
   * @param transport sends our exchanges; must outlive the runner
   * @throw std::invalid_argument naming what is wrong: no peers, this partition among them or one
   *        twice, an interval not finite and > 0, K < 0, a grid of 2^32 points or more (soil points
   *        travel as 32-bit indices)
   */
  PartitionRunner(PartitionOptions options, World& world, terrain::ObjectSet& objects,
                  std::vector<PartitionVehicle> vehicles, std::vector<std::uint32_t> standing, ModelLoader load_model,
                  ExchangeTransport& transport, Log log = Log());

  /**
   * @brief A peer's exchange arrived; checked, then kept until applied. A repeated one replaces
   *        the copy kept.
   * @param peer the sender as the transport knows it
   * @throw ExchangeError "bad exchange on <source>: <why>" for an unknown peer, a `partition`
   *        other than `peer`, soil arrays not 3 values per point, toppled arrays of other sizes
   */
  void receive(const std::string& peer, PartitionExchange exchange);

  enum class Ready
  {
    kReady,   ///< step the interval
    kWaiting  ///< an exchange it needs has not arrived from every peer: waitingFor(), missingPeers()
  };
  /**
   * @brief Before stepping from `from` (the last interval end finished) to `to`: applies, oldest
   *        first, the peers' exchanges K or more intervals old, then the newer ones while a peer
   *        vehicle may come near ours by `to`. Call again after kWaiting (nothing changes until an
   *        exchange arrives).
   * @throw ExchangeError "bad exchange on <source> for t = <t> s: <why>": a soil point off the
   *        grid, a peer's vehicle named as one of ours, a model that is not a name or does not
   *        load, an orientation that is not a unit quaternion, a non-finite state
   */
  Ready prepare(double from, double to);

  /// After stepping to `t`: sends our exchange of t (vehicles; soil changes unless held back;
  /// objects our vehicles toppled since the last one).
  void finish(double t);

  /**
   * @brief A vehicle added to this partition's World between intervals (spawned at run time):
   *        it goes out with our next exchange, and the peers take it as a proxy.
   * @throw std::invalid_argument when the name is one of ours or a peer's (ownerOf())
   */
  void addVehicle(PartitionVehicle vehicle);
  /**
   * @brief One of ours removed from the World between intervals (after World::removeVehicle:
   *        the later vehicles' ids move down by one). It is missing from our next exchange, which
   *        also carries every soil change not sent yet (its ruts), and the peers drop its proxy.
   * @return false when no vehicle of ours has the name
   */
  bool removeVehicle(const std::string& name);
  /// The peer partition that runs `name` (a proxy here), "" when none does.
  std::string ownerOf(const std::string& name) const;
  /// Whether `name` is one of this partition's vehicles.
  bool runs(const std::string& name) const;

  /// s: the exchange prepare() last found missing.
  double waitingFor() const { return waiting_for_; }
  /// The peers whose exchange of waitingFor() has not arrived, as their sources.
  std::vector<std::string> missingSources() const;
  /// Objects the peers toppled since the last call: not ours to report.
  std::vector<std::uint32_t> takeToppledByPeers();

  /// s: the latest peers' exchange applied (0 before the first).
  double peersApplied() const { return peers_applied_; }
  std::uint64_t exchangesSent() const { return exchanges_; }
  /// Exchanges sent with our soil changes (the others held them back).
  std::uint64_t soilExchangesSent() const { return soil_exchanges_; }
  /// Intervals stepped before the peers' latest exchange was applied.
  std::uint64_t steppedAhead() const { return stepped_ahead_; }
  /// Soil points both this partition and a peer changed in one interval (merged, not copied).
  std::uint64_t mergedPoints() const { return merged_points_; }
  const PartitionOptions& options() const { return options_; }

private:
  /// A peer's vehicle as its last applied exchange gave it.
  struct Proxy
  {
    std::string peer;       ///< the partition that runs it
    std::size_t index = 0;  ///< World proxy index
    VehicleBox box;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero(), angular_velocity = Eigen::Vector3d::Zero();
    double time = 0.0;  ///< s, the exchange's time
  };
  /// One of our vehicles when we last sent our soil changes.
  struct SentState
  {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero(), angular_velocity = Eigen::Vector3d::Zero();
  };

  bool allArrived(double t) const;
  /// Applies every peer's exchange of t (peers in name order). @throw ExchangeError
  void apply(double t);
  void applyOne(const std::string& peer, const PartitionExchange& m, double t);
  void placeProxy(const std::string& peer, const ExchangedVehicle& v, double t);
  bool peersApart(double from, double to) const;
  bool unsentSoilApart(double t) const;
  void addSoilChanges(PartitionExchange& m, double t);
  void note(Level level, const std::string& text) const;

  PartitionOptions options_;
  World& world_;
  terrain::DeformableTerrain& terrain_;
  terrain::ObjectSet& objects_;
  std::vector<PartitionVehicle> vehicles_;
  std::vector<std::uint32_t> standing_;  ///< toppleable objects not yet sent as toppled
  ModelLoader load_model_;
  ExchangeTransport& transport_;
  Log log_;

  double soil_reach_ = 0.0;    ///< m, how far from a vehicle's box its soil changes may reach
  double topple_reach_ = 0.0;  ///< m, how far an object a peer's vehicle topples may fall
  /// Per peer, its exchanges by time (ns) until applied.
  std::map<std::string, std::map<std::int64_t, PartitionExchange>> received_;
  std::map<std::string, Proxy> proxies_;  ///< the peers' vehicles by name
  std::deque<double> pending_;            ///< s: the peers' exchanges not applied yet, oldest first
  std::optional<double> queued_;          ///< s: the latest interval start queued in pending_
  double waiting_for_ = 0.0;
  std::vector<std::uint32_t> toppled_by_peers_;
  std::vector<terrain::PointChange> sent_changes_, received_changes_;  ///< buffers kept between intervals
  std::vector<SentState> soil_sent_states_;                            ///< per vehicle, in vehicles_ order
  double soil_sent_ = 0.0;    ///< s: the last exchange that carried our soil changes
  bool peers_known_ = false;  ///< every peer's exchange applied at least once
  bool flush_soil_ = false;   ///< a vehicle left: the next exchange carries every unsent soil change
  double peers_applied_ = 0.0;
  std::uint64_t exchanges_ = 0, soil_exchanges_ = 0, stepped_ahead_ = 0, merged_points_ = 0;
};

}  // namespace dynamics
}  // namespace avsp
