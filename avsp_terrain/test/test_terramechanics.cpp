// The terramechanics formulas against closed forms (docs/MODELS.md T2, T3, T7-T13;
// docs/SOILS_AND_SENSORS.md for Janosi-Hanamoto and the rigid wheel's validity range).
#include <cmath>

#include <gtest/gtest.h>

#include "avsp_terrain/soil.hpp"
#include "avsp_terrain/terramechanics.hpp"

using namespace avsp::terrain;

namespace
{
const SoilLibrary& library()
{
  static const SoilLibrary lib = SoilLibrary::load(std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  return lib;
}
}  // namespace

// --- T13: a rigid wheel's static sinkage from the model vs Bekker's closed form ---
//
// T13 replaces the exact load integral of a parabolic rim, b k (sqrt(D)/2) z0^(n+1/2)
// B(n+1, 1/2), by b k sqrt(D) z0^(n+1/2) (3-n)/3: exact at n = 1, about 4 % high in load at
// n = 0.75 and 6 % at n = 0.5 (more in sinkage). So T13 is the check (docs/MODELS.md's 5 %) for
// the library's soils with n in [0.7, 1.3]: dry sand, gravel, grass over loam. The model's
// integration is checked for every soil against the exact parabolic rim (shallow) and, for
// n = 1, against the exact circle.

namespace
{
/// Sinkage of a parabolic-rim wheel carrying W in Bekker soil, exact (Beta function).
double parabolicRimSinkage(const SoilParameters& soil, double diameter, double width, double load)
{
  const double n = soil.n;
  const double beta = std::tgamma(n + 1.0) * std::tgamma(0.5) / std::tgamma(n + 1.5);
  const double k = soil.k_c / width + soil.k_phi;
  return std::pow(2.0 * load / (width * k * std::sqrt(diameter) * beta), 1.0 / (n + 0.5));
}

const double kDiameter = 1.092;  // m, FED-Alpha-class tyre as a rigid wheel
const double kWidth = 0.365;     // m
}  // namespace

struct WheelCase
{
  const char* soil;
  double load;  // N
};

class BekkerStaticSinkage : public ::testing::TestWithParam<WheelCase>
{
};

TEST_P(BekkerStaticSinkage, ModelWithinFivePercentOfT13)
{
  const SoilParameters& soil = library().get(GetParam().soil);
  ASSERT_GE(soil.n, 0.7);
  ASSERT_LE(soil.n, 1.3);
  const double closed = bekkerStaticSinkageClosedForm(soil, kDiameter, kWidth, GetParam().load);
  // T13 holds only for D > 0.5 m and sinkage below D/6: the case must be inside that range.
  ASSERT_LT(closed, kDiameter / 6.0) << "case outside T13's validity";
  const double model = rigidWheelStaticSinkage(soil, kDiameter / 2.0, kWidth, GetParam().load);
  EXPECT_NEAR(model, closed, 0.05 * closed) << GetParam().soil << " W=" << GetParam().load;
  // And the model carries exactly the load at its sinkage.
  EXPECT_NEAR(rigidWheelOnBekkerSoil(soil, kDiameter / 2.0, kWidth, model).normal_force, GetParam().load,
              1e-6 * GetParam().load);
}

INSTANTIATE_TEST_SUITE_P(ThreeSoilsTwoLoads, BekkerStaticSinkage,
                         ::testing::Values(WheelCase{ "dry_sand", 5000.0 }, WheelCase{ "dry_sand", 14000.0 },
                                           WheelCase{ "gravel", 5000.0 }, WheelCase{ "gravel", 14000.0 },
                                           WheelCase{ "grass_over_loam", 5000.0 },
                                           WheelCase{ "grass_over_loam", 14000.0 }));

TEST(BekkerRigidWheel, ShallowSinkageMatchesExactParabolicRimForEverySoil)
{
  // Where the rim is shallow (z0 < D/25) a circle is a parabola to within 1 %.
  int checked = 0;
  for (const std::string& name : library().names())
  {
    const SoilParameters& soil = library().get(name);
    if (soil.model == SinkageModel::kRigid)
      continue;  // pavement has no pressure-sinkage law
    const double load = 1500.0;
    const double exact = parabolicRimSinkage(soil, kDiameter, kWidth, load);
    if (exact > kDiameter / 25.0)
      continue;
    ++checked;
    EXPECT_NEAR(rigidWheelStaticSinkage(soil, kDiameter / 2.0, kWidth, load), exact, 0.01 * exact) << name;
  }
  EXPECT_GE(checked, 5);
}

TEST(BekkerRigidWheel, LinearSoilLoadMatchesExactCircleIntegral)
{
  // n = 1: W = b k r [r (t/2 + sin(2t)/4) - (r - z0) sin t], t = acos(1 - z0/r), exactly.
  SoilParameters soil = library().get("dry_sand");
  soil.n = 1.0;
  const double r = 0.546, b = 0.365, k = soil.k_c / b + soil.k_phi;
  for (const double z0 : { 0.01, 0.05, 0.15, 0.3 })
  {
    const double t = std::acos(1.0 - z0 / r);
    const double exact = b * k * r * (r * (t / 2 + std::sin(2 * t) / 4) - (r - z0) * std::sin(t));
    EXPECT_NEAR(rigidWheelOnBekkerSoil(soil, r, b, z0).normal_force, exact, 1e-6 * exact) << z0;
  }
}

TEST(BekkerRigidWheel, CompactionResistanceMatchesClosedForm)
{
  // The horizontal reaction integrates p dz over the front arc: exactly Bekker's R_c.
  for (const char* name : { "dry_sand", "sandy_loam", "snow" })
  {
    const SoilParameters& soil = library().get(name);
    const double z0 = 0.04;
    const double numeric = rigidWheelOnBekkerSoil(soil, 0.546, 0.365, z0, 20000).compaction_resistance;
    const double closed = bekkerCompactionResistanceClosedForm(soil, 0.365, z0);
    EXPECT_NEAR(numeric, closed, 1e-3 * closed) << name;
  }
}

TEST(BekkerRigidWheel, WheelThatCannotBeCarriedThrows)
{
  EXPECT_THROW(rigidWheelStaticSinkage(library().get("mud"), 0.1, 0.05, 1e6), std::domain_error);
}

// --- T7/T11: strip-summed traction vs the Janosi-Hanamoto closed form ---

class JanosiTraction : public ::testing::TestWithParam<double>
{
};

TEST_P(JanosiTraction, StripSumWithinOnePercentOfFormula)
{
  const double slip = GetParam();
  // A 0.4 m x 0.3 m track-segment patch at 0.05 m cells, 20 kN spread uniformly.
  const double length = 0.4, width = 0.3, cell = 0.05, load = 20000.0;
  const double sigma = load / (length * width);
  for (const char* name : { "sandy_loam", "clay", "snow" })
  {
    const SoilParameters& soil = library().get(name);
    std::vector<ContactStrip> strips;
    for (double x = 0.0; x < length - 1e-12; x += cell)
      for (double y = 0.0; y < width - 1e-12; y += cell)
        strips.push_back({ cell * cell, x, x + cell, sigma });
    const double formula = janosiTractiveEffort(soil, length * width, length, load, slip);
    EXPECT_NEAR(tractionForce(soil, strips, slip), formula, 0.01 * formula) << name << " s=" << slip;
    // Braking mirrors driving.
    EXPECT_NEAR(tractionForce(soil, strips, -slip), -formula, 0.01 * formula);
  }
}

INSTANTIATE_TEST_SUITE_P(Slips, JanosiTraction, ::testing::Values(0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0));

TEST(JanosiTraction, FullSlipOnLongContactApproachesMohrCoulombLimit)
{
  const SoilParameters& soil = library().get("sandy_loam");
  const double a = 0.5, w = 10000.0;
  const double limit = a * soil.cohesion + w * std::tan(soil.friction_angle);
  EXPECT_NEAR(janosiTractiveEffort(soil, a, 3.0, w, 1.0), limit * (1 - soil.shear_modulus / 3.0), 1e-6 * limit);
  EXPECT_NEAR(janosiTractiveEffort(soil, a, 3.0, w, 0.0), 0.0, 1e-12);
  EXPECT_LT(janosiTractiveEffort(soil, a, 3.0, w, 0.05), janosiTractiveEffort(soil, a, 3.0, w, 0.1));
}

TEST(JanosiTraction, PerPointShearFollowsT7)
{
  const SoilParameters& soil = library().get("clay");
  const double sigma = 50e3, j = 0.03;
  EXPECT_NEAR(shearStress(soil, sigma, j),
              (soil.cohesion + sigma * std::tan(soil.friction_angle)) * (1 - std::exp(-j / soil.shear_modulus)), 1e-9);
}

// --- T8-T10: slip and theoretical speeds ---

TEST(Slip, DrivingBrakingAndReverse)
{
  EXPECT_DOUBLE_EQ(longitudinalSlip(2.0, 1.5), 0.25);    // (v_t - v) / v_t
  EXPECT_DOUBLE_EQ(longitudinalSlip(1.0, 0.0), 1.0);     // spinning in place
  EXPECT_DOUBLE_EQ(longitudinalSlip(1.5, 2.0), -0.25);   // braking: (v_t - v) / v
  EXPECT_DOUBLE_EQ(longitudinalSlip(0.0, 2.0), -1.0);    // locked wheel sliding
  EXPECT_DOUBLE_EQ(longitudinalSlip(-2.0, -1.5), 0.25);  // driving in reverse
  EXPECT_DOUBLE_EQ(longitudinalSlip(0.0, 0.0), 0.0);
}

TEST(Slip, TheoreticalSpeeds)
{
  EXPECT_DOUBLE_EQ(wheelTheoreticalSpeed(0.546, 10.0), 5.46);  // T9
  // T10 with the M113-class sprocket: 0.152 m pitch, 10 teeth, one turn per second.
  EXPECT_NEAR(trackTheoreticalSpeed(0.152, 10, 2.0 * M_PI), 1.52, 1e-12);
}

// --- T2, T3, T12 ---

TEST(Compaction, MassInTheColumnIsConserved)
{
  for (const std::string& name : library().names())
  {
    const SoilParameters& soil = library().get(name);
    if (soil.model == SinkageModel::kRigid)
      continue;  // pavement does not compact
    EXPECT_DOUBLE_EQ(plasticSinkage(soil, 0.0), 0.0) << name;
    double previous = 0.0;
    for (double sigma = 0.0; sigma <= 6e5; sigma += 2.5e4)
    {
      const double zp = plasticSinkage(soil, sigma);
      // T2: h0 rho0 = (h0 - z_p) rho(sigma).
      EXPECT_NEAR((soil.h0 - zp) * soil.compression.density(sigma), soil.h0 * soil.rho0, 1e-9 * soil.h0 * soil.rho0)
          << name << " sigma=" << sigma;
      EXPECT_GE(zp, previous) << name;  // more stress never lifts the soil
      previous = zp;
    }
  }
}

TEST(Compaction, DrySandAtTableStress)
{
  // dry_sand: rho 1600 -> 1730 kg/m^3 at 100 kPa, h0 0.5 m: z_p = 0.5 (1 - 1600/1730).
  EXPECT_NEAR(plasticSinkage(library().get("dry_sand"), 1e5), 0.5 * (1 - 1600.0 / 1730.0), 1e-12);
}

TEST(Elastic, LinearInStressAndGoneWhenUnloaded)
{
  const SoilParameters& soil = library().get("sandy_loam");
  EXPECT_DOUBLE_EQ(elasticSinkage(soil, 0.0, 0.05), 0.0);
  EXPECT_NEAR(elasticSinkage(soil, 1e5, 0.05), (soil.h0 - 0.05) * soil.elastic_e * 1e5, 1e-15);
  EXPECT_NEAR(elasticSinkage(soil, 2e5, 0.05), 2 * elasticSinkage(soil, 1e5, 0.05), 1e-15);
}

TEST(Resistance, BulldozingPlusRolling)
{
  const SoilParameters& soil = library().get("clay");
  const double sigma = 80e3, w = 0.365, z = 0.04, a = 0.12;
  const double expected =
      (soil.cohesion + sigma * std::tan(soil.friction_angle)) * w * z + soil.rolling_resistance * a * sigma;
  EXPECT_NEAR(resistanceForce(soil, sigma, w, z, a), expected, 1e-9 * expected);
  EXPECT_NEAR(resistanceForce(soil, sigma, w, 0.0, a), soil.rolling_resistance * a * sigma, 1e-9);
}
