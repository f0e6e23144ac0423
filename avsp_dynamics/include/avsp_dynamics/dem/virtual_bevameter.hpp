#pragma once
/**
 * @file virtual_bevameter.hpp
 * @brief Plate-sinkage and shear-plate tests run in the DEM, and the fits that turn them into a
 *        soil's Bekker (k_c, k_phi, n) and Mohr-Coulomb/Janosi (c, phi, K) parameters
 *        (docs/MODELS.md, "DEM soil": Bekker 1969, Wong 2008 ch. 2 and 4).
 *
 * Plate test: a flat rectangular plate (width b, the smaller side) pressed into the bed at a
 * constant, slow speed; pressure p = F_z / (b l) against sinkage z below the bed's surface.
 * Bekker's p = (k_c / b + k_phi) z^n is fitted to two or more plates: n from the common slope
 * of log p against log z, then k = k_c / b + k_phi per plate, a straight line in 1 / b.
 *
 * Shear test: a grouser plate (a plate with transverse lugs, Wong's translational shear plate)
 * loaded by a dead weight (normal stress sigma) and pulled along the bed at a constant speed;
 * shear stress tau = F_x / A against displacement j. Per normal stress the curve's plateau is
 * tau_max; c and tan(phi) are the line tau_max = c + sigma tan(phi); Janosi's K is fitted to
 * tau / tau_max = 1 - exp(-j / K).
 */
#include <functional>
#include <memory>
#include <vector>

#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/dem/dem_world.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// One plate's pressure-sinkage record.
struct PlateSinkageCurve
{
  double width = 0.0;            ///< m, the plate's smaller side (Bekker's b)
  double length = 0.0;           ///< m
  std::vector<double> sinkage;   ///< m below the bed's surface, one per coupling interval
  std::vector<double> pressure;  ///< Pa
};

/// One shear test's record.
struct ShearCurve
{
  double normal_stress = 0.0;        ///< Pa, dead weight over the plate's area
  std::vector<double> displacement;  ///< m, j
  std::vector<double> shear_stress;  ///< Pa, tau
};

/// Bekker-Wong pressure-sinkage parameters and how well they fit.
struct BekkerFit
{
  double n = 0.0;
  double k_c = 0.0;            ///< N/m^(n+1)
  double k_phi = 0.0;          ///< N/m^(n+2)
  double rms_log_error = 0.0;  ///< root mean square of log(p_fit / p) over the fitted points
};

/// Mohr-Coulomb strength and Janosi's shear deformation modulus.
struct ShearFit
{
  double cohesion = 0.0;            ///< Pa (c)
  double friction_angle = 0.0;      ///< rad (phi)
  double shear_modulus = 0.0;       ///< m (K)
  std::vector<double> peak_stress;  ///< Pa, tau_max per curve
};

/**
 * @brief Fits p = (k_c / b + k_phi) z^n to plate curves of two or more widths, over the points
 *        with z in [z_min, z_max] (the first millimetres are the plate seating on the surface
 *        particles, not the soil's law).
 * @throw DemParameterError when fewer than two widths or fewer than 3 points per plate remain,
 *        or the fit is degenerate (equal widths)
 */
BekkerFit fitBekker(const std::vector<PlateSinkageCurve>& plates, double z_min, double z_max);

/**
 * @brief Fits c, phi (the line through the curves' plateaus, tau_max the mean over the last
 *        quarter of each curve's displacement) and K (least squares of tau / tau_max against
 *        1 - exp(-j / K) over all curves).
 * @throw DemParameterError with fewer than two curves or normal stresses
 */
ShearFit fitShear(const std::vector<ShearCurve>& curves);

/// The tests' settings. Defaults for the CI beds (0.24 m between walls): plates of the running
/// gear's size, as Bekker and Wong advise (the wheels there are 0.08 m wide), and no wider, so
/// that 3 or more particle diameters stay between a plate and the walls (a plate nearer the
/// walls is stiffened by them).
struct BevameterSpec
{
  std::vector<double> plate_widths = { 0.05, 0.08 };       ///< m
  double plate_length = 0.15;                              ///< m, along the bed
  double press_speed = 0.1;                                ///< m/s
  double max_sinkage = 0.03;                               ///< m, the press stops there
  std::vector<double> normal_stresses = { 5.0e3, 1.0e4 };  ///< Pa, shear tests
  double shear_speed = 0.1;                                ///< m/s
  double shear_travel = 0.06;                              ///< m
  double shear_plate_length = 0.12;                        ///< m
  double shear_plate_width = 0.10;                         ///< m
  int grousers = 3;                                        ///< lugs under the shear plate
  double grouser_height = 0.015;                           ///< m
  double fit_min_sinkage = 0.005;                          ///< m, plate points below this are left out of the fit
};

/// What a virtual bevameter run gives.
struct BevameterResult
{
  std::vector<PlateSinkageCurve> plates;
  std::vector<ShearCurve> shears;
  BekkerFit bekker;
  ShearFit shear;
};

/// Makes a fresh, settled bed for each test (every test disturbs its bed).
using BedFactory = std::function<std::unique_ptr<DemWorld>()>;

/// Presses a plate of `width` x `length` centred on the bed at `speed` down to `max_sinkage`.
PlateSinkageCurve plateSinkageTest(DemWorld& world, double width, double length, double speed, double max_sinkage);

/// Loads a grouser plate with `normal_stress` and pulls it `travel` along the bed at `speed`.
ShearCurve shearTest(DemWorld& world, const BevameterSpec& spec, double normal_stress);

/**
 * @brief Runs every plate and shear test of `spec` on fresh beds and fits them.
 * @throw DemParameterError naming the spec field that cannot be used
 */
BevameterResult runBevameter(const BedFactory& fresh_bed, const BevameterSpec& spec);

/**
 * @brief The fitted soil as avsp_terrain parameters (model bekker): n, k_c, k_phi, c, phi, K and
 *        rho0 = the bed's bulk density; `name` and `source` as given.
 */
terrain::SoilParameters fittedSoil(const BevameterResult& r, double bulk_density, const std::string& name);

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
