// The partitions' exchange protocol (PartitionRunner) in one process, its exchanges moved in
// memory and the partitions scheduled by the test:
// - the same two vehicles in one World and split over two partitions drive the same
//   trajectories bit for bit, the second driving over the first's rut (made in the other
//   partition); with the soil left out of the exchanges it does not (the check sees the ruts);
// - stepping ahead of the peers (K = 4) with one partition run as far ahead as the protocol lets
//   it gives the strict lockstep's (K = 0) answer bit for bit; it stepped ahead and held its
//   soil back while apart;
// - a peer vehicle far away lets a partition step K intervals past the peers' latest exchange,
//   one near does not; soil changes wait while no peer vehicle can reach them;
// - a soil point both partitions changed in one interval is merged;
// - malformed exchanges are refused naming the source, the time and the reason.
#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>
#include <avsp_terrain/terrain_objects.hpp>

#include "avsp_dynamics/partition_reach.hpp"
#include "avsp_dynamics/partition_runner.hpp"
#include "avsp_dynamics/vehicle_model.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp::dynamics;
namespace terrain = avsp::terrain;

namespace
{
constexpr double kInterval = 0.01;  ///< s, the exchanges' period (lockstep_clock's default)

const terrain::SoilLibrary& soils()
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  return lib;
}

VehicleModel model(const std::string& name)
{
  return loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/" + name + ".yaml");
}

/// Level sandy loam (soft: every wheel leaves a rut), 50 m x 30 m from (-25, -15), 0.1 m cells.
std::unique_ptr<terrain::DeformableTerrain> flatLoam()
{
  const std::size_t nx = 501, ny = 301;
  return std::make_unique<terrain::DeformableTerrain>(
      terrain::ElevationGrid(-25.0, -15.0, 0.1, 0.1, nx, ny, std::vector<float>(nx * ny, 0.f)),
      soils().get("sandy_loam"), terrain::DeformableTerrain::Options{ true });
}

/// A vehicle of the scenario and its open-loop commands.
struct VehicleSetup
{
  std::string name, model;
  double x = 0.0, y = 0.0, yaw = 0.0;
  double start = 0.0;     ///< s: braked before
  double steering = 0.0;  ///< amplitude of a slow weave
};

DriveCommand command(const VehicleSetup& v, double t)
{
  if (t < v.start)
    return DriveCommand{ 0.0, 1.0, 0.0 };
  return DriveCommand{ std::min(1.0, 0.3 + 0.2 * (t - v.start)), 0.0, v.steering * std::sin(0.8 * t) };
}

/// A vehicle's state at an interval's end, compared bit for bit.
struct Sample
{
  double time;
  Eigen::Matrix4d pose;
  Eigen::Vector3d linear_velocity, angular_velocity;
  bool operator==(const Sample& o) const
  {
    return time == o.time && pose == o.pose && linear_velocity == o.linear_velocity &&
           angular_velocity == o.angular_velocity;
  }
};

/// One World with some of the scenario's vehicles, stepping with their commands.
struct Sim
{
  std::unique_ptr<terrain::DeformableTerrain> ground = flatLoam();
  terrain::ObjectSet objects;
  std::unique_ptr<World> world = std::make_unique<World>(*ground);
  std::vector<std::pair<std::size_t, VehicleSetup>> vehicles;  ///< World index, setup
  std::map<std::string, std::vector<Sample>> samples;          ///< by vehicle, one per interval end

  explicit Sim(const std::vector<VehicleSetup>& setups)
  {
    for (const VehicleSetup& v : setups)
    {
      const VehicleModel m = model(v.model);
      vehicles.emplace_back(world->addVehicle(m, world->restingPose(m, v.x, v.y, v.yaw, 0.01), v.name), v);
    }
  }

  /// Steps to `end` (s) with the commands of each step's time, then samples every vehicle.
  void stepTo(double end)
  {
    while (world->time() + 0.5 * world->options().step < end)
    {
      for (const auto& [id, v] : vehicles)
        world->setCommand(id, command(v, world->time()));
      world->step();
    }
    for (const auto& [id, v] : vehicles)
    {
      const VehicleState& s = world->state(id);
      samples[v.name].push_back(Sample{ end, s.pose.matrix(), s.linear_velocity, s.angular_velocity });
    }
  }

