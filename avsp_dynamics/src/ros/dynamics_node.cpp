// dynamics_node's class (the node's main is ../dynamics_node.cpp): one or more wheeled or tracked
// vehicles in one avsp::dynamics::World on avsp_terrain's deformable soil, driven through each
// vehicle's avt_341/cmd_vel (or cmd_drive), publishing odometry, TF odom -> <vehicle>/base_link, joint_states
// and the ruts (/terrain/ruts).
//
// Thin: the physics is avsp_dynamics_core, the command checks are its checkCommand(), the
// partitions' exchange protocol is its PartitionRunner; this file converts parameters and
// messages and keeps time. Parameters and topics: README.md.
//
// Time. With ~publish_clock the node is the clock source: it advances the physics in fixed
// steps and publishes /clock = the world's time, as fast as it can (~real_time_factor 0) or
// paced to the wall clock. Without it, the node follows /clock from elsewhere: it steps the
// physics until its world time catches up with ros::Time::now(). Every time it uses (command
// age, publication periods) is the world's time, so a run does not depend on the wall clock.
//
// Lockstep with controllers (~lockstep_vehicles): at every multiple t_k of ~lockstep_period
// the node publishes the odometry of t_k and waits until each listed vehicle's cmd_drive
// stamped t_k (or later) has arrived; that command acts from t_k on. So a controller in
// another process closes its loop at the same sim instants however fast the physics runs,
// and the run does not depend on how the processes are scheduled. A vehicle that does not
// answer within ~lockstep_timeout (wall) stops the run with an error naming it.
//
// Clock followers (~clock_followers, with ~publish_clock): nodes that report on /lockstep/done
// the sim time they have processed (sensors_node ~lockstep_partition). The node publishes a
// clock time T only once each has reported T - ~follower_lag: /clock never runs further ahead
// of the sensors than that, whatever the real-time factor or the load (ad::ClockFollowers). A
// follower silent for ~lockstep_timeout (wall) stops the run with an error naming it.
//
// Partition (~partition): one of several dynamics processes of a run, each with its own
// vehicles in its own world. lockstep_clock publishes /clock; on each tick the node steps its
// world to that time (with its controllers' barriers on the way) and reports it on
// /lockstep/done, and the clock moves on only when every partition has.
//
// Peers (~peers, the run's other partitions): at the end of every interval the partition sends
// its exchange on /lockstep/exchange/<partition> and, before stepping on, applies its peers'
// (partition_runner.hpp: what is exchanged, when an exchange may wait, stepping ahead of the
// peers by up to ~step_ahead_intervals, soil held back). This node waits (wall clock) for what
// the runner needs and stops the run when a peer stays silent or sends a bad exchange.
#include "avsp_dynamics/ros/dynamics_node.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <avsp_msgs/AddSensedVehicle.h>
#include <avsp_msgs/DemCrossing.h>
#include <avsp_msgs/DriveCommand.h>
#include <avsp_msgs/ObjectToppled.h>
#include <avsp_msgs/RemoveSensedVehicle.h>
#include <avsp_msgs/RemoveVehicle.h>
#include <avsp_msgs/StepDone.h>
#include <avsp_msgs/SetVehiclePose.h>
#include <avsp_msgs/SpawnVehicle.h>
#include <avsp_msgs/StepPhysics.h>
#include <avsp_msgs/TerrainPatch.h>
#include <avsp_msgs/VehicleTelemetry.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Empty.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <avsp_terrain/height_patch.hpp>
#include <avsp_terrain/ros/agent_params.hpp>
#include <avsp_terrain/ros/conversions.hpp>
#include <avsp_terrain/ros/node_params.hpp>
#include <avsp_terrain/ros/ros_graph.hpp>
#include <avsp_terrain/ros/terrain_source_params.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/clock_followers.hpp"
#include "avsp_dynamics/collision_counter.hpp"
#include "avsp_dynamics/dem/dem_soil_config.hpp"
#include "avsp_dynamics/dem/dem_vehicle_soil.hpp"
#include "avsp_dynamics/partition_reach.hpp"
#include "avsp_dynamics/partition_runner.hpp"
#include "avsp_dynamics/real_time_factor.hpp"
#include "avsp_dynamics/ros/conversions.hpp"
#include "avsp_dynamics/ros/exchange_transport.hpp"
#include "avsp_dynamics/stuck_detector.hpp"
#include "avsp_dynamics/vehicle_model.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"
#include "avsp_dynamics/wheel_odometry.hpp"

namespace avsp
{
namespace dynamics
{
namespace node
{
namespace ad = avsp::dynamics;
namespace at = avsp::terrain;

namespace
{
using avsp::node::boundedParam;
using avsp::node::StartupError;
/// Outgoing queue of a vehicle's odometry and telemetry, messages per subscriber.
constexpr std::uint32_t kStateQueue = 2000;

/// "a, b, c".
std::string joined(const std::vector<std::string>& names)
{
  std::string out;
  for (const std::string& n : names)
    out += (out.empty() ? "" : ", ") + n;
  return out;
}

/// A number as printf's %g writes it (the parameters' values in messages).
std::string shortNumber(double v)
{
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

/// Number of a vehicle entry's key (int or double XML-RPC value), or the fallback if absent.
double numberOf(XmlRpc::XmlRpcValue& entry, const std::string& key, double fallback, const std::string& where)
{
  if (!entry.hasMember(key))
    return fallback;
  XmlRpc::XmlRpcValue& v = entry[key];
  double value;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
    value = static_cast<int>(v);
  else if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    value = static_cast<double>(v);
  else
    throw StartupError(where + "." + key + " must be a number");
  if (!std::isfinite(value))
    throw StartupError(where + "." + key + " must be finite");
  return value;
}

struct VehicleSpec
{
  std::string name, model;
  double x = 0.0, y = 0.0, yaw = 0.0;
};

std::vector<VehicleSpec> vehicleSpecs(const ros::NodeHandle& pnh)
{
  std::vector<VehicleSpec> specs;
  for (avsp::node::VehicleListEntry& e :
       avsp::node::vehicleListParam(pnh, true, { "name", "model", "x", "y", "yaw" }, "{name, model, x, y, yaw}"))
  {
    VehicleSpec s;
    s.name = e.name;
    s.model = e.model;
    s.x = numberOf(e.fields, "x", 0.0, "parameter " + e.where);
    s.y = numberOf(e.fields, "y", 0.0, "parameter " + e.where);
    s.yaw = numberOf(e.fields, "yaw", 0.0, "parameter " + e.where);
    specs.push_back(s);
  }
  return specs;
}

/// One simulated vehicle's ROS side.
struct VehicleIo
{
  std::string name;
  std::size_t id = 0;
  std::string odom_frame = "odom";  ///< the frame of its odometry: odom, or <v>/odom (~per_vehicle_odom_frames)
  ad::VehicleModel model;
  std::string model_name;  ///< ~vehicles[k].model (config_dir/<model_name>.yaml); peers load it too
  std::string cmd_topic, drive_topic;
  ros::Subscriber cmd_sub, drive_sub;
  ros::Publisher odom_pub, joint_pub, telemetry_pub;
  ros::Publisher truth_pub;                 ///< ground_truth/odometry: the same as avt_341/odometry
  ros::Publisher wheel_odom_pub;            ///< wheel_odometry: dead reckoning from the running gear and a gyro
  ad::WheelOdometry wheel_odom;             ///< integrated every step from the start pose
  std::optional<ad::DriveCommand> pending;  ///< arrived since the last step, not applied yet
  std::optional<ad::DriveCommand> last;     ///< last good command
  double last_time = -std::numeric_limits<double>::infinity();  ///< world time it was applied, s
  bool released = false;         ///< the parking brake let go (a command with throttle > 0 came)
  bool lockstep = false;         ///< in ~lockstep_vehicles
  nav_msgs::Odometry last_odom;  ///< the last published (resent at the first barrier)
  double answered = -std::numeric_limits<double>::infinity();  ///< latest cmd_drive stamp, s
  std::vector<double> spin_angle;                              ///< rad per wheel, integrated from the spin rate
  double rut_margin = 0.0;                                     ///< m, a contact's reach beyond its centre
  ad::StuckDetector stuck;                                     ///< VehicleTelemetry.stuck
  // Commands from either topic, for /diagnostics: received, rejected (NaN, unknown gear),
  // clamped, and superseded (another came before a step took it: never applied).
  std::uint64_t commands = 0, refused = 0, clamped = 0, superseded = 0;
  std::uint64_t refused_reported = 0;  ///< `refused` at the last diagnostics publication
  ad::CollisionCounter collisions;     ///< VehicleTelemetry.collisions
  /// terramechanics dem (~dem_vehicles): its wheels on the DEM moving patch over ~dem's segment
  std::shared_ptr<ad::dem::DemVehicleSoil> dem;
  int dem_moves = 0;  ///< patch moves and finished sides seen (the terrain written back since)
  bool dem_reported = false;
  ros::Publisher dem_pub;          ///< <v>/dem_crossing, latched
  sensor_msgs::JointState joints;  ///< names fixed at start-up, values per publication
  // Area the wheels ran over since the last rut publication (map x, y, m).
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  bool ran = false;
};
}  // namespace

class DynamicsNode::Impl
{
public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh) : nh_(nh), pnh_(pnh)
  {
    const std::vector<VehicleSpec> specs = vehicleSpecs(pnh_);
    config_dir_ = avsp::node::stringParam(pnh_, "config_dir", ros::package::getPath("avsp") + "/config/vehicles");
    const std::string soils_file =
        avsp::node::stringParam(pnh_, "soils_file", ros::package::getPath("avsp") + "/config/soils.yaml");
    try
    {
      soils_ = std::make_unique<at::SoilLibrary>(at::SoilLibrary::load(soils_file));
    }
    catch (const std::exception& e)
    {
      throw StartupError("parameter ~soils_file: " + std::string(e.what()));
    }
    std::set<std::string> lockstep_names;
    const ad::WorldOptions options = readOptions(specs, lockstep_names);
    loadWorld(options);
    readDem(specs);
    for (const VehicleSpec& s : specs)
      addVehicle(s, lockstep_names.count(s.name) > 0);
    transforms_.resize(vehicles_.size());
    publishOdomFrames();
    toppled_pub_ = nh_.advertise<avsp_msgs::ObjectToppled>("/terrain/toppled", 100);
    // Every patch reaches every subscriber (a dropped one would be a rut a sensor never sees).
    ruts_pub_ = nh_.advertise<avsp_msgs::TerrainPatch>("/terrain/ruts", 1000);
    if (publish_clock_)
      clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
    loadPeers();
    if (!start_topic_.empty())
      start_sub_ = nh_.subscribe<std_msgs::Empty>(
          start_topic_, 1, [this](const std_msgs::Empty::ConstPtr&) { start_signalled_ = true; });
    if (!partition_.empty())
    {
      done_pub_ = nh_.advertise<avsp_msgs::StepDone>("/lockstep/done", 10);
      tick_sub_ = nh_.subscribe("/clock", 100, &Impl::onTick, this, ros::TransportHints().tcpNoDelay());
    }
    if (followers_)
      followers_sub_ =
          nh_.subscribe("/lockstep/done", 1000, &Impl::onFollowerDone, this, ros::TransportHints().tcpNoDelay());
    if (publish_clock_ && partition_.empty())
    {
      // Run control (the node is the clock): pause, single steps, resume.
      pause_srv_ = pnh_.advertiseService("pause", &Impl::onPause, this);
      resume_srv_ = pnh_.advertiseService("resume", &Impl::onResume, this);
      step_srv_ = pnh_.advertiseService("step", &Impl::onStep, this);
    }
    set_pose_srv_ = pnh_.advertiseService("set_vehicle_pose", &Impl::onSetVehiclePose, this);
    spawn_srv_ = pnh_.advertiseService("spawn_vehicle", &Impl::onSpawnVehicle, this);
    remove_srv_ = pnh_.advertiseService("remove_vehicle", &Impl::onRemoveVehicle, this);
    setUpDiagnostics();
    ROS_INFO("dynamics_node: %zu vehicle(s) on %s, step %.4f s, %s, real_time_factor %g", vehicles_.size(),
             source_.c_str(), options.step, publish_clock_ ? "publishing /clock" : "following /clock",
             real_time_factor_);
  }

