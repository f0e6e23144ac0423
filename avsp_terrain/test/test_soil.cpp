// The soil library file: every soil loads with SI values; bad files name the file and key.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "avsp_terrain/soil.hpp"

using avsp::terrain::SinkageModel;
using avsp::terrain::SoilError;
using avsp::terrain::SoilLibrary;

namespace
{
const std::string kSoils = std::string(AVSP_CONFIG_DIR) + "/soils.yaml";

std::string readFile(const std::string& path)
{
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Writes `text` to a scratch file, loads it, returns the error (or "" if it loaded).
std::string loadError(const std::string& text)
{
  char name[] = "/tmp/avsp_soils_XXXXXX.yaml";
  const int fd = mkstemps(name, 5);
  EXPECT_GE(fd, 0);
  close(fd);
  std::ofstream(name) << text;
  std::string err;
  try
  {
    SoilLibrary::load(name);
  }
  catch (const SoilError& e)
  {
    err = e.what();
    EXPECT_NE(err.find(name), std::string::npos) << "error must name the file: " << err;
  }
  std::remove(name);
  return err;
}

std::string edited(const std::string& from, const std::string& to)
{
  std::string text = readFile(kSoils);
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}
}  // namespace

TEST(SoilLibrary, AllEightSoilsLoadInSiUnits)
{
  const SoilLibrary lib = SoilLibrary::load(kSoils);
  for (const char* name : { "asphalt", "gravel", "dry_sand", "sandy_loam", "clay", "mud", "snow", "grass_over_loam" })
    EXPECT_TRUE(lib.contains(name)) << name;
  const auto& sand = lib.get("dry_sand");
  // Wong Table 2.3, dry sand: n 1.1, k_c 0.99 kN/m^2.1, k_phi 1528.43 kN/m^3.1, c 1.04 kPa, 28 deg.
  EXPECT_EQ(sand.model, SinkageModel::kBekker);
  EXPECT_DOUBLE_EQ(sand.n, 1.1);
  EXPECT_DOUBLE_EQ(sand.k_c, 990.0);
  EXPECT_DOUBLE_EQ(sand.k_phi, 1528430.0);
  EXPECT_DOUBLE_EQ(sand.cohesion, 1040.0);
  EXPECT_NEAR(sand.friction_angle, 28.0 * M_PI / 180.0, 1e-15);
  EXPECT_DOUBLE_EQ(sand.compression.density(0.0), sand.rho0);
  EXPECT_NEAR(sand.compression.density(7.5e4), 1705.0, 1e-9);  // halfway between table points
  EXPECT_DOUBLE_EQ(sand.k_unload, 2.0e8);                      // N/m^3
  const auto& asphalt = lib.get("asphalt");
  EXPECT_EQ(asphalt.model, SinkageModel::kRigid);
  EXPECT_DOUBLE_EQ(asphalt.friction_peak, 0.85);
  EXPECT_DOUBLE_EQ(asphalt.friction_sliding, 0.75);
  EXPECT_DOUBLE_EQ(asphalt.rolling_resistance, 0.015);
  EXPECT_THROW(lib.get("lava"), SoilError);
}

TEST(SoilLibrary, BadFilesNameFileAndKey)
{
  std::string err = loadError(edited("cohesion_kpa: 4.14", "cohesion_kpa: -4.14"));
  EXPECT_NE(err.find("soils.clay.strength.cohesion_kpa"), std::string::npos) << err;
  err = loadError(edited("model: rigid\n", "model: magic\n"));
  EXPECT_NE(err.find("soils.asphalt.model"), std::string::npos) << err;
  err = loadError(edited("[5.0e4, 1680]", "[5.0e4, 1500]"));
  EXPECT_NE(err.find("soils.dry_sand.simple.compression"), std::string::npos) << err;
  EXPECT_NE(err.find("must not decrease"), std::string::npos) << err;
  err = loadError(edited("friction_angle_deg: 13.0", "friction_angle_deg: 95.0"));
  EXPECT_NE(err.find("friction_angle_deg"), std::string::npos) << err;
  err = loadError(edited("shear_modulus: 0.03}", "shear_modulu: 0.03}"));
  EXPECT_NE(err.find("unknown key"), std::string::npos) << err;
  err = loadError(edited("    bekker: {n: 1.6, k_c_kn: 4.37, k_phi_kn: 196.72, k_unload_kn: 4.0e4}\n", ""));
  EXPECT_NE(err.find("soils.snow.bekker"), std::string::npos) << err;
  EXPECT_NE(err.find("missing"), std::string::npos) << err;
  // The unloading stiffness: required, and > 0 (a Bekker soil that never springs back would
  // ratchet a parked wheel down step after step).
  err = loadError(edited("k_phi_kn: 196.72, k_unload_kn: 4.0e4}", "k_phi_kn: 196.72}"));
  EXPECT_NE(err.find("soils.snow.bekker.k_unload_kn"), std::string::npos) << err;
  EXPECT_NE(err.find("missing"), std::string::npos) << err;
  err = loadError(edited("k_phi_kn: 196.72, k_unload_kn: 4.0e4}", "k_phi_kn: 196.72, k_unload_kn: -4.0e4}"));
  EXPECT_NE(err.find("soils.snow.bekker.k_unload_kn"), std::string::npos) << err;
  // Rigid surfaces: their tyre parameters, each named.
  err = loadError(edited("friction_peak: 0.85", "friction_peak: -0.85"));
  EXPECT_NE(err.find("soils.asphalt.rigid.friction_peak"), std::string::npos) << err;
  err = loadError(edited("friction_sliding: 0.75", "friction_sliding: 0.95"));
  EXPECT_NE(err.find("soils.asphalt.rigid.friction_sliding"), std::string::npos) << err;
  EXPECT_NE(err.find("must not exceed friction_peak"), std::string::npos) << err;
  err = loadError(edited("friction_sliding: 0.75, ", ""));
  EXPECT_NE(err.find("soils.asphalt.rigid.friction_sliding"), std::string::npos) << err;
  EXPECT_NE(err.find("missing"), std::string::npos) << err;
  err = loadError(edited("rolling_resistance: 0.015}", "rolling_resistance: nan}"));
  EXPECT_NE(err.find("soils.asphalt.rigid.rolling_resistance"), std::string::npos) << err;
  err = loadError(
      edited("    model: rigid\n",
             "    model: rigid\n    strength: {cohesion_kpa: 1.0, friction_angle_deg: 30.0, shear_modulus: 0.01}\n"));
  EXPECT_NE(err.find("soils.asphalt.strength"), std::string::npos) << err;
  EXPECT_NE(err.find("unknown key"), std::string::npos) << err;
  err = loadError(edited("drying_time_constant_h: 48.0", "drying_time_constant_h: -48.0"));
  EXPECT_NE(err.find("soils.sandy_loam.moisture.drying_time_constant_h"), std::string::npos) << err;
  err = loadError(edited("- {moisture: 0.55, cohesion_kpa: 2.07", "- {moisture: 0.55, cohesion_kpa: oops"));
  EXPECT_NE(err.find("soils.clay.moisture.table[0].cohesion_kpa"), std::string::npos) << err;
  err = loadError("soils: {}\n");
  EXPECT_NE(err.find("no soil"), std::string::npos) << err;
  err = loadError("soils: [\n");
  EXPECT_NE(err.find("not valid YAML"), std::string::npos) << err;
}

TEST(SoilLibrary, RandomEditsLoadOrFailCleanly)
{
  const std::string original = readFile(kSoils);
  std::mt19937 rng(7321);  // fixed seed
  const std::string alphabet = "-:{}[],#\n 0123456789.eE_'\"x";
  int rejected = 0;
  for (int iteration = 0; iteration < 300; ++iteration)
  {
    std::string text = original;
    for (int e = 0; e < 3; ++e)
    {
      const std::size_t at = rng() % text.size();
      if (rng() % 2)
        text[at] = alphabet[rng() % alphabet.size()];
      else
        text.erase(at, 1 + rng() % 6);
    }
    rejected += !loadError(text).empty();
  }
  EXPECT_GT(rejected, 50);
}