  /// Adds a vehicle between intervals (a spawn); its World index.
  std::size_t add(const VehicleSetup& v)
  {
    const VehicleModel m = model(v.model);
    vehicles.emplace_back(world->addVehicle(m, world->restingPose(m, v.x, v.y, v.yaw, 0.01), v.name), v);
    return vehicles.back().first;
  }

  /// Removes a vehicle between intervals; the later ones' World indices move down.
  void remove(const std::string& name)
  {
    const auto it =
        std::find_if(vehicles.begin(), vehicles.end(), [&](const auto& e) { return e.second.name == name; });
    ASSERT_NE(it, vehicles.end());
    const std::size_t id = it->first;
    world->removeVehicle(id);
    vehicles.erase(it);
    for (auto& e : vehicles)
      if (e.first > id)
        --e.first;
  }

  std::vector<PartitionVehicle> partitionVehicles() const
  {
    std::vector<PartitionVehicle> out;
    for (const auto& [id, v] : vehicles)
      out.push_back(PartitionVehicle{ id, v.name, v.model, boundingBox(model(v.model)) });
    return out;
  }
};

/// Keeps what a partition sends until the test delivers it.
class MemoryTransport : public ExchangeTransport
{
public:
  void send(PartitionExchange exchange) override { outbox.push_back(std::move(exchange)); }
  std::string source(const std::string& peer) const override { return "memory/" + peer; }
  std::deque<PartitionExchange> outbox;
  std::vector<PartitionExchange> sent;  ///< everything delivered, for the checks
};

/// A partition: its World, its side of the protocol, its transport.
struct Partition
{
  std::string name;
  Sim sim;
  MemoryTransport transport;
  std::unique_ptr<PartitionRunner> runner;
  double reached = 0.0;  ///< s, the last interval end finished

  Partition(std::string partition, const std::vector<VehicleSetup>& setups, std::vector<std::string> peers, int k,
            PartitionRunner::Log log = {})
    : name(std::move(partition)), sim(setups)
  {
    PartitionOptions o;
    o.partition = name;
    o.peers = std::move(peers);
    o.interval = kInterval;
    o.step_ahead_intervals = k;
    runner = std::make_unique<PartitionRunner>(o, *sim.world, sim.objects, sim.partitionVehicles(),
                                               std::vector<std::uint32_t>(), model, transport, std::move(log));
    runner->finish(0.0);
  }

  /// Steps one interval if the protocol lets it.
  bool tryInterval()
  {
    const double end = kInterval * (std::round(reached / kInterval) + 1.0);
    if (runner->prepare(reached, end) == PartitionRunner::Ready::kWaiting)
      return false;
    sim.stepTo(end);
    runner->finish(end);
    reached = end;
    return true;
  }
};

/// Moves every exchange `from` sent to `to` (what a transport does), through `filter`.
void deliver(Partition& from, Partition& to, const std::function<void(PartitionExchange&)>& filter = {})
{
  while (!from.transport.outbox.empty())
  {
    PartitionExchange e = std::move(from.transport.outbox.front());
    from.transport.outbox.pop_front();
    from.transport.sent.push_back(e);
    if (filter)
      filter(e);
    to.runner->receive(from.name, std::move(e));
  }
}

enum class Schedule
{
  kRoundRobin,  ///< one interval each in turn
  kGreedy       ///< each partition as far ahead as the protocol lets it before the other moves
};

/// Runs two partitions to `until` (s); false if neither could move (a deadlock).
bool run(Partition& a, Partition& b, double until, Schedule schedule,
         const std::function<void(PartitionExchange&)>& filter = {})
{
  deliver(a, b, filter);
  deliver(b, a, filter);
  while (a.reached < until - 1e-9 || b.reached < until - 1e-9)
  {
    bool moved = false;
    for (Partition* p : { &a, &b })
    {
      Partition& other = p == &a ? b : a;
      while (p->reached < until - 1e-9 && p->tryInterval())
      {
        moved = true;
        deliver(*p, other, filter);
        if (schedule == Schedule::kRoundRobin)
          break;
      }
    }
    if (!moved)
      return false;
  }
  return true;
}