  /// A fatal error (a silent lockstep vehicle or peer, a bad exchange) stopped the run.
  bool failed() const { return failed_; }

  /// Runs until shutdown; false when a lockstep vehicle did not answer in time.
  bool run()
  {
    if (!partition_.empty())
      return runPartition();
    if (publish_clock_)
      publishClock();  // time 0: nodes waiting for a valid /clock see the source exists
    {
      // Physics starts once every vehicle has a command (~wait_for_command), so a command
      // published before the start acts from step 0 in every run (the determinism test relies
      // on it), and once the start signal came (~start_topic).
      ros::WallRate idle(200.0);
      while (ros::ok() && !readyToStart())
      {
        ros::spinOnce();
        idle.sleep();
      }
    }
    if (followers_ && lockstep_every_ == 0)
      publishStates();  // the followers' first report answers the odometry of time 0
    if (lockstep_every_ > 0)
    {
      // The controllers' first step answers the odometry of time 0. A controller (or a V2V
      // broadcaster its radio waits for) may connect after it went out, so until all have
      // answered, every vehicle's odometry of time 0 is sent again every 0.2 s (wall; only at
      // time 0: later the connections stand).
      publishStates();
      if (!waitForLockstep([](const VehicleIo& v) { return v.answered >= 0.0; }, "command", 0.2))
        return false;
    }
    while (ros::ok())
    {
      ros::spinOnce();
      if (publish_clock_)
      {
        if (paused_ && pending_steps_ == 0)
        {
          ros::WallDuration(0.001).sleep();  // paused (~pause): the services and nothing else
          continue;
        }
        if (!awaiting_.empty() && !waitForSensorSubscriptions())
          return false;
        // One clock period of physics per loop, commands taken at its start; paused, one step
        // of ~step per loop, each with its clock. Clock publications stay on the same steps
        // as without a pause, so the barriers below fall where they always do.
        const bool single = paused_;
        do
        {
          step();
          if (single)
            --pending_steps_;
        } while (ros::ok() && !single && world_->stepCount() % clock_every_ != 0);
        if (followers_ && !waitForFollowers())
          return false;
        publishClock();
        if (lockstep_every_ > 0 && world_->stepCount() % lockstep_every_ == 0 && !waitForCommands())
          return false;
        if (pacer_ && !single)
        {
          // Behind the pace by more than 0.1 s (wall), the pace restarts: sim time slows down
          // rather than sprinting later with every subscriber behind the clock.
          const double wait = pacer_->wait(world_->time(), ros::WallTime::now().toSec());
          if (wait > 0.0)
            ros::WallDuration(wait).sleep();
        }
      }
      else
      {
        // Follow the external clock: catch up with it, then wait for it to move on.
        const ros::Time now = ros::Time::now();
        if (now.isZero())
        {
          ros::WallDuration(0.001).sleep();
          continue;
        }
        if (!follow_start_)
          follow_start_ = now;
        const double target = (now - *follow_start_).toSec();
        if (world_->time() + 0.5 * world_->options().step >= target)
        {
          ros::WallDuration(0.0005).sleep();
          continue;
        }
        if (!awaiting_.empty() && !waitForSensorSubscriptions())
          return false;
        while (world_->time() + 0.5 * world_->options().step < target && ros::ok())
          step();
      }
    }
    return true;
  }

private:
  /// Wall time spent per interval of a partition's loop (logged every 1000 intervals and at the end).
  struct IntervalCosts
  {
    double stepping = 0.0;    ///< s, stepping (with the controllers' barriers)
    double waiting = 0.0;     ///< s, waiting for the clock and the peers
    double exchanging = 0.0;  ///< s, applying the peers' exchanges and sending ours
    std::uint64_t intervals = 0;
  };

  /// A partition's loop: each /clock tick T, step the world to T and report T done.
  /// ~wait_for_command: every vehicle has a command; ~start_topic: the start signal came.
  bool readyToStart() const
  {
    const bool commanded = !wait_for_command_ || std::all_of(vehicles_.begin(), vehicles_.end(),
                                                             [](const auto& v) { return v->pending.has_value(); });
    return commanded && (start_topic_.empty() || start_signalled_);
  }

  bool runPartition()
  {
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    while (ros::ok() && !tick_)
      queue->callAvailable(ros::WallDuration(0.001));
    if (!ros::ok())
      return true;
    // The world starts at the clock's 0 (lockstep_clock starts there).
    while (ros::ok() && !readyToStart())
      queue->callAvailable(ros::WallDuration(0.001));
    publishStates();
    if (lockstep_every_ > 0 && !waitForLockstep([](const VehicleIo& v) { return v.answered >= 0.0; }, "command", 0.2))
      return false;
    double reported = 0.0;
    if (runner_)
    {
      // Every peer must hear the first exchange: wait until all have subscribed.
      if (!waitForPeerSubscribers())
        return false;
      runner_->finish(reported);
    }
    reportDone(reported);
    const double h = world_->options().step;
    IntervalCosts costs;
    ros::WallTime mark = ros::WallTime::now();
    struct AtExit
    {
      std::function<void()> f;
      ~AtExit() { f(); }
    } at_exit{ [&] { logCosts(costs, reported); } };
    while (ros::ok())
    {
      // Wait for a callback only when there is nothing to step: the ticks processed after the
      // last interval may already be ahead, and a blocking call would idle until some other
      // message came (up to its 1 ms timeout).
      const bool behind = tick_ && *tick_ > reported + 0.5 * h;
      queue->callAvailable(behind ? ros::WallDuration(0.0) : ros::WallDuration(0.001));
      if (!(*tick_ > reported + 0.5 * h))
      {
        if (tick_repeated_)
        {
          reportDone(reported);  // the clock asks again: our report may have been lost
          // At time 0 a node that waits for our odometry (sensors_node in the lockstep) may
          // have connected after it went out: send it again (later the connections stand).
          if (reported == 0.0)
            for (const auto& v : vehicles_)
              v->odom_pub.publish(v->last_odom);
        }
        tick_repeated_ = false;
        continue;
      }
      // Interval by interval up to the tick (the clock may be ~lookahead intervals ahead of
      // the slowest partition): the peers exchange at every interval's end, so the result
      // does not depend on how far ahead the clock is.
      const double target = *tick_;
      while (ros::ok() && reported + 0.5 * h < target)
      {
        const double end = std::min(target, sync_interval_ * (std::floor(reported / sync_interval_ + 1e-6) + 1.0));
        if (!stepInterval(reported, end, mark, costs))
          return false;
        reported = end;
        if (costs.intervals % 1000 == 0)
          logCosts(costs, reported);
        queue->callAvailable();  // peers' exchanges and ticks that came in meanwhile
      }
    }
    return !failed_;
  }

  /// One interval of a partition: the peers' exchanges it needs, the steps (with the
  /// controllers' barriers), our exchange, the report on /lockstep/done. `mark`: when the last
  /// interval ended (wall); the time since, less what the exchanges took, was spent waiting.
  bool stepInterval(double from, double end, ros::WallTime& mark, IntervalCosts& costs)
  {
    const double h = world_->options().step;
    const double exchanged_before = costs.exchanging;
    if (runner_ && !prepareInterval(from, end, costs.exchanging))
      return false;
    if (!awaiting_.empty() && !waitForSensorSubscriptions())  // a spawned vehicle's first interval
      return false;
    const ros::WallTime begin = ros::WallTime::now();
    costs.waiting += (begin - mark).toSec() - (costs.exchanging - exchanged_before);
    while (ros::ok() && world_->time() + 0.5 * h < end)
    {
      step();
      if (lockstep_every_ > 0 && world_->stepCount() % lockstep_every_ == 0 && !waitForCommands())
        return false;
    }
    const ros::WallTime stepped = ros::WallTime::now();
    costs.stepping += (stepped - begin).toSec();
    if (runner_)
      runner_->finish(end);
    reportDone(end);
    mark = ros::WallTime::now();
    costs.exchanging += (mark - stepped).toSec();
    ++costs.intervals;
    return true;
  }

  /// The lockstep's cost per interval, and how often the partition stepped ahead of its peers
  /// and held its soil changes back.
  void logCosts(const IntervalCosts& c, double reported) const
  {
    if (c.intervals == 0)
      return;
    const auto count = [this](std::uint64_t (ad::PartitionRunner::*f)() const) {
      return static_cast<unsigned long long>(runner_ ? ((*runner_).*f)() : 0);
    };
    char line[512];
    std::snprintf(line, sizeof line,
                  "dynamics_node: partition '%s': %llu intervals to t = %.3f s; per interval %.1f us stepping, "
                  "%.1f us waiting for the clock and peers, %.1f us exchanging with them; %llu stepped ahead of "
                  "the peers' last exchange; our soil changes sent in %llu of %llu exchanges",
                  partition_.c_str(), static_cast<unsigned long long>(c.intervals), reported,
                  1e6 * c.stepping / c.intervals, 1e6 * c.waiting / c.intervals, 1e6 * c.exchanging / c.intervals,
                  count(&ad::PartitionRunner::steppedAhead), count(&ad::PartitionRunner::soilExchangesSent),
                  count(&ad::PartitionRunner::exchangesSent));
    if (ros::ok())
      ROS_INFO("%s", line);
    else
      std::printf("%s\n", line);  // rosconsole is shut down with the node
    std::fflush(stdout);
  }

  void onTick(const rosgraph_msgs::Clock::ConstPtr& c)
  {
    const double t = c->clock.toSec();
    if (tick_ && t <= *tick_)
      tick_repeated_ = true;
    else
      tick_ = t;
  }

