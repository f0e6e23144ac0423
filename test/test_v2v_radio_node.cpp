// rostest of v2v_radio_node (test/v2v_radio_node.test). This node owns /clock and advances it
// in lockstep: after each step it waits (wall time, bounded) until every delivery the radio
// owes by then has arrived, so rates and latencies are measured exactly on sim time.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <avsp_msgs/VehicleState.h>
#include <avsp_terrain/ros/run_command.hpp>
#include <avsp_terrain/ros/test_clock.hpp>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include "avsp/v2v/radio.hpp"

namespace
{
/// One message seen on a vehicle's v2v/in.
struct Received
{
  std::string sender;
  std::uint32_t seq;
  double stamp;    ///< the sender's state stamp
  double arrival;  ///< the test's sim clock when it arrived
};

avsp::node::TestClock* sim = nullptr;  // ticks of 1 ms

/// The test's side of a radio: publishers on <ns><v>/v2v/out, subscribers on <ns><v>/v2v/in.
struct Fleet
{
  ros::NodeHandle nh;
  std::vector<std::string> names;
  std::vector<ros::Publisher> out;
  std::vector<ros::Subscriber> in;
  std::map<std::string, std::vector<Received>> inbox;
  std::map<std::string, std::uint32_t> seq;

  Fleet(const std::string& ns, std::vector<std::string> vehicles) : names(std::move(vehicles))
  {
    for (const std::string& v : names)
    {
      out.push_back(nh.advertise<avsp_msgs::VehicleState>(ns + v + "/v2v/out", 100));
      in.push_back(nh.subscribe<avsp_msgs::VehicleState>(
          ns + v + "/v2v/in", 1000, [this, v](const avsp_msgs::VehicleState::ConstPtr& m) {
            inbox[v].push_back({ m->vehicle_id, m->seq, m->header.stamp.toSec(), sim->now() });
          }));
    }
  }

  bool connected() const
  {
    for (std::size_t k = 0; k < names.size(); ++k)
      if (out[k].getNumSubscribers() == 0 || in[k].getNumPublishers() == 0)
        return false;
    return true;
  }

  void broadcast(std::size_t k, double x, double y)
  {
    avsp_msgs::VehicleState s;
    s.header.stamp = ros::Time(sim->now());
    s.header.frame_id = "map";
    s.vehicle_id = names[k];
    s.position.x = x;
    s.position.y = y;
    s.speed = 1.0;
    s.seq = seq[names[k]]++;
    out[k].publish(s);
  }