/// Two mrzr: "lead" drives east along y = 0 from rest; "crosser" waits 2 s, then drives north
/// from (-19, -4.5) across lead's rut, about 2 s after lead passed x = -19.
std::vector<VehicleSetup> crossingScenario()
{
  return { VehicleSetup{ "lead", "mrzr", -22.0, 0.0, 0.0, 0.0, 0.0 },
           VehicleSetup{ "crosser", "mrzr", -19.0, -4.5, M_PI / 2, 2.0, 0.1 } };
}
constexpr double kCrossingUntil = 5.0;

/// Intervals where the two runs' samples of `vehicle` differ (all when the counts differ).
std::size_t differing(const Sim& x, const Sim& y, const std::string& vehicle)
{
  const std::vector<Sample>& a = x.samples.at(vehicle);
  const std::vector<Sample>& b = y.samples.at(vehicle);
  if (a.size() != b.size())
    return std::max(a.size(), b.size());
  std::size_t n = 0;
  for (std::size_t k = 0; k < a.size(); ++k)
    n += a[k] == b[k] ? 0 : 1;
  return n;
}

/// The reference: both vehicles in one World, sampled at every interval end.
const Sim& onePartition()
{
  static const std::unique_ptr<Sim> sim = [] {
    auto s = std::make_unique<Sim>(crossingScenario());
    for (int k = 1; k <= std::lround(kCrossingUntil / kInterval); ++k)
      s->stepTo(k * kInterval);
    return s;
  }();
  return *sim;
}

TEST(PartitionRunner, TwoPartitionsDriveTheOnePartitionTrajectoriesBitForBit)
{
  const std::vector<VehicleSetup> s = crossingScenario();
  Partition p1("p1", { s[0] }, { "p2" }, 0), p2("p2", { s[1] }, { "p1" }, 0);
  ASSERT_TRUE(run(p1, p2, kCrossingUntil, Schedule::kRoundRobin));
  const Sim& one = onePartition();
  ASSERT_EQ(one.samples.at("lead").size(), 500u);
  EXPECT_EQ(differing(one, p1.sim, "lead"), 0u);
  EXPECT_EQ(differing(one, p2.sim, "crosser"), 0u);
  // crosser crossed lead's path, over a rut made in the other partition: p2 has lead's rut
  // (at x = -20.5 m, where only lead drove) from the exchanges.
  const std::vector<Sample>& c = one.samples.at("crosser");
  EXPECT_LT(c.front().pose(1, 3), -4.0);
  EXPECT_GT(c.back().pose(1, 3), 1.5);
  float deepest = 0.0f;
  for (std::size_t j = 130; j <= 170; ++j)  // |y| < 2 m
    deepest = std::max(deepest, p2.sim.ground->deformation(45, j).plastic);
  EXPECT_GT(deepest, 0.01f) << "no rut of lead's in p2's terrain";
}

TEST(PartitionRunner, WithoutTheSoilInTheExchangesTheCrossingDiffers)
{
  // The check above sees the ruts: when the exchanges carry no soil, crosser crosses flat
  // ground in p2 and its trajectory leaves the one-partition run's.
  const std::vector<VehicleSetup> s = crossingScenario();
  Partition p1("p1", { s[0] }, { "p2" }, 0), p2("p2", { s[1] }, { "p1" }, 0);
  const auto no_soil = [](PartitionExchange& e) {
    e.soil_points.clear();
    e.soil_before.clear();
    e.soil_after.clear();
  };
  ASSERT_TRUE(run(p1, p2, kCrossingUntil, Schedule::kRoundRobin, no_soil));
  EXPECT_EQ(differing(onePartition(), p1.sim, "lead"), 0u);  // nothing crosses its path
  EXPECT_GT(differing(onePartition(), p2.sim, "crosser"), 0u);
}

