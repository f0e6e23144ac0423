#include "avsp_dynamics/dem/dem_parameters.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "parameter_error.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace
{
using detail::fail;
using detail::str;

void positive(const std::string& key, double v)
{
  if (!std::isfinite(v) || v <= 0.0)
    fail(key, "must be a finite number > 0 (got " + str(v) + ")");
}

void nonNegative(const std::string& key, double v)
{
  if (!std::isfinite(v) || v < 0.0)
    fail(key, "must be a finite number >= 0 (got " + str(v) + ")");
}
}  // namespace

double minRadius(const DemParameters& p)
{
  double r = std::numeric_limits<double>::infinity();
  for (const auto& c : p.particles)
    r = std::min(r, c.radius);
  return r;
}

double maxRadius(const DemParameters& p)
{
  double r = 0.0;
  for (const auto& c : p.particles)
    r = std::max(r, c.radius);
  return r;
}

double meanParticleVolume(const DemParameters& p)
{
  // Number share of class k is proportional to its mass share over its particle volume.
  double n = 0.0, v = 0.0;
  for (const auto& c : p.particles)
  {
    const double vol = 4.0 / 3.0 * M_PI * c.radius * c.radius * c.radius;
    n += c.mass_fraction / vol;
    v += c.mass_fraction;
  }
  return v / n;
}

double rayleighTime(const DemParameters& p, double packing)
{
  const double rho = p.bulk_density / packing;
  const double g = p.youngs_modulus / (2.0 * (1.0 + p.poisson_ratio));
  return M_PI * minRadius(p) * std::sqrt(rho / g) / (0.1631 * p.poisson_ratio + 0.8766);
}

double stabilityLimit(const DemParameters& p, double packing)
{
  return p.stability_fraction * rayleighTime(p, packing);
}

void validate(const DemParameters& p)
{
  if (p.particles.empty())
    fail("particles", "the size distribution has no class");
  double sum = 0.0;
  for (std::size_t k = 0; k < p.particles.size(); ++k)
  {
    const std::string key = "particles[" + std::to_string(k) + "]";
    positive(key + ".radius", p.particles[k].radius);
    positive(key + ".mass_fraction", p.particles[k].mass_fraction);
    sum += p.particles[k].mass_fraction;
  }
  if (std::abs(sum - 1.0) > 1e-6)
    fail("particles", "the mass fractions add up to " + str(sum) + ", not 1");
  positive("youngs_modulus", p.youngs_modulus);
  if (!(p.poisson_ratio >= 0.0 && p.poisson_ratio < 0.5))
    fail("poisson_ratio", "must be in [0, 0.5) (got " + str(p.poisson_ratio) + ")");
  if (!(p.restitution > 0.0 && p.restitution <= 1.0))
    fail("restitution", "must be in (0, 1] (got " + str(p.restitution) + ")");
  nonNegative("friction", p.friction);
  nonNegative("rolling_friction", p.rolling_friction);
  nonNegative("wall_friction", p.wall_friction);
  positive("bulk_density", p.bulk_density);
  positive("timestep", p.timestep);
  positive("coupling_interval", p.coupling_interval);
  if (!(p.stability_fraction > 0.0 && p.stability_fraction <= 0.5))
    fail("stability_fraction", "must be in (0, 0.5] (got " + str(p.stability_fraction) + ")");
  positive("memory_budget", p.memory_budget);
  const double limit = stabilityLimit(p, kNominalPacking);
  if (p.timestep > limit)
    fail("timestep", str(p.timestep) +
                         " s is above the stability limit of the contact stiffness: " + str(p.stability_fraction) +
                         " x the Rayleigh time of the smallest particle (r = " + str(minRadius(p)) +
                         " m, E = " + str(p.youngs_modulus) + " Pa) = " + str(limit) + " s");
  const double steps = p.coupling_interval / p.timestep;
  if (steps < 1.0 - 1e-9 || std::abs(steps - std::round(steps)) > 1e-6 * steps)
    fail("coupling_interval",
         str(p.coupling_interval) + " s is not a whole number of DEM steps of " + str(p.timestep) + " s");
}

std::uint64_t checkParticleBudget(const DemParameters& p, double volume, const std::string& what)
{
  const double n = volume * kNominalPacking / meanParticleVolume(p);
  const double bytes = n * kBytesPerParticle;
  if (!(bytes <= p.memory_budget))
    fail("memory_budget", what + " of " + str(volume) + " m^3 needs about " + str(n) + " particles (" +
                              str(bytes / 1e6) + " MB), more than the budget of " + str(p.memory_budget / 1e6) +
                              " MB: use larger particles, a smaller bed or a larger budget");
  return static_cast<std::uint64_t>(std::ceil(n));
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
