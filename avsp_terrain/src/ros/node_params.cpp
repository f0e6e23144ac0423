#include "avsp_terrain/ros/node_params.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <ros/names.h>

#include "avsp_terrain/rosparam_yaml.hpp"

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

bool ParamSource::get(const std::string& key, XmlRpc::XmlRpcValue& value) const
{
  read_.insert(key);
  if (pnh_ != nullptr)
    return pnh_->getParam(key, value);
  XmlRpc::XmlRpcValue* at = &tree_;
  std::size_t begin = 0;
  while (true)
  {
    const std::size_t end = key.find('/', begin);
    const std::string member = key.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
    if (at->getType() != XmlRpc::XmlRpcValue::TypeStruct || !at->hasMember(member))
      return false;
    at = &(*at)[member];
    if (end == std::string::npos)
      break;
    begin = end + 1;
  }
  value = *at;
  return true;
}

bool ParamSource::has(const std::string& key) const
{
  if (pnh_ != nullptr)
  {
    read_.insert(key);
    return pnh_->hasParam(key);
  }
  XmlRpc::XmlRpcValue ignored;
  return get(key, ignored);
}

double numberParam(const ParamSource& params, const std::string& key, double fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!params.get(key, v))
    return fallback;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    return static_cast<double>(v);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt)
    return static_cast<int>(v);
  throw StartupError("parameter ~" + key + " must be a number, got " + parameterKind(v));
}

double boundedParam(const ParamSource& params, const std::string& key, double fallback, double min, double max)
{
  const double value = numberParam(params, key, fallback);
  if (!std::isfinite(value) || value < min || value > max)
    throw StartupError("parameter ~" + key + " = " + std::to_string(value) + " must be finite and in [" +
                       std::to_string(min) + ", " + std::to_string(max) + "]");
  return value;
}

bool isWholeInt(double d)
{
  return std::floor(d) == d && d >= -2147483648.0 && d <= 2147483647.0;
}

int boundedIntParam(const ParamSource& params, const std::string& key, int fallback, int min, int max)
{
  int value = fallback;
  XmlRpc::XmlRpcValue v;
  if (params.get(key, v))
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

bool boolParam(const ParamSource& params, const std::string& key, bool fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!params.get(key, v))
    return fallback;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
    throw StartupError("parameter ~" + key + " must be true or false, got " + parameterKind(v));
  return static_cast<bool>(v);
}

std::string stringParam(const ParamSource& params, const std::string& key, const std::string& fallback)
{
  XmlRpc::XmlRpcValue v;
  if (!params.get(key, v))
    return fallback;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeString)
    throw StartupError("parameter ~" + key + " must be a string, got " + parameterKind(v));
  return static_cast<std::string>(v);
}