TEST(PartitionRunner, SteppingAheadGivesTheStrictAnswerBitForBit)
{
  const std::vector<VehicleSetup> s = crossingScenario();
  Partition p1("p1", { s[0] }, { "p2" }, 4), p2("p2", { s[1] }, { "p1" }, 4);
  ASSERT_TRUE(run(p1, p2, kCrossingUntil, Schedule::kGreedy));
  EXPECT_EQ(differing(onePartition(), p1.sim, "lead"), 0u);
  EXPECT_EQ(differing(onePartition(), p2.sim, "crosser"), 0u);
  // p1 ran ahead of p2's exchanges (never more than K + 1 intervals) and held its soil back.
  std::size_t ahead = 0;
  for (const PartitionExchange& e : p1.transport.sent)
  {
    const double lag = std::round((e.time - e.peers_applied) / kInterval);
    if (e.time > 0.0)
    {
      EXPECT_TRUE(lag >= 1 && lag <= 5) << "t = " << e.time << ": lag " << lag;
    }
    ahead += lag > 1 ? 1 : 0;
  }
  EXPECT_GT(ahead, 100u);
  EXPECT_GT(p1.runner->steppedAhead(), 100u);
  EXPECT_GT(p1.runner->exchangesSent() - p1.runner->soilExchangesSent(), 50u);  // soil held back
}

// Vehicles that join and leave a partitioned run (issue 22: spawn and remove in partitions).
// "late" joins p1 at 1 s, 8 m north of lead's path; lead leaves p1 at 3 s. The same calls at the
// same times in one World give the same trajectories bit for bit; the peers take the newcomer as
// a proxy from p1's next exchange and drop the leaver's proxy from the one after it left.
const VehicleSetup kLate{ "late", "mrzr", -10.0, 8.0, 0.0, 1.5, 0.05 };
constexpr double kLateJoins = 1.0, kLeadLeaves = 3.0;

const Sim& onePartitionWithJoinAndLeave()
{
  static const std::unique_ptr<Sim> sim = [] {
    auto s = std::make_unique<Sim>(crossingScenario());
    for (int k = 1; k <= std::lround(kCrossingUntil / kInterval); ++k)
    {
      s->stepTo(k * kInterval);
      if (k == std::lround(kLateJoins / kInterval))
        s->add(kLate);
      if (k == std::lround(kLeadLeaves / kInterval))
        s->remove("lead");
    }
    return s;
  }();
  return *sim;
}

void joinAndLeave(int k, Schedule schedule)
{
  const std::vector<VehicleSetup> s = crossingScenario();
  Partition p1("p1", { s[0] }, { "p2" }, k), p2("p2", { s[1] }, { "p1" }, k);
  ASSERT_TRUE(run(p1, p2, kLateJoins, schedule));
  EXPECT_EQ(p2.sim.world->proxyCount(), 1u);
  const std::size_t id = p1.sim.add(kLate);
  p1.runner->addVehicle(PartitionVehicle{ id, kLate.name, kLate.model, boundingBox(model(kLate.model)) });
  EXPECT_TRUE(p1.runner->runs("late"));
  // A name the peer runs, or one p1 runs, cannot join again.
  EXPECT_THROW(p1.runner->addVehicle(PartitionVehicle{ id, "crosser", "mrzr", boundingBox(model("mrzr")) }),
               std::invalid_argument);
  EXPECT_THROW(p1.runner->addVehicle(PartitionVehicle{ id, "late", "mrzr", boundingBox(model("mrzr")) }),
               std::invalid_argument);
  EXPECT_EQ(p1.runner->ownerOf("crosser"), "p2");

  ASSERT_TRUE(run(p1, p2, kLeadLeaves, schedule));
  EXPECT_EQ(p2.sim.world->proxyCount(), 2u);  // lead and late
  EXPECT_EQ(p2.runner->ownerOf("late"), "p1");
  p1.sim.remove("lead");
  EXPECT_TRUE(p1.runner->removeVehicle("lead"));
  EXPECT_FALSE(p1.runner->removeVehicle("lead"));
  EXPECT_FALSE(p1.runner->removeVehicle("crosser"));  // not p1's

  ASSERT_TRUE(run(p1, p2, kCrossingUntil, schedule));
  EXPECT_EQ(p2.sim.world->proxyCount(), 1u);  // late only
  EXPECT_EQ(p2.runner->ownerOf("lead"), "");
  const Sim& one = onePartitionWithJoinAndLeave();
  ASSERT_EQ(one.samples.at("late").size(), 400u);  // 1.01 .. 5.0 s
  ASSERT_EQ(one.samples.at("lead").size(), 300u);  // 0.01 .. 3.0 s
  EXPECT_EQ(differing(one, p1.sim, "lead"), 0u);
  EXPECT_EQ(differing(one, p1.sim, "late"), 0u);
  EXPECT_EQ(differing(one, p2.sim, "crosser"), 0u);
  EXPECT_GT(one.samples.at("late").back().pose(0, 3), kLate.x + 2.0);  // it drove
  // p2 holds every rut lead made (AVehicleThatLeavesTakesItsUnsentRutsWithIt: also held-back ones).
  std::size_t compared = 0, rutted = 0;
  for (std::size_t i = 0; i < 501; ++i)
    for (std::size_t j = 130; j <= 170; ++j)  // |y| < 2 m: lead's path
    {
      if (i >= 20 && i <= 70)  // crosser's crossing (x -23 .. -18 m): p2's own soil
        continue;
      ASSERT_EQ(p2.sim.ground->deformation(i, j).plastic, p1.sim.ground->deformation(i, j).plastic)
          << "point (" << i << ", " << j << ")";
      ++compared;
      rutted += p1.sim.ground->deformation(i, j).plastic > 0.0f ? 1 : 0;
    }
  EXPECT_GT(rutted, 100u) << "of " << compared << " points compared";
}