  /// The world's options and the node's own (timeouts, rates, clock, partition), checked;
  /// `lockstep_names`: ~lockstep_vehicles.
  ad::WorldOptions readOptions(const std::vector<VehicleSpec>& specs, std::set<std::string>& lockstep_names)
  {
    ad::WorldOptions options;
    options.step = boundedParam(pnh_, "step", 0.001, 1e-5, 0.01);
    options.seed = static_cast<std::uint64_t>(avsp::node::runIntParam(pnh_, avsp::terrain::kRunSeed));
    options.deform_terrain = avsp::node::boolParam(pnh_, "deform_terrain", true);
    command_timeout_ = boundedParam(pnh_, "command_timeout", 0.5, 0.0, 3600.0);
    hold_until_throttle_ = avsp::node::boolParam(pnh_, "hold_until_throttle", true);
    const double odom_rate = boundedParam(pnh_, "odometry_rate", 100.0, 1.0, 1.0 / options.step);
    const double clock_rate = boundedParam(pnh_, "clock_rate", 500.0, 1.0, 1.0 / options.step);
    const double ruts_rate = boundedParam(pnh_, "ruts_rate", 2.0, 0.0, 1.0 / options.step);
    real_time_factor_ = avsp::node::runNumberParam(pnh_, avsp::terrain::kRealTimeFactor);
    if (real_time_factor_ > 0.0)
      pacer_.emplace(real_time_factor_, kPaceMaxLag);
    publish_clock_ = avsp::node::boolParam(pnh_, "publish_clock", true);
    publish_odom_tf_ = avsp::node::boolParam(pnh_, "publish_odom_tf", true);
    per_vehicle_odom_frames_ = avsp::node::boolParam(pnh_, "per_vehicle_odom_frames", false);
    wait_for_command_ = avsp::node::boolParam(pnh_, "wait_for_command", false);
    start_topic_ = avsp::node::stringParam(pnh_, "start_topic", "");
    {
      std::string why;
      if (!start_topic_.empty() && !ros::names::validate(start_topic_, why))
        throw StartupError("parameter ~start_topic '" + start_topic_ + "' is not a ROS name: " + why);
    }
    partition_ = avsp::node::stringParam(pnh_, "partition", "");
    sync_interval_ = boundedParam(pnh_, "sync_interval", 0.01, options.step, 10.0);
    {
      const double steps = sync_interval_ / options.step;
      if (std::fabs(steps - std::round(steps)) > 1e-6 * steps)
        throw StartupError("parameter ~sync_interval " + std::to_string(sync_interval_) +
                           " s must be a whole number of ~step");
    }
    if (!partition_.empty())
    {
      std::string why;
      if (!ros::names::validate(partition_, why) || partition_.find('/') != std::string::npos)
        throw StartupError("parameter ~partition '" + partition_ + "' must be a plain name (no '/')");
      if (publish_clock_)
        throw StartupError("parameter ~partition needs ~publish_clock false: lockstep_clock is the clock");
    }
    // Publication periods in whole steps, so they fall on the same steps in every run.
    odom_every_ = std::max<std::uint64_t>(1, std::llround(1.0 / (odom_rate * options.step)));
    readFollowers(static_cast<double>(odom_every_) * options.step);
    clock_every_ = std::max<std::uint64_t>(1, std::llround(1.0 / (clock_rate * options.step)));
    ruts_every_ = ruts_rate > 0.0 ? std::max<std::uint64_t>(1, std::llround(1.0 / (ruts_rate * options.step))) : 0;
    lockstep_names = lockstepVehicles(specs, options.step, odom_rate);
    // The sensors_nodes told of a spawned or removed vehicle (~spawn_vehicle, ~remove_vehicle).
    for (const std::string& n :
         avsp::node::plainNamesParam(pnh_, "sensor_nodes", "sensors_node names (in this node's namespace)"))
      sensor_nodes_.push_back(nh_.resolveName(n));
    return options;
  }

  /// The terrain and its objects, the World on them (colliding with the objects unless
  /// ~obstacles is false), the agents.
  void loadWorld(const ad::WorldOptions& options)
  {
    loadTerrain();
    const bool obstacles = avsp::node::boolParam(pnh_, "obstacles", true);
    try
    {
      world_ = std::make_unique<ad::World>(*terrain_, options);
      if (obstacles && objects_.size() > 0)
        world_->setObstacles(objects_);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError(e.what());
    }
    if (obstacles)
      for (const at::TerrainObject& o : objects_.all())
        if (std::isfinite(o.strength) && !o.toppled)
          standing_.push_back(o.id);
    loadAgents();
  }

  /// ~dem_vehicles and ~dem (terramechanics dem): the DEM soil's spec checked, its bed template
  /// settled once (the patches are tiled from it). Not with ~partition (a vehicle's patch is
  /// its own partition's; not yet exchanged).
  void readDem(const std::vector<VehicleSpec>& specs)
  {
    const auto names = avsp::node::plainNamesParam(pnh_, "dem_vehicles", "vehicle names (terramechanics dem)");
    if (names.empty())
      return;
    for (const std::string& n : names)
      if (std::none_of(specs.begin(), specs.end(), [&](const VehicleSpec& v) { return v.name == n; }))
        throw StartupError("parameter ~dem_vehicles: there is no vehicle '" + n + "' in ~vehicles");
    if (!partition_.empty())
      throw StartupError(
          "parameter ~dem_vehicles: the DEM contact mode runs in one dynamics_node (not with ~partition)");
    try
    {
      dem_spec_ = ad::dem::parseDemSoilSpec(avsp::node::stringParam(pnh_, "dem", ""), "~dem");
      const ros::WallTime start = ros::WallTime::now();
      dem_bed_ = std::make_unique<ad::dem::BedTemplate>(ad::dem::BedTemplate::settle(
          dem_spec_->parameters, dem_spec_->template_length, dem_spec_->template_width, dem_spec_->template_depth));
      ROS_INFO(
          "dynamics_node: DEM bed template %zu particles, settled in %.2f s (%.1f s wall); %zu vehicle(s) on "
          "the DEM over x in [%g, %g] m",
          dem_bed_->particles().size(), dem_bed_->settleTime(), (ros::WallTime::now() - start).toSec(), names.size(),
          dem_spec_->segment.x_min, dem_spec_->segment.x_max);
    }
    catch (const ad::dem::DemParameterError& e)
    {
      throw StartupError(e.what());
    }
    dem_vehicles_.insert(names.begin(), names.end());
  }

