#include "avsp/scenario/launch_generator.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "avsp_terrain/rosparam_yaml.hpp"
#include "avsp_terrain/run_numbers.hpp"

namespace avsp
{
namespace scenario
{
namespace
{
/// s: lockstep_clock's interval with partitions (each partition's exchange period).
constexpr double kSyncInterval = 0.01;
/// lockstep_clock's name for sensors_node (scenario partitions may not use it).
const std::string kSensorsPartition = "sensors";
/// start_gate's ~open (node start_gate at the root): dynamics_node's ~start_topic.
const std::string kStartGateTopic = "/start_gate/open";
/// s: how far /clock may run ahead of sensors_node (dynamics_node ~follower_lag; lockstep_clock's
/// lookahead of 5 intervals with partitions).
constexpr double kSensorLag = 0.05;
/// s: environment_node's period (10 Hz, a lidar sweep): sensors_node senses a time only once the
/// /environment of its last multiple has come, so a weather change at t reaches the first sweep
/// after t in every run.
constexpr double kEnvironmentPeriod = 0.1;
/// s: dynamics_node's rut instants (its ~ruts_rate 2 Hz); sensors_node waits for each one's
/// end-of-patches marker (single process; partitions' markers are not waited for).
constexpr double kRutsPeriod = 0.5;
/// s (wall): a partition or peer silent this long stops the run.
constexpr double kPartitionTimeout = 30.0;
/// s: the controllers' period (20 Hz), the dynamics' barrier and the radio's batches.
constexpr double kLockstepPeriod = 0.05;

std::string xmlEscape(const std::string& s)
{
  std::string out;
  for (char c : s)
    switch (c)
    {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  return out;
}

std::string quoted(const std::string& s)
{
  std::string out = "\"";
  for (char c : s)
  {
    if (c == '"' || c == '\\')
      out += '\\';
    if (c == '\n')
    {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

/// A node's opening tag and its private parameters, written line by line. Every node clears its
/// private namespace first (clear_params): on a master that ran another scenario, what that run
/// set (another vehicle's ~vehicle_sensors, its ~agents) would otherwise be read as this run's.
class NodeWriter
{
public:
  NodeWriter(std::ostream& out, std::string indent) : out_(out), indent_(std::move(indent)) {}

  void open(const std::string& pkg, const std::string& type, const std::string& name, bool required = false,
            const std::string& extra = "")
  {
    out_ << indent_ << "<node pkg=\"" << pkg << "\" type=\"" << type << "\" name=\"" << name << "\""
         << " clear_params=\"true\"" << (required ? " required=\"true\"" : "") << extra << ">\n";
  }
  void close() { out_ << indent_ << "</node>\n"; }

  void param(const std::string& name, const std::string& value, const std::string& type = "str")
  {
    out_ << indent_ << "  <param name=\"" << name << "\" type=\"" << type << "\" value=\"" << xmlEscape(value)
         << "\"/>\n";
  }
  void param(const std::string& name, double value) { param(name, yamlDouble(value), "double"); }
  void paramInt(const std::string& name, long long value) { param(name, std::to_string(value), "int"); }
  void paramBool(const std::string& name, bool value) { param(name, value ? "true" : "false", "bool"); }
  void params(const std::vector<NodeParam>& ps)
  {
    for (const NodeParam& p : ps)
      param(p.name, p.value, p.type);
  }
  void rosparam(const std::string& name, const std::string& flow_yaml)
  {
    out_ << indent_ << "  <rosparam param=\"" << name << "\">" << xmlEscape(flow_yaml) << "</rosparam>\n";
  }

private:
  std::ostream& out_;
  std::string indent_;
};

/// ["a", "b"]: a YAML flow list of strings.
std::string flowList(const std::vector<std::string>& items)
{
  std::string out = "[";
  for (std::size_t i = 0; i < items.size(); ++i)
    out += (i ? ", " : "") + quoted(items[i]);
  return out + "]";
}

std::string vehicleListYaml(const Scenario& s)
{
  std::ostringstream o;
  o << "[";
  for (std::size_t i = 0; i < s.vehicles.size(); ++i)
  {
    const VehicleSpec& v = s.vehicles[i];
    o << (i ? ", " : "") << "{name: " << quoted(v.name) << ", model: " << quoted(v.model) << ", x: " << yamlDouble(v.x)
      << ", y: " << yamlDouble(v.y) << ", yaw: " << yamlDouble(v.yaw) << "}";
  }
  return o.str() + "]";
}

std::string leader(const VehicleSpec& v)
{
  return v.controller.type == ControllerType::kLeaderFollower ? v.controller.leader : std::string();
}

}  // namespace

namespace
{
/// "<what>: must be in [min, max] <unit>", for a number outside its run_numbers.hpp range.
std::string rangeMessage(const std::string& what, const terrain::RunNumber& n)
{
  return what + ": must be in [" + terrain::rosparamDouble(n.min) + ", " + terrain::rosparamDouble(n.max) + "]" +
         (*n.unit ? std::string(" ") + n.unit : std::string());
}
}  // namespace

std::string yamlDouble(double v)
{
  return terrain::rosparamDouble(v);
}

std::string flowYaml(const YAML::Node& node, bool force_double)
{
  return terrain::rosparamFlow(node, force_double);
}

namespace
{
/// What every section of the generated launch file reads: the scenario, the options and what
/// generateLaunch derived from them once.
struct LaunchInputs
{
  const Scenario& s;
  const LaunchOptions& options;
  std::vector<NodeParam> terrain;  ///< terrain_node's source parameters, shared by every node that loads it
  std::string vehicles;            ///< the ~vehicles list of every vehicle
  bool has_agents = false;
  std::string agents;  ///< the ~agents list (flow YAML) when there are agents
  double duration = 0.0;
};

/// The dynamics: one dynamics_node for every vehicle, which is the clock; or, with partitions,
/// the machines, lockstep_clock and one dynamics_node per partition, each seeing the others' vehicles.
void writeDynamics(std::ostream& o, const LaunchInputs& in)
{
  const Scenario& s = in.s;
  const LaunchOptions& options = in.options;
  const std::vector<NodeParam>& terrain = in.terrain;
  const bool has_agents = in.has_agents;
  const std::string& agents = in.agents;
  NodeWriter w(o, "  ");
  for (const MachineSpec& m : s.machines)
    o << "  <machine name=\"" << xmlEscape(m.name) << "\" address=\"" << xmlEscape(m.address) << "\" env-loader=\""
      << xmlEscape(m.env_loader) << "\"" << (m.user.empty() ? "" : " user=\"" + xmlEscape(m.user) + "\"") << "/>\n";
  if (!s.partitions.empty())
  {
    std::string list;
    for (const PartitionSpec& p : s.partitions)
      list += (list.empty() ? "" : ", ") + quoted(p.name);
    list += ", " + quoted(kSensorsPartition);  // the sensors hold the clock too
    // Not required: run_recorder watches it, and names it when it dies (roslaunch would not).
    w.open("avsp_dynamics", "lockstep_clock", "clock");
    w.rosparam("partitions", "[" + list + "]");
    w.param("sync_interval", kSyncInterval);
    w.param("real_time_factor", options.real_time_factor);
    w.param("timeout", kPartitionTimeout);
    w.close();
  }
  auto dynamics = [&](const std::string& node_name, const std::vector<std::string>& members, const PartitionSpec* p) {
    Scenario part;  // the members' specs, for the vehicle list
    for (const std::string& name : members)
      part.vehicles.push_back(s.vehicles[static_cast<std::size_t>(s.vehicleIndex(name))]);
    w.open("avsp_dynamics", "dynamics_node", node_name, false,
           p && !p->machine.empty() ? " machine=\"" + xmlEscape(p->machine) + "\"" : std::string());
    w.rosparam("vehicles", vehicleListYaml(part));
    w.param("config_dir", options.vehicles_dir);
    w.params(terrain);
    w.paramInt("seed", static_cast<long long>(s.seed));
    if (p)
    {
      w.param("partition", p->name);
      std::string peers;
      for (const PartitionSpec& q : s.partitions)
        if (q.name != p->name)
          peers += (peers.empty() ? "" : ", ") + quoted(q.name);
      w.rosparam("peers", "[" + peers + "]");
      w.paramBool("publish_clock", false);
      w.param("lockstep_timeout", kPartitionTimeout);
      w.rosparam("sensor_nodes", "[" + quoted(kSensorsPartition) + "]");  // a vehicle spawned here is sensed
    }
    else
    {
      w.param("real_time_factor", options.real_time_factor);
      w.param("clock_rate", options.clock_rate);
      w.param("ruts_rate", 1.0 / kRutsPeriod);
      // The sensors hold the clock: it never runs more than kSensorLag ahead of them.
      w.rosparam("clock_followers", "[" + quoted(kSensorsPartition) + "]");
      // A vehicle spawned at run time gets the run's default sensors from sensors_node (its
      // node name is the lockstep name).
      w.rosparam("sensor_nodes", "[" + quoted(kSensorsPartition) + "]");
      w.param("follower_lag", kSensorLag);
      w.param("lockstep_timeout", kPartitionTimeout);
    }
    // The start gate opens once all nodes are up: the physics starts then, so every node sees
    // the run from sim time 0. Until their first commands the vehicles stand braked.
    if (options.start_gate)
      w.param("start_topic", kStartGateTopic);
    // Lockstep: every 50 ms of sim time the physics waits for each controlled vehicle's command
    // for that instant (controller_node ~lockstep), and each follower for its radio's batch, so a
    // run does not depend on how fast the processes are scheduled.
    std::string names;
    for (const VehicleSpec& v : part.vehicles)
      if (v.controller.type != ControllerType::kExternal)
        names += (names.empty() ? "" : ", ") + quoted(v.name);
    if (!names.empty())
    {
      w.rosparam("lockstep_vehicles", "[" + names + "]");
      w.param("lockstep_period", kLockstepPeriod);
    }
    // terramechanics dem: those vehicles' wheels on the DEM moving patch (one dynamics_node).
    std::string dem_names;
    for (const VehicleSpec& v : part.vehicles)
      if (v.dem)
        dem_names += (dem_names.empty() ? "" : ", ") + quoted(v.name);
    if (!dem_names.empty())
    {
      w.rosparam("dem_vehicles", "[" + dem_names + "]");
      w.param("dem", s.dem);
    }
    if (has_agents)
      w.rosparam("agents", agents);
    w.close();
  };
  if (s.partitions.empty())
  {
    std::vector<std::string> all;
    for (const VehicleSpec& v : s.vehicles)
      all.push_back(v.name);
    dynamics("dynamics", all, nullptr);
  }
  else
    for (const PartitionSpec& p : s.partitions)
      dynamics("dynamics_" + p.name, p.vehicles, &p);
}

/// One sensors_node for every vehicle.
void writeSensors(std::ostream& o, const LaunchInputs& in)
{
  const Scenario& s = in.s;
  const LaunchOptions& options = in.options;
  const std::vector<NodeParam>& terrain = in.terrain;
  const std::string& vehicles = in.vehicles;
  const bool has_agents = in.has_agents;
  const std::string& agents = in.agents;
  NodeWriter w(o, "  ");
  w.open("avsp_sensors", "sensors_node", "sensors");
  w.rosparam("vehicles", vehicles);
  w.param("config_dir", options.vehicles_dir);
  w.params(terrain);
  w.param("output_dir", options.output_dir);  // where <v>/save_map writes
  w.param("latitude", s.latitude);
  w.param("longitude", s.longitude);
  w.param("altitude", s.altitude);
  // The magnetometer's World Magnetic Model is evaluated on the run's date (start_utc is checked
  // by parseRunStartUtc, so its first ten characters are YYYY-MM-DD).
  w.param("date", s.start_utc.substr(0, 10));
  w.paramInt("seed", static_cast<long long>(s.seed));
  if (s.sensors.IsDefined() && !s.sensors.IsNull())
    w.rosparam("sensors", flowYaml(s.sensors, false));
  for (const VehicleSpec& v : s.vehicles)
    if (v.sensors.IsDefined() && !v.sensors.IsNull())
      w.rosparam("vehicle_sensors/" + v.name, flowYaml(v.sensors, false));
  if (has_agents)
    w.rosparam("agents", agents);
  // In the lockstep in every run: the clock waits for the sensors (lockstep_clock with
  // partitions, dynamics_node's ~clock_followers without), and the sensors for /environment.
  w.param("lockstep_partition", kSensorsPartition);
  w.param("lockstep_interval", kSyncInterval);
  w.param("environment_period", kEnvironmentPeriod);
  if (s.partitions.empty())
    w.param("ruts_period", kRutsPeriod);  // a rut reaches the same sweep in every run
  w.close();
}

/// Sky and weather.
void writeEnvironment(std::ostream& o, const LaunchInputs& in)
{
  const Scenario& s = in.s;
  NodeWriter w(o, "  ");
  w.open("avsp", "environment_node", "environment");
  w.param("latitude", s.latitude);
  w.param("longitude", s.longitude);
  w.param("altitude", s.altitude);
  w.param("start_utc", s.start_utc);
  w.param("time_acceleration", s.time_acceleration);
  w.param("rate", 1.0 / kEnvironmentPeriod);
  if (s.weather.IsDefined() && !s.weather.IsNull() && s.weather.size() > 0)
    w.rosparam("weather", flowYaml(s.weather, true));
  w.close();
}

/// V2V radio between all vehicles.
void writeV2vRadio(std::ostream& o, const LaunchInputs& in)
{
  const Scenario& s = in.s;
  const std::vector<NodeParam>& terrain = in.terrain;
  NodeWriter w(o, "  ");
  w.open("avsp", "v2v_radio_node", "v2v_radio");
  {
    std::string names = "[";
    for (std::size_t i = 0; i < s.vehicles.size(); ++i)
      names += (i ? ", " : "") + quoted(s.vehicles[i].name);
    w.rosparam("vehicles", names + "]");
  }
  w.param("range", s.v2v.range);
  w.param("latency", s.v2v.latency);
  w.param("loss_probability", s.v2v.loss_probability);
  w.param("antenna_height", s.v2v.antenna_height);
  w.paramInt("seed", static_cast<long long>(s.seed));
  w.paramBool("line_of_sight", s.v2v.line_of_sight);
  w.param("lockstep_period", kLockstepPeriod);  // batches on v2v/in_lockstep for lockstep followers
  if (s.v2v.line_of_sight)
  {
    w.param("los_step", s.v2v.los_step);
    w.params(terrain);
  }
  w.close();
}

/// Per vehicle: description, V2V transmitter, controller.
void writeVehicleGroups(std::ostream& o, const LaunchInputs& in)
{
  const Scenario& s = in.s;
  const LaunchOptions& options = in.options;
  for (const VehicleSpec& v : s.vehicles)
  {
    o << "  <!-- " << xmlEscape(v.name) << " (" << xmlEscape(v.model) << "): " << toString(v.controller.type)
      << " -->\n"
      << "  <include file=\"$(find avsp)/launch/vehicle_description.launch\">\n"
      << "    <arg name=\"vehicle\" value=\"" << xmlEscape(v.name) << "\"/>\n"
      << "    <arg name=\"model\" value=\"" << xmlEscape(v.model) << "\"/>\n"
      << "    <arg name=\"parked\" value=\"false\"/>\n"
      << "  </include>\n"
      << "  <group ns=\"" << xmlEscape(v.name) << "\">\n";
    NodeWriter g(o, "    ");
    g.open("avsp", "v2v_broadcaster", "v2v_broadcaster");
    g.close();
    if (v.controller.type != ControllerType::kExternal)
    {
      g.open("avsp", "controller_node", "controller");
      for (const NodeParam& p : controllerNodeParams(s, v, options.vehicles_dir))
        if (p.type == "yaml")
          g.rosparam(p.name, p.value);
        else
          g.param(p.name, p.value, p.type);
      g.close();
    }
    o << "  </group>\n";
  }
  o << "\n";
}

/// The recorder ends the run: results/<scenario>/ when /clock reaches the duration. It watches
/// `run_nodes` besides the dynamics.
void writeRunRecorder(std::ostream& o, const LaunchInputs& in, const std::vector<std::string>& run_nodes)
{
  const Scenario& s = in.s;
  const LaunchOptions& options = in.options;
  const std::vector<NodeParam>& terrain = in.terrain;
  const double duration = in.duration;
  NodeWriter w(o, "  ");
  if (options.have_run_recorder)
  {
    w.open("avsp", "run_recorder", "run_recorder", true, " output=\"screen\"");
    {
      std::string list = "[";
      for (std::size_t i = 0; i < s.vehicles.size(); ++i)
      {
        const VehicleSpec& v = s.vehicles[i];
        list += std::string(i ? ", " : "") + "{name: " + quoted(v.name) + ", leader: " + quoted(leader(v));
        // What the model can do, for the recorder's anomaly counts.
        if (v.max_speed > 0.0 && v.wheel_radius > 0.0)
          list += ", max_speed: " + yamlDouble(v.max_speed) + ", rest_height: " + yamlDouble(v.rest_height) +
                  ", wheel_radius: " + yamlDouble(v.wheel_radius);
        list += "}";
      }
      w.rosparam("vehicles", list + "]");
    }
    w.param("output_dir", options.output_dir);
    w.param("scenario_name", s.name);
    w.param("duration", duration);
    w.param("real_time_factor", options.real_time_factor);  // the progress line shows it
    w.param("progress_period", options.progress_period);
    // A finished run ends its roslaunch with a SIGINT (no "REQUIRED process has died" banner).
    w.paramBool("end_launch", true);
    w.params(terrain);
    // Every node that must live for the whole run: if one exits, the recorder stops the run,
    // writes what it has and names the node (README, "Run recorder").
    std::vector<std::string> watch = { "/map_to_odom" };
    if (s.partitions.empty())
      watch.push_back("/dynamics");
    else
    {
      watch.push_back("/clock");
      for (const PartitionSpec& p : s.partitions)
        watch.push_back("/dynamics_" + p.name);
    }
    watch.insert(watch.end(), run_nodes.begin(), run_nodes.end());
    w.rosparam("watch", flowList(watch));
    w.close();
  }
  else
    o << "  <!-- run_recorder is not built: no results, and the run does not end by itself -->\n";
}

/// The start gate: releases the physics once every node of `run_nodes` (and the recorder) is up.
void writeStartGate(std::ostream& o, const LaunchInputs& in, const std::vector<std::string>& run_nodes)
{
  const LaunchOptions& options = in.options;
  NodeWriter w(o, "  ");
  if (options.start_gate)
  {
    // Releases the physics once every other node has advertised or subscribed something
    // (they do so after loading their terrain and parameters).
    std::vector<std::string> nodes = run_nodes;
    if (options.have_run_recorder)
      nodes.push_back("/run_recorder");
    w.open("avsp", "start_gate", "start_gate");
    w.rosparam("nodes", flowList(nodes));
    w.close();
  }
}

/// The nodes of the run besides the dynamics, the recorder and the gate: what start_gate waits
/// for and run_recorder watches.
std::vector<std::string> runNodes(const LaunchInputs& in)
{
  const Scenario& s = in.s;
  const LaunchOptions& options = in.options;
  const bool has_agents = in.has_agents;
  std::vector<std::string> run_nodes = { "/terrain", "/sensors", "/environment", "/v2v_radio" };
  if (has_agents && options.have_agents_node)
    run_nodes.push_back("/agents");
  for (const VehicleSpec& v : s.vehicles)
  {
    run_nodes.push_back("/" + v.name + "/v2v_broadcaster");
    run_nodes.push_back("/" + v.name + "/robot_state_publisher");
    if (v.controller.type != ControllerType::kExternal)
      run_nodes.push_back("/" + v.name + "/controller");
  }

  return run_nodes;
}

}  // namespace

std::vector<NodeParam> controllerNodeParams(const Scenario& s, const VehicleSpec& v, const std::string& vehicles_dir)
{
  std::vector<NodeParam> p;
  if (v.controller.type == ControllerType::kExternal)
    return p;
  p.push_back({ "mode", toString(v.controller.type), "str" });
  p.push_back({ "lockstep", "true", "bool" });
  p.push_back({ "lockstep_period", yamlDouble(kLockstepPeriod), "double" });  // dynamics_node's barrier
  p.push_back({ "model", v.model, "str" });
  p.push_back({ "config_dir", vehicles_dir, "str" });
  if (v.controller.type == ControllerType::kWaypoints)
  {
    std::string wps = "[";
    const std::vector<Waypoint>& path = s.paths.at(v.controller.path);
    for (std::size_t k = 0; k < path.size(); ++k)
      wps += std::string(k ? ", " : "") + "{x: " + yamlDouble(path[k].x) + ", y: " + yamlDouble(path[k].y) +
             ", speed: " + yamlDouble(path[k].speed) + "}";
    p.push_back({ "waypoints", wps + "]", "yaml" });
  }
  else
  {
    p.push_back({ "leader", v.controller.leader, "str" });
    p.push_back({ "gap", yamlDouble(v.controller.gap), "double" });
    p.push_back({ "offset", yamlDouble(v.controller.offset), "double" });
  }
  if (v.controller.params.IsDefined() && v.controller.params.IsMap())
    for (const auto& kv : v.controller.params)
    {
      // Each key with rosparam's type for it: the node's reader (and --check, which runs it on
      // these) refuses a value of the wrong type, where dropping it would leave the default.
      const YAML::Node value = terrain::rosparamTyped(kv.second, true, "controller.params." + kv.first.Scalar());
      const bool text = value.IsScalar() && value.Tag() == "!";
      const bool boolean = value.IsScalar() && !text && (value.Scalar() == "true" || value.Scalar() == "false");
      p.push_back({ kv.first.Scalar(), value.IsScalar() ? value.Scalar() : flowYaml(value, true),
                    !value.IsScalar() ? "yaml" : (text ? "str" : (boolean ? "bool" : "double")) });
    }
  return p;
}

std::string generateLaunch(const Scenario& s, const LaunchOptions& options)
{
  if (options.output_dir.empty())
    throw std::invalid_argument("output_dir: required");
  if (options.vehicles_dir.empty())
    throw std::invalid_argument("vehicles_dir: required");
  // The nodes' own ranges (run_numbers.hpp): a value run_recorder or dynamics_node would refuse
  // at start-up is refused here, before any node starts.
  if (!terrain::inRange(terrain::kRealTimeFactor, options.real_time_factor))
    throw std::invalid_argument(rangeMessage("real_time_factor", terrain::kRealTimeFactor));
  if (!terrain::inRange(terrain::kProgressPeriod, options.progress_period))
    throw std::invalid_argument(rangeMessage("progress_period", terrain::kProgressPeriod));
  const double duration = options.duration > 0.0 ? options.duration : s.duration;
  if (!terrain::inRange(terrain::kRunDuration, duration))
    throw std::invalid_argument(rangeMessage("duration", terrain::kRunDuration));
  LaunchInputs in{ s, options, s.terrain.nodeParams(), vehicleListYaml(s), false, "", duration };
  in.has_agents = s.agents.IsDefined() && !s.agents.IsNull() && s.agents.size() > 0;
  if (in.has_agents)
    in.agents = flowYaml(s.agents, true);

  std::ostringstream o;
  o << "<?xml version=\"1.0\"?>\n"
    << "<!-- Generated by avsp's scenario_launch from " << xmlEscape(s.file) << " (scenario '" << xmlEscape(s.name)
    << "', " << yamlDouble(duration) << " s, real-time factor " << yamlDouble(options.real_time_factor)
    << "). Do not edit: edit the scenario. -->\n"
    << "<launch>\n"
    << "  <param name=\"/use_sim_time\" value=\"true\"/>\n"
    << "  <include file=\"$(find avsp)/launch/world_frames.launch\"/>\n\n";

  NodeWriter w(o, "  ");
  // Terrain: mesh, objects, ruts, soil moisture.
  w.open("avsp_terrain", "terrain_node", "terrain");
  w.params(in.terrain);
  w.param("output_dir", options.output_dir);  // where ~save_map writes
  w.close();

  writeDynamics(o, in);
  writeSensors(o, in);
  writeEnvironment(o, in);
  writeV2vRadio(o, in);
  if (in.has_agents && options.have_agents_node)
  {
    w.open("avsp", "agents_node", "agents");
    w.rosparam("agents", in.agents);
    w.params(in.terrain);
    w.close();
  }
  o << "\n";

  writeVehicleGroups(o, in);
  const std::vector<std::string> run_nodes = runNodes(in);
  writeRunRecorder(o, in, run_nodes);
  writeStartGate(o, in, run_nodes);

  if (options.rviz)
    o << "  <node pkg=\"rviz\" type=\"rviz\" name=\"rviz\" clear_params=\"true\" args=\"-d '"
      << xmlEscape(options.rviz_config.empty() ? "$(find avsp)/rviz/avsp.rviz" : options.rviz_config) << "'\"/>\n";
  o << "</launch>\n";
  return o.str();
}

namespace
{
double parseNumber(const std::string& option, const std::string& text)
{
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument(option + ": '" + text + "' is not a number");
  return v;
}
}  // namespace

LaunchCommand parseLaunchCommand(const std::vector<std::string>& args)
{
  LaunchCommand c;
  for (std::size_t i = 0; i < args.size(); ++i)
  {
    const std::string& a = args[i];
    if (a.find(":=") != std::string::npos)
      continue;  // roslaunch's remappings (__name:=, __log:=)
    const auto value = [&](void) -> std::string {
      if (i + 1 >= args.size())
        throw std::invalid_argument(a + ": needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h")
      c.help = true;
    else if (a == "--duration")
    {
      c.options.duration = parseNumber(a, value());
      if (c.options.duration != 0.0 && !terrain::inRange(terrain::kRunDuration, c.options.duration))
        throw std::invalid_argument(rangeMessage("--duration", terrain::kRunDuration) + " (0: the scenario's)");
    }
    else if (a == "--real-time-factor")
    {
      c.options.real_time_factor = parseNumber(a, value());
      if (!terrain::inRange(terrain::kRealTimeFactor, c.options.real_time_factor))
        throw std::invalid_argument(rangeMessage("--real-time-factor", terrain::kRealTimeFactor) +
                                    " (0: as fast as possible)");
    }
    else if (a == "--rviz")
    {
      c.options.rviz = true;
      if (i + 1 < args.size() && (args[i + 1] == "true" || args[i + 1] == "false"))
        c.options.rviz = args[++i] == "true";
    }
    else if (a == "--output-dir")
      c.options.output_dir = value();
    else if (a == "--out")
      c.out = value();
    else if (a == "--config-dir")
      c.config_dir = value();
    else if (a == "--progress-period")
    {
      c.options.progress_period = parseNumber(a, value());
      if (!terrain::inRange(terrain::kProgressPeriod, c.options.progress_period))
        throw std::invalid_argument(rangeMessage("--progress-period", terrain::kProgressPeriod));
    }
    else if (a == "--check")
      c.check_only = true;
    else if (a == "--end-launch")
      c.end_launch = true;
    else if (a == "--no-start-gate")
      c.options.start_gate = false;
    else if (!a.empty() && a[0] == '-')
      throw std::invalid_argument(a + ": unknown option");
    else if (c.scenario.empty())
      c.scenario = a;
    else
      throw std::invalid_argument(a + ": only one scenario file");
  }
  if (c.scenario.empty() && !c.help)
    throw std::invalid_argument("a scenario file is required");
  return c;
}

std::string launchCommandUsage(const std::string& program)
{
  return "usage: " + program +
         " SCENARIO.yaml [--duration S] [--real-time-factor R] [--rviz [true|false]]\n"
         "       [--output-dir DIR] [--out FILE|-] [--config-dir DIR] [--progress-period S] [--check]\n"
         "Validates the scenario and writes a roslaunch file with every node of the run.\n"
         "  --duration S          s of sim time (0: the scenario's duration)\n"
         "  --real-time-factor R  0 = as fast as possible in lockstep (default), 1 = wall-clock pace\n"
         "  --rviz                add RViz with the run's own configuration (<name>.rviz beside the launch file)\n"
         "  --output-dir DIR      results folder (default results/<scenario> under $PWD)\n"
         "  --out FILE            the launch file (default <output-dir>/<scenario>.launch; - = stdout)\n"
         "  --config-dir DIR      folder with vehicles/ and soils.yaml (default the avsp package's config)\n"
         "  --progress-period S   wall s between run_recorder's progress lines (default 1)\n"
         "  --check               validate only\n"
         "  --no-start-gate       start the physics at once instead of when every node is up\n"
         "  --end-launch          (scenario_node) when the run ends, end the roslaunch that started it\n";
}

}  // namespace scenario
}  // namespace avsp