TEST(PartitionRunner, VehiclesJoinAndLeaveAsInOneWorldStrict)
{
  joinAndLeave(0, Schedule::kRoundRobin);
}

TEST(PartitionRunner, VehiclesJoinAndLeaveAsInOneWorldSteppingAhead)
{
  joinAndLeave(4, Schedule::kGreedy);
}

TEST(PartitionRunner, AVehicleThatLeavesTakesItsUnsentRutsWithIt)
{
  // K = 4, the peer's vehicle far away: p1 holds back what its mrzr presses. When the mrzr
  // leaves, the next exchange carries all of it (no peer vehicle would ever come near it).
  Partition p("p1", { VehicleSetup{ "mrzr", "mrzr", 0.0, 0.0, 0.0, 1e9, 0.0 } }, { "p2" }, 4);
  PartitionExchange far;
  far.partition = "p2";
  ExchangedVehicle v;
  v.name = "far";
  v.model = "fed_alpha";
  v.position = Eigen::Vector3d(60.0, 40.0, 1.0);
  far.vehicles.push_back(v);
  for (int k = 0; k < 30; ++k)
  {
    far.time = 0.01 * k;
    p.runner->receive("p2", far);
    ASSERT_TRUE(p.tryInterval()) << "interval " << k;
  }
  ASSERT_EQ(p.runner->soilExchangesSent(), 1u);  // at 0 only
  std::set<std::uint32_t> pressed;
  for (std::uint32_t j = 120; j <= 180; ++j)
    for (std::uint32_t i = 220; i <= 280; ++i)
    {
      const terrain::PointDeformation d = p.sim.ground->deformation(i, j);
      if (d.plastic != 0.0f || d.displaced != 0.0f || d.sigma_max != 0.0f)
        pressed.insert(j * 501 + i);
    }
  ASSERT_GT(pressed.size(), 20u);
  p.sim.remove("mrzr");
  ASSERT_TRUE(p.runner->removeVehicle("mrzr"));
  far.time = 0.3;
  p.runner->receive("p2", far);
  ASSERT_TRUE(p.tryInterval());
  EXPECT_EQ(p.runner->soilExchangesSent(), 2u);
  const PartitionExchange& last = p.transport.outbox.back();
  EXPECT_TRUE(last.vehicles.empty());
  EXPECT_EQ(std::set<std::uint32_t>(last.soil_points.begin(), last.soil_points.end()), pressed);
}