  /// A vehicle of ~vehicles: its model in the world at its resting pose, its joints, its topics.
  void addVehicle(const VehicleSpec& s, bool lockstep)
  {
    auto v = std::make_unique<VehicleIo>();
    v->name = s.name;
    v->odom_frame = per_vehicle_odom_frames_ ? s.name + "/odom" : "odom";
    const std::string yaml = config_dir_ + "/" + s.model + ".yaml";
    try
    {
      v->model = ad::loadVehicleModel(yaml);
      // Lowest wheel 1 cm above the ground: it settles in the first fraction of a second.
      v->id = world_->addVehicle(v->model, world_->restingPose(v->model, s.x, s.y, s.yaw, 0.01), s.name);
    }
    catch (const std::exception& e)
    {
      throw StartupError("vehicle '" + s.name + "' (model '" + s.model + "', ~vehicles, ~config_dir " + config_dir_ +
                         "): " + e.what());
    }
    if (dem_vehicles_.count(s.name))
    {
      try
      {
        v->dem = std::make_shared<ad::dem::DemVehicleSoil>(*dem_bed_, *terrain_, dem_spec_->segment);
        world_->setExternalWheelSoil(v->id, v->dem);
        v->dem_pub = nh_.advertise<avsp_msgs::DemCrossing>(s.name + "/dem_crossing", 1, true);
      }
      catch (const std::exception& e)
      {
        throw StartupError("vehicle '" + s.name + "' (~dem_vehicles): " + e.what());
      }
    }
    v->model_name = s.model;
    v->wheel_odom = ad::WheelOdometry(world_->state(v->id).pose);
    v->spin_angle.assign(v->model.wheels.size(), 0.0);
    for (const ad::WheelSpec& w : v->model.wheels)
    {
      v->joints.name.push_back(w.spin_joint);
      v->joints.name.push_back(w.suspension_joint);
      if (!w.steering_joint.empty())
        v->joints.name.push_back(w.steering_joint);
    }
    for (const ad::TrackSpec& t : v->model.tracks)
    {
      v->joints.name.push_back(t.sprocket_joint);
      v->joints.name.push_back(t.idler_joint);
      for (const ad::RoadWheelSpec& w : t.road_wheels)
      {
        v->joints.name.push_back(w.arm_joint);
        v->joints.name.push_back(w.spin_joint);
      }
    }
    // m: how far outside its centre a contact deforms the soil (the rut patch's margin).
    for (const ad::WheelSpec& w : v->model.wheels)
      v->rut_margin = std::max(v->rut_margin, w.radius + w.width);
    for (const ad::TrackSpec& t : v->model.tracks)
      for (const ad::RoadWheelSpec& w : t.road_wheels)
        v->rut_margin = std::max(v->rut_margin, w.radius + v->model.track.shoe_width);
    v->lockstep = lockstep;
    v->joints.position.assign(v->joints.name.size(), 0.0);
    v->joints.velocity.assign(v->joints.name.size(), 0.0);
    ros::NodeHandle vnh(nh_, s.name);
    v->cmd_topic = vnh.resolveName("avt_341/cmd_vel");
    VehicleIo* raw = v.get();
    v->cmd_sub = vnh.subscribe<geometry_msgs::Twist>(
        "avt_341/cmd_vel", 10, [this, raw](const geometry_msgs::Twist::ConstPtr& msg) { onCmdVel(*raw, *msg); });
    v->drive_topic = vnh.resolveName("cmd_drive");
    v->drive_sub = vnh.subscribe<avsp_msgs::DriveCommand>(
        "cmd_drive", 10, [this, raw](const avsp_msgs::DriveCommand::ConstPtr& msg) { onCmdDrive(*raw, *msg); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());  // the lockstep round trip: no Nagle delay
    // Deep outgoing queues: a subscriber whose process is not scheduled for a while (a loaded
    // machine, real-time factor 0) stops reading its socket, and roscpp then drops the oldest
    // queued messages for it. With 50 (0.5 s of sim, a few ms of wall at full speed)
    // run_recorder lost 13 of 1000 odometry samples under load; 2000 is 20 s of sim at 100 Hz.
    // Subscribers are seen connecting: a spawned vehicle's first step waits for its sensors.
    const std::string name = s.name;
    v->odom_pub = vnh.advertise<nav_msgs::Odometry>(
        "avt_341/odometry", kStateQueue,
        [this, name](const ros::SingleSubscriberPublisher& p) { onOdometrySubscriber(name, p.getSubscriberName()); });
    v->telemetry_pub = vnh.advertise<avsp_msgs::VehicleTelemetry>("telemetry", kStateQueue);
    v->joint_pub = vnh.advertise<sensor_msgs::JointState>("joint_states", 50);
    v->truth_pub = vnh.advertise<nav_msgs::Odometry>("ground_truth/odometry", kStateQueue);
    v->wheel_odom_pub = vnh.advertise<nav_msgs::Odometry>("wheel_odometry", kStateQueue);
    vehicles_.push_back(std::move(v));
  }

  /// ~peers: the run's other partitions (plain names, not this one, each once); with any, the
  /// exchange protocol's runner over the ROS transport.
  void loadPeers()
  {
    ad::PartitionOptions options;
    options.partition = partition_;
    options.interval = sync_interval_;
    options.peers = avsp::node::plainNamesParam(pnh_, "peers", "partition names");
    if (!options.peers.empty() && partition_.empty())
      throw StartupError("parameter ~peers needs a ~partition");
    for (std::size_t k = 0; k < options.peers.size(); ++k)
      if (options.peers[k] == partition_)
        throw StartupError("parameter ~peers[" + std::to_string(k) + "] '" + partition_ +
                           "' is this partition (~partition)");
    if (options.peers.empty())
      return;
    options.step_ahead_intervals = avsp::node::boundedIntParam(pnh_, "step_ahead_intervals", 4, 0, 100);
    std::vector<ad::PartitionVehicle> ours;
    for (const auto& v : vehicles_)
      ours.push_back(ad::PartitionVehicle{ v->id, v->name, v->model_name, ad::boundingBox(v->model) });
    const std::string config_dir = config_dir_;
    auto load_model = [config_dir](const std::string& model) {
      return ad::loadVehicleModel(config_dir + "/" + model + ".yaml");
    };
    auto log = [](ad::PartitionRunner::Level level, const std::string& text) {
      if (level == ad::PartitionRunner::Level::kDebug)
        ROS_DEBUG("dynamics_node: %s", text.c_str());
      else if (level == ad::PartitionRunner::Level::kInfo)
        ROS_INFO("dynamics_node: %s", text.c_str());
      else
        ROS_WARN("dynamics_node: %s", text.c_str());
    };
    transport_ = std::make_unique<RosExchangeTransport>(
        nh_, partition_, options.peers,
        [this](const std::string& peer, ad::PartitionExchange exchange) { onExchange(peer, std::move(exchange)); });
    try
    {
      runner_ = std::make_unique<ad::PartitionRunner>(options, *world_, objects_, std::move(ours), standing_,
                                                      load_model, *transport_, log);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError(std::string(e.what()) + " (~peers needs fewer)");
    }
    ROS_INFO("dynamics_node: partition '%s' exchanges vehicles and soil with %zu peer(s)", partition_.c_str(),
             options.peers.size());
  }

  /// Until as many subscribers as peers listen to this partition's exchange (or
  /// ~lockstep_timeout): the first exchange then mostly goes out once, live (it is latched too).
  /// The count also takes other listeners (a test, rostopic), so it cannot tell that every peer
  /// is there; the latch covers a late one.
  bool waitForPeerSubscribers()
  {
    const std::size_t peers = runner_->options().peers.size();
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(lockstep_timeout_);
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    while (ros::ok() && transport_->subscriberCount() < peers)
    {
      queue->callAvailable(ros::WallDuration(0.001));
      if (ros::WallTime::now() > deadline)
      {
        const std::string missing = joined(transport_->unconnectedPeers());
        fatal("partition '" + partition_ + "': only " + std::to_string(transport_->subscriberCount()) + " of " +
              std::to_string(peers) + " peers subscribed to /lockstep/exchange/" + partition_ +
              " within ~lockstep_timeout " + shortNumber(lockstep_timeout_) +
              " s (wall); not connected: " + (missing.empty() ? "?" : missing));
        return false;
      }
    }
    return ros::ok();
  }

  /// Applies what the interval from `from` to `to` needs of the peers' exchanges, waiting (wall
  /// clock, up to ~lockstep_timeout per exchange) for those that have not arrived. `exchanging`
  /// (s, wall) grows by the time spent applying them. False after a fatal error or on shutdown.
  bool prepareInterval(double from, double to, double& exchanging)
  {
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    std::optional<double> waited;  // the exchange being waited for
    ros::WallTime deadline;
    while (ros::ok() && !failed_)
    {
      const ros::WallTime start = ros::WallTime::now();
      ad::PartitionRunner::Ready ready;
      try
      {
        ready = runner_->prepare(from, to);
      }
      catch (const ad::ExchangeError& e)
      {
        fatal(e.what());
        return false;
      }
      exchanging += (ros::WallTime::now() - start).toSec();
      // Toppled by a peer: not ours to report on /terrain/toppled.
      for (std::uint32_t id : runner_->takeToppledByPeers())
        standing_.erase(std::remove(standing_.begin(), standing_.end(), id), standing_.end());
      if (ready == ad::PartitionRunner::Ready::kReady)
        return true;
      if (waited != runner_->waitingFor())
      {
        waited = runner_->waitingFor();
        deadline = ros::WallTime::now() + ros::WallDuration(lockstep_timeout_);
      }
      else if (ros::WallTime::now() > deadline)
      {
        char t[32];
        std::snprintf(t, sizeof t, "%.3f", *waited);
        fatal("partition '" + partition_ + "': no exchange for t = " + t + " s on " +
              joined(runner_->missingSources()) + " within ~lockstep_timeout " + shortNumber(lockstep_timeout_) +
              " s (wall)");
        return false;
      }
      queue->callAvailable(ros::WallDuration(0.001));
    }
    return false;
  }

  /// A peer's exchange arrives: the runner checks it and keeps it until the interval it closes.
  void onExchange(const std::string& peer, ad::PartitionExchange exchange)
  {
    if (failed_)
      return;
    try
    {
      runner_->receive(peer, std::move(exchange));
    }
    catch (const ad::ExchangeError& e)
    {
      fatal(e.what());  // the lockstep cannot go on without it, nor guess it
    }
  }

  /// Stops the run after an error it cannot go on from (exit 1).
  void fatal(const std::string& why)
  {
    ROS_FATAL("dynamics_node: %s; stopping the run", why.c_str());
    failed_ = true;
    ros::shutdown();
  }

  void reportDone(double t)
  {
    avsp_msgs::StepDone d;
    d.header.stamp = ros::Time(t);
    d.partition = partition_;
    done_pub_.publish(d);
  }

  /// ~clock_followers and ~follower_lag (s). The lag must cover one odometry period: a
  /// follower reports time t once it has the odometry of t, which goes out before /clock does.
  void readFollowers(double odom_period)
  {
    const std::vector<std::string> names =
        avsp::node::plainNamesParam(pnh_, "clock_followers", "names (the followers' ~lockstep_partition)");
    if (names.empty())
      return;
    if (!publish_clock_ || !partition_.empty())
      throw StartupError(
          "parameter ~clock_followers needs ~publish_clock true and no ~partition (with partitions "
          "lockstep_clock waits for the sensors)");
    const double lag = boundedParam(pnh_, "follower_lag", 0.05, 0.0, 10.0);
    if (lag < odom_period - 1e-9)
      throw StartupError("parameter ~follower_lag " + shortNumber(lag) + " s must be at least the odometry period (" +
                         shortNumber(odom_period) + " s): a follower reports a time once it has its odometry");
    try
    {
      followers_.emplace(names, lag);
    }
    catch (const std::invalid_argument& e)
    {
      throw StartupError("parameter ~" + std::string(e.what()));
    }
    for (const std::string& n : names)
      follower_waited_[n] = 0.0;
  }

  void onFollowerDone(const avsp_msgs::StepDone::ConstPtr& msg)
  {
    if (followers_->done(msg->partition, msg->header.stamp.toSec()) == ad::ClockFollowers::Report::kUnknown)
      ROS_WARN_THROTTLE(5.0, "dynamics_node: /lockstep/done from '%s' ignored: not in ~clock_followers (%s)",
                        msg->partition.c_str(), joined(followers_->names()).c_str());
  }

  /// Before /clock goes to the world's time: callbacks run until every follower is within
  /// ~follower_lag of it. While waiting, the last clock time and odometry go out again every
  /// 0.2 s (wall): a follower that connected after they did would otherwise never answer.
  /// False (after an error naming the silent followers) after ~lockstep_timeout (wall).
  bool waitForFollowers()
  {
    const double t = world_->time();
    if (followers_->allows(t))
      return true;
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    ros::WallTime last = ros::WallTime::now();
    ros::WallTime resend = last + ros::WallDuration(0.2);
    const ros::WallTime deadline = last + ros::WallDuration(lockstep_timeout_);
    while (ros::ok() && !followers_->allows(t))
    {
      queue->callAvailable(ros::WallDuration(0.001));
      const ros::WallTime now = ros::WallTime::now();
      // The wait is charged to every follower that held the clock back, from when the pace
      // (if any) would have let the clock go: waiting that the pace would have spent sleeping
      // held nothing back.
      const double from = std::max(last.toSec(), pacer_ ? pacer_->due(t) : last.toSec());
      if (now.toSec() > from)
        for (const std::string& n : followers_->holding(t))
          follower_waited_[n] += now.toSec() - from;
      last = now;
      if (now > resend)
      {
        rosgraph_msgs::Clock c;
        c.clock = ros::Time(clock_published_);
        clock_pub_.publish(c);
        for (const auto& v : vehicles_)
          v->odom_pub.publish(v->last_odom);
        resend = now + ros::WallDuration(0.2);
      }
      if (now > deadline && !followers_->allows(t))
      {
        std::string silent;
        for (const std::string& n : followers_->holding(t))
        {
          const double r = followers_->reached(n);
          silent += (silent.empty() ? "" : ", ") + n +
                    (std::isfinite(r) ? " (at " + shortNumber(r) + " s)" : std::string(" (no report yet)"));
        }
        fatal("clock followers: " + silent + " did not reach t = " + shortNumber(t - followers_->lag()) +
              " s within ~lockstep_timeout " + shortNumber(lockstep_timeout_) + " s (wall)");
        return false;
      }
    }
    return ros::ok();
  }

  // ---- run control (~pause, ~resume, ~step) ---------------------------------------------
  // The services only set what the loop reads between clock periods: a pause takes effect
  // after the current one, and no step is taken or skipped because of when a call came.

  bool onPause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res)
  {
    res.success = !paused_;
    res.message = (paused_ ? "already paused at t = " : "paused at t = ") + shortNumber(world_->time()) + " s";
    paused_ = true;
    ROS_INFO("dynamics_node: ~pause: %s", res.message.c_str());
    return true;
  }

  bool onResume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res)
  {
    if (!paused_)
    {
      res.success = false;
      res.message = "not paused (t = " + shortNumber(world_->time()) + " s); nothing changed";
      return true;
    }
    paused_ = false;
    pending_steps_ = 0;
    if (pacer_)
      pacer_->reanchor();  // the pace starts again here: no catch-up for the time paused
    res.success = true;
    res.message = "resumed at t = " + shortNumber(world_->time()) + " s";
    ROS_INFO("dynamics_node: ~resume: %s", res.message.c_str());
    return true;
  }

  bool onStep(avsp_msgs::StepPhysics::Request& req, avsp_msgs::StepPhysics::Response& res)
  {
    res.until = world_->time();
    res.success = false;
    if (!paused_)
      res.message = "refused: not paused (call ~pause first); nothing changed";
    else if (req.steps == 0)
      res.message = "refused: steps must be at least 1";
    else if (pending_steps_ + req.steps > kMaxPendingSteps)
      res.message = "refused: more than " + std::to_string(kMaxPendingSteps) + " steps pending";
    else
    {
      pending_steps_ += req.steps;
      res.success = true;
      res.until = static_cast<double>(world_->stepCount() + pending_steps_) * world_->options().step;
      res.message = std::to_string(req.steps) + " step(s) queued; /clock reaches " + shortNumber(res.until) +
                    " s, then stays paused";
    }
    if (!res.success)
      ROS_WARN("dynamics_node: ~step: %s", res.message.c_str());
    return true;
  }

  /// ~set_vehicle_pose: the vehicle set down again at (x, y, yaw), resting on the ground and
  /// stopped (World::setPose), unless the place is off the terrain or in a standing object.
  /// Taken between clock periods, like every callback: for a reproducible script, ~pause,
  /// ~step to the instant, call, ~resume.
  bool onSetVehiclePose(avsp_msgs::SetVehiclePose::Request& req, avsp_msgs::SetVehiclePose::Response& res)
  {
    res.success = false;
    VehicleIo* v = nullptr;
    std::string known;
    for (const auto& c : vehicles_)
    {
      known += (known.empty() ? "" : ", ") + c->name;
      if (c->name == req.vehicle)
        v = c.get();
    }
    if (!v)
      res.message = "refused: no vehicle '" + req.vehicle + "' (vehicles: " + known + ")";
    else if (!std::isfinite(req.x) || !std::isfinite(req.y) || !std::isfinite(req.yaw))
      res.message = "refused: x, y and yaw must be finite numbers";
    else
    {
      try
      {
        const Eigen::Isometry3d pose = world_->restingPose(v->model, req.x, req.y, req.yaw, 0.01);
        const std::string blocked = standingObjectUnder(v->model, pose);
        if (!blocked.empty())
          res.message = "refused: at (" + shortNumber(req.x) + ", " + shortNumber(req.y) + ") '" + v->name +
                        "' would stand in " + blocked;
        else
        {
          if (v->ran && ruts_every_ > 0 && ruts_pub_.getNumSubscribers() > 0)
            publishRuts();  // the ruts so far, before the rut area jumps
          v->ran = false;
          world_->setPose(v->id, pose);
          v->wheel_odom = ad::WheelOdometry(world_->state(v->id).pose);  // dead reckoning restarts there
          res.success = true;
          res.message = "'" + v->name + "' set down at (" + shortNumber(req.x) + ", " + shortNumber(req.y) + "), yaw " +
                        shortNumber(req.yaw) + " rad, at t = " + shortNumber(world_->time()) + " s";
        }
      }
      catch (const std::exception& e)
      {
        res.message = std::string("refused: ") + e.what();
      }
    }
    if (res.success)
      ROS_INFO("dynamics_node: ~set_vehicle_pose: %s", res.message.c_str());
    else
      ROS_WARN("dynamics_node: ~set_vehicle_pose: %s (nothing changed)", res.message.c_str());
    return true;
  }

