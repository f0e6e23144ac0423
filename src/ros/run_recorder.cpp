// run_recorder's class (the node's main is ../run_recorder.cpp): the main job's results writer.
// Records every listed vehicle's odometry and telemetry and the ruts on /terrain/ruts on sim
// time (the tables stream to the results folder as the run goes, in memory that does not grow
// with its length), prints a progress line at most once per ~progress_period wall seconds, and
// when /clock reaches ~duration writes ~output_dir/ (summary.json, CSVs, .npy grids), runs
// scripts/plot_results.py for the PNGs and exits 0 (non-zero naming the file or topic on
// failure). Launched required="true", it ends the run.
//
// Thin: the computations and file formats are avsp_results (include/avsp/results/, no ROS);
// this file reads parameters, converts messages and keeps time. Parameters: README.md,
// "Run recorder".
#include "avsp/ros/run_recorder.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <avsp_msgs/DemCrossing.h>
#include <avsp_msgs/ObjectToppled.h>
#include <avsp_msgs/TerrainPatch.h>
#include <avsp_msgs/VehicleTelemetry.h>
#include <avsp_terrain/height_patch.hpp>
#include <avsp_terrain/ros/conversions.hpp>
#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/terrain_source_params.hpp>
#include <avsp_terrain/soil.hpp>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <nav_msgs/Odometry.h>
#include <ros/package.h>
#include <ros/ros.h>

#include "avsp/results/anomaly_monitor.hpp"
#include "avsp/results/gap.hpp"
#include "avsp/results/output.hpp"
#include "avsp/results/rut_map.hpp"
#include "avsp/results/vehicle_record.hpp"
#include "avsp/ros/run_supervisor.hpp"