/// A partition with one braked mrzr at the origin, and a peer "p2" the test plays by hand.
struct Solo
{
  std::vector<std::string> log;  ///< the runner's log lines
  Partition p;

  explicit Solo(int k = 4)
    : p("p1", { VehicleSetup{ "mrzr", "mrzr", 0.0, 0.0, 0.0, 1e9, 0.0 } }, { "p2" }, k,
        [this](PartitionRunner::Level, const std::string& text) { log.push_back(text); })
  {
  }

  /// p2's exchange of t with a fed_alpha at (x, y, z) at rest (without gravity, as proxies are).
  static PartitionExchange peer(double t, double x, double y, double z = 1.0)
  {
    PartitionExchange e;
    e.partition = "p2";
    e.time = t;
    ExchangedVehicle v;
    v.name = "far";
    v.model = "fed_alpha";
    v.position = Eigen::Vector3d(x, y, z);
    e.vehicles.push_back(v);
    return e;
  }
};

/// The flatLoam() grid point (j * 501 + i) nearest under wheel `w` of the Sim's first vehicle.
std::uint32_t wheelPoint(const Sim& sim, std::size_t w)
{
  const VehicleModel m = model(sim.vehicles[0].second.model);
  const Eigen::Vector3d c = sim.world->state(sim.vehicles[0].first).pose * m.wheels[w].rest_position;
  const auto i = static_cast<std::uint32_t>(std::lround((c.x() + 25.0) / 0.1));
  const auto j = static_cast<std::uint32_t>(std::lround((c.y() + 15.0) / 0.1));
  return j * 501 + i;
}

TEST(PartitionRunner, APeerVehicleFarAwayLetsThePartitionStepKIntervalsAhead)
{
  Solo s;
  s.p.runner->receive("p2", Solo::peer(0.0, 15.0, 10.0));
  // Exchanges of 0.01 s on never arrive: intervals up to 0.05 s need none of them (K = 4).
  for (int k = 0; k < 5; ++k)
    ASSERT_TRUE(s.p.tryInterval()) << "interval " << k;
  EXPECT_EQ(s.p.runner->steppedAhead(), 4u);
  EXPECT_FALSE(s.p.tryInterval());  // from 0.05 s the exchange of 0.01 s is due
  EXPECT_DOUBLE_EQ(s.p.runner->waitingFor(), 0.01);
  EXPECT_EQ(s.p.runner->missingSources(), std::vector<std::string>{ "memory/p2" });
  s.p.runner->receive("p2", Solo::peer(0.01, 15.0, 10.0));
  EXPECT_TRUE(s.p.tryInterval());
  EXPECT_DOUBLE_EQ(s.p.runner->peersApplied(), 0.01);
  ASSERT_EQ(s.log.size(), 1u);
  EXPECT_EQ(s.log[0], "partition 'p1' sees far (fed_alpha, partition 'p2') as a proxy");
}

TEST(PartitionRunner, APeerVehicleNearbyMakesThePartitionWaitForItsLatestExchange)
{
  Solo s;
  // Above the mrzr: no contact, but what the conservative check looks at, the shadows on the
  // map's plane, overlap.
  s.p.runner->receive("p2", Solo::peer(0.0, 0.0, 0.0, 6.0));
  ASSERT_TRUE(s.p.tryInterval());
  EXPECT_FALSE(s.p.tryInterval());
  EXPECT_DOUBLE_EQ(s.p.runner->waitingFor(), 0.01);
  EXPECT_EQ(s.p.runner->steppedAhead(), 0u);
}

