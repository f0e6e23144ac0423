#pragma once
/**
 * @file node_params.hpp
 * @brief Start-up parameter checks every AVSP node shares: a bad value is a StartupError
 *        naming the private parameter (~key), its value and the allowed range; the node logs
 *        it and exits 1 instead of running on a silent default.
 */
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace avsp
{
namespace msgs
{
/// A start-up problem: the node logs it (naming the parameter, vehicle or file) and exits 1.
struct StartupError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/// What a parameter value is, for messages ("a string", "a list", ...).
inline std::string parameterKind(const XmlRpc::XmlRpcValue& v)
{
  switch (v.getType())
  {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return "a boolean";
    case XmlRpc::XmlRpcValue::TypeInt:
      return "an integer";
    case XmlRpc::XmlRpcValue::TypeDouble:
      return "a number";
    case XmlRpc::XmlRpcValue::TypeString:
      return "a string";
    case XmlRpc::XmlRpcValue::TypeArray:
      return "a list";
    case XmlRpc::XmlRpcValue::TypeStruct:
      return "a dictionary";
    default:
      return "not a number";
  }
}

/// A private number parameter (default `fallback`), written as an int or a double; a value of
/// another type (a string, a list) is refused, not replaced by the default.
inline double numberParam(const ros::NodeHandle& pnh, const std::string& key, double fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(key, v))
    return fallback;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    return static_cast<double>(v);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
    return static_cast<int>(v);
  throw StartupError("parameter ~" + key + " must be a number, got " + parameterKind(v));
}

/// A private double parameter (default `fallback`) that must be finite and in [min, max]
/// (numberParam()).
inline double boundedParam(const ros::NodeHandle& pnh, const std::string& key, double fallback, double min,
                           double max)
{
  const double value = numberParam(pnh, key, fallback);
  if (!std::isfinite(value) || value < min || value > max)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be finite and in [" +
                       std::to_string(min) + ", " + std::to_string(max) + "]");
  return value;
}

/// Whether `d` is a whole number an int holds.
inline bool isWholeInt(double d)
{
  return std::floor(d) == d && d >= -2147483648.0 && d <= 2147483647.0;
}

/// A private int parameter (default `fallback`) that must be in [min, max]. A whole number
/// written as a double (4.0) is taken; a fraction or a value of another type is refused, not
/// rounded or replaced by the default.
inline int boundedIntParam(const ros::NodeHandle& pnh, const std::string& key, int fallback, int min, int max)
{
  int value = fallback;
  XmlRpc::XmlRpcValue v;
  if (pnh.getParam(key, v))
  {
    if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
      value = static_cast<int>(v);
    else if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble && isWholeInt(static_cast<double>(v)))
      value = static_cast<int>(static_cast<double>(v));
    else
    {
      std::string got = parameterKind(v);
      if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
      {
        char text[32];
        std::snprintf(text, sizeof text, "%g", static_cast<double>(v));
        got = text;
      }
      throw StartupError("parameter ~" + key + " must be an integer, got " + got);
    }
  }
  if (value < min || value > max)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be in [" + std::to_string(min) +
                       ", " + std::to_string(max) + "]");
  return value;
}

/// A private boolean parameter (default `fallback`); a value of another type (a string, a
/// number) is refused, not replaced by the default.
inline bool boolParam(const ros::NodeHandle& pnh, const std::string& key, bool fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(key, v))
    return fallback;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
    throw StartupError("parameter ~" + key + " must be true or false, got " + parameterKind(v));
  return static_cast<bool>(v);
}

/// A private string parameter (default `fallback`); a value of another type (a number, a list)
/// is refused, not replaced by the default.
inline std::string stringParam(const ros::NodeHandle& pnh, const std::string& key, const std::string& fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(key, v))
    return fallback;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeString)
    throw StartupError("parameter ~" + key + " must be a string, got " + parameterKind(v));
  return static_cast<std::string>(v);
}

}  // namespace msgs
}  // namespace avsp
