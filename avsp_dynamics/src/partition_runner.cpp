#include "avsp_dynamics/partition_runner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <utility>

namespace avsp
{
namespace dynamics
{
namespace
{
/// The key of an exchange's time: whole nanoseconds, as its stamp travels.
std::int64_t timeKey(double t)
{
  return std::llround(t * 1e9);
}

std::string seconds(double t)
{
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", t);
  return text;
}
}  // namespace

std::vector<std::uint32_t> takeToppled(const terrain::ObjectSet& objects, std::vector<std::uint32_t>& standing)
{
  auto fallen = std::stable_partition(standing.begin(), standing.end(),
                                      [&objects](std::uint32_t id) { return !objects.get(id).toppled; });
  std::vector<std::uint32_t> out(fallen, standing.end());
  standing.erase(fallen, standing.end());
  return out;
}

PartitionRunner::PartitionRunner(PartitionOptions options, World& world, terrain::ObjectSet& objects,
                                 std::vector<PartitionVehicle> vehicles, std::vector<std::uint32_t> standing,
                                 ModelLoader load_model, ExchangeTransport& transport, Log log)
  : options_(std::move(options)),
    world_(world),
    terrain_(world.terrain()),
    objects_(objects),
    vehicles_(std::move(vehicles)),
    standing_(std::move(standing)),
    load_model_(std::move(load_model)),
    transport_(transport),
    log_(std::move(log))
{
  if (options_.peers.empty())
    throw std::invalid_argument("partition '" + options_.partition + "': no peers");
  std::set<std::string> names;
  for (const std::string& peer : options_.peers)
  {
    if (peer == options_.partition)
      throw std::invalid_argument("partition '" + peer + "' is its own peer");
    if (!names.insert(peer).second)
      throw std::invalid_argument("peer '" + peer + "' is listed twice");
    received_[peer];
  }
  if (!std::isfinite(options_.interval) || options_.interval <= 0.0)
    throw std::invalid_argument("the exchange interval " + std::to_string(options_.interval) +
                                " s must be finite and > 0");
  if (options_.step_ahead_intervals < 0)
    throw std::invalid_argument("step_ahead_intervals must be >= 0");
  const terrain::ElevationGrid& g = terrain_.base();
  if (g.columns() * g.rows() > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("the terrain grid has " + std::to_string(g.columns() * g.rows()) +
                                " points; partitions exchange soil points as 32-bit indices");
  terrain_.setChangeTracking(true);
  // A wheel's soil changes stay under it, bar the soil pushed to the cells round it.
  soil_reach_ = 0.25 + 2.0 * std::max(g.dx(), g.dy());
  // An object a peer's vehicle pushes over may fall its height (plus its own size) away.
  for (std::uint32_t id : standing_)
  {
    const terrain::TerrainObject& o = objects_.get(id);
    topple_reach_ = std::max(topple_reach_, o.height + std::hypot(o.length, o.width));
  }
}

void PartitionRunner::receive(const std::string& peer, PartitionExchange exchange)
{
  auto it = received_.find(peer);
  std::string why;
  if (it == received_.end())
    why = "'" + peer + "' is not a peer of partition '" + options_.partition + "'";
  else if (exchange.partition != peer)
    why = "partition is '" + exchange.partition + "', not '" + peer + "'";
  else if (exchange.soil_before.size() != 3 * exchange.soil_points.size() ||
           exchange.soil_after.size() != 3 * exchange.soil_points.size())
    why = "soil_before and soil_after must hold 3 values per soil_points entry";
  else if (exchange.toppled_directions.size() != exchange.toppled_ids.size())
    why = "toppled_directions must have one entry per toppled_ids entry";
  if (!why.empty())
    throw ExchangeError("bad exchange on " + transport_.source(peer) + ": " + why);
  const std::int64_t key = timeKey(exchange.time);
  it->second[key] = std::move(exchange);
}

PartitionRunner::Ready PartitionRunner::prepare(double from, double to)
{
  if (!queued_ || from > *queued_)
  {
    pending_.push_back(from);
    queued_ = from;
  }
  const double lag = (options_.step_ahead_intervals - 0.5) * options_.interval;
  while (!pending_.empty())
  {
    const double t = pending_.front();
    // Oldest first: those K intervals old or more, then the newer ones while a peer's vehicle
    // may come near ours in this interval.
    const bool due = from == 0.0 || t < from - lag;
    if (!due && peersApart(from, to))
      break;
    if (!allArrived(t))
    {
      waiting_for_ = t;
      return Ready::kWaiting;
    }
    apply(t);
    pending_.pop_front();
  }
  stepped_ahead_ += pending_.empty() ? 0 : 1;
  return Ready::kReady;
}

bool PartitionRunner::allArrived(double t) const
{
  const std::int64_t key = timeKey(t);
  return std::all_of(received_.begin(), received_.end(), [&](const auto& p) { return p.second.count(key) > 0; });
}

std::vector<std::string> PartitionRunner::missingSources() const
{
  const std::int64_t key = timeKey(waiting_for_);
  std::vector<std::string> out;
  for (const auto& [peer, exchanges] : received_)
    if (!exchanges.count(key))
      out.push_back(transport_.source(peer));
  return out;
}

void PartitionRunner::apply(double t)
{
  const std::int64_t key = timeKey(t);
  for (auto& [peer, exchanges] : received_)
  {
    try
    {
      applyOne(peer, exchanges.at(key), t);
    }
    catch (const std::exception& e)
    {
      throw ExchangeError("bad exchange on " + transport_.source(peer) + " for t = " + seconds(t) + " s: " + e.what());
    }
    // Older intervals are done with too (a repeated exchange can leave one behind).
    exchanges.erase(exchanges.begin(), exchanges.upper_bound(key));
  }
  peers_applied_ = t;
  peers_known_ = true;
}

void PartitionRunner::applyOne(const std::string& peer, const PartitionExchange& m, double t)
{
  for (const ExchangedVehicle& v : m.vehicles)
    placeProxy(peer, v, t);
  // A vehicle the peer no longer sends has left its run: its proxy goes too.
  for (auto it = proxies_.begin(); it != proxies_.end();)
  {
    const bool sent = std::any_of(m.vehicles.begin(), m.vehicles.end(),
                                  [&](const ExchangedVehicle& v) { return v.name == it->first; });
    if (it->second.peer != peer || sent)
    {
      ++it;
      continue;
    }
    const std::size_t index = it->second.index;
    world_.removeProxy(index);
    for (auto& [name, other] : proxies_)
      if (other.index > index)
        --other.index;
    note(Level::kInfo, "partition '" + options_.partition + "': " + it->first + " (partition '" + peer +
                           "') left the run at t = " + seconds(t) + " s; its proxy is gone");
    it = proxies_.erase(it);
  }
  // Thousands of points per interval: one 32-bit division each (the grid has fewer than 2^32
  // points, see the constructor), into a buffer kept from the last interval.
  const terrain::ElevationGrid& g = terrain_.base();
  const auto columns = static_cast<std::uint32_t>(g.columns());
  const std::size_t points = g.columns() * g.rows();
  std::vector<terrain::PointChange>& changes = received_changes_;
  changes.resize(m.soil_points.size());
  const float* before = m.soil_before.data();
  const float* after = m.soil_after.data();
  for (std::size_t k = 0; k < changes.size(); ++k, before += 3, after += 3)
  {
    const std::uint32_t index = m.soil_points[k];
    if (index >= points)
      throw std::out_of_range("soil_points[" + std::to_string(k) + "] = " + std::to_string(index) + " is outside the " +
                              std::to_string(g.columns()) + " x " + std::to_string(g.rows()) + " grid");
    terrain::PointChange& c = changes[k];
    c.j = index / columns;
    c.i = index - c.j * columns;
    c.before = { before[0], before[1], before[2] };
    c.after = { after[0], after[1], after[2] };
  }
  const std::size_t merged = terrain_.applyChanges(changes);
  merged_points_ += merged;
  if (merged > 0)
    note(Level::kDebug, std::to_string(merged) + " soil point(s) changed by both this partition and '" + peer +
                            "' before t = " + seconds(t) + " s: merged");
  for (std::size_t k = 0; k < m.toppled_ids.size(); ++k)
  {
    std::string why;
    const std::uint32_t id = m.toppled_ids[k];
    if (!objects_.applyToppled(id, m.toppled_directions[k], why))
      note(Level::kWarning,
           transport_.source(peer) + ": toppled object " + std::to_string(id) + " not applied: " + why);
    // Toppled by the peer: not ours to report or to send.
    toppled_by_peers_.push_back(id);
    standing_.erase(std::remove(standing_.begin(), standing_.end(), id), standing_.end());
  }
}

void PartitionRunner::placeProxy(const std::string& peer, const ExchangedVehicle& v, double t)
{
  auto it = proxies_.find(v.name);
  if (it == proxies_.end())
  {
    if (std::any_of(vehicles_.begin(), vehicles_.end(), [&](const PartitionVehicle& o) { return o.name == v.name; }))
      throw std::invalid_argument("vehicle '" + v.name + "' is simulated here too");
    if (v.model.empty() || v.model.find('/') != std::string::npos)
      throw std::invalid_argument("vehicle '" + v.name + "' has model '" + v.model + "', not a model name");
    VehicleModel model;
    try
    {
      model = load_model_(v.model);
    }
    catch (const std::exception& e)
    {
      throw std::invalid_argument("vehicle '" + v.name + "' of partition '" + peer + "': " + e.what());
    }
    Proxy p;
    p.peer = peer;
    p.index = world_.addProxy(model, v.name);
    p.box = boundingBox(model);
    it = proxies_.emplace(v.name, p).first;
    note(Level::kInfo, "partition '" + options_.partition + "' sees " + v.name + " (" + v.model + ", partition '" +
                           peer + "') as a proxy");
  }
  const Eigen::Quaterniond& q = v.orientation;
  if (!(std::fabs(q.norm() - 1.0) < 1e-3))
    throw std::invalid_argument("vehicle '" + v.name + "': orientation is not a unit quaternion");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = v.position;
  pose.linear() = q.normalized().toRotationMatrix();
  Proxy& p = it->second;
  p.linear_velocity = v.linear_velocity;
  p.angular_velocity = v.angular_velocity;
  world_.setProxyState(p.index, pose, p.linear_velocity, p.angular_velocity);  // refuses a non-finite state
  p.pose = pose;
  p.time = t;
}

/**
 * Whether no peer vehicle, as the last applied exchange gave it, can come near one of ours while
 * we step from `from` to `to`: then the peers' exchange of `from` cannot change that interval.
 * Each box grows by the distance its points can travel by `to` (accelerations up to
 * kMaxAcceleration); a peer's also by the reach of its soil changes and of what it topples.
 */
bool PartitionRunner::peersApart(double from, double to) const
{
  std::vector<double> grow(vehicles_.size());  // each of ours, once
  for (std::size_t k = 0; k < vehicles_.size(); ++k)
  {
    const VehicleState& s = world_.state(vehicles_[k].id);
    grow[k] = sweptReach(vehicles_[k].box, s.linear_velocity, s.angular_velocity, to - from, kMaxAcceleration);
  }
  for (const auto& [name, r] : proxies_)
  {
    const double grow_peer = sweptReach(r.box, r.linear_velocity, r.angular_velocity, to - r.time, kMaxAcceleration) +
                             soil_reach_ + topple_reach_;
    for (std::size_t k = 0; k < vehicles_.size(); ++k)
      if (!shadowsApart(world_.state(vehicles_[k].id).pose, vehicles_[k].box, grow[k], r.pose, r.box, grow_peer))
        return false;
  }
  return true;
}

/**
 * Whether the soil we changed since our last soil exchange (soil_sent_) may wait for a later
 * exchange: no peer vehicle, as the last applied exchange gave it, can come within reach of it
 * before the peers would apply our next exchange (they step at most K intervals past an exchange
 * they have not applied, so K + 1 intervals from `t`). Our changes since soil_sent_ lie in our
 * vehicles' boxes grown by how far they could go since then, plus the soil's reach; a peer's
 * vehicle is grown by how far it could go by then, plus the soil's reach too (the soil its wheels
 * push). The decision depends on simulated states only: runs stay deterministic.
 */
bool PartitionRunner::unsentSoilApart(double t) const
{
  const double horizon = t + (options_.step_ahead_intervals + 1) * options_.interval;
  std::vector<double> grow(vehicles_.size());  // each of ours, once
  for (std::size_t k = 0; k < vehicles_.size(); ++k)
  {
    const SentState& s = soil_sent_states_[k];
    grow[k] = sweptReach(vehicles_[k].box, s.linear_velocity, s.angular_velocity, t - soil_sent_, kMaxAcceleration) +
              soil_reach_;
  }
  for (const auto& [name, r] : proxies_)
  {
    const double grow_peer =
        sweptReach(r.box, r.linear_velocity, r.angular_velocity, horizon - r.time, kMaxAcceleration) + soil_reach_;
    for (std::size_t k = 0; k < vehicles_.size(); ++k)
      if (!shadowsApart(soil_sent_states_[k].pose, vehicles_[k].box, grow[k], r.pose, r.box, grow_peer))
        return false;
  }
  return true;
}

void PartitionRunner::finish(double t)
{
  PartitionExchange m;
  m.partition = options_.partition;
  m.time = t;
  m.peers_applied = peers_applied_;
  for (const PartitionVehicle& v : vehicles_)
  {
    const VehicleState& s = world_.state(v.id);
    ExchangedVehicle e;
    e.name = v.name;
    e.model = v.model;
    e.position = s.pose.translation();
    e.orientation = Eigen::Quaterniond(s.pose.linear());
    e.linear_velocity = s.linear_velocity;
    e.angular_velocity = s.angular_velocity;
    m.vehicles.push_back(std::move(e));
  }
  addSoilChanges(m, t);
  for (std::uint32_t id : takeToppled(objects_, standing_))
  {
    m.toppled_ids.push_back(id);
    m.toppled_directions.push_back(objects_.get(id).fall_direction);
  }
  ++exchanges_;
  transport_.send(std::move(m));
}

void PartitionRunner::addSoilChanges(PartitionExchange& m, double t)
{
  const auto columns = static_cast<std::uint32_t>(terrain_.base().columns());
  std::vector<terrain::PointChange>& changes = sent_changes_;
  changes.clear();
  if (options_.step_ahead_intervals == 0 || !peers_known_ || flush_soil_ || !unsentSoilApart(t))
  {
    flush_soil_ = false;
    // Changes accumulate in the terrain until taken: a point changed in several intervals goes
    // out once, from its state at our last soil exchange to now.
    terrain_.takeChanges(changes);
    soil_sent_ = t;
    soil_sent_states_.resize(vehicles_.size());
    for (std::size_t k = 0; k < vehicles_.size(); ++k)
    {
      const VehicleState& s = world_.state(vehicles_[k].id);
      soil_sent_states_[k] = SentState{ s.pose, s.linear_velocity, s.angular_velocity };
    }
    ++soil_exchanges_;
  }
  // Sized once and written in place: thousands of points per interval.
  m.soil_points.resize(changes.size());
  m.soil_before.resize(3 * changes.size());
  m.soil_after.resize(3 * changes.size());
  float* before = m.soil_before.data();
  float* after = m.soil_after.data();
  for (std::size_t k = 0; k < changes.size(); ++k, before += 3, after += 3)
  {
    const terrain::PointChange& c = changes[k];
    m.soil_points[k] = c.j * columns + c.i;
    before[0] = c.before.plastic;
    before[1] = c.before.displaced;
    before[2] = c.before.sigma_max;
    after[0] = c.after.plastic;
    after[1] = c.after.displaced;
    after[2] = c.after.sigma_max;
  }
}

void PartitionRunner::addVehicle(PartitionVehicle vehicle)
{
  if (runs(vehicle.name))
    throw std::invalid_argument("vehicle '" + vehicle.name + "' already runs in partition '" + options_.partition +
                                "'");
  const std::string owner = ownerOf(vehicle.name);
  if (!owner.empty())
    throw std::invalid_argument("vehicle '" + vehicle.name + "' runs in partition '" + owner + "'");
  // Its soil changes are reckoned from where it stands now, at rest: at least as far as it can
  // have gone since our last soil exchange (it did not exist before).
  const VehicleState& s = world_.state(vehicle.id);
  soil_sent_states_.resize(vehicles_.size());
  soil_sent_states_.push_back(SentState{ s.pose, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero() });
  vehicles_.push_back(std::move(vehicle));
  note(Level::kInfo, "partition '" + options_.partition + "' runs " + vehicles_.back().name + " (" +
                         vehicles_.back().model + ") from t = " + seconds(world_.time()) + " s");
}

bool PartitionRunner::removeVehicle(const std::string& name)
{
  const auto it =
      std::find_if(vehicles_.begin(), vehicles_.end(), [&](const PartitionVehicle& v) { return v.name == name; });
  if (it == vehicles_.end())
    return false;
  const std::size_t id = it->id;
  const auto k = it - vehicles_.begin();
  vehicles_.erase(it);
  if (static_cast<std::size_t>(k) < soil_sent_states_.size())
    soil_sent_states_.erase(soil_sent_states_.begin() + k);
  for (PartitionVehicle& v : vehicles_)
    if (v.id > id)
      --v.id;  // World::removeVehicle moved the later ones down
  // Its unsent ruts would otherwise wait for a peer to come near a vehicle that is gone.
  flush_soil_ = true;
  note(Level::kInfo,
       "partition '" + options_.partition + "': " + name + " left the run at t = " + seconds(world_.time()) + " s");
  return true;
}

std::string PartitionRunner::ownerOf(const std::string& name) const
{
  const auto it = proxies_.find(name);
  return it == proxies_.end() ? std::string() : it->second.peer;
}

bool PartitionRunner::runs(const std::string& name) const
{
  return std::any_of(vehicles_.begin(), vehicles_.end(), [&](const PartitionVehicle& v) { return v.name == name; });
}

std::vector<std::uint32_t> PartitionRunner::takeToppledByPeers()
{
  std::vector<std::uint32_t> out;
  out.swap(toppled_by_peers_);
  return out;
}

void PartitionRunner::note(Level level, const std::string& text) const
{
  if (log_)
    log_(level, text);
}

}  // namespace dynamics
}  // namespace avsp
