#pragma once
/**
 * @file contact_soil.hpp
 * @brief One soil prepared for the per-grid-point contact solve of DeformableTerrain: the
 *        constants the inner loop needs (tan phi, the compression curve as arrays) and the
 *        pressure-sinkage laws of docs/MODELS.md (simple T2 + T3 + T4, or Bekker's T13 family)
 *        solved in closed form, so a contact costs no iteration per point.
 */
#include <cmath>
#include <vector>

#include "avsp_terrain/soil.hpp"

namespace avsp
{
namespace terrain
{
/// Pa: a simple-model point that cannot absorb a penetration at any stress (compacted to its
/// hard layer with no elastic or bearing-flow give left) carries this stress.
constexpr double kRigidStress = 1e8;
/// Pa/m: the largest pressure-sinkage slope a point reports (a point with no give left).
constexpr double kMaxPointStiffness = 1e10;

/// A point's pressure at a penetration and how it changes with it.
struct PointLoad
{
  double sigma = 0.0;   ///< Pa
  double slope = 0.0;   ///< Pa/m, d sigma / d penetration going deeper (loading)
  double unload = 0.0;  ///< Pa/m, d sigma / d penetration coming back up (unloading: elastic)
  bool virgin = false;  ///< the point yields (first loading): its permanent sinkage grows
};

/**
 * @brief A validated soil with the constants of the contact's inner loop precomputed.
 *
 * The simple model's extra sinkage of a point under stress sigma (docs/MODELS.md T2 + T4's b1
 * term + T3, with the point's state: plastic z_p, displaced z_f - z_n, largest stress seen) is
 *
 *     e(sigma) = max(z_p(max(sigma, sigma_max)) - plastic, 0) + b1 max(sigma - sigma_max, 0)
 *                + (h0 - plastic - displaced)^+ E sigma
 *
 * which only grows with sigma. On each segment of the piecewise-linear compression curve
 * rho(sigma), z_p = h0 (1 - rho0 / rho) makes e(sigma) = penetration a quadratic in sigma,
 * so stressForPenetration() finds the segment by evaluating e at the breakpoints and solves
 * it exactly (no iteration, no tolerance).
 */
class ContactSoil
{
public:
  /**
   * @brief Prepares `soil`.
   * @throw std::invalid_argument naming the soil and the field when a parameter is not finite
   *        or out of range (h0, rho0 > 0; compression curve present; E, b1, b2, f, c >= 0;
   *        0 <= phi < 90 deg; K > 0; Bekker n > 0, k_c, k_phi >= 0 and not both 0,
   *        k_unload > 0; rigid: 0 < friction_sliding <= friction_peak, f >= 0)
   */
  explicit ContactSoil(const SoilParameters& soil);

  SinkageModel model() const { return model_; }

  /// T2: h0 (1 - rho0 / rho(sigma_max)), m; equal to plasticSinkage(soil, sigma_max).
  double plasticSinkage(double sigma_max) const { return h0 * (1.0 - rho0 / density(sigma_max)); }

  /// T3: (h0 - z)^+ E sigma, m, for current total deformation z (m).
  double elasticSinkage(double sigma, double z) const
  {
    const double depth = h0 - z;
    return (depth > 0.0 ? depth : 0.0) * elastic_e * (sigma > 0.0 ? sigma : 0.0);
  }

  /**
   * @brief The simple model's extra sinkage e(sigma) (m) of a point in the given state (see
   *        class doc): plastic z_p (m), deformation z = z_p + z_f - z_n (m, T3's z), largest
   *        stress seen (Pa).
   */
  double extraSinkage(double plastic, double deformation, double sigma_max, double sigma) const;

  /**
   * @brief Simple model: the stress sigma >= 0 (Pa) at which e(sigma) = penetration (m, > 0)
   *        for a point in the given state (as extraSinkage()), exact to rounding;
   *        kRigidStress when no stress up to it absorbs the penetration.
   */
  double stressForPenetration(double plastic, double deformation, double sigma_max, double penetration) const;

  /// Bekker-Wong modulus k_c / b + k_phi (N/m^(n+2)) for a contact of smaller dimension b (m).
  double bekkerModulus(double b) const { return k_c / b + k_phi; }