  /// The map-frame bounding box (x0, y0, x1, y1) of a model's collision boxes at `pose`; empty
  /// (x0 > x1) for a model without collision boxes.
  static std::array<double, 4> footprint(const ad::VehicleModel& model, const Eigen::Isometry3d& pose)
  {
    double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
    for (const ad::CollisionBox& b : model.collision_boxes)
      for (int corner = 0; corner < 8; ++corner)
      {
        const Eigen::Vector3d local(((corner & 1) ? 0.5 : -0.5) * b.size.x(), ((corner & 2) ? 0.5 : -0.5) * b.size.y(),
                                    ((corner & 4) ? 0.5 : -0.5) * b.size.z());
        const Eigen::Vector3d p = pose * (b.pose * local);
        x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x()), y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
      }
    return { x0, y0, x1, y1 };
  }

  /// The first standing object (not grass, not toppled) whose footprint meets the bounding box
  /// of the vehicle's collision boxes at `pose`: "<type> <id> at (x, y)", or "".
  std::string standingObjectUnder(const ad::VehicleModel& model, const Eigen::Isometry3d& pose) const
  {
    const auto [x0, y0, x1, y1] = footprint(model, pose);
    if (!(x0 <= x1))
      return "";
    for (std::uint32_t id : objects_.query(x0, y0, x1, y1))
    {
      const at::TerrainObject& o = objects_.get(id);
      if (o.type == at::ObjectType::kGrass || o.toppled)
        continue;
      return std::string(at::toString(o.type)) + " " + std::to_string(id) + " at (" + shortNumber(o.x) + ", " +
             shortNumber(o.y) + ")";
    }
    return "";
  }

  /// The first vehicle of the run (not `except`) whose footprint where it is now meets the
  /// model's at `pose`: its name, or "".
  std::string vehicleUnder(const ad::VehicleModel& model, const Eigen::Isometry3d& pose,
                           const VehicleIo* except = nullptr) const
  {
    const std::array<double, 4> a = footprint(model, pose);
    for (const auto& v : vehicles_)
    {
      if (v.get() == except)
        continue;
      const std::array<double, 4> b = footprint(v->model, world_->state(v->id).pose);
      if (a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3])
        return v->name;
    }
    return "";
  }

  // ---- ~spawn_vehicle, ~remove_vehicle -------------------------------------------------------
  // Between two steps, like every callback: for a reproducible script, ~pause, ~step to the
  // instant, call, ~resume. In a partitioned run, between two intervals (the clock is
  // lockstep_clock's, which has no pause: the call takes effect at the interval it arrives in);
  // a request for another partition's vehicle, or naming another partition, is forwarded to the
  // node that publishes that partition's exchange.

  /// The node running partition `peer` (the publisher of /lockstep/exchange/<peer>), "" if none.
  static std::string peerNode(const std::string& peer)
  {
    avsp::node::RosGraph graph;
    if (!avsp::node::readRosGraph(graph))
      return "";
    const auto it = graph.publishers.find("/lockstep/exchange/" + peer);
    return it == graph.publishers.end() || it->second.size() != 1 ? std::string() : *it->second.begin();
  }

  /// Forwards a request to partition `peer`'s node: false (with `message`) when it cannot.
  template <class Service>
  bool forward(const std::string& peer, const std::string& service, Service& call, std::string& message)
  {
    const std::string node = peerNode(peer);
    if (node.empty())
      message = "refused: no node publishes /lockstep/exchange/" + peer + " (partition '" + peer + "')";
    else if (!ros::service::call(node + "/" + service, call))
      message = "refused: " + node + "/" + service + " (partition '" + peer + "') did not answer";
    else
      return true;
    return false;
  }

  bool onSpawnVehicle(avsp_msgs::SpawnVehicle::Request& req, avsp_msgs::SpawnVehicle::Response& res)
  {
    res.success = false;
    std::string why;
    const auto named = [&](const std::string& n) {
      return std::any_of(vehicles_.begin(), vehicles_.end(), [&](const auto& v) { return v->name == n; });
    };
    const std::vector<std::string> peers = runner_ ? runner_->options().peers : std::vector<std::string>();
    if (!req.partition.empty() && req.partition != partition_)
    {
      if (std::find(peers.begin(), peers.end(), req.partition) == peers.end())
        res.message = "refused: no partition '" + req.partition + "' in this run" +
                      (peers.empty() ? std::string(" (it has none)")
                                     : " (partitions: " + partition_ + ", " + joined(peers) + ")");
      else
      {
        avsp_msgs::SpawnVehicle call;
        call.request = req;
        if (forward(req.partition, "spawn_vehicle", call, res.message))
        {
          res = call.response;
          res.message = "partition '" + req.partition + "': " + res.message;
        }
      }
    }
    else if (req.name.empty() || req.name.find('/') != std::string::npos || !ros::names::validate(req.name, why))
      res.message = "refused: name '" + req.name + "' must be a valid ROS name without '/'";
    else if (named(req.name))
      res.message = "refused: there is already a vehicle '" + req.name + "'";
    else if (runner_ && !runner_->ownerOf(req.name).empty())
      res.message =
          "refused: there is already a vehicle '" + req.name + "' (partition '" + runner_->ownerOf(req.name) + "')";
    else if (req.model.empty() || req.model.find('/') != std::string::npos ||
             !std::filesystem::is_regular_file(config_dir_ + "/" + req.model + ".yaml"))
      res.message = "refused: no model '" + req.model + "' in ~config_dir " + config_dir_ +
                    " (models: " + joined(knownModels()) + ")";
    else if (!std::isfinite(req.x) || !std::isfinite(req.y) || !std::isfinite(req.yaw))
      res.message = "refused: x, y and yaw must be finite numbers";
    else
    {
      try
      {
        const ad::VehicleModel model = ad::loadVehicleModel(config_dir_ + "/" + req.model + ".yaml");
        const Eigen::Isometry3d pose = world_->restingPose(model, req.x, req.y, req.yaw, 0.01);
        const std::string object = standingObjectUnder(model, pose);
        const std::string vehicle = vehicleUnder(model, pose);
        if (!object.empty())
          res.message = "refused: at (" + shortNumber(req.x) + ", " + shortNumber(req.y) + ") '" + req.name +
                        "' would stand in " + object;
        else if (!vehicle.empty())
          res.message = "refused: at (" + shortNumber(req.x) + ", " + shortNumber(req.y) + ") '" + req.name +
                        "' would stand on vehicle '" + vehicle + "'";
        else
        {
          addVehicle(VehicleSpec{ req.name, req.model, req.x, req.y, req.yaw }, false);
          const std::string refused = tellSensorsOfSpawn(req.name, req.model);
          if (!refused.empty())
          {
            awaiting_.erase(req.name);
            world_->removeVehicle(vehicles_.back()->id);
            vehicles_.pop_back();
            throw std::runtime_error(refused);
          }
          if (runner_)
            runner_->addVehicle(ad::PartitionVehicle{ vehicles_.back()->id, req.name, req.model,
                                                      ad::boundingBox(vehicles_.back()->model) });
          transforms_.resize(vehicles_.size());
          publishOdomFrames();
          VehicleIo* raw = vehicles_.back().get();
          diagnostics_->add(raw->name,
                            [this, raw](diagnostic_updater::DiagnosticStatusWrapper& st) { vehicleStatus(*raw, st); });
          res.success = true;
          res.message = "'" + req.name + "' (" + req.model + ") set down at (" + shortNumber(req.x) + ", " +
                        shortNumber(req.y) + "), yaw " + shortNumber(req.yaw) +
                        " rad, at t = " + shortNumber(world_->time()) + " s";
        }
      }
      catch (const std::exception& e)
      {
        res.message = std::string("refused: ") + e.what();
      }
    }
    if (res.success)
      ROS_INFO("dynamics_node: ~spawn_vehicle: %s", res.message.c_str());
    else
      ROS_WARN("dynamics_node: ~spawn_vehicle: %s (nothing changed)", res.message.c_str());
    return true;
  }

  bool onRemoveVehicle(avsp_msgs::RemoveVehicle::Request& req, avsp_msgs::RemoveVehicle::Response& res)
  {
    res.success = false;
    const auto it =
        std::find_if(vehicles_.begin(), vehicles_.end(), [&](const auto& v) { return v->name == req.name; });
    std::vector<std::string> names;
    for (const auto& v : vehicles_)
      names.push_back(v->name);
    const std::string owner = runner_ && it == vehicles_.end() ? runner_->ownerOf(req.name) : std::string();
    if (!owner.empty())
    {
      avsp_msgs::RemoveVehicle call;
      call.request = req;
      if (forward(owner, "remove_vehicle", call, res.message))
      {
        res = call.response;
        res.message = "partition '" + owner + "': " + res.message;
      }
    }
    else if (it == vehicles_.end())
      res.message = "refused: no vehicle '" + req.name + "' (vehicles: " + joined(names) + ")";
    else
    {
      VehicleIo& v = **it;
      if (v.ran && ruts_every_ > 0 && ruts_pub_.getNumSubscribers() > 0)
        publishRuts();  // its ruts so far, before its rut area goes
      tellSensorsOfRemoval(v.name);
      awaiting_.erase(v.name);
      const std::size_t id = v.id;
      diagnostics_->removeByName(v.name);
      world_->removeVehicle(id);
      for (auto& o : vehicles_)
        if (o->id > id)
          --o->id;  // World::removeVehicle moved the later ones down
      transforms_.erase(transforms_.begin() + (it - vehicles_.begin()));
      vehicles_.erase(it);  // its subscribers and publishers shut down with it
      if (runner_)
        runner_->removeVehicle(req.name);
      res.success = true;
      res.message = "'" + req.name + "' removed at t = " + shortNumber(world_->time()) + " s";
    }
    if (res.success)
      ROS_INFO("dynamics_node: ~remove_vehicle: %s", res.message.c_str());
    else
      ROS_WARN("dynamics_node: ~remove_vehicle: %s (nothing changed)", res.message.c_str());
    return true;
  }

  /// Each of ~sensor_nodes takes the spawned vehicle (`<node>/add_vehicle`), sensed from half a
  /// step after now (before its first odometry, after every state sent); its first step then
  /// waits until each has subscribed its odometry. "" when all took it, else why not (those
  /// that took it are told of its removal again).
  std::string tellSensorsOfSpawn(const std::string& name, const std::string& model)
  {
    const double first_time = world_->time() + 0.5 * world_->options().step;
    std::vector<std::string> told;
    for (const std::string& node : sensor_nodes_)
    {
      avsp_msgs::AddSensedVehicle call;
      call.request.name = name;
      call.request.model = model;
      call.request.first_time = first_time;
      std::string why;
      if (!ros::service::call(node + "/add_vehicle", call))
        why = node + "/add_vehicle did not answer (~sensor_nodes)";
      else if (!call.response.success)
        why = node + ": " + call.response.message;
      if (!why.empty())
      {
        for (const std::string& t : told)
        {
          avsp_msgs::RemoveSensedVehicle undo;
          undo.request.name = name;
          undo.request.last_time = world_->time();  // before its first state: never sensed
          ros::service::call(t + "/remove_vehicle", undo);
        }
        return why;
      }
      told.push_back(node);
      awaiting_[name].insert(node);
    }
    return "";
  }

