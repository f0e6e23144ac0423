#pragma once
// Shared by the vehicle tests: config/soils.yaml (AVSP_SOILS_YAML), and settling a vehicle onto a
// Bekker soil without the drop's overshoot.
#include <algorithm>
#include <cmath>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"

namespace avsp
{
namespace dynamics
{
namespace test
{
/// The project's soil library, loaded once.
inline const terrain::SoilLibrary& soils()
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  return lib;
}

/// Steps `world` until `until` s with the terrain's soil 0 softened from 20x `soil`'s k_c and
/// k_phi at t = 0 to `soil` itself at t = `soften` s (geometrically): plastic sinkage keeps its
/// deepest, so a vehicle set down on the final soil would keep its landing's overshoot.
inline void settleOnSoftening(World& world, terrain::DeformableTerrain& ground, const terrain::SoilParameters& soil,
                              double soften, double until)
{
  while (world.time() < until)
  {
    terrain::SoilParameters stiff = soil;
    const double factor = std::pow(20.0, std::max(0.0, 1.0 - world.time() / soften));
    stiff.k_c *= factor;
    stiff.k_phi *= factor;
    ground.setSoil(0, stiff);
    world.step();
  }
}
}  // namespace test
}  // namespace dynamics
}  // namespace avsp
