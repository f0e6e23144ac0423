#pragma once
/**
 * @file terramechanics.hpp
 * @brief The soil-contact formulas of docs/MODELS.md as pure functions: compaction (T2), elastic
 *        sinkage (T3), Mohr-Coulomb/Janosi-Hanamoto traction (T7, T11), slip (T8-T10),
 *        resistance (T12), Bekker-Wong pressure-sinkage and the rigid wheel (T13).
 *        SI units throughout; no state (the deformable grid builds on these).
 */
#include <vector>

#include "avsp_terrain/soil.hpp"

namespace avsp
{
namespace terrain
{
/// T7 envelope: c + sigma tan(phi), Pa, for normal stress sigma (Pa, >= 0).
double shearStrength(const SoilParameters& soil, double sigma);

/// T7 at one point with shear displacement j (m): (c + sigma tan phi)(1 - exp(-j / K)), Pa.
double shearStress(const SoilParameters& soil, double sigma, double j);

/**
 * @brief Mean T7 shear stress over a strip of the contact between distances x0 < x1 (m)
 *        behind the leading edge, at slip s: the shear displacement there is j = s x, and
 *        the exponential is integrated exactly over the strip (no sampling error).
 */
double meanShearStress(const SoilParameters& soil, double sigma, double slip, double x0, double x1);

/// One strip of a contact patch under uniform normal stress.
struct ContactStrip
{
  double area;     ///< m^2
  double x_front;  ///< m behind the contact's leading edge
  double x_back;   ///< m, > x_front
  double sigma;    ///< Pa, normal stress
};

/// T11: tractive force of a contact (N) at slip s in [-1, 1]: sum of mean shear x area.
double tractionForce(const SoilParameters& soil, const std::vector<ContactStrip>& strips, double slip);

/**
 * @brief Janosi-Hanamoto tractive effort of a contact of area A (m^2), length l (m) under
 *        load W (N) at slip s, closed form: (A c + W tan phi)[1 - K/(s l)(1 - exp(-s l / K))].
 *        The reference the strip sum must reproduce for uniform pressure.
 */
double janosiTractiveEffort(const SoilParameters& soil, double area, double length, double load, double slip);

/**
 * @brief T8 longitudinal slip in [-1, 1] from the running gear's theoretical speed and the
 *        speed over ground (m/s, same sign when moving the same way): driving
 *        (v_t - v)/v_t >= 0, braking (v_t - v)/v <= 0 (skid), 0 when both are 0.
 */
double longitudinalSlip(double v_theoretical, double v_actual);

/// m/s: below this speed of travel and of the running gear, slip is taken relative to it (a
/// wheel at rest, or creeping, reads a slip near 0 instead of a ratio of two speeds near 0).
constexpr double kSlipRegularisationSpeed = 0.1;

/**
 * @brief T8 regularised at low speed: (v_t - v) / max(|v|, |v_t|, v0), clamped to [-1, 1]. Equal
 *        to longitudinalSlip() whenever the faster of the two speeds exceeds v0 and both have the
 *        same sign; near rest it goes to 0 with the speeds instead of jumping to +-1.
 */
double regularisedSlip(double v_theoretical, double v_actual, double v0 = kSlipRegularisationSpeed);

/// T9: wheel theoretical speed r omega (m/s) for radius r (m) and spin rate omega (rad/s).
double wheelTheoreticalSpeed(double radius, double omega);

/// T10: track theoretical speed p N omega / (2 pi) (m/s) for pitch p (m), N sprocket teeth.
double trackTheoreticalSpeed(double pitch, int teeth, double omega);

/// T2: plastic sinkage h0 (1 - rho0 / rho(sigma_max)) (m) under the largest stress seen.
double plasticSinkage(const SoilParameters& soil, double sigma_max);

/// T3: elastic sinkage (h0 - z) E sigma (m) at stress sigma with current total sinkage z (m).
double elasticSinkage(const SoilParameters& soil, double sigma, double z);

/// T12: (c + sigma tan phi) w z_rel + f A sigma (N) for a segment of width w (m) sunk z_rel
/// (m) into the surrounding soil, contact area A (m^2), normal stress sigma (Pa).
double resistanceForce(const SoilParameters& soil, double sigma, double width, double z_rel, double area);

/// Bekker-Wong pressure (k_c / b + k_phi) z^n (Pa) for contact width b (m) and sinkage z (m).
double bekkerPressure(const SoilParameters& soil, double b, double z);

/// Vertical load and compaction resistance of a rigid wheel in Bekker-Wong soil.
struct RigidWheelLoad
{
  double normal_force;           ///< N, vertical soil reaction
  double compaction_resistance;  ///< N, horizontal soil reaction (motion resistance)
  double contact_length;         ///< m, horizontal length of the loaded arc
};

/**
 * @brief A rigid wheel (radius r, width b) rolling at sinkage z0 in Bekker-Wong soil: radial
 *        pressure p(z) on the front arc only (the rear has unloaded), integrated numerically
 *        over the exact circle.
 * @param samples integration points along the arc (midpoint rule)
 */
RigidWheelLoad rigidWheelOnBekkerSoil(const SoilParameters& soil, double radius, double width, double sinkage,
                                      int samples = 4000);

/**
 * @brief Sinkage (m) at which rigidWheelOnBekkerSoil() carries `load` (N), by bisection.
 * @throw std::domain_error if the load exceeds what the wheel carries sunk to its axle
 */
double rigidWheelStaticSinkage(const SoilParameters& soil, double radius, double width, double load);

/**
 * @brief A rigid wheel rolling at sinkage z0 in Bekker-Wong soil that springs back on unloading
 *        (SoilParameters::k_unload): the front arc as rigidWheelOnBekkerSoil(), and behind the
 *        bottom the soil, rebounding from p_max = k z0^n by p_max / k_unload, presses on the rim
 *        with p_max - k_unload (z0 - z) (Wong's unloading line); that rear pressure carries load
 *        and pushes the wheel forward. Without k_unload (0) it is rigidWheelOnBekkerSoil().
 */
RigidWheelLoad rollingWheelOnBekkerSoil(const SoilParameters& soil, double radius, double width, double sinkage,
                                        int samples = 4000);

/**
 * @brief Tractive effort (N) of a rigid wheel rolling at sinkage z0 and slip s in Bekker-Wong
 *        soil: Janosi-Hanamoto over the loaded arc of rollingWheelOnBekkerSoil() (front arc and
 *        the elastic rear) with the pressure p(x) the rim has there, tau = (c + p tan(phi))
 *        (1 - e^(-j/K)), j = s x, x the horizontal distance behind the arc's leading edge (T7,
 *        T11), over the horizontal projection b dx. With uniform pressure it is
 *        janosiTractiveEffort(); the rim's pressure peaks at the bottom, where j is larger.
 */
double rollingWheelTraction(const SoilParameters& soil, double radius, double width, double sinkage, double slip,
                            int samples = 4000);

/**
 * @brief Sinkage (m) at which rollingWheelOnBekkerSoil() carries `load` (N), by bisection.
 * @throw std::domain_error if the load exceeds what the wheel carries sunk to its axle
 */
double rollingWheelSinkage(const SoilParameters& soil, double radius, double width, double load);

/// T13: Bekker's closed form z0 = [3W / ((3 - n)(k_c + b k_phi) sqrt(D))]^(2/(2n+1)), m.
double bekkerStaticSinkageClosedForm(const SoilParameters& soil, double diameter, double width, double load);

/// Bekker's compaction resistance (k_c + b k_phi) z0^(n+1) / (n + 1), N.
double bekkerCompactionResistanceClosedForm(const SoilParameters& soil, double width, double sinkage);

}  // namespace terrain
}  // namespace avsp
