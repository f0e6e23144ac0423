#pragma once
/**
 * @file parameter_error.hpp
 * @brief How the DEM sources refuse a parameter: DemParameterError "dem.<key>: <why>", numbers
 *        printed with 6 significant digits. Private to avsp_dynamics_dem.
 */
#include <sstream>
#include <string>

#include "avsp_dynamics/dem/dem_parameters.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace detail
{
[[noreturn]] inline void fail(const std::string& key, const std::string& why)
{
  throw DemParameterError("dem." + key + ": " + why);
}

inline std::string str(double v)
{
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}
}  // namespace detail
}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
