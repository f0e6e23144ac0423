#pragma once
/**
 * @file dem_parameters.hpp
 * @brief Parameters of the discrete-element (DEM) soil: particle sizes, contact law, steps,
 *        and the checks that refuse a bad set before LIGGGHTS is started (LIGGGHTS stops the
 *        whole process on an input error, so everything it would reject is checked here).
 *
 * "DEM" in avsp_dynamics::dem is the discrete element method; avsp_terrain's dem_io.hpp is
 * about digital elevation models. Units SI throughout.
 */
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// A DEM parameter or input that cannot be used; what() names the parameter and the reason.
class DemParameterError : public std::invalid_argument
{
public:
  using std::invalid_argument::invalid_argument;
};

/// One size class of the particle size distribution (a sieve fraction).
struct ParticleClass
{
  double radius = 0.0;         ///< m, > 0
  double mass_fraction = 0.0;  ///< share of the bed's mass, > 0; the classes' shares add up to 1
};

/**
 * @brief Everything the DEM soil needs besides geometry. Defaults: a coarse-grained dry
 *        granular soil (docs/MODELS.md, "DEM soil"): the particles stand for many grains
 *        (coarse graining), so their size is set by cost, not by the real grain size, and the
 *        stiffness is reduced to allow a usable step (the bulk behaviour depends on the
 *        friction, rolling resistance and packing, little on the stiffness once overlaps
 *        stay below about 1 % of the radius).
 */
struct DemParameters
{
  /// Size distribution: three sieve fractions of 10, 12.5 and 15 mm radius.
  std::vector<ParticleClass> particles = { { 0.010, 0.3 }, { 0.0125, 0.4 }, { 0.015, 0.3 } };
  double youngs_modulus = 5.0e7;      ///< Pa, particles and meshes (Hertz contact)
  double poisson_ratio = 0.3;         ///< [0, 0.5)
  double restitution = 0.3;           ///< coefficient of restitution, (0, 1]
  double friction = 0.5;              ///< Coulomb coefficient particle-particle, >= 0
  double rolling_friction = 0.3;      ///< rolling resistance coefficient (LIGGGHTS epsd2), >= 0
  double wall_friction = 0.6;         ///< Coulomb coefficient particle-mesh (wheel rim, plates), >= 0
  double bulk_density = 1600.0;       ///< kg/m^3, the bed's bulk density (a soil's rho0)
  double timestep = 5.0e-5;           ///< s, DEM step
  double coupling_interval = 1.0e-3;  ///< s, how often poses go in and forces come out; a whole number of DEM steps
  /// Largest DEM step as a fraction of the Rayleigh time of the smallest particle (the
  /// stability limit of the Hertz contact stiffness; LIGGGHTS' manual advises < 20 %).
  double stability_fraction = 0.2;
  double memory_budget = 2.0e9;  ///< bytes the particles may take (kBytesPerParticle each)
  std::uint64_t seed = 1;        ///< particle placement; a run is a function of it
};

/// Bytes per particle assumed for the memory budget: LIGGGHTS' per-atom arrays (about 0.4 kB)
/// plus its neighbour list and contact history (about 12 neighbours of 0.1 kB each).
constexpr double kBytesPerParticle = 2000.0;

/**
 * @brief Checks every field, naming it: a radius or fraction <= 0, fractions not adding up
 *        to 1, a contact parameter out of its range, a step above the stability limit
 *        (stabilityLimit()), a coupling interval that is not a whole number of steps.
 * @throw DemParameterError naming the field ("dem.timestep: ...")
 */
void validate(const DemParameters& p);

/**
 * @brief Rayleigh time (s) of the smallest particle: pi r sqrt(rho / G) / (0.1631 nu + 0.8766),
 *        G = E / (2 (1 + nu)), rho the particle density that gives the bulk density at
 *        `packing` (solid fraction). The time a shear wave takes across a particle: the Hertz
 *        contact's stability scale.
 */
double rayleighTime(const DemParameters& p, double packing);

/// s: the largest admissible DEM step, stability_fraction x rayleighTime().
double stabilityLimit(const DemParameters& p, double packing);

/// m^3: mean particle volume (number-weighted over the distribution).
double meanParticleVolume(const DemParameters& p);

/// Smallest and largest radius of the distribution (m).
double minRadius(const DemParameters& p);
double maxRadius(const DemParameters& p);

/// Solid fraction assumed before a bed has settled (random loose packing of spheres, 0.58),
/// used for the checks before anything runs; the bed's own is measured when it settles.
constexpr double kNominalPacking = 0.58;

/**
 * @brief Particles a bed of `volume` (m^3) holds at kNominalPacking.
 * @throw DemParameterError naming `what` when that exceeds p.memory_budget / kBytesPerParticle
 */
std::uint64_t checkParticleBudget(const DemParameters& p, double volume, const std::string& what);

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
