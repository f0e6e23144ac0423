// Dynamic soil: rain raises moisture and lowers cohesion per the soil's table, drying
// restores it with the stated time constant, snow builds a layer.
#include <cmath>

#include <gtest/gtest.h>

#include "avsp_terrain/dynamic_soil.hpp"

using namespace avsp::terrain;

namespace
{
const SoilLibrary& library()
{
  static const SoilLibrary lib = SoilLibrary::load(std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  return lib;
}
}  // namespace

TEST(SoilAtMoisture, TableRowsAreReproducedAndInterpolated)
{
  const SoilParameters& loam = library().get("sandy_loam");
  // Wong Table 2.3 sandy loam LLL: 15 % -> c 1.72 kPa, 22 % -> c 1.38 kPa, phi 29 -> 38 deg.
  EXPECT_NEAR(soilAtMoisture(loam, 0.15).cohesion, 1720.0, 1e-9);
  EXPECT_NEAR(soilAtMoisture(loam, 0.22).cohesion, 1380.0, 1e-9);
  EXPECT_NEAR(soilAtMoisture(loam, 0.22).k_phi, 43120.0, 1e-6);
  EXPECT_NEAR(soilAtMoisture(loam, 0.185).cohesion, 1550.0, 1e-9);  // halfway
  EXPECT_NEAR(soilAtMoisture(loam, 0.185).friction_angle, 33.5 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(soilAtMoisture(loam, 0.30).cohesion, 1380.0, 1e-9);  // held beyond the table
  EXPECT_NEAR(soilAtMoisture(loam, 0.05).cohesion, 1720.0, 1e-9);
  // A soil without a table does not change.
  const SoilParameters& gravel = library().get("gravel");
  EXPECT_EQ(soilAtMoisture(gravel, 0.11).cohesion, gravel.cohesion);
}

TEST(Moisture, RainRaisesMoistureAndLowersCohesion)
{
  const SoilParameters& clay = library().get("clay");
  SoilWeatherField field(0, 0, 10.0, 4, 3, clay);
  const double c0 = field.soilAt(5, 5).cohesion;
  double previous = field.moistureAt(5, 5);
  for (int hour = 0; hour < 6; ++hour)
  {
    for (int k = 0; k < 60; ++k)
      field.advance(60.0, 10.0, 0.0);  // 10 mm/h
    EXPECT_GT(field.moistureAt(5, 5), previous);
    previous = field.moistureAt(5, 5);
  }
  EXPECT_LE(previous, clay.moisture.saturated);
  // Clay (Wong: 38 % -> c 4.14 kPa, 55 % -> 2.07 kPa): wetter is weaker.
  EXPECT_LT(field.soilAt(5, 5).cohesion, c0);
  EXPECT_NEAR(field.soilAt(5, 5).cohesion, soilAtMoisture(clay, previous).cohesion, 1e-9);
}

TEST(Moisture, DryingFollowsTheStatedTimeConstant)
{
  const SoilParameters& loam = library().get("sandy_loam");
  const MoistureSpec& m = loam.moisture;
  const double wet = 0.30, tau = m.drying_time_constant;
  ASSERT_NEAR(tau, 48.0 * 3600.0, 1e-9);
  double w = wet;
  for (int k = 0; k < 48 * 60; ++k)
    w = advanceMoisture(m, w, 60.0, 0.0);  // one tau in one-minute steps
  EXPECT_NEAR(w - m.dry, (wet - m.dry) * std::exp(-1.0), 1e-12);
  // Three more tau: within 5 % of the way back to dry.
  for (int k = 0; k < 3 * 48; ++k)
    w = advanceMoisture(m, w, 3600.0, 0.0);
  EXPECT_NEAR(w - m.dry, (wet - m.dry) * std::exp(-4.0), 1e-12);
  // Cohesion returns towards its dry-side table value as it dries.
  EXPECT_GT(soilAtMoisture(loam, w).cohesion, soilAtMoisture(loam, wet).cohesion);
}

TEST(Moisture, SaturationCapsWetting)
{
  const MoistureSpec& m = library().get("mud").moisture;
  double w = m.initial;
  for (int k = 0; k < 1000; ++k)
    w = advanceMoisture(m, w, 3600.0, 50.0);
  EXPECT_LE(w, m.saturated);
  EXPECT_GT(w, 0.99 * m.saturated);
}

TEST(Snow, WaterEquivalentBecomesDepth)
{
  SoilWeatherField field(0, 0, 10.0, 2, 2, library().get("grass_over_loam"), 100.0);
  field.advance(3600.0, 0.0, 10.0);  // 10 mm/h water equivalent for 1 h, fresh snow 100 kg/m^3
  EXPECT_NEAR(field.snowDepthAt(1, 1), 0.10, 1e-12);
  EXPECT_THROW(field.advance(-1.0, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(field.advance(1.0, std::nan(""), 0.0), std::invalid_argument);
  EXPECT_THROW(SoilWeatherField(0, 0, 0.0, 1, 1, library().get("clay")), std::invalid_argument);
}