namespace avsp
{
namespace node
{
namespace ar = avsp::results;
namespace at = avsp::terrain;
namespace fs = std::filesystem;

namespace
{
/// The signal that interrupted the run (SIGINT, SIGTERM), or 0: the loop writes what it has.
volatile std::sig_atomic_t g_interrupt = 0;

void onInterrupt(int sig)
{
  g_interrupt = sig;
}

/// s of sim time between the rows of trajectories.csv and between gap samples.
constexpr double kTablePeriod = 0.1;
/// Grid cells along the longer side of the hillshade and rut grids at most.
constexpr std::size_t kMaxGridCells = 1500;
/// m: ruts shallower than this do not count for the rut map's extent (float rounding, elastic).
constexpr double kRutMinDepth = 0.002;

/**
 * @brief A warning at most once per `period` wall seconds per subject (a topic), with the count
 *        of those swallowed since. (ROS_WARN_THROTTLE counts on sim time from 0 and swallows
 *        every warning of a run's first `period` seconds.)
 */
void warnThrottled(const std::string& subject, double period, const std::string& text)
{
  struct Seen
  {
    ros::WallTime last;
    unsigned swallowed = 0;
  };
  static std::map<std::string, Seen> seen;
  const ros::WallTime now = ros::WallTime::now();
  const auto it = seen.find(subject);
  if (it != seen.end() && (now - it->second.last).toSec() < period)
  {
    ++it->second.swallowed;
    return;
  }
  const unsigned swallowed = it == seen.end() ? 0 : it->second.swallowed;
  const std::string more = swallowed ? " (and " + std::to_string(swallowed) + " more since the last warning)" : "";
  ROS_WARN("run_recorder: %s: %s%s", subject.c_str(), text.c_str(), more.c_str());
  seen[subject] = Seen{ now, 0 };
}

/// printf of one number into a std::string.
std::string format(const char* fmt, double a)
{
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, fmt, a);
  return buffer;
}

std::vector<ar::VehicleSpec> vehicleList(const ros::NodeHandle& pnh)
{
  std::vector<ar::VehicleSpec> out;
  for (avsp::node::VehicleListEntry& entry : avsp::node::vehicleListParam(
           pnh, false, { "name", "leader", "max_speed", "rest_height", "wheel_radius" }, "{name, leader}"))
  {
    const std::string where = "parameter " + entry.where;
    ar::VehicleSpec v;
    v.name = entry.name;
    int limits = 0;
    XmlRpc::XmlRpcValue& e = entry.fields;
    if (e.getType() == XmlRpc::XmlRpcValue::TypeStruct)
      for (auto it = e.begin(); it != e.end(); ++it)
      {
        if (it->first == "name")
          continue;
        if (it->first == "leader")
        {
          if (it->second.getType() != XmlRpc::XmlRpcValue::TypeString)
            throw StartupError(where + ".leader must be a string");
          v.leader = static_cast<std::string>(it->second);
          continue;
        }
        // max_speed, rest_height, wheel_radius (vehicleListParam allows no other key)
        const XmlRpc::XmlRpcValue& n = it->second;
        double value = 0.0;
        if (n.getType() == XmlRpc::XmlRpcValue::TypeDouble)
          value = static_cast<double>(const_cast<XmlRpc::XmlRpcValue&>(n));
        else if (n.getType() == XmlRpc::XmlRpcValue::TypeInt)
          value = static_cast<int>(const_cast<XmlRpc::XmlRpcValue&>(n));
        else
          throw StartupError(where + "." + it->first + " must be a number (m/s or m)");
        const bool positive = it->first != "rest_height";
        if (!std::isfinite(value) || (positive && !(value > 0.0)))
          throw StartupError(where + "." + it->first + " must be finite" + (positive ? " and > 0" : ""));
        (it->first == "max_speed" ? v.max_speed : it->first == "rest_height" ? v.rest_height : v.wheel_radius) = value;
        ++limits;
      }
    if (limits != 0 && limits != 3)
      throw StartupError(where + ": max_speed, rest_height and wheel_radius go together (all or none)");
    out.push_back(v);
  }
  try
  {
    ar::validateVehicles(out);
  }
  catch (const std::invalid_argument& e)
  {
    throw StartupError("parameter ~" + std::string(e.what()));
  }
  return out;
}

std::string requiredString(const ros::NodeHandle& pnh, const std::string& key)
{
  std::string value;
  if (!pnh.hasParam(key))
    throw StartupError("parameter ~" + key + " is required");
  if (!pnh.getParam(key, value) || value.empty())
    throw StartupError("parameter ~" + key + " must be a non-empty string");
  return value;
}

/// ~watch: resolved names of the nodes that must live for the whole run.
std::vector<std::string> watchList(const ros::NodeHandle& pnh)
{
  std::vector<std::string> out;
  XmlRpc::XmlRpcValue list;
  if (!avsp::node::structuredParam(pnh, "watch", list))
    return out;
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw StartupError("parameter ~watch must be a list of node names");
  for (int k = 0; k < list.size(); ++k)
  {
    std::string why;
    if (list[k].getType() != XmlRpc::XmlRpcValue::TypeString)
      throw StartupError("parameter ~watch[" + std::to_string(k) + "] must be a string");
    const std::string name = list[k];
    if (name.empty() || name[0] != '/' || !ros::names::validate(name, why))
      throw StartupError("parameter ~watch[" + std::to_string(k) + "] '" + name +
                         "' must be a resolved node name ('/...')");
    out.push_back(name);
  }
  return out;
}

/// Creates `dir` and checks that a file can be written in it.
void prepareOutputDir(const std::string& dir)
{
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    throw StartupError("parameter ~output_dir '" + dir + "': cannot create it: " + ec.message());
  if (!fs::is_directory(dir))
    throw StartupError("parameter ~output_dir '" + dir + "' is not a directory");
  const std::string probe = dir + "/.run_recorder_write_test";
  std::ofstream out(probe);
  if (!out)
    throw StartupError("parameter ~output_dir '" + dir + "' is not writable: " + std::strerror(errno));
  out.close();
  std::remove(probe.c_str());
}

struct Vehicle
{
  ar::VehicleSpec spec;
  std::size_t index = 0;  ///< in ~vehicles (its group in trajectories.csv)
  ar::VehicleRecord record;
  /// The gap trackers this vehicle leads, and the one it follows in (nullptr = none).
  std::vector<ar::GapTracker*> leads;
  ar::GapTracker* follows = nullptr;
  std::string odom_topic, telemetry_topic;
  ros::Subscriber odom_sub, telemetry_sub;
  ros::Subscriber dem_sub;                    ///< <v>/dem_crossing (terramechanics: dem)
  std::optional<avsp_msgs::DemCrossing> dem;  ///< the crossing, once it is over
  /// A message stamped after the duration arrived: everything up to it has (FIFO per topic).
  bool odom_done = false, telemetry_done = false;
};

}  // namespace

class RunRecorder::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh) : nh_(nh)
  {
    if (!ros::Time::isSimTime())
      throw StartupError("parameter /use_sim_time must be true: ~duration is sim time (/clock)");
    const std::vector<ar::VehicleSpec> specs = vehicleList(pnh);
    output_dir_ = requiredString(pnh, "output_dir");
    scenario_ = avsp::node::stringParam(pnh, "scenario_name", "");
    if (scenario_.empty())
    {
      fs::path p = fs::path(output_dir_).lexically_normal();
      if (p.filename().empty())  // "results/run/" ends in a separator
        p = p.parent_path();
      scenario_ = p.filename().string();
    }
    if (!pnh.hasParam("duration"))
      throw StartupError("parameter ~duration is required (s of sim time)");
    duration_ = avsp::node::runNumberParam(pnh, avsp::terrain::kRunDuration);
    progress_period_ = avsp::node::runNumberParam(pnh, avsp::terrain::kProgressPeriod);
    requested_rtf_ = avsp::node::runNumberParam(pnh, avsp::terrain::kRealTimeFactor);
    end_launch_ = avsp::node::boolParam(pnh, "end_launch", false);
    watch_period_ = avsp::node::boundedParam(pnh, "watch_period", 0.25, 0.05, 10.0);
    // Watching starts before the terrain loads: a node that dies meanwhile is seen at the first poll.
    supervisor_ = std::make_unique<RunSupervisor>(nh_, watchList(pnh));
    plot_script_ =
        avsp::node::stringParam(pnh, "plot_script", ros::package::getPath("avsp") + "/scripts/plot_results.py");
    if (plot_script_.empty() || !fs::is_regular_file(plot_script_))
      throw StartupError("parameter ~plot_script '" + plot_script_ + "' is not a file");
    std::string soils_file;
    soils_file = avsp::node::stringParam(pnh, "soils_file", ros::package::getPath("avsp") + "/config/soils.yaml");
    try
    {
      soils_ = std::make_unique<at::SoilLibrary>(at::SoilLibrary::load(soils_file));
    }
    catch (const std::exception& e)
    {
      throw StartupError("parameter ~soils_file: " + std::string(e.what()));
    }
    prepareOutputDir(output_dir_);
    // The tables stream to the results folder as the run goes: memory stays flat however long it is.
    std::vector<std::string> names;
    for (const ar::VehicleSpec& s : specs)
      names.push_back(s.name);
    try
    {
      trajectories_ = std::make_unique<ar::TrajectoryTable>(output_dir_, names, kTablePeriod);
      std::size_t followers = 0;
      for (const ar::VehicleSpec& s : specs)
        followers += s.leader.empty() ? 0 : 1;
      gaps_ = std::make_unique<ar::SpooledTable>(output_dir_, "gaps", ar::kGapsHeader, followers);
    }
    catch (const std::runtime_error& e)
    {
      throw StartupError("parameter ~output_dir: " + std::string(e.what()));
    }
    // The terrain source's parameters are checked now, loaded after subscribing (below).
    const at::TerrainSource source = at::node::terrainSourceFromParams(pnh);

    for (const ar::VehicleSpec& s : specs)
    {
      auto v = std::make_unique<Vehicle>();
      v->spec = s;
      v->index = vehicles_.size();
      Vehicle* raw = v.get();
      // Deep queues (100 s of sim time at 100 Hz): at a high real-time factor that is a few wall
      // seconds, and the messages that arrive while the terrain loads wait in them.
      v->odom_sub = nh_.subscribe<nav_msgs::Odometry>(
          s.name + "/avt_341/odometry", 10000,
          [this, raw](const nav_msgs::Odometry::ConstPtr& m) { onOdometry(*raw, *m); });
      v->telemetry_sub = nh_.subscribe<avsp_msgs::VehicleTelemetry>(
          s.name + "/telemetry", 10000,
          [this, raw](const avsp_msgs::VehicleTelemetry::ConstPtr& m) { onTelemetry(*raw, *m); });
      v->dem_sub = nh_.subscribe<avsp_msgs::DemCrossing>(
          s.name + "/dem_crossing", 1, [raw](const avsp_msgs::DemCrossing::ConstPtr& m) { raw->dem = *m; });
      v->odom_topic = v->odom_sub.getTopic();
      v->telemetry_topic = v->telemetry_sub.getTopic();
      if (s.max_speed > 0.0)
        anomalies_.addVehicle(s.name, ar::VehicleLimits{ s.max_speed, s.rest_height, s.wheel_radius });
      vehicles_.push_back(std::move(v));
    }
    for (auto& v : vehicles_)
      if (!v->spec.leader.empty())
      {
        const std::size_t group = trackers_.size();
        const std::string follower = v->spec.name, leader = v->spec.leader;
        trackers_.push_back(
            std::make_unique<ar::GapTracker>(kTablePeriod, [this, group, follower, leader](const ar::GapSample& g) {
              gaps_->add(group, ar::gapRow(follower, leader, g));
            }));
        v->follows = trackers_.back().get();
        find(leader)->leads.push_back(v->follows);
      }
    ruts_sub_ = nh_.subscribe("/terrain/ruts", 200, &Impl::onPatch, this);
    toppled_sub_ = nh_.subscribe("/terrain/toppled", 200, &Impl::onToppled, this);
    diagnostics_sub_ = nh_.subscribe("/diagnostics", 100, &Impl::onDiagnostics, this);
    // Subscribed first: loading a large course takes seconds, while which the simulation may
    // already run; its messages wait in the queues (callbacks run only once this returns).
    try
    {
      at::LoadedSource loaded = at::loadTerrainSource(source, *soils_);
      terrain_ = std::move(loaded.terrain);
      objects_ = std::move(loaded.objects);
      terrain_description_ = loaded.description;
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError(std::string("parameter ~") + e.what());
    }
    catch (const std::exception& e)
    {
      throw StartupError(std::string("terrain: ") + e.what());
    }
    ruts_ = std::make_unique<ar::RutMap>(terrain_->base());
    ROS_INFO("run_recorder: %zu vehicle(s), %s until sim time %.1f s, terrain %s, results in %s", vehicles_.size(),
             scenario_.c_str(), duration_, terrain_description_.c_str(), output_dir_.c_str());
  }

  /// Records until /clock reaches ~duration, then writes the results; stops early, writing what
  /// it has with "aborted" in summary.json, when the run fails or is interrupted.
  /// @return the exit code: 0 done, 1 failed (a node died, or results not written), 128 + signal
  int run()
  {
    const ros::WallTime started = ros::WallTime::now();
    ros::WallTime polled;
    while (ros::ok())
    {
      ros::spinOnce();
      const double now = ros::Time::now().toSec();
      const ros::WallTime wall = ros::WallTime::now();
      if (now > 0.0 && !first_clock_)
      {
        first_clock_ = true;
        sim_start_ = sim_last_ = now;
        wall_start_ = wall_last_ = wall;
      }
      if (first_clock_ && (wall - wall_last_).toSec() >= progress_period_)
        progress(now, wall);
      if (first_clock_ && now >= duration_)
      {
        // /clock can run ahead of the vehicles' topics: wait until each topic has delivered a
        // message stamped past the duration (dropped), or 2 s of wall time for a silent one.
        const ros::WallTime reached = ros::WallTime::now();
        auto complete = [this] {
          for (const auto& v : vehicles_)
            if (!v->odom_done || (!v->telemetry_done && v->record.telemetryCount() > 0))
              return false;
          return true;
        };
        while (ros::ok() && !complete() && (ros::WallTime::now() - reached).toSec() < 2.0)
        {
          ros::spinOnce();
          ros::WallDuration(0.002).sleep();
        }
        stopRecording(now);
        return finish();
      }
      if (g_interrupt != 0)
        supervisor_->fail(ros::this_node::getName(),
                          std::string("interrupted by ") + (g_interrupt == SIGINT ? "SIGINT" : "SIGTERM"), now);
      else if ((wall - polled).toSec() >= watch_period_)
      {
        supervisor_->poll(now);
        polled = wall;
      }
      if (supervisor_->abort())
        return abortRun();
      if (!first_clock_ && !waiting_said_ && (wall - started).toSec() >= 10.0)
      {
        ROS_WARN("run_recorder: no /clock after 10 s (wall); waiting for the simulation");
        waiting_said_ = true;
      }
      ros::WallDuration(0.002).sleep();
    }
    ROS_ERROR("run_recorder: shut down at sim time %.2f s before ~duration %.2f s: no results written",
              ros::Time::now().toSec(), duration_);
    return 1;
  }

