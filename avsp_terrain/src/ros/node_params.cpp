#include "avsp_terrain/ros/node_params.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <ros/names.h>

namespace avsp
{
namespace node
{
std::string parameterKind(const XmlRpc::XmlRpcValue& v)
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

double numberParam(const ros::NodeHandle& pnh, const std::string& key, double fallback)
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

double boundedParam(const ros::NodeHandle& pnh, const std::string& key, double fallback, double min, double max)
{
  const double value = numberParam(pnh, key, fallback);
  if (!std::isfinite(value) || value < min || value > max)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be finite and in [" +
                       std::to_string(min) + ", " + std::to_string(max) + "]");
  return value;
}

bool isWholeInt(double d)
{
  return std::floor(d) == d && d >= -2147483648.0 && d <= 2147483647.0;
}

int boundedIntParam(const ros::NodeHandle& pnh, const std::string& key, int fallback, int min, int max)
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

bool boolParam(const ros::NodeHandle& pnh, const std::string& key, bool fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(key, v))
    return fallback;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
    throw StartupError("parameter ~" + key + " must be true or false, got " + parameterKind(v));
  return static_cast<bool>(v);
}

std::string stringParam(const ros::NodeHandle& pnh, const std::string& key, const std::string& fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(key, v))
    return fallback;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeString)
    throw StartupError("parameter ~" + key + " must be a string, got " + parameterKind(v));
  return static_cast<std::string>(v);
}

std::vector<std::string> plainNamesParam(const ros::NodeHandle& pnh, const std::string& key, const std::string& what)
{
  std::vector<std::string> names;
  if (!pnh.hasParam(key))
    return names;
  XmlRpc::XmlRpcValue list;
  pnh.getParam(key, list);
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw StartupError("parameter ~" + key + " must be a list of " + what + ", got " + parameterKind(list));
  for (int k = 0; k < list.size(); ++k)
  {
    const std::string where = "parameter ~" + key + "[" + std::to_string(k) + "]";
    if (list[k].getType() != XmlRpc::XmlRpcValue::TypeString)
      throw StartupError(where + " must be a name (string), got " + parameterKind(list[k]));
    const std::string name = static_cast<std::string>(list[k]);
    std::string why;
    if (name.empty() || name.find('/') != std::string::npos || !ros::names::validate(name, why))
      throw StartupError(where + " '" + name + "' must be a plain name (no '/')");
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw StartupError(where + " '" + name + "' is listed twice");
    names.push_back(name);
  }
  return names;
}

}  // namespace node
}  // namespace avsp