  /// Bekker-Wong pressure k z^n (Pa) for modulus k from bekkerModulus() and sinkage z (m).
  double bekkerPressure(double modulus, double z) const;

  /**
   * @brief A Bekker point pressed `penetration` m (> 0) below its surface, which lies `plastic` m
   *        (its permanent sinkage) below the undeformed one: reloading along k_unload until the
   *        first-loading law k (plastic + penetration)^n is reached, then along that law:
   *        sigma = min(k_unload penetration, k (plastic + penetration)^n). A point that yields
   *        keeps plastic + penetration - sigma / k_unload once unloaded (it springs back by
   *        sigma / k_unload), so a parked wheel rests on an elastic floor instead of digging.
   * @param modulus bekkerModulus() of the contact
   */
  PointLoad bekkerLoad(double modulus, double plastic, double penetration) const
  {
    // Inline: a wheel's contact asks it for every sample of its rim (the inner loop).
    PointLoad out;
    if (!(penetration > 0.0))
      return out;
    const double depth = plastic + penetration;
    const double virgin = modulus * std::pow(depth, n);
    const double elastic = k_unload * penetration;
    out.unload = k_unload;
    if (elastic < virgin)
    {
      out.sigma = elastic;
      out.slope = k_unload;
    }
    else
    {
      out.sigma = virgin;
      out.slope = n * virgin / depth;
      out.virgin = true;
    }
    return out;
  }

  /// Simple model: the point's load at `penetration` (stressForPenetration()) with its slopes.
  PointLoad simpleLoad(double plastic, double deformation, double sigma_max, double penetration) const;

  // Constants read by the contact's inner loop (SI, as in SoilParameters).
  double cohesion = 0.0;            ///< c, Pa
  double tan_phi = 0.0;             ///< tan(friction angle)
  double shear_modulus = 0.0;       ///< K, m
  double rolling_resistance = 0.0;  ///< f of T12
  double b1 = 0.0;                  ///< m/Pa
  double b2 = 0.0;                  ///< 1/Pa
  double h0 = 0.0;                  ///< m
  double rho0 = 0.0;                ///< kg/m^3
  double elastic_e = 0.0;           ///< 1/Pa
  double n = 0.0;                   ///< Bekker exponent
  double k_c = 0.0;                 ///< N/m^(n+1)
  double k_phi = 0.0;               ///< N/m^(n+2)
  double k_unload = 0.0;            ///< N/m^3, Bekker unloading/reloading
  double friction_peak = 0.0;       ///< rigid surfaces
  double friction_sliding = 0.0;    ///< rigid surfaces

private:
  /// kg/m^3 at stress sigma: the compression curve, same arithmetic as CompressionCurve (so
  /// that z_p matches plasticSinkage() to the bit). Inline: it runs for every loaded point.
  double density(double sigma) const
  {
    if (sigma <= 0.0)
      return rho_.front();
    for (std::size_t k = 1; k < sigma_.size(); ++k)
      if (sigma <= sigma_[k])
        return rho_[k - 1] + (rho_[k] - rho_[k - 1]) * (sigma - sigma_[k - 1]) / (sigma_[k] - sigma_[k - 1]);
    return rho_.back();
  }
  /// T2's new compaction (m) over a point already at `plastic` (m), given z_p there (m).
  static double plasticIncrement(double z_p, double plastic)
  {
    const double increment = z_p - plastic;
    return increment > 0.0 ? increment : 0.0;
  }

  SinkageModel model_;
  std::vector<double> sigma_;  ///< compression curve breakpoints, Pa, sigma_[0] = 0
  std::vector<double> rho_;    ///< kg/m^3 at the breakpoints
  std::vector<double> z_p_;    ///< m, T2 at the breakpoints (what plasticSinkage() gives there)
  /// Segment k of the curve ([sigma_{k-1}, sigma_k], k >= 1) as rho = alpha_[k] + beta_[k] sigma
  /// (kg/m^3, kg/m^3/Pa), computed once instead of per loaded point.
  std::vector<double> beta_, alpha_;
};

}  // namespace terrain
}  // namespace avsp
