// The virtual bevameter and shear plate: the fits on synthetic records (closed forms), then the
// whole chain on a DEM bed: plates and shear plates give Bekker and Janosi parameters, and a
// wheel's DEM sinkage agrees with Bekker's closed form (T13) with them.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include <avsp_terrain/terramechanics.hpp>

#include "avsp_dynamics/dem/virtual_bevameter.hpp"
#include "avsp_dynamics/dem/wheel_rig.hpp"
#include "dem_test_beds.hpp"

namespace dem = avsp::dynamics::dem;

namespace
{
dem::PlateSinkageCurve syntheticPlate(double b, double n, double kc, double kphi)
{
  dem::PlateSinkageCurve c;
  c.width = b;
  c.length = 2 * b;
  for (double z = 0.001; z <= 0.05; z += 0.001)
  {
    c.sinkage.push_back(z);
    c.pressure.push_back((kc / b + kphi) * std::pow(z, n));
  }
  return c;
}

dem::ShearCurve syntheticShear(double sigma, double c, double phi, double K)
{
  dem::ShearCurve s;
  s.normal_stress = sigma;
  const double tmax = c + sigma * std::tan(phi);
  // Long enough that the last quarter is on the plateau (j >= 15 K there).
  for (double j = 0.0; j <= 20 * K; j += K / 50)
  {
    s.displacement.push_back(j);
    s.shear_stress.push_back(tmax * (1 - std::exp(-j / K)));
  }
  return s;
}

std::unique_ptr<dem::DemWorld> freshBed()
{
  const auto& bed = dem_test::smallTemplate();
  const int blocks = 3;
  auto world = std::make_unique<dem::DemWorld>(bed.parameters(), dem_test::domainFor(bed, blocks), bed);
  world->addBed(
      0.0, blocks * bed.length(), [&](double, double) { return bed.depth(); }, true, true);
  world->setBedEnds(0.0, blocks * bed.length());
  world->settle(0.2);
  return world;
}
}  // namespace

TEST(DemBevameter, FitBekkerRecoversAKnownSoil)
{
  // Wong's dry sand (Terramechanics, 2008, table 2.3): n 1.1, k_c 0.99 kN/m^(n+1), k_phi 1528 kN/m^(n+2).
  const double n = 1.1, kc = 0.99e3, kphi = 1528e3;
  const auto fit =
      dem::fitBekker({ syntheticPlate(0.05, n, kc, kphi), syntheticPlate(0.10, n, kc, kphi) }, 0.005, 0.05);
  EXPECT_NEAR(fit.n, n, 1e-9);
  EXPECT_NEAR(fit.k_c, kc, 1e-6 * kphi);
  EXPECT_NEAR(fit.k_phi, kphi, 1e-6 * kphi);
  EXPECT_LT(fit.rms_log_error, 1e-9);
}

TEST(DemBevameter, FitShearRecoversAKnownSoil)
{
  const double c = 1.0e3, phi = 30.0 * M_PI / 180.0, K = 0.02;
  const auto fit = dem::fitShear({ syntheticShear(5e3, c, phi, K), syntheticShear(15e3, c, phi, K) });
  // The plateau is the mean over the last quarter: within e^-15 of tau_max.
  EXPECT_NEAR(fit.cohesion, c, 1e-3 * c);
  EXPECT_NEAR(fit.friction_angle, phi, 1e-5);
  EXPECT_NEAR(fit.shear_modulus, K, 1e-4 * K);
}

TEST(DemBevameter, OnePlateIsRefusedByName)
{
  try
  {
    dem::fitBekker({ syntheticPlate(0.05, 1, 1e3, 1e6) }, 0.005, 0.05);
    FAIL() << "no error";
  }
  catch (const dem::DemParameterError& e)
  {
    EXPECT_NE(std::string(e.what()).find("dem.bevameter.plate_widths"), std::string::npos) << e.what();
  }
}

TEST(DemBevameter, WheelSinkageAgreesWithBekkerFromTheVirtualBevameter)
{
  const dem::BevameterSpec spec;  // plates 0.05 and 0.08 m wide, shear plate at 5 and 10 kPa
  const auto result = dem::runBevameter(freshBed, spec);
  const auto soil = dem::fittedSoil(result, dem_test::coarseParameters().bulk_density, "dem_coarse");
  std::cout << "fitted: n " << soil.n << ", k_c " << soil.k_c << ", k_phi " << soil.k_phi << " (rms log error "
            << result.bekker.rms_log_error << "); c " << soil.cohesion << " Pa, phi "
            << soil.friction_angle * 180 / M_PI << " deg, K " << soil.shear_modulus << " m\n";
  // A granular bed: a sinkage exponent of the order of 1 (Wong's sands 0.7-1.1), no cohesion to
  // speak of, a friction angle of sand (25-45 deg).
  EXPECT_GT(soil.n, 0.2);
  EXPECT_LT(soil.n, 2.5);
  EXPECT_GT(soil.friction_angle, 20 * M_PI / 180);
  EXPECT_LT(soil.friction_angle, 50 * M_PI / 180);

  // The wheel of the rig tests, 200 N on a 0.08 m wide, 0.3 m diameter rim: the plates' size, as
  // Bekker advises.
  auto world = freshBed();
  dem::WheelRigSpec wheel;
  wheel.load = 200.0;
  wheel.width = 0.08;
  dem::SingleWheelRig rig(*world, wheel, 1.5 * dem_test::smallTemplate().length());
  rig.setCarriageSpeed(0.0);
  rig.setSpinRate(0.0);
  double sum = 0.0;
  for (int k = 0; k < 200; ++k)
  {
    rig.step();
    if (k >= 150)
      sum += rig.state().sinkage;
  }
  const double dem_sinkage = sum / 50;
  const double bekker = avsp::terrain::bekkerStaticSinkageClosedForm(soil, 2 * wheel.radius, wheel.width, wheel.load);
  std::cout << "wheel sinkage: DEM " << dem_sinkage << " m, Bekker's closed form " << bekker << " m\n";
  EXPECT_NEAR(dem_sinkage, bekker, 0.25 * bekker);
}