  /// Each of ~sensor_nodes senses the vehicle up to now (its last odometry), then drops it.
  void tellSensorsOfRemoval(const std::string& name)
  {
    for (const std::string& node : sensor_nodes_)
    {
      avsp_msgs::RemoveSensedVehicle call;
      call.request.name = name;
      call.request.last_time = world_->time() + 0.5 * world_->options().step;
      if (!ros::service::call(node + "/remove_vehicle", call) || !call.response.success)
        ROS_WARN("dynamics_node: ~remove_vehicle: %s/remove_vehicle: %s", node.c_str(),
                 call.response.message.empty() ? "no answer" : call.response.message.c_str());
    }
  }

  /// A subscriber of a vehicle's odometry connected: a sensors_node awaited by its first step.
  void onOdometrySubscriber(const std::string& vehicle, const std::string& subscriber)
  {
    const auto it = awaiting_.find(vehicle);
    if (it == awaiting_.end())
      return;
    it->second.erase(subscriber);
    if (it->second.empty())
      awaiting_.erase(it);
  }

  /// Holds the next step until every spawned vehicle's odometry has its sensors_nodes'
  /// subscriptions (a state published before one connected would never reach it), within
  /// ~lockstep_timeout (wall); past it the run stops naming them.
  bool waitForSensorSubscriptions()
  {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(lockstep_timeout_);
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    while (ros::ok() && !awaiting_.empty())
    {
      queue->callAvailable(ros::WallDuration(0.001));
      if (ros::WallTime::now() > deadline && !awaiting_.empty())
      {
        std::string missing;
        for (const auto& [vehicle, nodes] : awaiting_)
          for (const std::string& n : nodes)
            missing += (missing.empty() ? "" : ", ") + n + " on " + vehicle + "/avt_341/odometry";
        fatal("spawned vehicle: no subscription of " + missing + " within ~lockstep_timeout " +
              shortNumber(lockstep_timeout_) + " s (wall)");
        return false;
      }
    }
    return ros::ok();
  }

