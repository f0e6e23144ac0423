#pragma once
/**
 * @file yaml_section.hpp
 * @brief Strict YAML reading for AVSP configuration files: required keys, types, ranges,
 *        unknown keys rejected, every error naming the file and the key path.
 */
#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "avsp_terrain/input_file.hpp"

namespace avsp
{
namespace terrain
{
/**
 * @brief A YAML map being read, with the file and key path needed for error messages.
 *
 * Every accessor either returns a checked value or throws `Error` (constructed from a
 * string) whose text is "<file>: key '<a.b[2].c>' (line N): <reason>". Shared by every
 * AVSP configuration loader so that all of them fail the same, clear way.
 * @tparam Error exception type thrown on a bad value, e.g. std::runtime_error
 */
template <class Error>
class YamlSection
{
public:
  YamlSection(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path))
  {
  }

  [[noreturn]] void fail(const std::string& key, const std::string& reason) const
  {
    std::ostringstream msg;
    msg << file_ << ": key '" << qualified(key) << "'";
    const YAML::Node at = (!key.empty() && node_.IsMap() && node_[key]) ? node_[key] : node_;
    if (at.Mark().line >= 0)
      msg << " (line " << at.Mark().line + 1 << ")";
    msg << ": " << reason;
    throw Error(msg.str());
  }

  std::string qualified(const std::string& key) const
  {
    if (path_.empty())
      return key;
    return key.empty() ? path_ : path_ + "." + key;
  }

  /// Rejects keys not in `allowed` (typos must not become silent defaults).
  void allowOnly(const std::set<std::string>& allowed) const
  {
    for (const auto& kv : node_)
    {
      const std::string key = kv.first.as<std::string>();
      if (!allowed.count(key))
      {
        std::string known;
        for (const auto& k : allowed)
          known += (known.empty() ? "" : ", ") + k;
        fail(key, "unknown key (known here: " + known + ")");
      }
    }
  }

  YAML::Node require(const std::string& key) const
  {
    const YAML::Node value = node_[key];
    if (!value || value.IsNull())
      fail(key, "missing");
    return value;
  }

  std::string string(const std::string& key) const
  {
    const YAML::Node value = require(key);
    if (!value.IsScalar())
      fail(key, "must be a string");
    return value.Scalar();
  }

  double number(const std::string& key) const
  {
    const YAML::Node value = require(key);
    double out = 0.0;
    if (!value.IsScalar() || !YAML::convert<double>::decode(value, out))
      fail(key, "must be a number, got '" + (value.IsScalar() ? value.Scalar() : std::string("a non-scalar")) + "'");
    if (!std::isfinite(out))
      fail(key, "must be finite");
    return out;
  }

  double positive(const std::string& key) const
  {
    const double v = number(key);
    if (!(v > 0.0))
      fail(key, "must be > 0, got " + std::to_string(v));
    return v;
  }

  double nonNegative(const std::string& key) const
  {
    const double v = number(key);
    if (v < 0.0)
      fail(key, "must be >= 0, got " + std::to_string(v));
    return v;
  }

  bool boolean(const std::string& key) const
  {
    const YAML::Node value = require(key);
    bool out = false;
    if (!value.IsScalar() || !YAML::convert<bool>::decode(value, out))
      fail(key, "must be true or false");
    return out;
  }

  int positiveInt(const std::string& key) const
  {
    const YAML::Node value = require(key);
    int out = 0;
    if (!value.IsScalar() || !YAML::convert<int>::decode(value, out) || out <= 0)
      fail(key, "must be a whole number > 0");
    return out;
  }

  YamlSection map(const std::string& key) const
  {
    const YAML::Node value = require(key);
    if (!value.IsMap())
      fail(key, "must be a map");
    return YamlSection(value, file_, qualified(key));
  }

  std::vector<YamlSection> sequence(const std::string& key) const
  {
    const YAML::Node value = require(key);
    if (!value.IsSequence() || value.size() == 0)
      fail(key, "must be a non-empty list");
    std::vector<YamlSection> out;
    for (std::size_t k = 0; k < value.size(); ++k)
    {
      const std::string item = qualified(key) + "[" + std::to_string(k) + "]";
      if (!value[k].IsMap())
        YamlSection(value[k], file_, item).fail("", "must be a map");
      out.emplace_back(value[k], file_, item);
    }
    return out;
  }

  const YAML::Node& node() const { return node_; }

private:
  YAML::Node node_;
  std::string file_;
  std::string path_;
};

/// Largest YAML configuration file read (soils.yaml, a DEM sidecar, a vehicle's YAML: a few kB).
constexpr std::uint64_t kMaxYamlFileBytes = 16u << 20;

/**
 * @brief Loads a YAML file whose top level must be a map; only a regular file of at most
 *        kMaxYamlFileBytes is read (input_file.hpp).
 * @throw Error naming the file: refused or cannot open, not valid YAML (with line), not a map
 */
template <class Error>
YamlSection<Error> loadYamlFile(const std::string& path)
{
  YAML::Node doc;
  try
  {
    doc = YAML::Load(readInputFile(path, kMaxYamlFileBytes, "a YAML file"));
  }
  catch (const InputFileRefused& e)
  {
    throw Error(path + ": " + e.what());
  }
  catch (const YAML::Exception& e)
  {
    throw Error(path + ": line " + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!doc.IsMap())
    throw Error(path + ": the top level must be a map of keys");
  return YamlSection<Error>(doc, path, "");
}

}  // namespace terrain
}  // namespace avsp