TEST(PartitionRunner, SoilChangesWaitWhileNoPeerVehicleCanReachThem)
{
  Solo s;
  // 0.3 s with the peer's vehicle far away: the mrzr settles into the soil, and holds back what
  // its wheels press.
  for (int k = 0; k < 30; ++k)
  {
    s.p.runner->receive("p2", Solo::peer(0.01 * k, 60.0, 40.0));
    ASSERT_TRUE(s.p.tryInterval()) << "interval " << k;
  }
  const std::uint32_t under_wheel = wheelPoint(s.p.sim, 0);
  ASSERT_GT(s.p.sim.ground->deformation(under_wheel % 501, under_wheel / 501).plastic, 0.0f);
  // From 0.3 s on the peer's vehicle is over ours; p1 learns it at 0.34 s, when the exchange
  // of 0.3 s is due (K = 4), and sends its soil changes with its next exchange.
  for (int k = 30; k < 35; ++k)
  {
    s.p.runner->receive("p2", Solo::peer(0.01 * k, 0.0, 0.0, 6.0));
    ASSERT_TRUE(s.p.tryInterval()) << "interval " << k;
  }
  EXPECT_EQ(s.p.runner->steppedAhead(), 33u);  // from 0.01 to 0.33 s
  const std::deque<PartitionExchange>& sent = s.p.transport.outbox;
  ASSERT_EQ(sent.size(), 36u);  // at 0, 0.01, ..., 0.35 s
  for (std::size_t k = 1; k < 35; ++k)
    EXPECT_TRUE(sent[k].soil_points.empty()) << "exchange of " << sent[k].time << " s";
  EXPECT_EQ(s.p.runner->soilExchangesSent(), 2u);  // at 0 and 0.35 s
  // The exchange of 0.35 s carries every point pressed since 0 (all within 3 m of the origin),
  // once each.
  const std::vector<std::uint32_t>& points = sent[35].soil_points;
  std::set<std::uint32_t> pressed;
  for (std::uint32_t j = 120; j <= 180; ++j)
    for (std::uint32_t i = 220; i <= 280; ++i)
    {
      const terrain::PointDeformation d = s.p.sim.ground->deformation(i, j);
      if (d.plastic != 0.0f || d.displaced != 0.0f || d.sigma_max != 0.0f)
        pressed.insert(j * 501 + i);
    }
  EXPECT_GT(pressed.size(), 20u);
  EXPECT_EQ(points.size(), pressed.size());
  EXPECT_EQ(std::set<std::uint32_t>(points.begin(), points.end()), pressed);
  EXPECT_EQ(pressed.count(under_wheel), 1u);
}

TEST(PartitionRunner, ASoilPointBothPartitionsChangedIsMerged)
{
  // Strict (K = 0): each interval needs the peer's exchange of its start.
  Solo s(0);
  for (int k = 0; k < 30; ++k)  // 0.3 s: the mrzr has settled into the soil
  {
    s.p.runner->receive("p2", Solo::peer(0.01 * k, 15.0, 10.0));
    ASSERT_TRUE(s.p.tryInterval());
  }
  // A point under its first wheel that p2 claims to have changed in the same interval.
  const std::uint32_t point = wheelPoint(s.p.sim, 0), i = point % 501, j = point / 501;
  const terrain::PointDeformation ours = s.p.sim.ground->deformation(i, j);
  ASSERT_GT(ours.plastic, 0.0f);
  PartitionExchange e = Solo::peer(0.3, 15.0, 10.0);
  e.soil_points = { point };
  e.soil_before = { 0.f, 0.f, 0.f };
  e.soil_after = { ours.plastic + 0.05f, 0.002f, 0.f };
  s.p.runner->receive("p2", e);
  EXPECT_EQ(s.p.runner->mergedPoints(), 0u);
  ASSERT_EQ(s.p.runner->prepare(0.3, 0.31), PartitionRunner::Ready::kReady);
  EXPECT_EQ(s.p.runner->mergedPoints(), 1u);
  const terrain::PointDeformation merged = s.p.sim.ground->deformation(i, j);
  EXPECT_EQ(merged.plastic, ours.plastic + 0.05f);             // the larger of the two
  EXPECT_EQ(merged.sigma_max, ours.sigma_max);                 // ours, the larger
  EXPECT_FLOAT_EQ(merged.displaced, ours.displaced + 0.002f);  // ours plus the peer's change
  ASSERT_GE(s.log.size(), 2u);
  EXPECT_NE(s.log.back().find("1 soil point(s) changed by both this partition and 'p2' before t = 0.300 s: merged"),
            std::string::npos)
      << s.log.back();
}