private:
  void stopRecording(double now)
  {
    for (auto& v : vehicles_)
    {
      v->odom_sub.shutdown();
      v->telemetry_sub.shutdown();
    }
    ruts_sub_.shutdown();
    sim_end_ = now;
    wall_end_ = ros::WallTime::now();
  }

  /// The run failed or was interrupted: the results so far, "aborted" in summary.json.
  int abortRun()
  {
    // A dying node's last /rosout lines may still be on their way: take them in for a moment.
    const ros::WallTime seen = ros::WallTime::now();
    while (g_interrupt == 0 && (ros::WallTime::now() - seen).toSec() < 0.3)
    {
      ros::spinOnce();
      ros::WallDuration(0.005).sleep();
    }
    aborted_ = supervisor_->abort();
    const ar::Abort& a = *aborted_;
    ROS_ERROR("run_recorder: run aborted at sim time %.2f s: %s: %s; writing the results so far to %s", a.sim_time,
              a.node.c_str(), a.reason.c_str(), output_dir_.c_str());
    const double now = ros::Time::now().toSec();
    if (!first_clock_)
      sim_start_ = now;
    stopRecording(now);
    if (!first_clock_)
      wall_start_ = wall_end_;
    finish();
    return g_interrupt != 0 ? 128 + static_cast<int>(g_interrupt) : 1;
  }

  void onOdometry(Vehicle& v, const nav_msgs::Odometry& m)
  {
    const double t = m.header.stamp.toSec();
    if (t > duration_)
    {
      v.odom_done = true;
      return;
    }
    const auto& p = m.pose.pose.position;
    const auto& l = m.twist.twist.linear;
    const double speed = std::sqrt(l.x * l.x + l.y * l.y + l.z * l.z);
    const ar::OdometryAdded added = v.record.addOdometry(t, p.x, p.y, p.z, speed);
    if (added == ar::OdometryAdded::kRepeat)
      return;  // the same instant again (dynamics_node repeats time 0 at start-up): not a sample
    double ground = 0.0;
    const bool on_terrain = std::isfinite(p.x) && std::isfinite(p.y) && terrain_->base().heightAt(p.x, p.y, ground);
    const std::string anomaly = anomalies_.sample(v.spec.name, t, p.x, p.y, p.z, speed,
                                                  on_terrain ? std::optional<double>(ground) : std::nullopt);
    if (!anomaly.empty())
      ROS_WARN("run_recorder: anomaly: %s (counted in summary.json; each kind is reported once per vehicle)",
               anomaly.c_str());
    if (added == ar::OdometryAdded::kRefused)
    {
      warnThrottled(v.odom_topic, 5.0, format("odometry at %.3f s ignored (a non-finite value, or out of order)", t));
      return;
    }
    const ar::OdometrySample sample = *v.record.last();
    try
    {
      trajectories_->add(v.index, sample);
      for (ar::GapTracker* g : v.leads)
        g->addLeader(sample);
      if (v.follows)
        v.follows->addFollower(sample);
    }
    catch (const std::exception& e)
    {
      // The tables stream to disk: a failed write stops the run, as its results would be incomplete.
      supervisor_->fail(ros::this_node::getName(), e.what(), t);
    }
  }

  void onTelemetry(Vehicle& v, const avsp_msgs::VehicleTelemetry& m)
  {
    const double t = m.header.stamp.toSec();
    if (t > duration_)
    {
      v.telemetry_done = true;
      return;
    }
    std::vector<ar::ContactSlip> contacts;
    contacts.reserve(m.contacts.size());
    for (const avsp_msgs::WheelContact& c : m.contacts)
      contacts.push_back(ar::ContactSlip{ c.slip, c.normal_force, c.driven != 0 });
    if (!v.record.addTelemetry(t, ar::maxDrivenSlip(contacts), m.stuck, m.collisions))
      warnThrottled(v.telemetry_topic, 5.0, format("message at %.3f s ignored (out of order)", t));
  }

  /// Every publisher's patches count: /terrain/ruts carries current heights, whoever deformed them.
  void onPatch(const ros::MessageEvent<const avsp_msgs::TerrainPatch>& event)
  {
    const avsp_msgs::TerrainPatch& m = *event.getMessage();
    if (at::node::isEndOfInstantMarker(m))
      return;  // an end-of-instant marker (TerrainPatch.msg): no heights
    if (!m.header.frame_id.empty() && m.header.frame_id != "map")
    {
      ++patches_rejected_;
      warnThrottled(
          "/terrain/ruts", 5.0,
          "from " + event.getPublisherName() + " in frame '" + m.header.frame_id + "', expected 'map'; ignored");
      return;
    }
    try
    {
      ruts_->apply(at::node::heightPatchFromMessage(m));
      ++patches_;
    }
    catch (const std::exception& e)
    {
      ++patches_rejected_;
      warnThrottled("/terrain/ruts", 5.0, "from " + event.getPublisherName() + " rejected: " + e.what());
    }
  }

  void onToppled(const avsp_msgs::ObjectToppled::ConstPtr& m) { toppled_.insert(m->id); }

  /// dynamics_node's "<node>: simulation" status: the wall time its clock waited for each of
  /// its ~clock_followers ("clock waited for <name> (wall s)"), running totals.
  void onDiagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& m)
  {
    static const std::string kPrefix = "clock waited for ", kSuffix = " (wall s)";
    for (const auto& status : m->status)
      for (const auto& kv : status.values)
        if (kv.key.size() > kPrefix.size() + kSuffix.size() && kv.key.compare(0, kPrefix.size(), kPrefix) == 0 &&
            kv.key.compare(kv.key.size() - kSuffix.size(), kSuffix.size(), kSuffix) == 0)
        {
          char* end = nullptr;
          const double waited = std::strtod(kv.value.c_str(), &end);
          if (end != kv.value.c_str() && std::isfinite(waited))
            clock_waited_[kv.key.substr(kPrefix.size(), kv.key.size() - kPrefix.size() - kSuffix.size())] = waited;
        }
  }

  void progress(double now, const ros::WallTime& wall)
  {
    const double rtf = (now - sim_last_) / std::max(1e-9, (wall - wall_last_).toSec());
    const double run_rtf = (now - sim_start_) / std::max(1e-9, (wall - wall_start_).toSec());
    std::string line;
    char buffer[160];
    std::snprintf(buffer, sizeof buffer, "[run_recorder] sim %.1f / %.1f s | RTF %.2f (run %.2f, requested ", now,
                  duration_, rtf, run_rtf);
    line += buffer;
    if (requested_rtf_ > 0.0)
      std::snprintf(buffer, sizeof buffer, "%.2f)", requested_rtf_);
    else
      std::snprintf(buffer, sizeof buffer, "max)");
    line += buffer;
    // The slowest node: the clock's follower it waited for most since the last line.
    std::string slowest;
    double most = 0.0;
    for (const auto& [name, waited] : clock_waited_)
    {
      const double since = waited - clock_waited_printed_[name];
      if (since > most)
        most = since, slowest = name;
      clock_waited_printed_[name] = waited;
    }
    if (!slowest.empty())
    {
      std::snprintf(buffer, sizeof buffer, " | clock held by %s %.2f s", slowest.c_str(), most);
      line += buffer;
    }
    for (const auto& v : vehicles_)
    {
      std::snprintf(buffer, sizeof buffer, " | %s %.1f m %.2f m/s", v->spec.name.c_str(), v->record.distance(),
                    v->record.speed());
      line += buffer;
    }
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
    sim_last_ = now;
    wall_last_ = wall;
  }

  Vehicle* find(const std::string& name)
  {
    for (auto& v : vehicles_)
      if (v->spec.name == name)
        return v.get();
    return nullptr;
  }

  /// Writes every file; @return the exit code.
  int finish()
  {
    const double wall_time = (wall_end_ - wall_start_).toSec();
    const double run_rtf = wall_time > 0.0 ? (sim_end_ - sim_start_) / wall_time : std::nan("");
    std::vector<std::string> silent;
    for (const auto& v : vehicles_)
      if (v->record.sampleCount() == 0)
        silent.push_back(v->odom_topic);
    try
    {
      const std::string dir = output_dir_ + "/";
      const std::array<double, 4> box = resultsBox();
      writeGrids(dir, box);
      trajectories_->write(dir + "trajectories.csv");
      gaps_->write(dir + "gaps.csv");
      writeObjects(dir + "objects.csv", box[0], box[1], box[2], box[3]);
      ar::writeText(dir + "summary.json", summaryJson(wall_time, run_rtf).dump());
    }
    catch (const std::exception& e)
    {
      ROS_ERROR("run_recorder: %s", e.what());
      return 1;
    }
    for (const auto& v : vehicles_)
      if (v->follows && v->follows->dropped() > 0)
        ROS_WARN("run_recorder: %s: %zu gap samples dropped: its leader %s sent no odometry for them",
                 v->spec.name.c_str(), v->follows->dropped(), v->spec.leader.c_str());
    if (!plot())
      return 1;
    printSummary(run_rtf);
    if (!silent.empty())
    {
      std::string list;
      for (const std::string& t : silent)
        list += (list.empty() ? "" : ", ") + t;
      ROS_ERROR("run_recorder: no odometry received on %s: the results miss those vehicles", list.c_str());
      return 1;
    }
    return 0;
  }

  /// The box (x0, y0, x1, y1) the results' grids and objects cover: the trajectories' (the
  /// whole terrain without any), 10 m or 10 % wider on every side.
  std::array<double, 4> resultsBox() const
  {
    double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
    for (const auto& v : vehicles_)
      if (const auto b = v->record.bounds())
      {
        x0 = std::min(x0, (*b)[0]);
        y0 = std::min(y0, (*b)[1]);
        x1 = std::max(x1, (*b)[2]);
        y1 = std::max(y1, (*b)[3]);
      }
    const at::ElevationGrid& base = terrain_->base();
    if (!(x1 >= x0))
    {
      x0 = base.originX();
      y0 = base.originY();
      x1 = x0 + base.dx() * static_cast<double>(base.columns() - 1);
      y1 = y0 + base.dy() * static_cast<double>(base.rows() - 1);
    }
    const double margin = std::max(10.0, 0.1 * std::max(x1 - x0, y1 - y0));
    return { x0 - margin, y0 - margin, x1 + margin, y1 + margin };
  }

  /// terrain_heights.npy, rut_depth.npy (when there are ruts) and grids.json over `box`.
  void writeGrids(const std::string& dir, const std::array<double, 4>& box) const
  {
    const ar::Grid heights = ar::sampleHeights(terrain_->base(), box[0], box[1], box[2], box[3], kMaxGridCells);
    ar::writeNpy(dir + "terrain_heights.npy", heights);
    ar::Json grids = ar::Json::object();
    grids.set("terrain", ar::gridJson("terrain_heights.npy", heights));
    const std::optional<ar::Grid> ruts = ruts_->depthGrid(kRutMinDepth, 2.0, kMaxGridCells);
    if (ruts)
    {
      ar::writeNpy(dir + "rut_depth.npy", *ruts);
      grids.set("ruts", ar::gridJson("rut_depth.npy", *ruts));
    }
    else
      grids.set("ruts", ar::Json());
    ar::writeText(dir + "grids.json", grids.dump());
  }

  /// summary.json: the run, each vehicle (vehicleJson), the ruts, the anomalies, how it ended.
  ar::Json summaryJson(double wall_time, double run_rtf) const
  {
    ar::Json summary = ar::Json::object();
    summary.set("scenario", scenario_);
    summary.set("duration", duration_);
    summary.set("sim_time_start", sim_start_);
    summary.set("sim_time_end", sim_end_);
    summary.set("wall_time", wall_time);
    summary.set("real_time_factor", run_rtf);
    summary.set("terrain", terrain_description_);
    ar::Json vehicles = ar::Json::array();
    for (const auto& v : vehicles_)
      vehicles.push(vehicleJson(*v));
    summary.set("vehicles", vehicles);
    ar::Json rut = ar::Json::object();
    rut.set("max_depth", ruts_->maxDepth());
    rut.set("area_deeper_than_1cm", ruts_->areaDeeperThan(0.01));
    rut.set("points", ruts_->pointCount());
    rut.set("patches", patches_);
    rut.set("patches_rejected", patches_rejected_);
    summary.set("ruts", rut);
    summary.set("anomalies", anomalies_.total());
    if (aborted_)
    {
      ar::Json a = ar::Json::object();
      a.set("node", aborted_->node);
      a.set("reason", aborted_->reason);
      a.set("sim_time", aborted_->sim_time);
      summary.set("aborted", a);
    }
    else
      summary.set("aborted", ar::Json());
    summary.set("units", unitsNote());
    return summary;
  }

  /// One vehicle's entry of summary.json.
  ar::Json vehicleJson(const Vehicle& v) const
  {
    const ar::VehicleRecord& r = v.record;
    ar::Json j = ar::Json::object();
    j.set("name", v.spec.name);
    j.set("leader", v.spec.leader.empty() ? ar::Json() : ar::Json(v.spec.leader));
    j.set("distance", r.distance());
    j.set("mean_speed", r.meanSpeed());
    j.set("max_speed", r.sampleCount() == 0 ? ar::Json() : ar::Json(r.maxSpeed()));
    j.set("max_slip", r.maxSlip());
    j.set("time_stuck", r.telemetryCount() > 0 ? ar::Json(r.timeStuck()) : ar::Json());
    j.set("collisions", r.collisions());
    if (v.dem)
    {
      // The DEM segment's crossing (terramechanics: dem), as dynamics_node reported it.
      ar::Json d = ar::Json::object();
      d.set("entered", v.dem->entered);
      d.set("left", v.dem->left);
      d.set("patch_moves", static_cast<double>(v.dem->patch_moves));
      d.set("peak_particles", static_cast<double>(v.dem->peak_particles));
      d.set("mean_sinkage", v.dem->mean_sinkage);
      d.set("max_sinkage", v.dem->max_sinkage);
      d.set("mean_slip", v.dem->mean_slip);
      d.set("energy", v.dem->energy);
      d.set("points_written", static_cast<double>(v.dem->points_written));
      j.set("dem", d);
    }
    const std::optional<ar::GapStats> gap = v.follows ? v.follows->stats() : std::nullopt;
    j.set("gap_min", gap ? ar::Json(gap->min) : ar::Json());
    j.set("gap_mean", gap ? ar::Json(gap->mean) : ar::Json());
    if (v.spec.max_speed > 0.0)
    {
      const ar::AnomalyCounts& c = anomalies_.counts(v.spec.name);
      ar::Json a = ar::Json::object();
      a.set("overspeed", c.overspeed);
      a.set("airborne", c.airborne);
      a.set("non_finite", c.non_finite);
      j.set("anomalies", a);
    }
    else
      j.set("anomalies", ar::Json());
    j.set("odometry_samples", r.sampleCount());
    j.set("telemetry_messages", r.telemetryCount());
    if (r.sampleCount() > 0)
    {
      const ar::OdometrySample a = *r.first(), b = *r.last();
      j.set("t_first", a.t);
      j.set("t_last", b.t);
      j.set("start", ar::Json::array().push(a.x).push(a.y));
      j.set("end", ar::Json::array().push(b.x).push(b.y));
    }
    return j;
  }

  /// A line per vehicle and one for the run on stdout.
  void printSummary(double run_rtf) const
  {
    for (const auto& v : vehicles_)
    {
      const ar::VehicleRecord& r = v->record;
      std::printf("[run_recorder] %s: %.1f m, mean %.2f m/s, max slip %s, stuck %.1f s, collisions %s\n",
                  v->spec.name.c_str(), r.distance(), r.meanSpeed().value_or(0.0),
                  r.maxSlip() ? std::to_string(*r.maxSlip()).c_str() : "n/a", r.timeStuck(),
                  r.collisions() ? std::to_string(*r.collisions()).c_str() : "n/a");
    }
    std::printf("[run_recorder] %.1f s of sim time in %.1f s wall (real-time factor %.2f); results in %s\n",
                sim_end_ - sim_start_, (wall_end_ - wall_start_).toSec(), run_rtf, output_dir_.c_str());
    std::fflush(stdout);
  }

  static ar::Json unitsNote()
  {
    ar::Json u = ar::Json::object();
    u.set("distance", "m, driven (3-D, from odometry)");
    u.set("mean_speed", "m/s, distance / (t_last - t_first)");
    u.set("max_speed", "m/s");
    u.set("max_slip", "longitudinal slip of the driven wheels/track segments on the ground, + = driving");
    u.set("time_stuck", "s of sim time with the stuck flag");
    u.set("collisions", "rigid contacts begun with obstacles or other vehicles");
    u.set("dem",
          "only for terramechanics: dem vehicles that crossed the DEM segment: entered, left (s of sim "
          "time), patch_moves, peak_particles, mean_sinkage, max_sinkage (m, wheels wholly on the DEM), "
          "mean_slip, energy (J the wheels did on the DEM soil), points_written (terrain grid points)");
    u.set("gap_min", "m along the leader's path, null without a leader");
    u.set("duration", "s of sim time");
    u.set("wall_time", "s from the first /clock tick to the end");
    u.set("real_time_factor", "sim time / wall time over the run");
    u.set("ruts", "m (depth below the undeformed terrain), m^2");
    u.set("anomalies",
          "odometry samples: overspeed (> 1.5 x governed), airborne (base_link > one wheel radius "
          "above its rest height over the undeformed ground), non_finite; null = limits not given");
    u.set("aborted", "null, or why the run stopped before its duration: {node, reason, sim_time (s)}");
    return u;
  }

  /// objects.csv: the terrain's objects inside the plotted box (toppled ones as reported).
  void writeObjects(const std::string& path, double x0, double y0, double x1, double y1)
  {
    std::string text = "id,type,x,y,yaw,length,width,height,rigid,toppled\n";
    char line[256];
    for (const at::TerrainObject& o : objects_.all())
    {
      const double reach = 0.5 * std::hypot(o.length, o.width);
      if (o.x + reach < x0 || o.x - reach > x1 || o.y + reach < y0 || o.y - reach > y1)
        continue;
      std::snprintf(line, sizeof line, "%u,%s,%.3f,%.3f,%.4f,%.3f,%.3f,%.3f,%d,%d\n", o.id, at::toString(o.type), o.x,
                    o.y, o.yaw, o.length, o.width, o.height, std::isfinite(o.strength) ? 0 : 1,
                    (o.toppled || toppled_.count(o.id)) ? 1 : 0);
      text += line;
    }
    ar::writeText(path, text);
  }

  /// Runs the plot script on the results folder; false (logged, naming what is missing) on failure.
  bool plot()
  {
    std::fflush(stdout);
    const pid_t pid = fork();
    if (pid < 0)
    {
      ROS_ERROR("run_recorder: cannot start %s: %s", plot_script_.c_str(), std::strerror(errno));
      return false;
    }
    if (pid == 0)
    {
      execl("/usr/bin/python3", "python3", plot_script_.c_str(), output_dir_.c_str(), static_cast<char*>(nullptr));
      std::fprintf(stderr, "run_recorder: cannot run /usr/bin/python3 %s: %s\n", plot_script_.c_str(),
                   std::strerror(errno));
      _exit(127);
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
    {
    }
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (code != 0)
    {
      ROS_ERROR(
          "run_recorder: /usr/bin/python3 %s %s failed (exit %d): trajectories.png, ruts.png or gaps.png "
          "not written (its message above names the file)",
          plot_script_.c_str(), output_dir_.c_str(), code);
      return false;
    }
    for (const char* png : { "trajectories.png", "ruts.png", "gaps.png" })
      if (!fs::is_regular_file(output_dir_ + "/" + png))
      {
        ROS_ERROR("run_recorder: %s/%s was not written by %s", output_dir_.c_str(), png, plot_script_.c_str());
        return false;
      }
    return true;
  }

  ros::NodeHandle& nh_;
  std::string output_dir_, scenario_, plot_script_, terrain_description_;
  double duration_ = 0.0, progress_period_ = 1.0, watch_period_ = 0.25;
  double requested_rtf_ = 0.0;  ///< ~real_time_factor: the run's target, for the progress line (0 = max)
  std::map<std::string, double> clock_waited_;          ///< follower -> wall s the clock waited for it
  std::map<std::string, double> clock_waited_printed_;  ///< the same at the last progress line
  ros::Subscriber diagnostics_sub_;

public:
  bool end_launch_ = false;  ///< ~end_launch: a finished run SIGINTs the roslaunch that started us

private:
  std::unique_ptr<RunSupervisor> supervisor_;
  std::optional<ar::Abort> aborted_;  // set when the run stopped early
  ar::AnomalyMonitor anomalies_;
  std::unique_ptr<at::SoilLibrary> soils_;
  std::unique_ptr<at::DeformableTerrain> terrain_;
  at::ObjectSet objects_;
  std::unique_ptr<ar::RutMap> ruts_;
  std::unique_ptr<ar::TrajectoryTable> trajectories_;
  std::unique_ptr<ar::SpooledTable> gaps_;
  std::vector<std::unique_ptr<ar::GapTracker>> trackers_;  ///< one per follower, in ~vehicles order
  std::vector<std::unique_ptr<Vehicle>> vehicles_;
  ros::Subscriber ruts_sub_, toppled_sub_;
  std::set<std::uint32_t> toppled_;
  std::size_t patches_ = 0, patches_rejected_ = 0;
  bool first_clock_ = false, waiting_said_ = false;
  double sim_start_ = 0.0, sim_last_ = 0.0, sim_end_ = 0.0;
  ros::WallTime wall_start_, wall_last_, wall_end_;
};

RunRecorder::RunRecorder(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

RunRecorder::~RunRecorder() = default;

void RunRecorder::handleInterrupts()
{
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = onInterrupt;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

int RunRecorder::spin()
{
  const int rc = impl_->run();
  if (rc == 0 && impl_->end_launch_)
  {
    // A required node that exits makes roslaunch print "REQUIRED process [...] has died!" even
    // when it finished cleanly: the finished run ends the launch itself, with the SIGINT of a
    // Ctrl-C, and exits when roslaunch's own SIGINT reaches it (30 s at most).
    const pid_t launcher = getppid();
    if (launcher > 1 && kill(launcher, SIGINT) == 0)
    {
      const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
      while (g_interrupt == 0 && ros::ok() && ros::WallTime::now() < deadline)
        ros::WallDuration(0.05).sleep();
    }
  }
  return rc;
}

}  // namespace node
}  // namespace avsp
