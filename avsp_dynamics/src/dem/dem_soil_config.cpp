#include "avsp_dynamics/dem/dem_soil_config.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include <yaml-cpp/yaml.h>

#include "parameter_error.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace
{
bool wholeBlocks(double length, double block)
{
  const double n = length / block;
  return n >= 1.0 - 1e-9 && std::abs(n - std::round(n)) < 1e-6;
}

using detail::fail;
using detail::str;

struct Reader
{
  std::string where;

  [[noreturn]] void fail(const std::string& key, const std::string& why) const
  {
    throw DemParameterError(where + (key.empty() ? "" : "." + key) + ": " + why);
  }

  /// The mapping's keys, each read by its reader; any other key is refused.
  void mapping(const YAML::Node& n, const std::string& key,
               const std::map<std::string, std::function<void(const YAML::Node&, const std::string&)>>& readers) const
  {
    if (!n.IsMap())
      fail(key, "must be a mapping");
    for (const auto& kv : n)
    {
      const std::string k = kv.first.as<std::string>();
      const auto it = readers.find(k);
      if (it == readers.end())
      {
        std::string known;
        for (const auto& r : readers)
          known += (known.empty() ? "" : ", ") + r.first;
        fail(key.empty() ? k : key + "." + k, "unknown key (allowed: " + known + ")");
      }
      it->second(kv.second, key.empty() ? k : key + "." + k);
    }
  }

  double number(const YAML::Node& n, const std::string& key) const
  {
    double v = 0.0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
      fail(key, "must be a finite number");
    return v;
  }

  long long integer(const YAML::Node& n, const std::string& key) const
  {
    long long v = 0;
    if (!n.IsScalar() || !YAML::convert<long long>::decode(n, v))
      fail(key, "must be an integer");
    return v;
  }
};
}  // namespace