/// Expects `f` to throw an ExchangeError whose message contains `text`.
void expectRefused(const std::function<void()>& f, const std::string& text)
{
  try
  {
    f();
    ADD_FAILURE() << "not refused: " << text;
  }
  catch (const ExchangeError& e)
  {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

TEST(PartitionRunnerRefuses, AnExchangeNamingAnotherPartition)
{
  Solo s;
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.partition = "p3";
  expectRefused([&] { s.p.runner->receive("p2", e); }, "bad exchange on memory/p2: partition is 'p3', not 'p2'");
}

TEST(PartitionRunnerRefuses, SoilArraysOfTheWrongSize)
{
  Solo s;
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.soil_points = { 1, 2 };
  e.soil_before = { 0.f, 0.f, 0.f };
  e.soil_after.assign(6, 0.f);
  expectRefused([&] { s.p.runner->receive("p2", e); },
                "bad exchange on memory/p2: soil_before and soil_after must hold 3 values per soil_points entry");
}

TEST(PartitionRunnerRefuses, ToppledArraysOfDifferentSizes)
{
  Solo s;
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.toppled_ids = { 3 };
  expectRefused([&] { s.p.runner->receive("p2", e); }, "toppled_directions must have one entry per toppled_ids");
}

TEST(PartitionRunnerRefuses, AnExchangeFromAPartitionThatIsNotAPeer)
{
  Solo s;
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.partition = "p9";
  expectRefused([&] { s.p.runner->receive("p9", e); }, "'p9' is not a peer of partition 'p1'");
}

/// Applies `bad` as p2's exchange of 0 and expects the refusal to contain `text`.
void expectRefusedWhenApplied(PartitionExchange bad, const std::string& text)
{
  Solo s;
  s.p.runner->receive("p2", std::move(bad));
  expectRefused([&] { s.p.tryInterval(); }, "bad exchange on memory/p2 for t = 0.000 s: " + text);
}

TEST(PartitionRunnerRefuses, ASoilPointOffTheGrid)
{
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.soil_points = { 501u * 301u };
  e.soil_before.assign(3, 0.f);
  e.soil_after.assign(3, 0.f);
  expectRefusedWhenApplied(e, "soil_points[0] = 150801 is outside the 501 x 301 grid");
}

TEST(PartitionRunnerRefuses, APeerVehicleNamedAsOneOfOurs)
{
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.vehicles[0].name = "mrzr";
  expectRefusedWhenApplied(e, "vehicle 'mrzr' is simulated here too");
}

TEST(PartitionRunnerRefuses, AModelThatIsNotAName)
{
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.vehicles[0].model = "../fed_alpha";
  expectRefusedWhenApplied(e, "vehicle 'far' has model '../fed_alpha', not a model name");
}

TEST(PartitionRunnerRefuses, AModelThatDoesNotLoad)
{
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.vehicles[0].model = "no_such_model";
  expectRefusedWhenApplied(e, "vehicle 'far' of partition 'p2': ");
}

TEST(PartitionRunnerRefuses, AnOrientationThatIsNotAUnitQuaternion)
{
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.vehicles[0].orientation = Eigen::Quaterniond(0.5, 0.0, 0.0, 0.0);
  expectRefusedWhenApplied(e, "vehicle 'far': orientation is not a unit quaternion");
}

TEST(PartitionRunnerRefuses, ANonFiniteVelocity)
{
  PartitionExchange e = Solo::peer(0.0, 15.0, 10.0);
  e.vehicles[0].linear_velocity.x() = std::nan("");
  expectRefusedWhenApplied(e, "World::setProxyState: state of proxy 'far' is not finite");
}

TEST(PartitionRunnerRefuses, ItsOwnNameAmongThePeers)
{
  Sim sim({});
  MemoryTransport t;
  EXPECT_THROW(
      PartitionRunner(PartitionOptions{ "p1", { "p1" }, kInterval, 4 }, *sim.world, sim.objects, {}, {}, model, t),
      std::invalid_argument);
  EXPECT_THROW(PartitionRunner(PartitionOptions{ "p1", { "p2", "p2" }, kInterval, 4 }, *sim.world, sim.objects, {}, {},
                               model, t),
               std::invalid_argument);
}

}  // namespace
