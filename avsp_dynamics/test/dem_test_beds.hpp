#pragma once
// Small DEM beds shared by the DEM tests: coarse particles so that a test runs in seconds.
// Settled once per test binary (settling is most of a small bed's cost).
#include "avsp_dynamics/dem/dem_world.hpp"

namespace dem_test
{
/// Two sieve fractions of 10 and 12.5 mm radius, a softer contact (E = 2e7 Pa: overlaps under
/// a 15 kPa wheel about 4 % of a radius) and a 0.1 ms step (78 % of its stability limit, 1.3e-4 s),
/// half the default's cost; otherwise the defaults.
inline avsp::dynamics::dem::DemParameters coarseParameters()
{
  avsp::dynamics::dem::DemParameters p;
  p.particles = { { 0.010, 0.5 }, { 0.0125, 0.5 } };
  p.youngs_modulus = 2.0e7;
  p.timestep = 1.0e-4;
  return p;
}

/// A 0.12 m long, 0.24 m wide, 0.1 m deep block.
inline const avsp::dynamics::dem::BedTemplate& smallTemplate()
{
  static const auto bed = avsp::dynamics::dem::BedTemplate::settle(coarseParameters(), 0.12, 0.24, 0.10);
  return bed;
}

/// A domain `blocks` template lengths long, the template's width, 0.5 m high, floor at 0.
inline avsp::dynamics::dem::DemDomain domainFor(const avsp::dynamics::dem::BedTemplate& bed, int blocks)
{
  return { 0.0, blocks * bed.length(), 0.0, bed.width(), 0.0, 0.5 };
}
/**
 * @brief A wheel of `radius` and `width` centred across the bed at x, 2 mm above the highest
 *        particle under it, lowered kinematically at 0.1 m/s until the soil carries `load` (N):
 *        placed gently, as a wheel set down on a bed (dropped, it would ring on the bed's
 *        elasticity for tenths of a second).
 * @return the body's index
 */
inline int placeWheel(avsp::dynamics::dem::DemWorld& world, double x, double radius, double width, double load)
{
  namespace dem = avsp::dynamics::dem;
  const auto& d = world.domain();
  const double y = 0.5 * (d.y_min + d.y_max);
  const double top = world.highestTop(x - radius, x + radius, y - 0.5 * width, y + 0.5 * width);
  const Eigen::Vector3d centre(x, y, top + 0.002 + radius);
  const int wheel = world.addBody(dem::wheelMesh(centre, Eigen::Vector3d::UnitY(), radius, width, 48), centre,
                                  Eigen::Vector3d::UnitY());
  world.setBodyVelocity(wheel, Eigen::Vector3d(0, 0, -0.1), 0.0);
  for (int k = 0; k < 1000 && world.load(wheel).force.z() < load; ++k)
    world.step();
  world.setBodyVelocity(wheel, Eigen::Vector3d::Zero(), 0.0);
  return wheel;
}

}  // namespace dem_test