DemSoilSpec parseDemSoilSpec(const std::string& yaml_text, const std::string& where)
{
  const Reader r{ where };
  YAML::Node root;
  try
  {
    root = YAML::Load(yaml_text);
  }
  catch (const YAML::Exception& e)
  {
    r.fail("", "YAML: line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  DemSoilSpec s;
  DemParameters& p = s.parameters;
  bool segment = false;
  auto num = [&](double& field) {
    return [&r, &field](const YAML::Node& n, const std::string& k) { field = r.number(n, k); };
  };
  r.mapping(root, "",
            { { "segment",
                [&](const YAML::Node& n, const std::string& k) {
                  bool lo = false, hi = false;
                  r.mapping(n, k,
                            { { "x_min",
                                [&](const YAML::Node& v, const std::string& kk) {
                                  s.segment.x_min = r.number(v, kk);
                                  lo = true;
                                } },
                              { "x_max", [&](const YAML::Node& v, const std::string& kk) {
                                 s.segment.x_max = r.number(v, kk);
                                 hi = true;
                               } } });
                  if (!lo || !hi)
                    r.fail(k, "needs x_min and x_max (m)");
                  segment = true;
                } },
              { "patch",
                [&](const YAML::Node& n, const std::string& k) {
                  r.mapping(n, k,
                            { { "length", num(s.segment.patch_length) },
                              { "front_margin", num(s.segment.front_margin) },
                              { "settle_time", num(s.segment.settle_time) },
                              { "max_yaw_deg", num(s.segment.max_yaw_deg) },
                              { "facets", [&](const YAML::Node& v, const std::string& kk) {
                                 const long long f = r.integer(v, kk);
                                 if (f < 12 || f > 100000)
                                   r.fail(kk, "must be in [12, 100000] flat faces round a rim");
                                 s.segment.facets = static_cast<int>(f);
                               } } });
                } },
              { "template",
                [&](const YAML::Node& n, const std::string& k) {
                  r.mapping(n, k,
                            { { "length", num(s.template_length) },
                              { "width", num(s.template_width) },
                              { "depth", num(s.template_depth) } });
                } },
              { "particles",
                [&](const YAML::Node& n, const std::string& k) {
                  if (!n.IsSequence() || n.size() == 0)
                    r.fail(k, "must be a non-empty list of {radius, mass_fraction}");
                  p.particles.clear();
                  for (std::size_t i = 0; i < n.size(); ++i)
                  {
                    ParticleClass c;
                    bool radius = false, fraction = false;
                    r.mapping(n[i], k + "[" + std::to_string(i) + "]",
                              { { "radius",
                                  [&](const YAML::Node& v, const std::string& kk) {
                                    c.radius = r.number(v, kk);
                                    radius = true;
                                  } },
                                { "mass_fraction", [&](const YAML::Node& v, const std::string& kk) {
                                   c.mass_fraction = r.number(v, kk);
                                   fraction = true;
                                 } } });
                    if (!radius || !fraction)
                      r.fail(k + "[" + std::to_string(i) + "]", "needs radius (m) and mass_fraction");
                    p.particles.push_back(c);
                  }
                } },
              { "youngs_modulus", num(p.youngs_modulus) },
              { "poisson_ratio", num(p.poisson_ratio) },
              { "restitution", num(p.restitution) },
              { "friction", num(p.friction) },
              { "rolling_friction", num(p.rolling_friction) },
              { "wall_friction", num(p.wall_friction) },
              { "bulk_density", num(p.bulk_density) },
              { "timestep", num(p.timestep) },
              { "coupling_interval", num(p.coupling_interval) },
              { "stability_fraction", num(p.stability_fraction) },
              { "memory_budget", num(p.memory_budget) },
              { "seed", [&](const YAML::Node& n, const std::string& k) {
                 const long long v = r.integer(n, k);
                 if (v < 0)
                   r.fail(k, "must be >= 0");
                 p.seed = static_cast<std::uint64_t>(v);
               } } });
  if (!segment)
    r.fail("segment", "required: {x_min, x_max} (m, map x) where the DEM soil lies");
  try
  {
    checkDemSoilSpec(s);
  }
  catch (const DemParameterError& e)
  {
    throw DemParameterError(where + ": " + e.what());
  }
  return s;
}

void checkDemSoilSpec(const DemSoilSpec& s)
{
  validate(s.parameters);
  const double rmax = maxRadius(s.parameters);
  auto size = [&](const char* key, double v, double min, const char* what) {
    if (!(std::isfinite(v) && v >= min))
      throw DemParameterError(std::string("dem.template.") + key + ": " + std::to_string(v) + " m must be at least " +
                              what + " (" + std::to_string(min) + " m)");
  };
  size("length", s.template_length, 4.0 * rmax, "four largest particle radii");
  size("width", s.template_width, 4.0 * rmax, "four largest particle radii");
  size("depth", s.template_depth, 2.0 * rmax + 1e-9, "two largest particle radii");
  // The patches of two vehicle sides, the template's width and depth (the bed's particles).
  checkParticleBudget(s.parameters, 2.0 * s.segment.patch_length * s.template_width * s.template_depth,
                      "dem.patch.length");
  checkSegment(s.segment, s.template_length);
}

void checkSegment(const DemSegmentSpec& spec, double template_length)
{
  const double L = template_length;
  if (!std::isfinite(spec.x_min) || !std::isfinite(spec.x_max) || !(spec.x_max > spec.x_min))
    fail("segment.x_max", "must be a finite number > x_min (" + str(spec.x_min) + ")");
  if (!wholeBlocks(spec.x_max - spec.x_min, L))
    fail("segment.x_max", "the segment's length " + str(spec.x_max - spec.x_min) +
                              " m is not a whole number of template lengths (" + str(L) + " m)");
  if (!wholeBlocks(spec.patch_length, L))
    fail("patch.length", str(spec.patch_length) + " m is not a whole number of template lengths (" + str(L) + " m)");
  if (spec.patch_length > spec.x_max - spec.x_min + 1e-9)
    fail("patch.length",
         str(spec.patch_length) + " m is longer than the segment (" + str(spec.x_max - spec.x_min) + " m)");
  if (!(spec.front_margin > 0.0 && spec.front_margin < spec.patch_length))
    fail("patch.front_margin", "must be in (0, patch.length)");
  if (!(spec.settle_time >= 0.0 && spec.settle_time <= 10.0))
    fail("patch.settle_time", "must be in [0, 10] s");
  if (spec.facets < 12)
    fail("patch.facets", "at least 12 flat faces round a rim (got " + std::to_string(spec.facets) + ")");
  if (!(spec.max_yaw_deg > 0.0 && spec.max_yaw_deg <= 45.0))
    fail("patch.max_yaw_deg", "must be in (0, 45]");
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
