#pragma once
/**
 * @file node_params.hpp
 * @brief Start-up parameter checks every AVSP node shares: a bad value is a StartupError
 *        naming the private parameter (~key), its value and the allowed range; the node logs
 *        it and exits 1 instead of running on a silent default.
 *
 * Part of avsp_terrain's ROS layer (library `avsp_terrain_ros`) because avsp_terrain is the
 * package every other one depends on: the helpers reach every node without a package of their
 * own, and avsp_msgs keeps messages only. Namespace avsp::node: they belong to no package's
 * domain.
 */
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include "avsp_terrain/run_numbers.hpp"

namespace avsp
{
namespace node
{
/// A start-up problem: the node logs it (naming the parameter, vehicle or file) and exits 1.
struct StartupError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/// What a parameter value is, for messages ("a string", "a list", ...).
std::string parameterKind(const XmlRpc::XmlRpcValue& v);

/**
 * @brief Where a node's private parameters come from: the master, through the node's private
 *        NodeHandle, or a tree of values (an XML-RPC struct: what a generated launch file sets,
 *        built without a master). The helpers below read through one, so a node's parameter
 *        parser serves both the node at start-up and `scenario_launch --check` before anything
 *        starts (include/avsp/ros/node_checks.hpp). It keeps the keys read, so a check can
 *        refuse a key the parser never asked for.
 */
class ParamSource
{
public:
  /// The master, through `pnh` (implicit: every helper takes a NodeHandle as before).
  ParamSource(const ros::NodeHandle& pnh) : pnh_(&pnh) {}  // NOLINT(google-explicit-constructor)
  /// A tree: a struct whose members are the private parameters; "a/b" walks into "a".
  explicit ParamSource(XmlRpc::XmlRpcValue tree) : tree_(std::move(tree)) {}

  /// The value of `key` (relative to the private namespace), if set.
  bool get(const std::string& key, XmlRpc::XmlRpcValue& value) const;
  /// Whether `key` is set.
  bool has(const std::string& key) const;
  /// The keys get() or has() asked for so far.
  const std::set<std::string>& keysRead() const { return read_; }

private:
  const ros::NodeHandle* pnh_ = nullptr;
  mutable XmlRpc::XmlRpcValue tree_;
  mutable std::set<std::string> read_;
};

/**
 * @brief A private number parameter written as an int or a double.
 * @return its value, `fallback` when unset
 * @throw StartupError for a value of another type (a string, a list): refused, not replaced by
 *        the default
 */
double numberParam(const ParamSource& params, const std::string& key, double fallback);

/**
 * @brief A private double parameter (numberParam()) that must be finite and in [min, max].
 * @throw StartupError naming ~key, its value and the range
 */
double boundedParam(const ParamSource& params, const std::string& key, double fallback, double min, double max);

/// Whether `d` is a whole number an int holds.
bool isWholeInt(double d);

/**
 * @brief A private int parameter that must be in [min, max]. A whole number written as a
 *        double (4.0) is taken.
 * @throw StartupError for a fraction or a value of another type (not rounded, not replaced by
 *        the default) and for a value outside the range
 */
int boundedIntParam(const ParamSource& params, const std::string& key, int fallback, int min, int max);

/// A number of the run (run_numbers.hpp) as a private parameter: boundedParam with its key,
/// default and range, the same as the launcher and the scenario check apply.
double runNumberParam(const ParamSource& params, const terrain::RunNumber& n);
/// The same for an integer number (the seed).
int runIntParam(const ParamSource& params, const terrain::RunNumber& n);

/**
 * @brief A private boolean parameter (default `fallback`).
 * @throw StartupError for a value of another type (a string, a number)
 */
bool boolParam(const ParamSource& params, const std::string& key, bool fallback);

/**
 * @brief A private string parameter (default `fallback`).
 * @throw StartupError for a value of another type (a number, a list)
 */
std::string stringParam(const ParamSource& params, const std::string& key, const std::string& fallback);

/**
 * @brief A private list of plain names (partitions, lockstep followers): empty when absent.
 * @param what what the names are, for the messages ("partition names")
 * @throw StartupError naming the key (and the index) for a value that is not a list, an entry
 *        that is not a string or not a plain ROS name (no '/'), or a name listed twice
 */
std::vector<std::string> plainNamesParam(const ParamSource& params, const std::string& key, const std::string& what);

/// One entry of a node's ~vehicles list.
struct VehicleListEntry
{
  std::string name;            ///< a plain ROS name (a namespace and a frame prefix), unique in the list
  std::string model;           ///< "" when the entry names none
  XmlRpc::XmlRpcValue fields;  ///< the entry's dictionary (invalid for an entry given as a plain name)
  std::string where;           ///< "~vehicles[k]", for the node's own messages about the entry
};

/**
 * @brief The ~vehicles list every node of a run reads (one parser: dynamics_node, sensors_node,
 *        v2v_radio_node, run_recorder, team_check), also given as YAML text (structuredParam).
 * @param with_model each entry is a dictionary with string 'name' and 'model' (model: a plain
 *        file name under ~config_dir); otherwise a plain name or a dictionary with a string 'name'
 * @param allowed the keys an entry may have; empty: any
 * @param what the entries, for the message about the list ("{name, model, x, y, yaw}")
 * @throw StartupError naming ~vehicles or ~vehicles[k](.key): not a non-empty list, an entry of
 *        the wrong form, a key not allowed, a name that is not a plain ROS name or is listed
 *        twice, a model that is not a plain name
 */
std::vector<VehicleListEntry> vehicleListParam(const ParamSource& params, bool with_model,
                                               const std::vector<std::string>& allowed, const std::string& what);

/**
 * @brief A YAML node as rosparam loads it: plain scalars typed as PyYAML's safe_load does
 *        (avsp_terrain/rosparam_yaml.hpp: yes/no/on/off booleans, 0x1f and 010 integers, 1e3 a
 *        string), quoted ones strings, sequences arrays, maps structs.
 * @throw std::invalid_argument for a null or a non-string map key (rosparam cannot set those)
 */
XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node);

/**
 * @brief An XML-RPC value as YAML, the inverse of toXmlRpc(): a string becomes a quoted scalar
 *        (tag "!": never read as a number or a boolean), numbers and booleans plain scalars,
 *        arrays sequences, structs maps. So the core's YAML parsers read a node's parameters.
 */
YAML::Node toYaml(const XmlRpc::XmlRpcValue& value);

/**
 * @brief A private list or dictionary parameter, also when given as YAML text: `rosrun pkg node
 *        _vehicles:='[a, b]'` sets the string "[a, b]" (roscpp types a command-line parameter
 *        as a number, a boolean or a string), which is read here as rosparam would read it.
 *        Other values come back as they are; the caller checks their type.
 * @return false when the parameter is not set (`value` untouched)
 * @throw StartupError naming the key when a string starting with '[' or '{' is not valid YAML
 */
bool structuredParam(const ParamSource& params, const std::string& key, XmlRpc::XmlRpcValue& value);

}  // namespace node
}  // namespace avsp
