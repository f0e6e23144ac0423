#pragma once
/**
 * @file agents.hpp
 * @brief Dynamic agents (deer, pedestrians, trucks) whose motion is a pure function of sim time:
 *        each moves along a smooth path through its points at a constant speed from its start
 *        time, once or looping, standing on the terrain. agents_node (TF, markers, states),
 *        sensors_node (ray-cast boxes) and dynamics_node (kinematic ODE bodies) each evaluate
 *        the same Agent at their own times and agree to the bit, with no message between them.
 *
 * The path is a centripetal Catmull-Rom spline (alpha = 1/2: no cusps or self-intersections
 * within a segment, Yuksel, Schaefer and Keyser, "Parameterization and applications of
 * Catmull-Rom curves", CAD 43(7), 2011) through the points, re-parameterised by arc length
 * (Gauss-Legendre quadrature of |C'(u)| and a safeguarded Newton inversion), so the agent's
 * speed along it is exactly `speed`. Heights come from the terrain's base elevation grid,
 * sampled along the path once at construction (ruts made later do not move the agents).
 */
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "avsp_terrain/elevation_grid.hpp"

namespace avsp
{
namespace terrain
{
/// What an agent is: fixes its body (agentBoxes) and how sensors see it.
enum class AgentType
{
  kDeer,
  kPedestrian,
  kTruck,
};

/// "deer", "pedestrian", "truck".
const char* toString(AgentType type);
/// The type named `name` (as toString), nullopt for anything else.
std::optional<AgentType> agentTypeFromString(const std::string& name);

/// One box of an agent's body, in the agent's frame: origin on the ground under the body's
/// centre, x forward (along the path), y left, z up.
struct AgentBox
{
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< m, agent frame
  Eigen::Vector3d size = Eigen::Vector3d::Ones();    ///< m, full edges along x, y, z (> 0)
};

/**
 * @brief The body of each type as a few boxes (README.md "Dynamic agents" gives the sources):
 *  - deer: an adult white-tailed deer, 1.6 m from rump to nose, 1.0 m at the shoulder: torso
 *    1.3 x 0.4 x 0.45 m over four 0.1 m legs 0.55 m long, neck and head 0.3 x 0.2 x 0.6 m;
 *  - pedestrian: an adult, 1.75 m tall, 0.5 m across the shoulders, 0.3 m deep (one box);
 *  - truck: a two-axle rigid truck, 8.0 m long, 2.5 m wide, 3.2 m high: body on a 0.5 m high
 *    block of running gear set 0.75 m in from each end.
 */
const std::vector<AgentBox>& agentBoxes(AgentType type);

/**
 * @brief kg, an agent's mass as a body the vehicles meet: a deer 100 kg (a northern white-tailed
 *        buck; does 40-90 kg, bucks 68-136 kg), a pedestrian 80 kg (US adults average 76-89 kg,
 *        CDC NHANES 2011-2014), a truck 10 t (a loaded FHWA class 6 medium truck, 8.8-11.8 t).
 */
double agentMass(AgentType type);

/**
 * @brief N, the most an agent pushes with to hold its path (the dynamics drive it along its path
 *        up to this, so a vehicle can push it aside): a deer its weight, a pedestrian half of it,
 *        a truck 0.7 of it (a tyre's grip on a road). Assumptions of the right order, not
 *        measurements.
 */
double agentPushForce(AgentType type);

/// Full edges (x, y, z) of the box bounding agentBoxes(type), agent frame, m.
Eigen::Vector3d agentSize(AgentType type);
/// Centre of that bounding box in the agent frame, m.
Eigen::Vector3d agentBoundsCentre(AgentType type);

/// What an agent does (a scenario's or a node's `~agents` entry).
struct AgentSpec
{
  std::string name;  ///< unique, a ROS name without '/': frame agents/<name>
  AgentType type = AgentType::kDeer;
  std::vector<Eigen::Vector2d> path;  ///< m, map (x, y): the points the path passes through
  double speed = 0.0;                 ///< m/s along the path, >= 0; 0 = standing at path[0]
  double start_time = 0.0;            ///< s (sim time) when it sets off from path[0], >= 0
  bool loop = false;                  ///< the path closes (last point back to the first) and repeats
  double yaw = 0.0;                   ///< rad: heading of an agent with a single path point
};

/**
 * @brief Checks one spec.
 * @param key how errors name it, e.g. "agents[1]"
 * @throw std::invalid_argument "<key>.<field>: <reason>", e.g. "agents[1].speed: must be finite
 *        and >= 0 m/s, got -1": empty or bad name, no point, a non-finite coordinate, a moving
 *        agent with < 2 points (< 3 looping), two consecutive points (or, looping, the last and
 *        the first) closer than 1 mm, speed or start_time negative or not finite, yaw not finite
 */
void validateAgentSpec(const AgentSpec& spec, const std::string& key);

/// validateAgentSpec() for each (key "<list_key>[k]") and unique names. @throw std::invalid_argument
void validateAgentSpecs(const std::vector<AgentSpec>& specs, const std::string& list_key = "agents");

/**
 * @brief The one parser of an agent list, {name, type, path, speed, start_time, loop, yaw} per
 *        agent: the scenario's `agents` (its YAML) and the nodes' `~agents` (their XML-RPC value
 *        as YAML) alike; then validateAgentSpecs(). A number is a plain YAML scalar (a quoted one
 *        is a string, as rosparam types it).
 * @param list_key names the list in messages ("agents", "~agents")
 * @throw std::invalid_argument "<list_key>[k].<field>: <why>": not a list, an entry not a map,
 *        an unknown or missing key, a value of the wrong type, an unknown type, then what
 *        validateAgentSpecs() refuses
 */
std::vector<AgentSpec> parseAgentSpecs(const YAML::Node& list, const std::string& list_key);

/// A point of a path at an arc length.
struct PathSample
{
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< m
  Eigen::Vector2d tangent = Eigen::Vector2d::UnitX();  ///< unit, direction of travel
  double curvature = 0.0;                              ///< 1/m, + turning left
};

/**
 * @brief A centripetal Catmull-Rom spline through points, by arc length. Open paths run from the
 *        first to the last point (end tangents from reflected phantom points); closed ones add
 *        the segment from the last point back to the first, with the neighbours wrapping.
 */
class AgentPath
{
public:
  /// @throw std::invalid_argument for < 2 points (< 3 closed) or coincident neighbours
  AgentPath(std::vector<Eigen::Vector2d> points, bool closed);

