// The moving patch: a DEM bed that follows a driven wheel over a DeformableTerrain, retiring
// blocks behind (their surface written into the terrain) and inserting blocks ahead.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numeric>

#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/dem/moving_patch.hpp"
#include "avsp_dynamics/dem/wheel_rig.hpp"
#include "dem_test_beds.hpp"

namespace dem = avsp::dynamics::dem;
namespace terrain = avsp::terrain;

namespace
{
/// Flat ground at the template's depth (0.1 m), 2 cm grid, x in [-0.1, 1.3], y in [-0.1, 0.34].
terrain::DeformableTerrain flatTerrain()
{
  const std::size_t columns = 71, rows = 23;
  terrain::ElevationGrid grid(
      -0.1, -0.1, 0.02, 0.02, columns, rows,
      std::vector<float>(columns * rows, static_cast<float>(dem_test::smallTemplate().depth())));
  return terrain::DeformableTerrain(std::move(grid), terrain::SoilLibrary::load(AVSP_SOILS_YAML).get("dry_sand"), {});
}

double mean(const std::vector<double>& v, std::size_t a, std::size_t b)
{
  return std::accumulate(v.begin() + a, v.begin() + b, 0.0) / (b - a);
}
}  // namespace

TEST(DemPatch, FollowsAWheelWritesTheRutBackWithoutAForceSpike)
{
  const auto& bed = dem_test::smallTemplate();
  auto ground = flatTerrain();
  dem::PatchSpec spec;
  spec.x_start = 0.0;
  spec.x_end = 1.2;
  spec.y_min = 0.0;
  spec.length = 5 * bed.length();  // 0.6 m
  spec.front_margin = 0.3;
  dem::MovingPatch patch(bed, ground, spec);
  patch.world().settle(0.2);
  dem::WheelRigSpec wheel;
  wheel.load = 150.0;
  wheel.width = 0.08;
  dem::SingleWheelRig rig(patch.world(), wheel, 0.2);
  rig.setSpinRate(0.48 / wheel.radius);
  rig.setCarriageSpeed(0.4);
  std::vector<double> fz;
  std::vector<std::size_t> moved;
  while (rig.state().centre.x() < 0.85 && fz.size() < 3000)
  {
    rig.step();
    fz.push_back(rig.state().soil.force.z());
    if (patch.follow(rig.state().centre.x()))
      moved.push_back(fz.size());
  }
  ASSERT_GE(moved.size(), 4u);
  EXPECT_EQ(patch.relocations(), static_cast<int>(moved.size()));
  EXPECT_GT(patch.pointsWritten(), 0u);
  // Across each relocation the wheel's vertical force shows no step beyond its own: the change
  // of the 100 ms mean across a relocation, against the same change across every other instant
  // (10 ms apart, 100 ms or more from a relocation) of the run: the rolling wheel's own
  // fluctuation on 20 mm particles (the retired and inserted blocks are 0.15 m and more from its
  // contact). Printed beside the 10 % of issue 25.
  auto change = [&](std::size_t k) {
    const double before = mean(fz, k - 100, k);
    return std::abs(mean(fz, k, k + 100) - before) / before;
  };
  double ss = 0.0;
  int count = 0;
  for (std::size_t k = 100; k + 100 <= fz.size(); k += 10)
  {
    bool near = false;
    for (std::size_t m : moved)
      near = near || (k + 100 > m && k < m + 100);
    if (!near)
    {
      ss += change(k) * change(k);
      ++count;
    }
  }
  ASSERT_GT(count, 10);
  const double natural = std::sqrt(ss / count);
  std::cout << "the 100 ms mean of F_z changes by " << 100 * natural << " % (rms) across ordinary instants\n";
  for (std::size_t k : moved)
  {
    if (k < 100 || k + 100 > fz.size())
      continue;
    std::cout << "relocation at " << k << " ms: F_z " << mean(fz, k - 100, k) << " N before, " << mean(fz, k, k + 100)
              << " N after (" << 100 * change(k) << " %)\n";
    EXPECT_LT(change(k), 3.0 * natural);
  }
  // Behind the patch the terrain shows the rut: along the wheel's track lower than beside it.
  double track = 0.0, side = 0.0;
  int n = 0;
  for (double x = 0.14; x < patch.rear() - 0.02; x += 0.02)
  {
    track += *ground.height(x, 0.12);
    side += 0.5 * (*ground.height(x, 0.04) + *ground.height(x, 0.20));
    ++n;
  }
  ASSERT_GT(n, 3);
  track /= n;
  side /= n;
  std::cout << "written back: track " << track << " m, beside it " << side << " m (ground was " << bed.depth()
            << " m); " << patch.relocations() << " relocations\n";
  EXPECT_LT(track, side - 0.002);
  // Ahead of the patch the terrain is untouched.
  EXPECT_NEAR(*ground.height(1.25, 0.12), bed.depth(), 1e-6);
}

TEST(DemPatch, ALengthThatIsNotWholeBlocksIsNamed)
{
  const auto& bed = dem_test::smallTemplate();
  auto ground = flatTerrain();
  dem::PatchSpec spec;
  spec.x_end = 1.2;
  spec.length = 0.5;
  try
  {
    dem::MovingPatch patch(bed, ground, spec);
    FAIL() << "no error";
  }
  catch (const dem::DemParameterError& e)
  {
    EXPECT_NE(std::string(e.what()).find("dem.patch.length"), std::string::npos) << e.what();
  }
}
