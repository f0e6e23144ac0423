// The contact's prepared soil: the closed-form stress solve against the reference formulas
// of terramechanics.hpp (T2 plasticSinkage, T3 elasticSinkage, T4's b1 term), and bad soils
// rejected by name.
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_terrain/contact_soil.hpp"
#include "avsp_terrain/terramechanics.hpp"

using namespace avsp::terrain;

namespace
{
const SoilLibrary& library()
{
  static const SoilLibrary lib = SoilLibrary::load(std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  return lib;
}

/// Extra sinkage of a point under stress sigma written from the reference formulas alone:
/// new compaction to the largest stress (T2), bearing flow for new stress (T4's b1 term), and
/// the elastic part with the point's current deformation as T3's z.
double referenceExtraSinkage(const SoilParameters& soil, float plastic, float displaced, float sigma_max, double sigma)
{
  const double compaction = std::max(plasticSinkage(soil, std::max<double>(sigma, sigma_max)) - plastic, 0.0);
  const double flow = soil.b1 * std::max(sigma - sigma_max, 0.0);
  return compaction + flow + elasticSinkage(soil, sigma, plastic + displaced);
}
}  // namespace

TEST(ContactSoil, StressSolvesTheReferenceSinkageExactly)
{
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int solved = 0, rigid = 0;
  // A simple-model soil thin and stiff enough for its hard layer to be reached (a pavement
  // written as a soil), so that the rigid-stress branch is exercised too.
  SoilParameters hard_layer = library().get("gravel");
  hard_layer.name = "hard_layer";
  hard_layer.h0 = 0.005;
  hard_layer.rho0 = 2300.0;
  hard_layer.compression = CompressionCurve({ { 0.0, 2300.0 }, { 1.0e7, 2310.0 } });
  hard_layer.elastic_e = 1e-9;
  hard_layer.b1 = 0.0;
  std::vector<SoilParameters> soils{ hard_layer };
  for (const std::string& name : library().names())
    if (library().get(name).model != SinkageModel::kRigid)
      soils.push_back(library().get(name));
  for (SoilParameters soil : soils)
  {
    const std::string& name = soil.name;
    soil.model = SinkageModel::kSimple;  // the simple law of every soil, Bekker ones included
    const ContactSoil prepared(soil);
    for (int k = 0; k < 4000; ++k)
    {
      // A state as the contact leaves it: virgin, or compacted at some largest stress with
      // some soil flowed away or heaped on.
      const bool virgin = k % 4 == 0;
      const float sigma_max = virgin ? 0.f : static_cast<float>(6e5 * unit(rng) * unit(rng));
      const float plastic = virgin ? 0.f : static_cast<float>(plasticSinkage(soil, sigma_max));
      const float displaced = virgin ? 0.f : static_cast<float>(0.06 * unit(rng) - 0.01);
      const double penetration = std::pow(10.0, -7.0 + 6.5 * unit(rng));  // 1e-7 .. 0.3 m
      const double deformation = plastic + displaced;
      const double sigma = prepared.stressForPenetration(plastic, deformation, sigma_max, penetration);
      ASSERT_GE(sigma, 0.0);
      if (sigma == kRigidStress)
      {
        // Nothing up to the rigid stress absorbs it (hard layer reached).
        EXPECT_LE(referenceExtraSinkage(soil, plastic, displaced, sigma_max, kRigidStress), penetration) << name;
        ++rigid;
        continue;
      }
      // Exact to rounding: the residual is a few ulps of the sinkage terms, far below the
      // 1e-10 m the earlier iterative solve stopped at.
      const double residual = referenceExtraSinkage(soil, plastic, displaced, sigma_max, sigma) - penetration;
      ASSERT_LE(std::abs(residual), 1e-13 + 1e-11 * penetration)
          << name << " sigma_max=" << sigma_max << " plastic=" << plastic << " displaced=" << displaced
          << " penetration=" << penetration << " sigma=" << sigma;
      // Monotone: more penetration never needs less stress.
      EXPECT_GE(prepared.stressForPenetration(plastic, deformation, sigma_max, 1.01 * penetration), sigma);
      ++solved;
    }
  }
  EXPECT_GT(solved, 25000);
  EXPECT_GT(rigid, 0);  // the hard layer is reached, so that branch is exercised too
}

TEST(ContactSoil, PlasticSinkageIsTheReferenceToTheBit)
{
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> stress(0.0, 1.2e6);
  for (const std::string& name : library().names())
  {
    const SoilParameters& soil = library().get(name);
    if (soil.model == SinkageModel::kRigid)
      continue;  // no compaction law
    const ContactSoil prepared(soil);
    for (int k = 0; k < 1000; ++k)
    {
      const double sigma = stress(rng);
      ASSERT_EQ(prepared.plasticSinkage(sigma), plasticSinkage(soil, sigma)) << name << " " << sigma;
    }
    EXPECT_DOUBLE_EQ(prepared.tan_phi, std::tan(soil.friction_angle));
  }
}

TEST(ContactSoil, BekkerPressureIsTheReference)
{
  const SoilParameters& sand = library().get("dry_sand");
  const ContactSoil prepared(sand);
  EXPECT_EQ(prepared.model(), SinkageModel::kBekker);
  for (const double z : { 0.001, 0.01, 0.05, 0.2 })
    EXPECT_EQ(prepared.bekkerPressure(prepared.bekkerModulus(0.3), z), bekkerPressure(sand, 0.3, z));
  EXPECT_EQ(prepared.bekkerPressure(prepared.bekkerModulus(0.3), 0.0), 0.0);
  EXPECT_EQ(prepared.bekkerPressure(prepared.bekkerModulus(0.3), -0.01), 0.0);
}

TEST(ContactSoil, BadSoilsAreRejectedByField)
{
  const auto expectRejected = [](SoilParameters soil, const char* field) {
    try
    {
      const ContactSoil prepared(soil);
      ADD_FAILURE() << "accepted a soil with bad " << field;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(soil.name), std::string::npos) << e.what();
    }
  };
  const SoilParameters good = library().get("clay");
  SoilParameters s = good;
  s.h0 = std::nan("");
  expectRejected(s, "h0");
  s = good;
  s.shear_modulus = -0.02;
  expectRejected(s, "shear_modulus");
  s = good;
  s.friction_angle = M_PI / 2;
  expectRejected(s, "friction_angle");
  s = good;
  s.cohesion = std::numeric_limits<double>::infinity();
  expectRejected(s, "cohesion");
  s = good;
  s.compression = CompressionCurve();
  expectRejected(s, "compression");
  s = good;
  s.model = SinkageModel::kBekker;
  s.k_c = 0.0;
  s.k_phi = 0.0;
  expectRejected(s, "k_phi");
  s = good;
  s.model = SinkageModel::kBekker;
  s.n = 0.0;
  expectRejected(s, "n");
}