std::vector<std::string> plainNamesParam(const ParamSource& params, const std::string& key, const std::string& what)
{
  std::vector<std::string> names;
  if (!params.has(key))
    return names;
  XmlRpc::XmlRpcValue list;
  structuredParam(params, key, list);
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

std::vector<VehicleListEntry> vehicleListParam(const ParamSource& params, bool with_model,
                                               const std::vector<std::string>& allowed, const std::string& what)
{
  XmlRpc::XmlRpcValue list;
  if (!structuredParam(params, "vehicles", list) || list.getType() != XmlRpc::XmlRpcValue::TypeArray ||
      list.size() == 0)
    throw StartupError("parameter ~vehicles must be a non-empty list of " + what);
  std::vector<VehicleListEntry> out;
  for (int k = 0; k < list.size(); ++k)
  {
    VehicleListEntry e;
    e.where = "~vehicles[" + std::to_string(k) + "]";
    XmlRpc::XmlRpcValue& v = list[k];
    const bool is_map = v.getType() == XmlRpc::XmlRpcValue::TypeStruct;
    auto isString = [&](const char* key) {
      return is_map && v.hasMember(key) && v[key].getType() == XmlRpc::XmlRpcValue::TypeString;
    };
    if (with_model && !(isString("name") && isString("model")))
      throw StartupError("parameter " + e.where + " must be a dictionary with string keys 'name' and 'model'");
    if (!with_model && v.getType() != XmlRpc::XmlRpcValue::TypeString && !isString("name"))
      throw StartupError("parameter " + e.where + " must be a name or a dictionary with a string 'name'");
    if (is_map && !allowed.empty())
      for (auto it = v.begin(); it != v.end(); ++it)
        if (std::find(allowed.begin(), allowed.end(), it->first) == allowed.end())
        {
          std::string known;
          for (const std::string& a : allowed)
            known += (known.empty() ? "" : ", ") + a;
          throw StartupError("parameter " + e.where + "." + it->first + ": unknown key (known: " + known + ")");
        }
    e.name = is_map ? static_cast<std::string>(v["name"]) : static_cast<std::string>(v);
    if (is_map)
    {
      e.fields = v;
      if (isString("model"))
        e.model = static_cast<std::string>(v["model"]);
    }
    const std::string name_key = "parameter " + e.where + (is_map ? ".name" : "");
    std::string why;
    if (e.name.empty() || e.name.find('/') != std::string::npos || !ros::names::validate(e.name, why))
      throw StartupError(name_key + " '" + e.name + "' must be a valid ROS name without '/'");
    for (const VehicleListEntry& earlier : out)
      if (earlier.name == e.name)
        throw StartupError(name_key + " '" + e.name + "' is listed twice");
    if (with_model && (e.model.empty() || e.model.find('/') != std::string::npos))
      throw StartupError("parameter " + e.where + ".model '" + e.model +
                         "' must be a model name (~config_dir/<model>.yaml)");
    out.push_back(std::move(e));
  }
  return out;
}

double runNumberParam(const ParamSource& params, const terrain::RunNumber& n)
{
  return boundedParam(params, n.key, n.fallback, n.min, n.max);
}

int runIntParam(const ParamSource& params, const terrain::RunNumber& n)
{
  return boundedIntParam(params, n.key, static_cast<int>(n.fallback), static_cast<int>(n.min), static_cast<int>(n.max));
}

namespace
{
/// A plain scalar typed as PyYAML's safe_load (rosparam) types it (rosparam_yaml.hpp).
XmlRpc::XmlRpcValue plainScalar(const std::string& text)
{
  const terrain::RosparamScalar s = terrain::rosparamScalar(text);
  switch (s.kind)
  {
    case terrain::RosparamScalar::Kind::kBool:
      return XmlRpc::XmlRpcValue(s.boolean);
    case terrain::RosparamScalar::Kind::kInt:
      if (s.integer >= std::numeric_limits<int>::min() && s.integer <= std::numeric_limits<int>::max())
        return XmlRpc::XmlRpcValue(static_cast<int>(s.integer));
      return XmlRpc::XmlRpcValue(s.real);  // XML-RPC ints are 32-bit
    case terrain::RosparamScalar::Kind::kDouble:
      return XmlRpc::XmlRpcValue(s.real);
    case terrain::RosparamScalar::Kind::kNull:
      throw std::invalid_argument("a null value (rosparam cannot set it)");
    case terrain::RosparamScalar::Kind::kString:
      break;
  }
  return XmlRpc::XmlRpcValue(text);
}
}  // namespace

XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node)
{
  switch (node.Type())
  {
    case YAML::NodeType::Scalar:
      // yaml-cpp tags a quoted scalar "!": a string whatever it spells.
      return node.Tag() == "!" ? XmlRpc::XmlRpcValue(node.Scalar()) : plainScalar(node.Scalar());
    case YAML::NodeType::Sequence:
    {
      XmlRpc::XmlRpcValue out;
      out.setSize(static_cast<int>(node.size()));
      for (std::size_t k = 0; k < node.size(); ++k)
        out[static_cast<int>(k)] = toXmlRpc(node[k]);
      return out;
    }
    case YAML::NodeType::Map:
    {
      // Parsed from XML so that an empty map is still a struct (XmlRpcValue has no other way).
      int offset = 0;
      XmlRpc::XmlRpcValue out("<value><struct></struct></value>", &offset);
      for (const auto& kv : node)
      {
        if (!kv.first.IsScalar())
          throw std::invalid_argument("a map key that is not a string");
        out[kv.first.Scalar()] = toXmlRpc(kv.second);
      }
      return out;
    }
    default:
      throw std::invalid_argument("a null value (rosparam cannot set it)");
  }
}

YAML::Node toYaml(const XmlRpc::XmlRpcValue& value)
{
  XmlRpc::XmlRpcValue& v = const_cast<XmlRpc::XmlRpcValue&>(value);  // XmlRpcValue's readers are not const
  switch (v.getType())
  {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(v) ? "true" : "false");
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(std::to_string(static_cast<int>(v)));
    case XmlRpc::XmlRpcValue::TypeDouble:
    {
      const double d = static_cast<double>(v);
      if (std::isnan(d))
        return YAML::Node(".nan");
      if (std::isinf(d))
        return YAML::Node(d > 0 ? ".inf" : "-.inf");
      char text[32];
      std::snprintf(text, sizeof text, "%.17g", d);
      return YAML::Node(std::string(text));
    }
    case XmlRpc::XmlRpcValue::TypeString:
    {
      YAML::Node n(static_cast<std::string>(v));
      n.SetTag("!");
      return n;
    }
    case XmlRpc::XmlRpcValue::TypeArray:
    {
      YAML::Node n(YAML::NodeType::Sequence);
      for (int k = 0; k < v.size(); ++k)
        n.push_back(toYaml(v[k]));
      return n;
    }
    case XmlRpc::XmlRpcValue::TypeStruct:
    {
      YAML::Node n(YAML::NodeType::Map);
      for (auto it = v.begin(); it != v.end(); ++it)
        n[it->first] = toYaml(it->second);
      return n;
    }
    default:
      return YAML::Node();
  }
}

bool structuredParam(const ParamSource& params, const std::string& key, XmlRpc::XmlRpcValue& value)
{
  XmlRpc::XmlRpcValue v;
  if (!params.get(key, v))
    return false;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeString)
  {
    const std::string text = static_cast<std::string>(v);
    const std::size_t first = text.find_first_not_of(" \t");
    if (first != std::string::npos && (text[first] == '[' || text[first] == '{'))
    {
      try
      {
        v = toXmlRpc(YAML::Load(text));
      }
      catch (const std::exception& e)
      {
        throw StartupError("parameter ~" + key + " = '" + text + "' is not a YAML list or dictionary: " + e.what());
      }
    }
  }
  value = v;
  return true;
}

}  // namespace node
}  // namespace avsp
