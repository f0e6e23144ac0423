/**
 * @file
 * @brief YAML as rosparam reads it, without ROS: the types PyYAML's safe_load (YAML 1.1) gives
 *        plain scalars, and YAML text written so that it reads back with exactly those types.
 *
 * A scenario's sensors, agents and weather sections reach their nodes as YAML text in the
 * generated launch file, which roslaunch parses with PyYAML. The scenario loader and
 * `scenario_launch --check` type the same sections with rosparamTyped(), so they see what the
 * node will see (`max_range: 1e3` is the string "1e3" to PyYAML, `yes` the boolean true).
 */
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

namespace avsp
{
namespace terrain
{
/// A plain (unquoted) scalar as PyYAML 6's safe_load resolves it.
struct RosparamScalar
{
  enum class Kind
  {
    kNull,    ///< "", ~, null, Null, NULL
    kBool,    ///< yes/no, true/false, on/off in three cases
    kInt,     ///< decimal, 0b binary, 0 octal, 0x hex, sexagesimal (1:30), '_' ignored
    kDouble,  ///< needs a '.', a signed exponent; .inf, .nan, sexagesimal
    kString,  ///< anything else (1e3, 1.5e3, y, n, 2026-06-01 are strings here)
  };
  Kind kind = Kind::kString;
  bool boolean = false;
  long long integer = 0;  ///< kInt (saturated at the long long range)
  double real = 0.0;      ///< kDouble, and kInt as a double
};

/// How PyYAML's safe_load (rosparam, roslaunch) types the plain scalar `text`.
RosparamScalar rosparamScalar(const std::string& text);

/**
 * @brief A YAML tree with every scalar typed as rosparam would type it: strings (quoted in the
 *        source, or plain scalars PyYAML leaves as text) become quoted scalars (tag "!"), numbers
 *        and booleans plain scalars in a canonical form (rosparamText).
 * @param force_double integers become doubles (a section whose readers want doubles)
 * @throw std::invalid_argument for a null or a map key that is not a scalar (rosparam cannot set
 *        them), naming the path
 */
YAML::Node rosparamTyped(const YAML::Node& node, bool force_double = false, const std::string& path = "");

/// A double written so that PyYAML reads back the same double: .inf, -.inf, .nan, or the
/// shortest of %.15g..%.17g that round-trips, with a '.' (1.0, 1.0e+20).
std::string rosparamDouble(double v);

/**
 * @brief `node` as one line of YAML flow text that PyYAML reads back with rosparamTyped()'s
 *        types: strings single-quoted, booleans true/false, integers in decimal, doubles as
 *        rosparamDouble().
 * @throw std::invalid_argument as rosparamTyped()
 */
std::string rosparamFlow(const YAML::Node& node, bool force_double = false);

}  // namespace terrain
}  // namespace avsp
