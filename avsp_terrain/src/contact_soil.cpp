#include "avsp_terrain/contact_soil.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace avsp
{
namespace terrain
{
namespace
{
[[noreturn]] void reject(const SoilParameters& soil, const char* field, const char* rule, double value)
{
  std::ostringstream why;
  why << "soil '" << soil.name << "': " << field << " must be " << rule << ", got " << value;
  throw std::invalid_argument(why.str());
}

void requirePositive(const SoilParameters& soil, const char* field, double value)
{
  if (!(value > 0.0) || !std::isfinite(value))
    reject(soil, field, "finite and > 0", value);
}

void requireNonNegative(const SoilParameters& soil, const char* field, double value)
{
  if (!(value >= 0.0) || !std::isfinite(value))
    reject(soil, field, "finite and >= 0", value);
}
}  // namespace

ContactSoil::ContactSoil(const SoilParameters& soil) : model_(soil.model)
{
  // The library validates what it loads; a palette may also be built by hand (tests, moisture
  // updates), and a NaN here would silently poison every force of the contact.
  requireNonNegative(soil, "rolling_resistance", soil.rolling_resistance);
  if (soil.model == SinkageModel::kRigid)
  {
    requirePositive(soil, "friction_peak", soil.friction_peak);
    requirePositive(soil, "friction_sliding", soil.friction_sliding);
    if (soil.friction_sliding > soil.friction_peak)
      reject(soil, "friction_sliding", "at most friction_peak", soil.friction_sliding);
    friction_peak = soil.friction_peak;
    friction_sliding = soil.friction_sliding;
    rolling_resistance = soil.rolling_resistance;
    return;
  }
  requirePositive(soil, "h0", soil.h0);
  requirePositive(soil, "rho0", soil.rho0);
  requireNonNegative(soil, "elastic_e", soil.elastic_e);
  requireNonNegative(soil, "b1", soil.b1);
  requireNonNegative(soil, "b2", soil.b2);
  requireNonNegative(soil, "cohesion", soil.cohesion);
  requireNonNegative(soil, "friction_angle", soil.friction_angle);
  if (!(soil.friction_angle < 0.5 * M_PI))
    reject(soil, "friction_angle", "below pi/2 rad", soil.friction_angle);
  requirePositive(soil, "shear_modulus", soil.shear_modulus);
  if (soil.compression.points().empty())
    reject(soil, "compression", "a curve with at least one point", 0.0);
  if (soil.model == SinkageModel::kBekker)
  {
    requirePositive(soil, "n", soil.n);
    requireNonNegative(soil, "k_c", soil.k_c);
    requireNonNegative(soil, "k_phi", soil.k_phi);
    if (!(soil.k_c > 0.0 || soil.k_phi > 0.0))
      reject(soil, "k_c or k_phi", "> 0 (the soil would carry no load)", 0.0);
    requirePositive(soil, "k_unload", soil.k_unload);
  }
  cohesion = soil.cohesion;
  tan_phi = std::tan(soil.friction_angle);
  shear_modulus = soil.shear_modulus;
  rolling_resistance = soil.rolling_resistance;
  b1 = soil.b1;
  b2 = soil.b2;
  h0 = soil.h0;
  rho0 = soil.rho0;
  elastic_e = soil.elastic_e;
  n = soil.n;
  k_c = soil.k_c;
  k_phi = soil.k_phi;
  k_unload = soil.k_unload;
  for (const auto& [sigma, rho] : soil.compression.points())
  {
    sigma_.push_back(sigma);
    rho_.push_back(rho);
    z_p_.push_back(h0 * (1.0 - rho0 / rho));
  }
  // rho = alpha + beta sigma on each segment of the curve, as stressForPenetration() solves on it.
  beta_.assign(sigma_.size(), 0.0);
  alpha_.assign(sigma_.size(), 0.0);
  for (std::size_t k = 1; k < sigma_.size(); ++k)
  {
    beta_[k] = (rho_[k] - rho_[k - 1]) / (sigma_[k] - sigma_[k - 1]);
    alpha_[k] = rho_[k - 1] - beta_[k] * sigma_[k - 1];
  }
}

double ContactSoil::extraSinkage(double plastic, double deformation, double sigma_max, double sigma) const
{
  const double compaction = plasticIncrement(plasticSinkage(std::max(sigma, sigma_max)), plastic);
  const double flow = b1 * std::max(sigma - sigma_max, 0.0);
  return compaction + flow + elasticSinkage(sigma, deformation);
}

double ContactSoil::stressForPenetration(double plastic, double deformation, double sigma_max, double penetration) const
{
  const double a = elasticSinkage(1.0, deformation);  // m/Pa: T3's (h0 - z)^+ E
  // Virgin points (the common case under a moving wheel) need no curve lookup.
  const double q0 = plasticIncrement(sigma_max > 0.0 ? plasticSinkage(sigma_max) : z_p_.front(), plastic);
  // Reloading up to the largest stress seen: no new compaction or bearing flow, only T3.
  if (q0 + a * sigma_max >= penetration)
    return a > 0.0 ? std::max((penetration - q0) / a, 0.0) : 0.0;

  // Virgin loading beyond sigma_max: e(sigma) - penetration = C + d sigma - h0 rho0 / rho(sigma)
  // while the compaction increment is positive. Walk the curve's breakpoints to the segment
  // where it changes sign (it only grows), then solve there exactly.
  const double d = b1 + a;
  const double c = h0 - plastic - b1 * sigma_max - penetration;
  std::size_t k = 1;
  while (k < sigma_.size() && sigma_[k] <= sigma_max)
    ++k;
  for (; k < sigma_.size(); ++k)
  {
    const double at_k = plasticIncrement(z_p_[k], plastic) + b1 * (sigma_[k] - sigma_max) + a * sigma_[k];
    if (at_k >= penetration)
      break;
  }
  double sigma;
  if (k == sigma_.size())
  {
    // Beyond the table the density holds: only bearing flow and T3 still give.
    if (!(d > 0.0))
      return kRigidStress;
    sigma = (penetration + b1 * sigma_max - plasticIncrement(z_p_.back(), plastic)) / d;
  }
  else
  {
    // rho = alpha + beta sigma on [sigma_{k-1}, sigma_k]: (C + d sigma)(alpha + beta sigma) = h0 rho0.
    const double lo = std::max(sigma_[k - 1], sigma_max), hi = sigma_[k];
    const double beta = beta_[k], alpha = alpha_[k];
    const double qa = d * beta, qb = d * alpha + c * beta, qc = c * alpha - h0 * rho0;
    if (qa > 0.0)
    {
      // Both factors are positive at the physical root, which is therefore the larger one.
      // The roots are q / qa and qc / q (no cancellation); with qa > 0 the larger is qc / q
      // when qb >= 0 (then q <= 0 and q / qa <= 0) and q / qa otherwise.
      const double root = std::sqrt(std::max(qb * qb - 4.0 * qa * qc, 0.0));
      const double q = -0.5 * (qb + std::copysign(root, qb));
      sigma = qb >= 0.0 ? (q != 0.0 ? qc / q : 0.0) : q / qa;
    }
    else
    {
      sigma = (qb != 0.0) ? -qc / qb : hi;
    }
    sigma = std::clamp(sigma, lo, hi);
    // Just above sigma_max the float-stored plastic may exceed z_p(sigma) by a rounding: there
    // the compaction increment is clamped to 0 and e(sigma) is linear. (Virgin points cannot
    // be there; rho on this segment is alpha + beta sigma.)
    // h0 (1 - rho0 / rho) < plastic, multiplied out by rho > 0.
    if (plastic > 0.0 && d > 0.0 && (h0 - plastic) * (alpha + beta * sigma) < h0 * rho0)
      sigma = std::max((penetration + b1 * sigma_max) / d, lo);
  }
  return std::min(sigma, kRigidStress);
}

double ContactSoil::bekkerPressure(double modulus, double z) const
{
  return z > 0.0 ? modulus * std::pow(z, n) : 0.0;
}

PointLoad ContactSoil::simpleLoad(double plastic, double deformation, double sigma_max, double penetration) const
{
  PointLoad out;
  out.sigma = stressForPenetration(plastic, deformation, sigma_max, penetration);
  const double a = elasticSinkage(1.0, deformation);  // m/Pa, the elastic part's give
  out.unload = a > 1.0 / kMaxPointStiffness ? 1.0 / a : kMaxPointStiffness;
  if (out.sigma >= kRigidStress)
  {
    out.slope = kMaxPointStiffness;
    return out;
  }
  // de/dsigma at the solution: T3 always; beyond sigma_max also T4's b1 and T2's compaction,
  // h0 rho0 rho'(sigma) / rho^2 on the curve's segment (0 where the point is not compacting).
  double give = a;
  if (out.sigma > sigma_max)
  {
    out.virgin = true;
    give += b1;
    std::size_t k = 1;
    while (k < sigma_.size() && sigma_[k] < out.sigma)
      ++k;
    if (k < sigma_.size())
    {
      const double rho = alpha_[k] + beta_[k] * out.sigma;
      if (h0 * (1.0 - rho0 / rho) > plastic)
        give += h0 * rho0 * beta_[k] / (rho * rho);
    }
  }
  out.slope = give > 1.0 / kMaxPointStiffness ? 1.0 / give : kMaxPointStiffness;
  return out;
}

}  // namespace terrain
}  // namespace avsp