  std::size_t count(const std::string& receiver, const std::function<bool(const Received&)>& pick) const
  {
    const auto it = inbox.find(receiver);
    if (it == inbox.end())
      return 0;
    std::size_t n = 0;
    for (const Received& r : it->second)
      n += pick(r) ? 1 : 0;
    return n;
  }
};

/// Picks the states from `sender` stamped after `t`.
std::function<bool(const Received&)> from_sender_after(const std::string& sender, double t)
{
  return [sender, t](const Received& r) { return r.sender == sender && r.stamp > t; };
}

/// Spins (republishing the clock) until `done` or `timeout` wall seconds.
bool waitFor(const std::function<bool()>& done, double timeout = 10.0)
{
  return sim->waitFor(done, timeout);
}

TEST(V2vRadioNode, InRangeAt10HzOutOfRangeNeverLatencyExact)
{
  Fleet fleet("", { "alpha", "bravo", "charlie", "delta", "flush" });
  std::vector<visualization_msgs::MarkerArray> markers;
  ros::Subscriber marker_sub = fleet.nh.subscribe<visualization_msgs::MarkerArray>(
      "/v2v/fleet_markers", 10, [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers.push_back(*m); });
  ASSERT_TRUE(waitFor([&] { return fleet.connected() && sim->subscribers() >= 2; }))
      << "v2v_radio_node did not connect";

  // alpha at the origin, bravo 250 m east (in range of alpha), charlie 400 m north (out of
  // range of everyone), delta 400 m east (in range of bravo only). At 20 s bravo moves to
  // 350 m east: out of alpha's range. bravo <-> delta stays in range throughout, so waiting
  // for bravo's state at delta also proves the radio has taken bravo's new position before
  // alpha's next broadcast is sent (the radio processes different topics in any order).
  const double charlie_y = 400.0, delta_x = 400.0;
  auto bravo_x = [](long ticks) { return ticks < 20000 ? 250.0 : 350.0; };
  auto broadcastAll = [&] {
    fleet.broadcast(0, 0.0, 0.0);
    fleet.broadcast(1, bravo_x(sim->ticks()), 0.0);
    fleet.broadcast(2, 0.0, charlie_y);
    fleet.broadcast(3, delta_x, 0.0);
  };
  // Warm-up: one round (stamped 0.01 s: a zero stamp would mean "stamp on reception") so that
  // every vehicle's position is known before counting. The radio has taken both ends of a link
  // once either end hears the other (whichever it took second reaches the first): alpha-bravo
  // and bravo-delta. charlie, in range of nobody, is heard by nobody either way. The clock goes
  // 50 ms (the latency) ahead to release them; the 10 Hz rounds still fall on 0.1 s, 0.2 s ...
  sim->step(10);
  broadcastAll();
  sim->step(50);
  auto heard = [&](const std::string& receiver, const std::string& sender) {
    return fleet.count(receiver, [&](const Received& r) { return r.sender == sender && r.seq == 0; }) > 0;
  };
  ASSERT_TRUE(waitFor([&] {
    return (heard("bravo", "alpha") || heard("alpha", "bravo")) && (heard("delta", "bravo") || heard("bravo", "delta"));
  })) << "the warm-up round did not reach the radio";

  const double latency = 0.05;
  const long end_ms = 25000;
  auto window = [](double lo, double hi) {
    return [lo, hi](const Received& r) { return r.stamp >= lo - 1e-9 && r.stamp <= hi + 1e-9; };
  };
  while (sim->ticks() < end_ms)
  {
    sim->step(10);
    if (sim->ticks() % 100 == 0)  // 10 Hz
      broadcastAll();
    // Owed by now (whole milliseconds: 0.15 - 0.05 is below 0.1 in doubles): states stamped
    // from 0.1 s to now - latency, alpha <-> bravo until 19.9 s, bravo <-> delta throughout.
    const long due_ms = sim->ticks() - 50;
    auto owedUpTo = [&](long last_ms) {
      const long last = std::min(due_ms, last_ms);
      return last < 100 ? std::size_t{ 0 } : static_cast<std::size_t>((last - 100) / 100 + 1);
    };
    const std::size_t owed_ab = owedUpTo(19900), owed_bd = owedUpTo(end_ms);
    auto from = [&](const std::string& sender, double lo, double hi) {
      return [sender, w = window(lo, hi)](const Received& r) { return r.sender == sender && w(r); };
    };
    auto owedArrived = [&] {
      return fleet.count("bravo", from("alpha", 0.1, 19.9)) >= owed_ab &&
             fleet.count("alpha", from("bravo", 0.1, 19.9)) >= owed_ab &&
             fleet.count("delta", from("bravo", 0.1, 25.0)) >= owed_bd &&
             fleet.count("bravo", from("delta", 0.1, 25.0)) >= owed_bd;
    };
    ASSERT_TRUE(waitFor(owedArrived, 5.0)) << "deliveries owed by sim time " << sim->now() << " did not arrive";
  }
  // Barrier: 'flush', silent until now (so unknown to the radio and in nobody's range), speaks
  // once from (200, 200), within 300 m of all four. The radio sends each vehicle's v2v/in in
  // order of due time over one connection, so once its state (due at 25.05 s) is in every
  // inbox, everything due before it is too: no grace period to wait out.
  fleet.broadcast(4, 200.0, 200.0);
  sim->step(50);
  ASSERT_TRUE(waitFor([&] {
    for (const char* v : { "alpha", "bravo", "charlie", "delta" })
      if (fleet.count(v, [](const Received& r) { return r.sender == "flush"; }) == 0)
        return false;
    return true;
  })) << "the barrier state from 'flush' did not reach every vehicle";
  auto before_flush = [](const Received& r) { return r.sender != "flush"; };

  // Rate: alpha's states reach bravo at 10 Hz over [5, 15) s of sim time, and back: exactly the
  // 100 stamped 5.0 .. 14.9 s (arriving 5.05 .. 14.95 s; the test drives the clock).
  for (const auto& [receiver, sender] :
       { std::pair<std::string, std::string>{ "bravo", "alpha" }, { "alpha", "bravo" } })
  {
    const std::size_t n = fleet.count(receiver, [&, s = sender](const Received& r) {
      return r.sender == s && r.arrival >= 5.0 - 1e-9 && r.arrival < 15.0 - 1e-9;
    });
    EXPECT_EQ(n, 100u) << sender << " -> " << receiver << ": " << n << " in 10 s";
  }
  // Latency: every delivery the lockstep waited for (alpha <-> bravo stamped 0.1-19.9 s,
  // bravo <-> delta 0.1-24.9 s) arrived exactly 50 ms of sim time after its stamp: not a clock
  // step earlier or later.
  std::size_t timed = 0;
  for (const auto& [receiver, list] : fleet.inbox)
    for (const Received& r : list)
      if ((receiver == "delta" || r.sender == "delta") ? window(0.1, 24.9)(r) : window(0.1, 19.9)(r))
      {
        ASSERT_NEAR(r.arrival - r.stamp, latency, 1e-6) << r.sender << " seq " << r.seq << " -> " << receiver;
        ++timed;
      }
  EXPECT_EQ(timed, 2u * 199u + 2u * 249u);
  // Out of range: charlie hears nobody and nobody hears charlie; alpha and delta (400 m) never
  // hear each other; after bravo moved to 350 m, nothing between alpha and bravo (the states
  // stamped 20.0 s race bravo's move and may go either way).
  EXPECT_EQ(fleet.count("charlie", before_flush), 0u);
  for (const char* v : { "alpha", "bravo", "delta" })
    EXPECT_EQ(fleet.count(v, [](const Received& r) { return r.sender == "charlie"; }), 0u) << v;
  EXPECT_EQ(fleet.count("alpha", [](const Received& r) { return r.sender == "delta"; }), 0u);
  EXPECT_EQ(fleet.count("delta", [](const Received& r) { return r.sender == "alpha"; }), 0u);
  EXPECT_EQ(fleet.count("bravo", from_sender_after("alpha", 20.05)), 0u);
  EXPECT_EQ(fleet.count("alpha", from_sender_after("bravo", 20.05)), 0u);
  EXPECT_GE(fleet.count("delta", from_sender_after("bravo", 20.05)), 49u);  // bravo still heard by delta
  // Nothing duplicated: each (sender, seq) once per receiver.
  for (const auto& [receiver, list] : fleet.inbox)
  {
    std::set<std::pair<std::string, std::uint32_t>> seen;
    for (const Received& r : list)
      EXPECT_TRUE(seen.insert({ r.sender, r.seq }).second)
          << receiver << " got " << r.sender << " " << r.seq << " twice";
  }

  // Fleet view: while bravo is at 250 m, green links alpha-bravo and bravo-delta, none to charlie.
  bool saw_link = false;
  for (const auto& array : markers)
    for (const auto& m : array.markers)
      if (m.ns == "links" && m.header.stamp.toSec() > 2.0 && m.header.stamp.toSec() < 19.0)
      {
        ASSERT_EQ(m.points.size(), 4u);  // two segments
        for (std::size_t k = 0; k < 4; k += 2)
        {
          EXPECT_NEAR(std::abs(m.points[k].x - m.points[k + 1].x), k == 0 ? 250.0 : 150.0, 1e-9);
          EXPECT_NEAR(m.points[k].y, 0.0, 1e-9);
          EXPECT_NEAR(m.points[k + 1].y, 0.0, 1e-9);
        }
        saw_link = true;
      }
  EXPECT_TRUE(saw_link) << markers.size() << " marker arrays, none with the links";
}

TEST(V2vRadioNode, LossAsConfiguredAndExactlyAsTheCorePredicts)
{
  Fleet fleet("/lossy/", { "l0", "l1", "l2", "l3", "l4" });
  ASSERT_TRUE(waitFor([&] { return fleet.connected(); })) << "lossy radio did not connect";
  auto position = [](std::size_t k) { return std::pair<double, double>{ 10.0 * k, 5.0 * (k % 2) }; };
  // The radio's fleet view (10 Hz of sim time) draws a dot for every vehicle whose position it
  // knows: counting starts once it knows all five from the warm-up round (sequence numbers 0).
  std::size_t dots = 0;
  ros::Subscriber marker_sub = fleet.nh.subscribe<visualization_msgs::MarkerArray>(
      "/lossy/v2v/fleet_markers", 10, [&](const visualization_msgs::MarkerArray::ConstPtr& m) {
        dots = static_cast<std::size_t>(
            std::count_if(m->markers.begin(), m->markers.end(), [](const auto& x) { return x.ns == "vehicles"; }));
      });
  ASSERT_TRUE(waitFor([&] { return marker_sub.getNumPublishers() > 0; })) << "no fleet view";
  for (std::size_t k = 0; k < 5; ++k)
    fleet.broadcast(k, position(k).first, position(k).second);
  for (int tick = 0; tick < 50 && dots < 5; ++tick)
  {
    sim->step(100);
    waitFor([&] { return dots == 5; }, 1.0);
  }
  ASSERT_EQ(dots, 5u) << "the radio does not know every position after the warm-up round";

  // 100 rounds at 10 Hz: 5 x 4 x 100 = 2000 (message, receiver) pairs, each lost with p = 0.2.
  std::set<std::tuple<std::string, std::string, std::uint32_t>> expected;
  std::size_t attempts = 0;
  for (int round = 0; round < 100; ++round)
  {
    sim->step(100);
    for (std::size_t k = 0; k < 5; ++k)
    {
      const std::uint32_t seq = fleet.seq[fleet.names[k]];
      fleet.broadcast(k, position(k).first, position(k).second);
      for (std::size_t r = 0; r < 5; ++r)
        if (r != k)
        {
          ++attempts;
          if (avsp::v2v::Radio::lossDraw(7, fleet.names[k], fleet.names[r], seq) >= 0.2)
            expected.insert({ fleet.names[k], fleet.names[r], seq });
        }
    }
    ASSERT_TRUE(waitFor(
        [&] {
          std::size_t got = 0;
          for (const auto& [receiver, list] : fleet.inbox)
            got += fleet.count(receiver, [](const Received& x) { return x.seq >= 1; });
          return got >= expected.size();
        },
        5.0))
        << "round " << round;
  }
  // Barrier: more rounds until every vehicle has had one of their states (the seeded draws say
  // which arrive). The radio sends each v2v/in in order of due time over one connection, so
  // then anything unexpected from the counted rounds would be in the inboxes already.
  const std::uint32_t counted = fleet.seq[fleet.names[0]];  // sequence numbers 1 .. counted - 1
  std::set<std::string> barred;
  for (int round = 0; round < 10 && barred.size() < 5; ++round)
  {
    sim->step(100);
    std::set<std::tuple<std::string, std::string, std::uint32_t>> due;
    for (std::size_t k = 0; k < 5; ++k)
    {
      const std::uint32_t seq = fleet.seq[fleet.names[k]];
      fleet.broadcast(k, position(k).first, position(k).second);
      for (std::size_t r = 0; r < 5; ++r)
        if (r != k && avsp::v2v::Radio::lossDraw(7, fleet.names[k], fleet.names[r], seq) >= 0.2)
          due.insert({ fleet.names[k], fleet.names[r], seq });
    }
    ASSERT_TRUE(waitFor([&] {
      for (const auto& [sender, receiver, seq] : due)
        if (fleet.count(receiver,
                        [&, s = sender, q = seq](const Received& x) { return x.sender == s && x.seq == q; }) == 0)
          return false;
      return true;
    })) << "barrier round "
        << round;
    for (const auto& d : due)
      barred.insert(std::get<1>(d));
  }
  ASSERT_EQ(barred.size(), 5u);

  std::set<std::tuple<std::string, std::string, std::uint32_t>> got;
  for (const auto& [receiver, list] : fleet.inbox)
    for (const Received& r : list)
      if (r.seq >= 1 && r.seq < counted)
        got.insert({ r.sender, receiver, r.seq });
  EXPECT_EQ(got, expected) << "deliveries differ from the seeded loss draws";
  const double loss = 1.0 - static_cast<double>(got.size()) / attempts;
  EXPECT_EQ(attempts, 2000u);
  EXPECT_NEAR(loss, 0.2, 0.02) << got.size() << " of " << attempts << " delivered";
}

/// Runs v2v_radio_node under a fresh name with parameters set on the master: exit code, output.
std::pair<int, std::string> runBadNode(const std::function<void(const std::string&)>& set_params)
{
  static int run = 0;
  const std::string name = "bad_v2v_" + std::to_string(getpid()) + "_" + std::to_string(run++);
  ros::NodeHandle nh;
  XmlRpc::XmlRpcValue vehicles;
  vehicles[0] = std::string("a");
  vehicles[1] = std::string("b");
  nh.setParam("/" + name + "/vehicles", vehicles);
  set_params("/" + name + "/");
  return avsp::node::runCommand(std::string(V2V_RADIO_NODE_PATH) + " __name:=" + name);
}

TEST(V2vRadioNodeStartup, BadParametersExitNamingTheKey)
{
  ros::NodeHandle nh;
  auto [code, out] = runBadNode([&](const std::string& ns) { nh.setParam(ns + "loss_probability", 1.5); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~loss_probability"), std::string::npos) << out;
  std::tie(code, out) = runBadNode([&](const std::string& ns) { nh.setParam(ns + "range", -3.0); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~range"), std::string::npos) << out;
  std::tie(code, out) = runBadNode([&](const std::string& ns) {
    XmlRpc::XmlRpcValue twice;
    twice[0] = std::string("a");
    twice[1] = std::string("a");
    nh.setParam(ns + "vehicles", twice);
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~vehicles[1] 'a' is listed twice"), std::string::npos) << out;
  std::tie(code, out) = runBadNode([&](const std::string& ns) { nh.deleteParam(ns + "vehicles"); });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~vehicles"), std::string::npos) << out;
  // Line of sight loads the terrain through the shared terrain parameters: a bad one is named.
  std::tie(code, out) = runBadNode([&](const std::string& ns) {
    nh.setParam(ns + "line_of_sight", true);
    nh.setParam(ns + "flat_soil", std::string("marmalade"));
  });
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~flat_soil"), std::string::npos) << out;
}
}  // namespace

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_v2v_radio_node");
  avsp::node::TestClock clock(1e-3);
  sim = &clock;
  return RUN_ALL_TESTS();
}