  double length() const { return length_; }  ///< m
  bool closed() const { return closed_; }
  /// The point at arc length s, clamped to [0, length] (closed paths: wrapped).
  PathSample sample(double s) const;

private:
  struct Segment
  {
    Eigen::Vector2d p1, m1, p2, m2;  ///< cubic Hermite form on u in [0, 1]
    std::vector<double> s;           ///< arc length at u = k / kSubdivisions from the path's start
  };
  static constexpr int kSubdivisions = 32;
  Eigen::Vector2d point(const Segment& g, double u) const;
  Eigen::Vector2d derivative(const Segment& g, double u) const;
  Eigen::Vector2d secondDerivative(const Segment& g, double u) const;
  double arcLength(const Segment& g, double u0, double u1) const;

  bool closed_ = false;
  std::vector<Segment> segments_;
  double length_ = 0.0;
};

/// An agent's state at a time. Level body (no roll or pitch): the boxes stand upright.
struct AgentState
{
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< m, map: agent frame origin on the ground
  double yaw = 0.0;                                    ///< rad, heading of x about map z
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s, map
  double yaw_rate = 0.0;                               ///< rad/s
  bool moving = false;                                 ///< started, not yet at its end (or looping)
};

/**
 * @brief An agent: its spec, path and height profile. state(t) depends on t only.
 *
 * Before start_time and for a standing agent (speed 0): at path[0], heading along the path's
 * start (or `yaw` for a single point), still. Then at arc length speed (t - start_time): an
 * open path ends at its last point, heading along its end, still; a loop repeats with period
 * length / speed.
 */
class Agent
{
public:
  /**
   * @param ground heights: z = the bilinear height at (x, y), sampled along the path every
   *        half grid cell (at most 0.1 m) and interpolated linearly between samples
   * @param key how errors name the agent, e.g. "agents[1]"
   * @throw std::invalid_argument from validateAgentSpec, or "<key>.path: leaves the terrain at
   *        (x, y)" when the path (spline included) runs off the grid
   */
  Agent(AgentSpec spec, const ElevationGrid& ground, const std::string& key);

  const AgentSpec& spec() const { return spec_; }
  /// m, 0 for a single point.
  double length() const { return path_ ? path_->length() : 0.0; }
  /// s, time to run the path once (infinity when standing).
  double period() const;
  /// The state at sim time t (s, any finite value).
  AgentState state(double t) const;

private:
  double heightAt(double s, double& slope) const;

  AgentSpec spec_;
  std::optional<AgentPath> path_;
  double profile_step_ = 0.1;    ///< m between height samples
  std::vector<double> profile_;  ///< m, ground height at s = k profile_step_
};

/// Agent for each spec (key "<list_key>[k]"), names checked unique. @throw std::invalid_argument
std::vector<Agent> makeAgents(const std::vector<AgentSpec>& specs, const ElevationGrid& ground,
                              const std::string& list_key = "agents");

}  // namespace terrain
}  // namespace avsp