  /// The model names ~config_dir offers (<name>.yaml), sorted.
  std::vector<std::string> knownModels() const
  {
    std::vector<std::string> out;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(config_dir_, ec))
      if (e.path().extension() == ".yaml")
        out.push_back(e.path().stem().string());
    std::sort(out.begin(), out.end());
    return out;
  }

  /// ~lockstep_vehicles (names in ~vehicles) and ~lockstep_period / ~lockstep_timeout.
  std::set<std::string> lockstepVehicles(const std::vector<VehicleSpec>& specs, double step, double odom_rate)
  {
    std::set<std::string> names;
    lockstep_timeout_ = boundedParam(pnh_, "lockstep_timeout", 30.0, 0.01, 3600.0);
    if (!pnh_.hasParam("lockstep_vehicles"))
      return names;
    XmlRpc::XmlRpcValue list;
    avsp::node::structuredParam(pnh_, "lockstep_vehicles", list);
    if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
      throw StartupError("parameter ~lockstep_vehicles must be a list of vehicle names");
    for (int k = 0; k < list.size(); ++k)
    {
      const std::string where = "parameter ~lockstep_vehicles[" + std::to_string(k) + "]";
      if (list[k].getType() != XmlRpc::XmlRpcValue::TypeString)
        throw StartupError(where + " must be a vehicle name (string)");
      const std::string name = static_cast<std::string>(list[k]);
      if (std::none_of(specs.begin(), specs.end(), [&](const VehicleSpec& s) { return s.name == name; }))
        throw StartupError(where + " '" + name + "' is not in ~vehicles");
      if (!names.insert(name).second)
        throw StartupError(where + " '" + name + "' is listed twice");
    }
    const double period = boundedParam(pnh_, "lockstep_period", 0.05, step, 10.0);
    if (names.empty())
      return names;
    if (!publish_clock_ && partition_.empty())
      throw StartupError(
          "parameter ~lockstep_vehicles needs ~publish_clock true or a ~partition (the barrier holds "
          "the clock)");
    // The barrier instants must be steps on which the odometry and the clock go out.
    const double steps = period / step;
    lockstep_every_ = static_cast<std::uint64_t>(std::llround(steps));
    if (std::fabs(steps - static_cast<double>(lockstep_every_)) > 1e-6 * steps || lockstep_every_ % odom_every_ != 0 ||
        (publish_clock_ && lockstep_every_ % clock_every_ != 0))
      throw StartupError("parameter ~lockstep_period " + std::to_string(period) +
                         " s must be a whole multiple of the odometry period (" + std::to_string(1.0 / odom_rate) +
                         " s) and of the clock period");
    return names;
  }

  /// The lockstep barrier at the current world time: callbacks run until every lockstep
  /// vehicle's cmd_drive for this instant is in. False (after an error naming the silent
  /// vehicles) on timeout.
  bool waitForCommands()
  {
    const double t = world_->time() - 0.5 * world_->options().step;
    return waitForLockstep([t](const VehicleIo& v) { return v.answered >= t; }, "command");
  }

  /// Runs callbacks until `ready` holds for every lockstep vehicle or ~lockstep_timeout
  /// (wall) passes; then the error names what was missing and on which topics.
  /// With `resend_period` > 0 (wall s), every vehicle's last odometry is sent again that often
  /// while waiting. With ~publish_clock, /clock is sent again every second (wall) of waiting: a
  /// node that answers through the clock (v2v_radio_node emits its lockstep batches when /clock
  /// reaches them) and connected after the last tick went out would otherwise never answer.
  template <typename Ready>
  bool waitForLockstep(Ready ready, const char* missing, double resend_period = 0.0)
  {
    ros::WallTime resend = ros::WallTime::now() + ros::WallDuration(resend_period);
    ros::WallTime clock_again = ros::WallTime::now() + ros::WallDuration(1.0);
    const auto all_ready = [&] {
      return std::all_of(vehicles_.begin(), vehicles_.end(), [&](const auto& v) { return !v->lockstep || ready(*v); });
    };
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(lockstep_timeout_);
    ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
    while (ros::ok() && !all_ready())
    {
      queue->callAvailable(ros::WallDuration(0.001));
      if (resend_period > 0.0 && ros::WallTime::now() > resend)
      {
        for (const auto& v : vehicles_)
          v->odom_pub.publish(v->last_odom);
        resend = ros::WallTime::now() + ros::WallDuration(resend_period);
      }
      if (publish_clock_ && ros::WallTime::now() > clock_again)
      {
        publishClock();  // the same time again: harmless to every /clock listener
        clock_again = ros::WallTime::now() + ros::WallDuration(1.0);
      }
      if (ros::WallTime::now() > deadline && !all_ready())
      {
        std::string silent;
        for (const auto& v : vehicles_)
          if (v->lockstep && !ready(*v))
            silent += (silent.empty() ? "" : ", ") + v->drive_topic;
        ROS_FATAL(
            "dynamics_node: lockstep: no %s for t = %.3f s on %s within ~lockstep_timeout %g s (wall); "
            "stopping the run",
            missing, world_->time(), silent.c_str(), lockstep_timeout_);
        ros::shutdown();
        failed_ = true;
        return false;
      }
    }
    return ros::ok();
  }

  /// ~agents: kinematic bodies the vehicles collide with, on the terrain's base heights (as
  /// agents_node and sensors_node place them).
  void loadAgents()
  {
    world_->setAgents(at::node::agentsFromParams(pnh_, terrain_->base()));
    if (world_->agentCount() > 0)
      ROS_INFO("dynamics_node: %zu dynamic agent(s) collide with the vehicles", world_->agentCount());
  }

  void loadTerrain()
  {
    at::LoadedSource loaded = at::node::loadTerrainFromParams(pnh_, *soils_);
    if (loaded.filled_no_data > 0)
      ROS_WARN("dynamics_node: %s: %zu no-data points filled from their nearest valid neighbours",
               loaded.description.c_str(), loaded.filled_no_data);
    terrain_ = std::move(loaded.terrain);
    objects_ = std::move(loaded.objects);
    source_ = loaded.description;
  }

  void onCmdVel(VehicleIo& v, const geometry_msgs::Twist& twist)
  {
    avsp_msgs::DriveCommand cmd;
    std::string why;
    accept(v, v.cmd_topic, ad::node::driveCommandFromTwist(twist, cmd, why), cmd, why);
  }

  void onCmdDrive(VehicleIo& v, const avsp_msgs::DriveCommand& msg)
  {
    avsp_msgs::DriveCommand cmd = msg;
    std::string why;
    // Even a rejected command answers the barrier: the last good one then stays in force.
    v.answered = std::max(v.answered, msg.header.stamp.toSec());
    accept(v, v.drive_topic, ad::node::sanitizeDriveCommand(cmd, why), cmd, why);
  }

  /// A command from either topic after the core's command rule (checkCommand(): NaN/inf
  /// rejected, the rest clamped; an unknown gear rejected). A rejected one leaves the last good
  /// command in force, ageing towards the timeout. Message stamps are not trusted for the
  /// timeout (publishers' clocks differ): a command counts from the step that takes it.
  void accept(VehicleIo& v, const std::string& topic, ad::CommandCheck check, const avsp_msgs::DriveCommand& cmd,
              const std::string& why)
  {
    ++v.commands;
    if (check == ad::CommandCheck::kRejected)
    {
      ++v.refused;
      ROS_WARN_THROTTLE(2.0, "dynamics_node: %s rejected: %s", topic.c_str(), why.c_str());
      return;
    }
    if (check == ad::CommandCheck::kClamped)
    {
      ++v.clamped;
      ROS_WARN_THROTTLE(2.0, "dynamics_node: %s clamped: %s", topic.c_str(), why.c_str());
    }
    if (v.pending)
      ++v.superseded;
    v.pending = ad::node::toDriveCommand(cmd);
  }

  /// One physics step: commands in (with the timeout on world time), step, publications out.
  void step()
  {
    const double now = world_->time();
    for (auto& v : vehicles_)
    {
      if (v->pending)
      {
        v->last = v->pending;
        v->last_time = now;
        v->pending.reset();
      }
      ad::DriveCommand cmd{ 0.0, 1.0, 0.0 };  // none yet, or stale: zero throttle, full brake
      if (v->last && now - v->last_time <= command_timeout_)
        cmd = *v->last;
      else if (v->last)
        cmd.steering = v->last->steering;  // the steering stays where it was
      // Parking brake: full brake until the first command that asks for throttle, so a stack
      // whose first commands are zeros (throttle 0, brake 0: coast) does not let the vehicle
      // roll away before it has a plan.
      if (hold_until_throttle_ && !v->released)
      {
        if (cmd.throttle > 0.0)
          v->released = true;
        else
          cmd.brake = 1.0;
      }
      world_->setCommand(v->id, cmd);
    }
    try
    {
      world_->step();
    }
    catch (const std::exception& e)  // e.g. the DEM contact mode's, which names the key and the wheel
    {
      fatal(std::string("the physics step at t = ") + std::to_string(world_->time()) + " s: " + e.what());
      return;
    }
    // A contact that produced a non-finite force was clamped out of the step; the World names
    // the vehicle and wheel once.
    for (const std::string& w : world_->takeWarnings())
      ROS_WARN("dynamics_node: %s", w.c_str());
    const double h = world_->options().step;
    for (auto& v : vehicles_)
    {
      const ad::VehicleState& s = world_->state(v->id);
      v->stuck.update(v->model, s, world_->time());
      v->wheel_odom.step(ad::runningGearSpeed(v->model, s), ad::bodyYawRate(s), h);
      v->collisions.update(s, world_->time());  // every step: a short impact is not missed
      for (std::size_t w = 0; w < s.wheels.size(); ++w)
      {
        v->spin_angle[w] = std::remainder(v->spin_angle[w] + s.wheels[w].spin_rate * h, 2.0 * M_PI);
        if (s.wheels[w].in_contact && ruts_every_ > 0)
          coverWheel(*v, s.pose * v->model.wheels[w].rest_position);
      }
      if (v->dem)
        demProgress(*v, s);
      for (std::size_t t = 0; t < s.tracks.size() && ruts_every_ > 0; ++t)
        for (std::size_t k = 0; k < s.tracks[t].segments.size(); ++k)
          if (s.tracks[t].segments[k].in_contact)
            coverWheel(*v, s.pose * v->model.tracks[t].road_wheels[k].rest_position);
    }
    const std::uint64_t n = world_->stepCount();
    if (n % odom_every_ == 0)
    {
      publishStates();
      publishToppled();
    }
    if (ruts_every_ > 0 && n % ruts_every_ == 0 && ruts_pub_.getNumSubscribers() > 0)
      publishRuts();
  }

  /// A DEM vehicle's patches wrote soil back behind it: the segment across its wheels goes out
  /// with the next ruts; the crossing's figures are logged once when it is over.
  void demProgress(VehicleIo& v, const ad::VehicleState& s)
  {
    const ad::dem::DemSoilReport& r = v.dem->report();
    const int moves = r.relocations + (r.crossed ? 1 : 0);
    if (moves != v.dem_moves && ruts_every_ > 0)
    {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const ad::WheelSpec& w : v.model.wheels)
      {
        const double y = (s.pose * w.rest_position).y();
        lo = std::min(lo, y);
        hi = std::max(hi, y);
      }
      const double half = 0.5 * v.dem->bed().width();
      coverWheel(v, Eigen::Vector3d(dem_spec_->segment.x_min, lo - half, 0.0));
      coverWheel(v, Eigen::Vector3d(dem_spec_->segment.x_max, hi + half, 0.0));
    }
    v.dem_moves = moves;
    if (r.crossed && !v.dem_reported)
    {
      v.dem_reported = true;
      avsp_msgs::DemCrossing m;
      m.header.stamp = stamp();
      m.header.frame_id = "map";
      m.vehicle = v.name;
      m.entered = r.entered;
      m.left = r.left;
      m.patch_moves = r.relocations;
      m.peak_particles = static_cast<std::uint32_t>(r.peak_particles);
      m.coupling_intervals = r.coupling_intervals;
      m.mean_sinkage = r.mean_sinkage;
      m.max_sinkage = r.max_sinkage;
      m.mean_slip = r.mean_slip;
      m.energy = r.energy;
      m.points_written = r.points_written;
      v.dem_pub.publish(m);
      ROS_INFO(
          "dynamics_node: vehicle '%s' crossed the DEM segment (t %.3f..%.3f s): %d patch moves, peak %zu "
          "particles, sinkage mean %.4f max %.4f m, slip mean %.3f, %.1f J into the soil",
          v.name.c_str(), r.entered, r.left, r.relocations, r.peak_particles, r.mean_sinkage, r.max_sinkage,
          r.mean_slip, r.energy);
    }
  }

  void coverWheel(VehicleIo& v, const Eigen::Vector3d& c)
  {
    if (!v.ran)
    {
      v.min_x = v.max_x = c.x();
      v.min_y = v.max_y = c.y();
      v.ran = true;
      return;
    }
    v.min_x = std::min(v.min_x, c.x());
    v.max_x = std::max(v.max_x, c.x());
    v.min_y = std::min(v.min_y, c.y());
    v.max_y = std::max(v.max_y, c.y());
  }

  /// The sim time of the last step: world time, offset by the external clock's value when the
  /// node started following it (so a catch-up burst of steps still gets distinct stamps).
  ros::Time stamp() const
  {
    if (publish_clock_ || !follow_start_)
      return ros::Time(world_->time());
    return *follow_start_ + ros::Duration(world_->time());
  }

  void publishClock()
  {
    rosgraph_msgs::Clock c;
    c.clock = ros::Time(world_->time());
    clock_published_ = world_->time();
    clock_pub_.publish(c);
  }

  /// With ~per_vehicle_odom_frames and ~publish_odom_tf: map -> <v>/odom, the identity, latched
  /// once for every vehicle (the simulator knows ground truth, as world_frames.launch's map ->
  /// odom says for the shared frame). Without ~publish_odom_tf the localisation stack that owns
  /// <v>/odom -> <v>/base_link owns map -> <v>/odom too.
  void publishOdomFrames()
  {
    if (!per_vehicle_odom_frames_ || !publish_odom_tf_)
      return;
    std::vector<geometry_msgs::TransformStamped> frames;
    for (const auto& v : vehicles_)
    {
      geometry_msgs::TransformStamped t;
      t.header.stamp = ros::Time(0);
      t.header.frame_id = "map";
      t.child_frame_id = v->odom_frame;
      t.transform.rotation.w = 1.0;
      frames.push_back(t);
    }
    if (!static_tf_)
      static_tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    static_tf_->sendTransform(frames);  // by child frame: a vehicle spawned later adds its own
  }

  void publishStates()
  {
    const ros::Time t = stamp();
    for (std::size_t k = 0; k < vehicles_.size(); ++k)
    {
      VehicleIo* v = vehicles_[k].get();
      const ad::VehicleState& s = world_->state(v->id);
      nav_msgs::Odometry odom;
      odom.header.stamp = t;
      odom.header.frame_id = v->odom_frame;  // identity child of map: the simulator knows ground truth
      odom.child_frame_id = v->name + "/base_link";
      odom.pose.pose = toPose(s.pose);
      odom.twist.twist.linear = toVector3(s.body_velocity);
      odom.twist.twist.angular = toVector3(s.pose.linear().transpose() * s.angular_velocity);
      v->odom_pub.publish(odom);
      v->last_odom = odom;
      if (v->truth_pub.getNumSubscribers() > 0)
        v->truth_pub.publish(odom);
      if (v->wheel_odom_pub.getNumSubscribers() > 0)
        v->wheel_odom_pub.publish(wheelOdometry(*v, s, t));

      geometry_msgs::TransformStamped& tf = transforms_[k];
      tf.header = odom.header;
      tf.child_frame_id = odom.child_frame_id;
      tf.transform.translation.x = odom.pose.pose.position.x;
      tf.transform.translation.y = odom.pose.pose.position.y;
      tf.transform.translation.z = odom.pose.pose.position.z;
      tf.transform.rotation = odom.pose.pose.orientation;

      if (v->joint_pub.getNumSubscribers() > 0)
        publishJoints(*v, s, t);
      if (v->telemetry_pub.getNumSubscribers() > 0)
        publishTelemetry(*v, s, t);
    }
    if (publish_odom_tf_)
      tf_.sendTransform(transforms_);
    rtf_.add(world_->time(), ros::WallTime::now().toSec());
    diagnostics_->update();
  }

  // ---- /diagnostics (diagnostic_updater) ---------------------------------------------------
  // Published every ~diagnostic_period of sim time, checked at every odometry publication:
  // "<node>: simulation" (sim time, the real-time factor achieved over the last 5 s of wall
  // time, behind an external clock) and "<node>: <vehicle>" (stuck, commands refused).

  void setUpDiagnostics()
  {
    // Validated here; diagnostic_updater reads the same parameter itself.
    boundedParam(pnh_, "diagnostic_period", 1.0, 0.01, 3600.0);
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_);
    diagnostics_->setHardwareID(ros::this_node::getName());
    diagnostics_->add("simulation", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { simulationStatus(s); });
    for (const auto& v : vehicles_)
    {
      VehicleIo* raw = v.get();
      diagnostics_->add(v->name,
                        [this, raw](diagnostic_updater::DiagnosticStatusWrapper& s) { vehicleStatus(*raw, s); });
    }
  }

  void simulationStatus(diagnostic_updater::DiagnosticStatusWrapper& s) const
  {
    const std::optional<double> rtf = rtf_.factor();
    s.add("sim time (s)", world_->time());
    s.add("steps", world_->stepCount());
    s.add("real-time factor", rtf ? *rtf : 0.0);
    s.add("real-time factor window (wall s)", rtf_.span());
    s.add("real-time factor target", real_time_factor_);  // 0: as fast as it can
    s.add("paused", paused_);
    if (pacer_)
    {
      s.add("pace restarts", pacer_->restarts());  // the host fell > 0.1 s behind the pace
      s.add("pace given up (wall s)", pacer_->lost());
    }
    if (!publish_clock_)
      s.add("behind /clock (s)", (ros::Time::now() - stamp()).toSec());
    if (followers_)
    {
      // Who holds the clock back: each follower's lag behind the world and the wall time the
      // clock waited for it (the slowest node is the one with the most).
      for (const std::string& n : followers_->names())
      {
        const double r = followers_->reached(n);
        s.add("follower " + n + " behind (s)", std::isfinite(r) ? world_->time() - r : world_->time());
        s.add("clock waited for " + n + " (wall s)", follower_waited_.at(n));
      }
    }
    if (real_time_factor_ > 0.0 && rtf && *rtf < kRealTimeFactorShare * real_time_factor_)
      s.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "running at %.2fx, below %.0f %% of the target %.2fx", *rtf,
                 100.0 * kRealTimeFactorShare, real_time_factor_);
    else if (rtf)
      s.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "running at %.2fx", *rtf);
    else
      s.summary(diagnostic_msgs::DiagnosticStatus::OK, "starting");
  }

  void vehicleStatus(VehicleIo& v, diagnostic_updater::DiagnosticStatusWrapper& s)
  {
    const double now = world_->time();
    s.add("stuck", v.stuck.stuck());
    s.add("stuck for (s)", v.stuck.heldFor(now));
    s.add("collisions", v.collisions.count());
    s.add("commands received", v.commands);
    s.add("commands refused", v.refused);
    s.add("commands clamped", v.clamped);
    s.add("commands superseded", v.superseded);
    s.add("command age (s)", v.last ? now - v.last_time : std::numeric_limits<double>::infinity());
    s.add("parking brake", hold_until_throttle_ && !v.released);
    const std::uint64_t new_refused = v.refused - v.refused_reported;
    v.refused_reported = v.refused;
    if (v.stuck.stuck())
      s.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "stuck for %.1f s", v.stuck.heldFor(now));
    else if (new_refused > 0)
      s.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%llu command(s) refused since the last report",
                 static_cast<unsigned long long>(new_refused));
    else if (!v.last)
      s.summary(diagnostic_msgs::DiagnosticStatus::OK, "braked: no command yet");
    else if (now - v.last_time > command_timeout_)
      s.summary(diagnostic_msgs::DiagnosticStatus::OK, "braked: the last command is stale");
    else
      s.summary(diagnostic_msgs::DiagnosticStatus::OK, "commanded");
  }

  /// `<v>/wheel_odometry`: the dead reckoning in `odom` (from the start pose), its twist the
  /// running gear's speed and the gyro's yaw rate; covariances of WheelOdometryCovariance.
  nav_msgs::Odometry wheelOdometry(const VehicleIo& v, const ad::VehicleState& s, const ros::Time& t) const
  {
    using C = ad::WheelOdometryCovariance;
    nav_msgs::Odometry o;
    o.header.stamp = t;
    o.header.frame_id = v.odom_frame;
    o.child_frame_id = v.name + "/base_link";
    o.pose.pose = toPose(v.wheel_odom.pose());
    const double speed = ad::runningGearSpeed(v.model, s);
    o.twist.twist.linear.x = speed;
    o.twist.twist.angular.z = ad::bodyYawRate(s);
    auto sq = [](double x) { return x * x; };
    const double position = sq(C::kPositionShare * v.wheel_odom.distance()) + sq(C::kSpeedFloor);
    o.pose.covariance = {};
    o.pose.covariance[0] = o.pose.covariance[7] = position;
    o.pose.covariance[14] = o.pose.covariance[21] = o.pose.covariance[28] = C::kUnmeasured;
    o.pose.covariance[35] = sq(C::kHeadingShare * v.wheel_odom.turned()) + sq(C::kYawRate);
    o.twist.covariance = {};
    o.twist.covariance[0] = sq(C::kSpeedShare * std::abs(speed) + C::kSpeedFloor);
    o.twist.covariance[7] = sq(C::kLateralSpeed);
    o.twist.covariance[14] = o.twist.covariance[21] = o.twist.covariance[28] = C::kUnmeasured;
    o.twist.covariance[35] = sq(C::kYawRate);
    return o;
  }

  /// URDF joint names (robot_state_publisher in the vehicle's namespace prefixes frames), in
  /// the order jointNames() gave them.
  void publishJoints(VehicleIo& v, const ad::VehicleState& s, const ros::Time& t)
  {
    sensor_msgs::JointState& js = v.joints;
    js.header.stamp = t;
    std::size_t k = 0;
    for (std::size_t w = 0; w < v.model.wheels.size(); ++w)
    {
      const ad::WheelState& ws = s.wheels[w];
      js.position[k] = v.spin_angle[w];
      js.velocity[k++] = ws.spin_rate;
      js.position[k++] = ws.suspension_deflection;
      if (!v.model.wheels[w].steering_joint.empty())
        js.position[k++] = ws.steering_angle;
    }
    for (const ad::TrackState& t : s.tracks)
    {
      js.position[k] = t.sprocket_angle;
      js.velocity[k++] = t.sprocket_speed;
      js.position[k] = t.idler_angle;
      js.velocity[k++] = t.idler_speed;
      for (const ad::RoadWheelState& w : t.road_wheels)
      {
        js.position[k] = w.arm_angle;
        js.velocity[k++] = w.arm_rate;
        js.position[k] = w.spin_angle;
        js.velocity[k++] = w.spin_rate;
      }
    }
    v.joint_pub.publish(js);
  }

  /// The soil at the grid point nearest `p` (map), "" off the grid.
  std::string soilUnder(const Eigen::Vector3d& p) const
  {
    const at::ElevationGrid& g = terrain_->base();
    const double fi = std::round((p.x() - g.originX()) / g.dx());
    const double fj = std::round((p.y() - g.originY()) / g.dy());
    if (fi >= 0 && fj >= 0 && fi < g.columns() && fj < g.rows())
      return terrain_->soil(static_cast<std::size_t>(fi), static_cast<std::size_t>(fj)).name;
    return "";
  }

  void publishTelemetry(VehicleIo& v, const ad::VehicleState& s, const ros::Time& t)
  {
    avsp_msgs::VehicleTelemetry tm;
    tm.header.stamp = t;
    tm.header.frame_id = v.name + "/base_link";
    tm.vehicle_id = v.name;
    tm.command.header.stamp = t;
    tm.command.throttle = s.command.throttle;
    tm.command.brake = s.command.brake;
    tm.command.steering = s.command.steering;
    // Per wheel, or per track segment (the patch under each road wheel), in the model's order.
    auto add = [&](const std::string& name, const auto& c, const Eigen::Vector3d& rest, bool driven) {
      avsp_msgs::WheelContact m;
      m.name = name;
      m.driven = driven;
      m.normal_force = c.normal_force;
      m.sinkage = c.sinkage;
      m.slip = c.slip;
      m.slip_angle = c.slip_angle;
      m.traction_force = c.traction_force;
      m.resistance_force = c.resistance_force;
      m.soil = soilUnder(s.pose * rest);
      tm.contacts.push_back(m);
    };
    for (std::size_t w = 0; w < v.model.wheels.size(); ++w)
      add(v.model.wheels[w].link, s.wheels[w], v.model.wheels[w].rest_position, v.model.wheels[w].driven);
    for (std::size_t k = 0; k < s.tracks.size(); ++k)
      for (std::size_t w = 0; w < s.tracks[k].segments.size(); ++w)
        add(s.tracks[k].segments[w].name, s.tracks[k].segments[w], v.model.tracks[k].road_wheels[w].rest_position,
            true);  // a track is driven as a whole by its sprocket
    tm.stuck = v.stuck.stuck();
    tm.collisions = v.collisions.count();
    v.telemetry_pub.publish(tm);
  }

  /// Objects the vehicles pushed over since the last call, once each, in id order; the vehicle
  /// named is the one nearest the object (the collision does not say who pushed).
  void publishToppled()
  {
    for (std::uint32_t id : ad::takeToppled(objects_, standing_))
    {
      const at::TerrainObject& o = objects_.get(id);
      avsp_msgs::ObjectToppled msg;
      msg.header.stamp = stamp();
      msg.header.frame_id = "map";
      msg.id = o.id;
      msg.fall_direction = o.fall_direction;
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& v : vehicles_)
      {
        const double d = (world_->state(v->id).pose.translation().head<2>() - Eigen::Vector2d(o.x, o.y)).norm();
        if (d < nearest)
        {
          nearest = d;
          msg.vehicle = v->name;
        }
      }
      toppled_pub_.publish(msg);
      ROS_INFO("dynamics_node: %s toppled object %u at (%.1f, %.1f)", msg.vehicle.c_str(), o.id, o.x, o.y);
    }
  }

  /// The grid points under each vehicle's wheels since the last call, as one TerrainPatch per
  /// vehicle: the bounding box of the wheel centres widened by a wheel's radius and width plus
  /// two cells (flowed soil lands on the neighbours of a contact).
  void publishRuts()
  {
    const at::ElevationGrid& g = terrain_->base();
    for (auto& v : vehicles_)
    {
      if (!v->ran)
        continue;
      v->ran = false;
      const double margin = v->rut_margin + 2.0 * g.dx();
      auto index = [](double value, double origin, double d, std::size_t n) {
        const double f = std::floor((value - origin) / d);
        return static_cast<std::size_t>(std::clamp(f, 0.0, static_cast<double>(n - 1)));
      };
      at::PointRange r;
      r.i0 = index(v->min_x - margin, g.originX(), g.dx(), g.columns());
      r.i1 = index(v->max_x + margin + g.dx(), g.originX(), g.dx(), g.columns());
      r.j0 = index(v->min_y - margin, g.originY(), g.dy(), g.rows());
      r.j1 = index(v->max_y + margin + g.dy(), g.originY(), g.dy(), g.rows());
      if (r.i1 <= r.i0 || r.j1 <= r.j0)
        continue;
      std_msgs::Header header;
      header.stamp = stamp();
      header.frame_id = "map";
      ruts_pub_.publish(at::node::toTerrainPatch(at::extractPatch(*terrain_, r), header));
    }
    // The instant's end-of-patches marker (TerrainPatch.msg): sensors_node ~ruts_period waits
    // for it, so a rut reaches the same sweep in every run.
    std_msgs::Header header;
    header.stamp = stamp();
    header.frame_id = "map";
    ruts_pub_.publish(at::node::endOfInstantMarker(header, g.dx()));
  }

  ros::NodeHandle& nh_;
  ros::NodeHandle& pnh_;
  std::unique_ptr<at::SoilLibrary> soils_;
  std::unique_ptr<at::DeformableTerrain> terrain_;  // declared before world_: outlives it
  at::ObjectSet objects_;                           // the terrain's objects (the world collides with them)
  std::vector<std::uint32_t> standing_;             ///< toppleable objects not yet reported fallen
  std::unique_ptr<ad::World> world_;
  std::vector<std::unique_ptr<VehicleIo>> vehicles_;
  std::vector<geometry_msgs::TransformStamped> transforms_;  ///< odom -> base_link per vehicle
  std::string source_;
  double command_timeout_ = 0.5;
  bool hold_until_throttle_ = true;                ///< ~hold_until_throttle: the parking brake
  std::set<std::string> dem_vehicles_;             ///< ~dem_vehicles
  std::optional<ad::dem::DemSoilSpec> dem_spec_;   ///< ~dem, when ~dem_vehicles names any
  std::unique_ptr<ad::dem::BedTemplate> dem_bed_;  ///< settled at start-up from dem_spec_
  double real_time_factor_ = 0.0;
  bool publish_clock_ = true;
  bool publish_odom_tf_ = true;           ///< ~publish_odom_tf: broadcast odom -> <v>/base_link
  bool per_vehicle_odom_frames_ = false;  ///< ~per_vehicle_odom_frames: <v>/odom instead of odom
  bool wait_for_command_ = false;
  std::string start_topic_;       ///< ~start_topic: physics waits for a message there ("" = no wait)
  bool start_signalled_ = false;  ///< a message came on ~start_topic
  ros::Subscriber start_sub_;
  std::uint64_t lockstep_every_ = 0;  ///< steps between barriers (0: no lockstep)
  std::string partition_;             ///< this process's partition name ("" = the only one)
  double sync_interval_ = 0.01;       ///< s, lockstep_clock's interval: the peers exchange at its multiples
  std::optional<double> tick_;        ///< latest /clock tick (partition), s
  bool tick_repeated_ = false;        ///< the clock re-sent a tick already reached
  ros::Publisher done_pub_;
  ros::Subscriber tick_sub_;
  std::optional<ad::ClockFollowers> followers_;    ///< ~clock_followers (none: the clock runs free)
  std::map<std::string, double> follower_waited_;  ///< wall s the clock waited for each follower
  ros::Subscriber followers_sub_;
  double clock_published_ = 0.0;                                ///< s, the last time sent on /clock
  bool paused_ = false;                                         ///< ~pause came (and no ~resume since)
  std::uint64_t pending_steps_ = 0;                             ///< ~step's steps not yet taken
  static constexpr std::uint64_t kMaxPendingSteps = 100000000;  ///< 1e8 (a day at 1 ms)
  ros::ServiceServer pause_srv_, resume_srv_, step_srv_, set_pose_srv_, spawn_srv_, remove_srv_;
  // With ~peers: the exchanges' transport and the protocol (declared after world_, objects_ and
  // the transport they refer to: destroyed before them).
  std::unique_ptr<RosExchangeTransport> transport_;
  std::unique_ptr<ad::PartitionRunner> runner_;
  bool failed_ = false;  ///< a fatal error stopped the run (exit 1; a plain shutdown exits 0)
  std::string config_dir_;
  double lockstep_timeout_ = 30.0;         ///< s, wall
  std::vector<std::string> sensor_nodes_;  ///< ~sensor_nodes, resolved: told of spawned and removed vehicles
  std::map<std::string, std::set<std::string>> awaiting_;  ///< spawned vehicle -> sensors_nodes not yet subscribed
  std::optional<ros::Time> follow_start_;                  ///< external clock when following began
  std::uint64_t odom_every_ = 10, clock_every_ = 2, ruts_every_ = 500;
  ros::Publisher toppled_pub_, ruts_pub_, clock_pub_;
  tf2_ros::TransformBroadcaster tf_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_tf_;  ///< map -> <v>/odom
  /// Wall s behind the ~real_time_factor pace after which the pace restarts (ad::Pacer).
  static constexpr double kPaceMaxLag = 0.1;
  std::optional<ad::Pacer> pacer_;  ///< with ~real_time_factor > 0 and ~publish_clock
  /// Below this share of ~real_time_factor the simulation status is a warning.
  static constexpr double kRealTimeFactorShare = 0.9;
  ad::RealTimeFactorWindow rtf_{ 5.0 };  ///< sim over wall time, the last 5 s of wall time
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
};

DynamicsNode::DynamicsNode(ros::NodeHandle& nh, ros::NodeHandle& pnh) : impl_(std::make_unique<Impl>(nh, pnh))
{
}

DynamicsNode::~DynamicsNode() = default;

int DynamicsNode::spin()
{
  impl_->run();
  return impl_->failed() ? 1 : 0;
}

}  // namespace node
}  // namespace dynamics
}  // namespace avsp
