#pragma once
/**
 * @file node_params.hpp
 * @brief Start-up parameter checks every AVSP node shares: a bad value is a StartupError
 *        naming the private parameter (~key), its value and the allowed range; the node logs
 *        it and exits 1 instead of running on a silent default.
 */
#include <cmath>
#include <stdexcept>
#include <string>

#include <ros/node_handle.h>

namespace avsp
{
namespace msgs
{
/// A start-up problem: the node logs it (naming the parameter, vehicle or file) and exits 1.
struct StartupError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/// A private double parameter (default `fallback`) that must be finite and in [min, max].
inline double boundedParam(const ros::NodeHandle& pnh, const std::string& key, double fallback, double min,
                           double max)
{
  double value = fallback;
  pnh.param(key, value, fallback);
  if (!std::isfinite(value) || value < min || value > max)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be finite and in [" +
                       std::to_string(min) + ", " + std::to_string(max) + "]");
  return value;
}

/// A private int parameter (default `fallback`) that must be in [min, max].
inline int boundedIntParam(const ros::NodeHandle& pnh, const std::string& key, int fallback, int min, int max)
{
  int value = fallback;
  pnh.param(key, value, fallback);
  if (value < min || value > max)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be in [" + std::to_string(min) +
                       ", " + std::to_string(max) + "]");
  return value;
}

}  // namespace msgs
}  // namespace avsp
