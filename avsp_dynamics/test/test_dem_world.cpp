// The DEM soil world (LIGGGHTS in-process): parameter checks, a settled bed's packing and
// density, a wheel resting on it carried by the soil with its own weight.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "avsp_dynamics/dem/dem_world.hpp"
#include "dem_test_beds.hpp"

namespace dem = avsp::dynamics::dem;

namespace
{
template <typename F>
std::string errorOf(F f)
{
  try
  {
    f();
  }
  catch (const dem::DemParameterError& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(DemParameters, DefaultsAreValid)
{
  EXPECT_NO_THROW(dem::validate(dem::DemParameters{}));
}

TEST(DemParameters, ParticleSizeNotPositiveIsNamed)
{
  dem::DemParameters p;
  p.particles[1].radius = 0.0;
  EXPECT_NE(errorOf([&] { dem::validate(p); }).find("dem.particles[1].radius"), std::string::npos);
  p.particles[1].radius = -0.01;
  EXPECT_NE(errorOf([&] { dem::validate(p); }).find("dem.particles[1].radius"), std::string::npos);
}

TEST(DemParameters, MassFractionsMustAddUpToOne)
{
  dem::DemParameters p;
  p.particles[0].mass_fraction = 0.5;
  EXPECT_NE(errorOf([&] { dem::validate(p); }).find("dem.particles: the mass fractions add up to 1.2"),
            std::string::npos);
}

TEST(DemParameters, StepAboveTheStabilityLimitIsNamed)
{
  dem::DemParameters p;
  // Rayleigh time of the 10 mm particles: pi r sqrt(rho / G) / (0.1631 nu + 0.8766) with
  // rho = 1600 / 0.58, G = 5e7 / 2.6: 4.07e-4 s; the limit is 20 % of it, 8.1e-5 s.
  EXPECT_NEAR(dem::rayleighTime(p, dem::kNominalPacking), 4.07e-4, 0.01e-4);
  p.timestep = 1.0e-4;
  p.coupling_interval = 1.0e-3;
  const std::string e = errorOf([&] { dem::validate(p); });
  EXPECT_NE(e.find("dem.timestep"), std::string::npos) << e;
  EXPECT_NE(e.find("stability limit"), std::string::npos) << e;
}

TEST(DemParameters, CouplingIntervalMustBeWholeSteps)
{
  dem::DemParameters p;
  p.coupling_interval = 1.02e-3;
  EXPECT_NE(errorOf([&] { dem::validate(p); }).find("dem.coupling_interval"), std::string::npos);
}

TEST(DemParameters, BedAboveTheMemoryBudgetIsRefusedBeforeAnythingRuns)
{
  dem::DemParameters p;
  p.memory_budget = 1.0e6;  // 1 MB: 500 particles
  // A 2 x 1 x 0.3 m bed holds about 0.6 x 0.58 / 6.6e-6 = 53 000 of the default particles.
  const std::string e = errorOf([&] { dem::BedTemplate::settle(p, 2.0, 1.0, 0.3); });
  EXPECT_NE(e.find("dem.memory_budget"), std::string::npos) << e;
}

TEST(DemWorld, BedHasTheSoilsBulkDensityAtARandomPacking)
{
  const auto& bed = dem_test::smallTemplate();
  // Random packings of spheres: 0.64 at most (random close packing, Scott & Kilgour 1969);
  // frictional spheres poured under gravity stand looser, down to about 0.55 with sliding
  // friction alone (Onoda & Liniger, Phys. Rev. Lett. 64, 2727, 1990) and lower still with
  // rolling resistance, which lets arches stand (the DEM soil has both).
  EXPECT_GT(bed.packing(), 0.45);
  EXPECT_LT(bed.packing(), 0.66);
  // Mass of the particles in the interior over its volume: the soil's bulk density.
  const double rmax = dem::maxRadius(bed.parameters());
  double mass = 0.0;
  for (const auto& q : bed.particles())
    if (q.x.z() >= 2 * rmax && q.x.z() < bed.depth() - 2 * rmax)
      mass += bed.particleDensity() * 4.0 / 3.0 * M_PI * std::pow(q.radius, 3);
  const double volume = bed.length() * bed.width() * (bed.depth() - 4 * rmax);
  // (The density was set from the packing measured just before a last short settle: 1 %.)
  EXPECT_NEAR(mass / volume, bed.parameters().bulk_density, 0.01 * bed.parameters().bulk_density);
  // The probe reads the settled surface within a particle diameter of the cut (it settles a
  // little after the cut; the probe meets the tops of the spheres and the gaps between them).
  EXPECT_LT(std::abs(bed.surfaceBias()), 2 * rmax);
}

TEST(DemWorld, RestingWheelCarriesItsWeight)
{
  const auto& bed = dem_test::smallTemplate();
  dem::DemWorld world(bed.parameters(), dem_test::domainFor(bed, 3), bed);
  world.addBed(
      0.0, 3 * bed.length(), [&](double, double) { return bed.depth(); }, true, true);
  world.setBedEnds(0.0, 3 * bed.length());
  world.settle(0.2);
  const double radius = 0.15, width = 0.1, mass = 15.0, g = 9.81;
  const int wheel = dem_test::placeWheel(world, 1.5 * bed.length(), radius, width, mass * g);
  const double z_placed = world.load(wheel).reference.z();
  // Then free in one vertical degree of freedom: each coupling interval the DEM runs with the
  // wheel at its current velocity, and the interval's mean force moves it (semi-implicit Euler;
  // the DEM steps first, as with ODE).
  const double h = bed.parameters().coupling_interval;
  double z = z_placed, vz = 0.0, z_sum = 0.0;
  int n = 0;
  for (int k = 0; k < 300; ++k)
  {
    world.setBodyVelocity(wheel, Eigen::Vector3d(0, 0, vz + (z - world.load(wheel).reference.z()) / h), 0.0);
    world.step();
    vz += (world.load(wheel).force.z() / mass - g) * h;
    z += vz * h;
    if (k >= 200)
    {
      z_sum += world.load(wheel).reference.z();
      ++n;
    }
  }
  // It came to rest: neither sinking on nor bouncing (within 2 mm of where it was placed).
  const double z_rest = z_sum / n;
  EXPECT_LT(std::abs(z_rest - z_placed), 0.002);
  EXPECT_LT(std::abs(vz), 0.01);
  // Held still where it rested (its mean height over the last 0.1 s), the soil pushes back with
  // the wheel's weight: the mean DEM force over 0.05 s within 2 % of m g. (While it was free
  // the mean force was m g + m dv / T by Newton's law; held, it is the soil's alone.)
  world.setBodyVelocity(wheel, Eigen::Vector3d(0, 0, (z_rest - world.load(wheel).reference.z()) / h), 0.0);
  world.step();
  world.setBodyVelocity(wheel, Eigen::Vector3d::Zero(), 0.0);
  double fz_sum = 0.0;
  for (int k = 0; k < 50; ++k)
  {
    world.step();
    fz_sum += world.load(wheel).force.z();
  }
  EXPECT_NEAR(fz_sum / 50, mass * g, 0.02 * mass * g);
}

TEST(DemWorld, SpinAxisMovesWithTheBody)
{
  const auto& bed = dem_test::smallTemplate();
  dem::DemWorld world(bed.parameters(), dem_test::domainFor(bed, 4), bed);
  const Eigen::Vector3d centre(1.5 * bed.length(), 0.5 * bed.width(), bed.depth() + 0.2);
  const int wheel =
      world.addBody(dem::wheelMesh(centre, Eigen::Vector3d::UnitY(), 0.1, 0.05, 24), centre, Eigen::Vector3d::UnitY());
  world.setBodyVelocity(wheel, Eigen::Vector3d(0.5, 0.0, 0.0), 10.0);
  for (int i = 0; i < 50; ++i)
    world.step();
  // The reference point translates only: the spin is about the moving axle, not the start point.
  const Eigen::Vector3d expected = centre + Eigen::Vector3d(0.5 * world.time(), 0.0, 0.0);
  EXPECT_LT((world.load(wheel).reference - expected).norm(), 1e-9);
}

TEST(DemWorld, ABodyLeavingTheDomainIsRefusedByName)
{
  const auto& bed = dem_test::smallTemplate();
  dem::DemWorld world(bed.parameters(), dem_test::domainFor(bed, 3), bed);
  const Eigen::Vector3d centre(2.5 * bed.length(), 0.5 * bed.width(), 0.3);
  const int wheel =
      world.addBody(dem::wheelMesh(centre, Eigen::Vector3d::UnitY(), 0.05, 0.05, 24), centre, Eigen::Vector3d::UnitY());
  // 0.05 m from the end of the domain, at 100 m/s: 0.1 m in one interval.
  world.setBodyVelocity(wheel, Eigen::Vector3d(100.0, 0.0, 0.0), 0.0);
  const std::string e = errorOf([&] { world.step(); });
  EXPECT_NE(e.find("dem.body: body 0 would leave the domain"), std::string::npos) << e;
  EXPECT_EQ(world.time(), 0.0);
}
