#include "avsp_terrain/soil.hpp"

#include <cmath>

#include "avsp_terrain/yaml_section.hpp"

namespace avsp
{
namespace terrain
{
CompressionCurve::CompressionCurve(std::vector<std::pair<double, double>> points) : points_(std::move(points))
{
  if (points_.empty() || points_.front().first != 0.0)
    throw std::invalid_argument("the curve must start at sigma = 0");
  for (std::size_t k = 0; k < points_.size(); ++k)
  {
    const auto& [sigma, rho] = points_[k];
    if (!std::isfinite(sigma) || !std::isfinite(rho) || !(rho > 0.0))
      throw std::invalid_argument("point " + std::to_string(k) + " must be finite with rho > 0");
    if (k > 0 && !(sigma > points_[k - 1].first))
      throw std::invalid_argument("sigma must increase (point " + std::to_string(k) + ")");
    if (k > 0 && rho < points_[k - 1].second)
      throw std::invalid_argument("rho must not decrease with sigma (point " + std::to_string(k) + ")");
  }
}

double CompressionCurve::density(double sigma) const
{
  if (sigma <= 0.0)
    return points_.front().second;
  for (std::size_t k = 1; k < points_.size(); ++k)
  {
    if (sigma <= points_[k].first)
    {
      const auto& [s0, r0] = points_[k - 1];
      const auto& [s1, r1] = points_[k];
      return r0 + (r1 - r0) * (sigma - s0) / (s1 - s0);
    }
  }
  return points_.back().second;
}

namespace
{
using Section = YamlSection<SoilError>;

/// phi in rad from a `friction_angle_deg` key: in [0, 90) degrees.
double frictionAngle(const Section& s)
{
  const double deg = s.nonNegative("friction_angle_deg");
  if (deg >= 90.0)
    s.fail("friction_angle_deg", "must be below 90");
  return deg * M_PI / 180.0;
}

/// The `rigid` section: what running gear meets on pavement, concrete or rock.
void readRigid(const Section& s, SoilParameters& p)
{
  const Section rigid = s.map("rigid");
  rigid.allowOnly({ "friction_peak", "friction_sliding", "rolling_resistance" });
  p.friction_peak = rigid.positive("friction_peak");
  if (p.friction_peak > 2.0)
    rigid.fail("friction_peak", "must be at most 2 (no tyre on any surface grips harder)");
  p.friction_sliding = rigid.positive("friction_sliding");
  if (p.friction_sliding > p.friction_peak)
    rigid.fail("friction_sliding", "must not exceed friction_peak");
  p.rolling_resistance = rigid.nonNegative("rolling_resistance");
  if (p.rolling_resistance > 0.5)
    rigid.fail("rolling_resistance", "must be at most 0.5");
}

void readDeformable(const Section& s, SoilParameters& p)
{
  const Section simple = s.map("simple");
  simple.allowOnly({ "h0", "rho0", "compression", "elastic_e", "b1", "b2", "rolling_resistance" });
  p.h0 = simple.positive("h0");
  p.rho0 = simple.positive("rho0");
  p.elastic_e = simple.nonNegative("elastic_e");
  p.b1 = simple.nonNegative("b1");
  p.b2 = simple.nonNegative("b2");
  p.rolling_resistance = simple.nonNegative("rolling_resistance");
  const YAML::Node curve = simple.require("compression");
  std::vector<std::pair<double, double>> points;
  if (!curve.IsSequence())
    simple.fail("compression", "must be a list of [sigma Pa, rho kg/m^3] pairs");
  for (const YAML::Node& pt : curve)
  {
    double sigma = 0.0, rho = 0.0;
    if (!pt.IsSequence() || pt.size() != 2 || !YAML::convert<double>::decode(pt[0], sigma) ||
        !YAML::convert<double>::decode(pt[1], rho))
      simple.fail("compression", "must be a list of [sigma Pa, rho kg/m^3] pairs");
    points.emplace_back(sigma, rho);
  }
  try
  {
    p.compression = CompressionCurve(points);
  }
  catch (const std::invalid_argument& e)
  {
    simple.fail("compression", e.what());
  }
  if (p.compression.density(0.0) != p.rho0)
    simple.fail("compression", "must start at rho0 (the density at sigma = 0)");

  const Section strength = s.map("strength");
  strength.allowOnly({ "cohesion_kpa", "friction_angle_deg", "shear_modulus" });
  p.cohesion = 1e3 * strength.nonNegative("cohesion_kpa");
  p.friction_angle = frictionAngle(strength);
  p.shear_modulus = strength.positive("shear_modulus");

  const Section bekker = s.map("bekker");
  bekker.allowOnly({ "n", "k_c_kn", "k_phi_kn", "k_unload_kn" });
  p.n = bekker.positive("n");
  p.k_c = 1e3 * bekker.nonNegative("k_c_kn");
  p.k_phi = 1e3 * bekker.nonNegative("k_phi_kn");
  if (!(p.k_c > 0.0 || p.k_phi > 0.0))
    bekker.fail("k_phi_kn", "k_c and k_phi cannot both be 0 (the soil would carry no load)");
  p.k_unload = 1e3 * bekker.positive("k_unload_kn");
}

SoilParameters readSoil(const Section& s, const std::string& name)
{
  SoilParameters p;
  p.name = name;
  const std::string model = s.string("model");
  if (model == "simple")
    p.model = SinkageModel::kSimple;
  else if (model == "bekker")
    p.model = SinkageModel::kBekker;
  else if (model == "rigid")
    p.model = SinkageModel::kRigid;
  else
    s.fail("model", "must be 'simple', 'bekker' or 'rigid', got '" + model + "'");
  if (p.model == SinkageModel::kRigid)
  {
    // Nothing of a soil's deformation or strength applies to pavement: those sections would
    // be numbers nobody reads.
    s.allowOnly({ "source", "model", "rigid", "moisture" });
    readRigid(s, p);
  }
  else
  {
    s.allowOnly({ "source", "model", "simple", "strength", "bekker", "moisture" });
    readDeformable(s, p);
  }
  p.source = s.string("source");

  const Section m = s.map("moisture");
  m.allowOnly({ "initial", "dry", "saturated", "wetting_per_mm", "drying_time_constant_h", "table" });
  MoistureSpec& spec = p.moisture;
  spec.initial = m.nonNegative("initial");
  spec.dry = m.nonNegative("dry");
  spec.saturated = m.positive("saturated");
  if (spec.dry > spec.saturated || spec.initial > spec.saturated)
    m.fail("saturated", "must be at least 'dry' and 'initial'");
  spec.wetting_per_mm = m.nonNegative("wetting_per_mm");
  spec.drying_time_constant = 3600.0 * m.positive("drying_time_constant_h");
  const YAML::Node table = m.require("table");
  if (!table.IsSequence())
    m.fail("table", "must be a list (empty when moisture does not change the soil)");
  const std::vector<Section> rows = table.size() > 0 ? m.sequence("table") : std::vector<Section>{};
  if (!rows.empty() && p.model == SinkageModel::kRigid)
    m.fail("table", "must be [] for a rigid surface (moisture changes a soil's strength, not pavement's)");
  for (std::size_t k = 0; k < rows.size(); ++k)
  {
    const Section& r = rows[k];
    r.allowOnly({ "moisture", "cohesion_kpa", "friction_angle_deg", "n", "k_c_kn", "k_phi_kn" });
    MoistureRow mr;
    mr.moisture = r.nonNegative("moisture");
    if (mr.moisture == spec.initial)
      r.fail("moisture", "equals moisture.initial, whose values are 'strength' and 'bekker'");
    mr.cohesion = 1e3 * r.nonNegative("cohesion_kpa");
    mr.friction_angle = frictionAngle(r);
    mr.n = r.positive("n");
    mr.k_c = 1e3 * r.nonNegative("k_c_kn");
    mr.k_phi = 1e3 * r.nonNegative("k_phi_kn");
    spec.table.push_back(mr);
  }
  return p;
}
}  // namespace

SoilLibrary SoilLibrary::load(const std::string& path)
{
  const Section root = loadYamlFile<SoilError>(path);
  root.allowOnly({ "soils" });
  const Section soils = root.map("soils");
  SoilLibrary library;
  library.path_ = path;
  try
  {
    for (const auto& kv : soils.node())
    {
      const std::string name = kv.first.as<std::string>();
      library.soils_[name] = readSoil(soils.map(name), name);
    }
  }
  catch (const YAML::Exception& e)
  {
    throw SoilError(path + ": line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (library.soils_.empty())
    soils.fail("", "no soil defined");
  return library;
}

const SoilParameters& SoilLibrary::get(const std::string& name) const
{
  const auto it = soils_.find(name);
  if (it == soils_.end())
    throw SoilError(path_ + ": no soil named '" + name + "'");
  return it->second;
}

std::vector<std::string> SoilLibrary::names() const
{
  std::vector<std::string> out;
  for (const auto& kv : soils_)
    out.push_back(kv.first);
  return out;
}

}  // namespace terrain
}  // namespace avsp
