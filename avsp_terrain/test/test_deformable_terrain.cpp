// Deformable terrain: probes leave no trace, elastic sinkage recovers and compaction stays
// (T2, T3, T6), flowed soil is conserved and forms berms with transport on and vanishes
// with it off (T4, T5), and the contact force grows with sinkage.
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

#include "avsp_terrain/default_course.hpp"
#include "avsp_terrain/deformable_terrain.hpp"
#include "avsp_terrain/terramechanics.hpp"

using namespace avsp::terrain;

namespace
{
const SoilLibrary& library()
{
  static const SoilLibrary lib = SoilLibrary::load(std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  return lib;
}

/// Flat ground at z = 0: n x n points at `cell` m, origin at (0, 0).
DeformableTerrain flat(const std::string& soil, bool transport, std::size_t n = 120, double cell = 0.05)
{
  return DeformableTerrain(ElevationGrid(0, 0, cell, cell, n, n, std::vector<float>(n * n, 0.f)), library().get(soil),
                           DeformableTerrain::Options{ transport });
}

WheelPatch wheelAt(double x, double y, double bottom_z, double radius = 0.35, double width = 0.25)
{
  WheelPatch w;
  w.centre = Eigen::Vector3d(x, y, bottom_z + radius);
  w.radius = radius;
  w.width = width;
  w.velocity = Eigen::Vector3d::Zero();
  return w;
}

/// Sum over points of (z_f - z_n) * A: the volume that left minus what arrived, m^3.
double netDisplacedVolume(const DeformableTerrain& t)
{
  double sum = 0.0;
  for (std::size_t j = 0; j < t.base().rows(); ++j)
    for (std::size_t i = 0; i < t.base().columns(); ++i)
      sum += t.deformation(i, j).displaced;
  return sum * t.base().dx() * t.base().dy();
}
}  // namespace

TEST(DeformableTerrain, ProbeLeavesNoTrace)
{
  DeformableTerrain t = flat("sandy_loam", true);
  const ContactForces f = t.wheelContact(wheelAt(3.0, 3.0, -0.03), 0.001, false);
  EXPECT_GT(f.normal_force, 0.0);
  EXPECT_GT(f.contact_points, 0);
  EXPECT_EQ(t.deformedPoints(), 0u);
  EXPECT_DOUBLE_EQ(*t.height(3.0, 3.0), 0.0);
}

TEST(DeformableTerrain, NormalForceGrowsWithSinkage)
{
  DeformableTerrain t = flat("clay", true);
  double previous = 0.0;
  for (const double depth : { 0.005, 0.01, 0.02, 0.04 })
  {
    const double force = t.wheelContact(wheelAt(3.0, 3.0, -depth), 0.001, false).normal_force;
    EXPECT_GT(force, previous) << depth;
    previous = force;
  }
  // Above the ground: no contact at all.
  EXPECT_EQ(t.wheelContact(wheelAt(3.0, 3.0, 0.001), 0.001, false).contact_points, 0);
}

TEST(DeformableTerrain, ElasticRecoversPlasticStays)
{
  DeformableTerrain t = flat("sandy_loam", false);
  const double depth = 0.03;
  const ContactForces loaded = t.wheelContact(wheelAt(3.0, 3.0, -depth), 0.001, true);
  ASSERT_GT(loaded.elastic_sinkage, 1e-5);
  // The point under the wheel's bottom (x = 3.0 -> i = 60, y = 3.0 -> j = 60).
  const PointDeformation d = t.deformation(60, 60);
  EXPECT_GT(d.plastic, 0.f);
  EXPECT_NEAR(d.plastic, plasticSinkage(t.soil(60, 60), d.sigma_max), 1e-7);  // T2 at the largest stress
  // Unloaded, the surface sits at the permanent deformation only: z_e is gone (T6).
  const double unloaded_depth = -t.pointHeight(60, 60);
  EXPECT_NEAR(unloaded_depth, d.plastic + d.displaced, 1e-9);
  // While loaded it was deformed by the full penetration: permanent + elastic.
  EXPECT_NEAR(depth, unloaded_depth + elasticSinkage(t.soil(60, 60), d.sigma_max, 0.0), 1e-6);
  // Lifting the wheel and pressing again less deeply does not undo the compaction.
  t.wheelContact(wheelAt(3.0, 3.0, -0.5 * unloaded_depth), 0.001, true);
  EXPECT_FLOAT_EQ(t.deformation(60, 60).plastic, d.plastic);
}

namespace
{
/// A slipping wheel driven 2 m along +x through the middle of the patch, 1 ms steps.
void driveThrough(DeformableTerrain& t)
{
  const double depth = 0.04, speed = 1.0, dt = 0.002;
  for (double x = 1.0; x < 3.0; x += speed * dt)
  {
    WheelPatch w = wheelAt(x, 3.0, -depth);
    w.velocity = Eigen::Vector3d(speed, 0, 0);
    w.spin_rate = 1.3 * speed / w.radius;  // 23 % slip: shearing flow (T4's b2 term)
    t.wheelContact(w, dt, true);
  }
}
}  // namespace

TEST(DeformableTerrain, TransportConservesVolumeAndRaisesBerms)
{
  DeformableTerrain t = flat("mud", true);
  driveThrough(t);
  ASSERT_GT(t.flowedVolume(), 1e-4);
  // T5: what left equals what arrived, so the net displaced volume is zero.
  EXPECT_NEAR(t.arrivedVolume(), t.flowedVolume(), 1e-9 * t.flowedVolume());
  EXPECT_LT(std::abs(netDisplacedVolume(t)), 1e-6 * t.flowedVolume());
  // Berms: beside the rut (|y - 3| just beyond the half width) the ground rose.
  double berm = -1.0, rut = 1.0;
  for (std::size_t i = 30; i < 50; ++i)
  {
    for (std::size_t j = 0; j < t.base().rows(); ++j)
    {
      const double y = j * t.base().dy();
      if (std::abs(y - 3.0) > 0.14)
        berm = std::max(berm, t.pointHeight(i, j));
      rut = std::min(rut, t.pointHeight(i, j));
    }
  }
  EXPECT_GT(berm, 1e-4) << "no berm beside the rut";
  EXPECT_LT(rut, -0.01) << "no rut";
}

TEST(DeformableTerrain, NoTransportNoBerms)
{
  DeformableTerrain t = flat("mud", false);
  driveThrough(t);
  ASSERT_GT(t.flowedVolume(), 1e-4);
  EXPECT_EQ(t.arrivedVolume(), 0.0);
  // All flowed soil is gone (z_n = 0): the net displaced volume is the flowed volume ...
  EXPECT_NEAR(netDisplacedVolume(t), t.flowedVolume(), 1e-6 * t.flowedVolume());
  // ... and nothing rose anywhere.
  for (std::size_t j = 0; j < t.base().rows(); ++j)
    for (std::size_t i = 0; i < t.base().columns(); ++i)
      ASSERT_LE(t.pointHeight(i, j), 0.0) << i << "," << j;
}

TEST(DeformableTerrain, DrivingWheelGetsTractionAndResistance)
{
  DeformableTerrain t = flat("sandy_loam", true);
  WheelPatch w = wheelAt(3.0, 3.0, -0.03);
  w.velocity = Eigen::Vector3d(1.0, 0, 0);
  w.spin_rate = 1.25 / w.radius;  // slip 0.2
  const ContactForces f = t.wheelContact(w, 0.001, false);
  EXPECT_NEAR(f.slip, 0.2, 1e-12);
  EXPECT_GT(f.longitudinal_force, 0.0);
  EXPECT_GT(f.resistance_force, 0.0);
  EXPECT_NEAR(f.lateral_force, 0.0, 1e-9);
  // Traction cannot exceed the Mohr-Coulomb envelope over the contact (T7 with j -> inf).
  const double area = t.base().dx() * t.base().dy() * f.contact_points;
  EXPECT_LT(f.longitudinal_force, area * t.soil(60, 60).cohesion + f.normal_force * std::tan(t.soil(60, 60).friction_angle));
  // Braking reverses it; sliding sideways gives a restoring lateral force.
  w.spin_rate = 0.8 / w.radius;
  EXPECT_LT(t.wheelContact(w, 0.001, false).longitudinal_force, 0.0);
  w.spin_rate = 1.0 / w.radius;
  w.velocity = Eigen::Vector3d(1.0, 0.2, 0);
  EXPECT_LT(t.wheelContact(w, 0.001, false).lateral_force, 0.0);
}

TEST(DeformableTerrain, StateOnlyWhereTouched)
{
  DeformableTerrain t = flat("clay", true, 400, 0.1);
  EXPECT_EQ(t.deformationBytes(), t.deformationBytes());
  const std::size_t empty = t.deformationBytes();
  t.wheelContact(wheelAt(20.0, 20.0, -0.03), 0.001, true);
  EXPECT_GT(t.deformedPoints(), 0u);
  // A single wheel print touches a handful of 8x8 tiles, not the 160,000-point grid.
  EXPECT_LT(t.deformationBytes() - empty, 20u * 1024u);
}

TEST(DeformableTerrain, BadWheelInputThrowsNamingTheField)
{
  DeformableTerrain t = flat("clay", true, 40);
  const auto expectRejected = [&](const WheelPatch& w, double dt, const char* field) {
    try
    {
      t.wheelContact(w, dt, true);
      ADD_FAILURE() << "accepted a bad " << field;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  const WheelPatch good = wheelAt(1.0, 1.0, -0.02);
  WheelPatch w = good;
  w.radius = -0.35;
  expectRejected(w, 0.01, "wheel.radius");
  w = good;
  w.width = 0.0;
  expectRejected(w, 0.01, "wheel.width");
  w = good;
  w.centre.z() = std::nan("");
  expectRejected(w, 0.01, "wheel.centre");
  w = good;
  w.velocity.x() = std::numeric_limits<double>::infinity();
  expectRejected(w, 0.01, "wheel.velocity");
  w = good;
  w.heading = std::nan("");
  expectRejected(w, 0.01, "wheel.heading");
  w = good;
  w.spin_rate = std::nan("");
  expectRejected(w, 0.01, "wheel.spin_rate");
  expectRejected(good, -0.01, "dt");
  expectRejected(good, std::nan(""), "dt");
  EXPECT_EQ(t.deformedPoints(), 0u);  // nothing was half-applied
  // Far outside the grid (even absurdly far) is simply no contact.
  w = good;
  w.centre.x() = 1e300;
  EXPECT_EQ(t.wheelContact(w, 0.01, true).contact_points, 0);
  w.centre.x() = -1e300;
  EXPECT_EQ(t.wheelContact(w, 0.01, true).contact_points, 0);
}

TEST(DeformableTerrain, RepeatedRunsAreBitIdentical)
{
  // Same inputs, same terrain and forces to the bit (lockstep simulation relies on it).
  DeformableTerrain a = flat("mud", true), b = flat("mud", true);
  for (double x = 1.0; x < 2.0; x += 0.0037)
  {
    WheelPatch w = wheelAt(x, 3.0 + 0.1 * std::sin(3 * x), -0.035);
    w.heading = 0.3 * std::sin(2 * x);
    w.velocity = Eigen::Vector3d(std::cos(w.heading), std::sin(w.heading), 0);
    w.spin_rate = 1.2 / w.radius;
    const ContactForces fa = a.wheelContact(w, 0.004, true), fb = b.wheelContact(w, 0.004, true);
    ASSERT_EQ(fa.normal_force, fb.normal_force);
    ASSERT_EQ(fa.longitudinal_force, fb.longitudinal_force);
    ASSERT_EQ(fa.lateral_force, fb.lateral_force);
    ASSERT_EQ(fa.resistance_force, fb.resistance_force);
  }
  for (std::size_t j = 0; j < a.base().rows(); ++j)
    for (std::size_t i = 0; i < a.base().columns(); ++i)
    {
      const PointDeformation da = a.deformation(i, j), db = b.deformation(i, j);
      ASSERT_EQ(std::memcmp(&da, &db, sizeof(da)), 0) << i << "," << j;
    }
  EXPECT_EQ(a.flowedVolume(), b.flowedVolume());
  EXPECT_EQ(a.arrivedVolume(), b.arrivedVolume());
}

namespace
{
/// Flat n x n terrain at 0.05 m: clay (palette 0) for x < 3 m, mud (palette 1) from x = 3 m.
DeformableTerrain clayAndMud(bool transport = true, std::size_t n = 120)
{
  std::vector<std::uint8_t> map(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      map[j * n + i] = i < 60 ? 0 : 1;
  return DeformableTerrain(ElevationGrid(0, 0, 0.05, 0.05, n, n, std::vector<float>(n * n, 0.f)),
                           { library().get("clay"), library().get("mud") }, std::move(map),
                           DeformableTerrain::Options{ transport });
}
}  // namespace

TEST(DeformableTerrain, SoilMapEachPointUsesItsOwnSoil)
{
  DeformableTerrain mixed = clayAndMud();
  DeformableTerrain clay = flat("clay", true), mud = flat("mud", true);
  EXPECT_EQ(mixed.soil(10, 10).name, "clay");
  EXPECT_EQ(mixed.soil(100, 10).name, "mud");
  // A wheel wholly on one side feels exactly that soil.
  WheelPatch w = wheelAt(1.5, 3.0, -0.03);
  w.velocity = Eigen::Vector3d(1.0, 0, 0);
  w.spin_rate = 1.2 / w.radius;
  const ContactForces on_clay = mixed.wheelContact(w, 0.01, false);
  EXPECT_EQ(on_clay.normal_force, clay.wheelContact(w, 0.01, false).normal_force);
  EXPECT_EQ(on_clay.longitudinal_force, clay.wheelContact(w, 0.01, false).longitudinal_force);
  w.centre.x() = 4.5;
  const ContactForces on_mud = mixed.wheelContact(w, 0.01, false);
  EXPECT_EQ(on_mud.normal_force, mud.wheelContact(w, 0.01, false).normal_force);
  EXPECT_NE(on_mud.normal_force, on_clay.normal_force);
  // Straddling the boundary (rolling along y, across it), each point compacts by its own T2.
  w.centre.x() = 3.0;
  w.heading = M_PI / 2;
  w.velocity = Eigen::Vector3d(0, 1.0, 0);
  const ContactForces straddle = mixed.wheelContact(w, 0.01, true);
  int clay_points = 0, mud_points = 0;
  for (std::size_t j = 0; j < 120; ++j)
    for (std::size_t i = 0; i < 120; ++i)
    {
      const PointDeformation d = mixed.deformation(i, j);
      if (d.sigma_max == 0.f)
        continue;
      const SoilParameters& soil = mixed.soil(i, j);
      EXPECT_EQ(d.plastic, static_cast<float>(plasticSinkage(soil, d.sigma_max))) << i << "," << j;
      (soil.name == "clay" ? clay_points : mud_points) += 1;
    }
  EXPECT_GT(clay_points, 5);
  EXPECT_GT(mud_points, 5);
  EXPECT_EQ(clay_points + mud_points, straddle.contact_points);
}

TEST(DeformableTerrain, BadPaletteOrSoilMapThrowsNamingIt)
{
  const std::size_t n = 20;
  const ElevationGrid grid(0, 0, 0.1, 0.1, n, n, std::vector<float>(n * n, 0.f));
  const auto expectRejected = [&](std::vector<SoilParameters> palette, std::vector<std::uint8_t> map,
                                  const char* what) {
    try
    {
      DeformableTerrain t(grid, std::move(palette), std::move(map), DeformableTerrain::Options{});
      ADD_FAILURE() << "accepted: " << what;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  const SoilParameters clay = library().get("clay"), mud = library().get("mud");
  expectRejected({ clay, mud }, std::vector<std::uint8_t>(n * n - 1, 0), "soil_map has 399 entries");
  std::vector<std::uint8_t> map(n * n, 1);
  map[3 * n + 7] = 2;
  expectRejected({ clay, mud }, map, "soil_map: index 2 at grid point (7, 3) is not in the palette of 2");
  expectRejected({}, std::vector<std::uint8_t>(n * n, 0), "palette has 0 soils");
  expectRejected(std::vector<SoilParameters>(257, clay), std::vector<std::uint8_t>(n * n, 0), "palette has 257");
  SoilParameters broken = mud;
  broken.shear_modulus = std::nan("");
  expectRejected({ clay, broken }, std::vector<std::uint8_t>(n * n, 0), "palette[1]: soil 'mud': shear_modulus");
  // A full palette of 256 is fine, and a single soil stores no map.
  std::vector<std::uint8_t> all(n * n);
  for (std::size_t k = 0; k < all.size(); ++k)
    all[k] = static_cast<std::uint8_t>(k % 256);
  EXPECT_EQ(DeformableTerrain(grid, std::vector<SoilParameters>(256, clay), all, {}).soilIndex(15, 12), 255);
  EXPECT_EQ(DeformableTerrain(grid, { clay }, std::vector<std::uint8_t>(n * n, 0), {}).soilMapBytes(), 0u);
  EXPECT_THROW(DeformableTerrain(grid, clay, {}).soilIndex(n, 0), std::out_of_range);
}

TEST(DeformableTerrain, SetSoilChangesThatPaletteEntryOnly)
{
  DeformableTerrain mixed = clayAndMud();
  DeformableTerrain clay = flat("clay", true);
  WheelPatch w = wheelAt(4.5, 3.0, -0.03);  // on the mud side
  mixed.setSoil(1, library().get("clay"));
  EXPECT_EQ(mixed.wheelContact(w, 0.01, false).normal_force, clay.wheelContact(w, 0.01, false).normal_force);
  SoilParameters broken = library().get("mud");
  broken.h0 = -1.0;
  EXPECT_THROW(mixed.setSoil(1, broken), std::invalid_argument);
  EXPECT_EQ(mixed.palette()[1].name, "clay");  // a rejected soil changes nothing
  try
  {
    mixed.setSoil(2, library().get("mud"));
    ADD_FAILURE() << "set a soil outside the palette";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("index 2"), std::string::npos) << e.what();
  }
}

TEST(DeformableTerrain, PaletteFromCourseNames)
{
  const auto palette = paletteFromNames({ "gravel", "mud" }, library());
  ASSERT_EQ(palette.size(), 2u);
  EXPECT_EQ(palette[1].name, "mud");
  EXPECT_THROW(paletteFromNames({ "gravel", "lava" }, library()), SoilError);
}

TEST(DeformableTerrain, DefaultCourseSoilMapDrivesTheContact)
{
  CourseOptions options;
  options.length_x = kMinCourseLengthX;
  options.length_y = kMinCourseLengthY;
  options.cell_size = 0.25;
  Course course = makeDefaultCourse(options);
  const std::vector<std::string> names = course.soil_names;
  DeformableTerrain t(std::move(course.heights), paletteFromNames(names, library()), std::move(course.soil_map),
                      DeformableTerrain::Options{ true });
  const auto soilAt = [&](const CourseFeature& f) {
    const double x = 0.5 * (f.min_x + f.max_x), y = 0.5 * (f.min_y + f.max_y);
    return t.soil(static_cast<std::size_t>(std::lround(x / 0.25)), static_cast<std::size_t>(std::lround(y / 0.25)))
        .name;
  };
  EXPECT_EQ(soilAt(course.feature("road")), "asphalt");
  EXPECT_EQ(soilAt(course.feature("pond")), "mud");
  // The same 2 cm press needs far more force on the road than in the pond.
  const auto press = [&](const CourseFeature& f) {
    const double x = 0.5 * (f.min_x + f.max_x), y = 0.5 * (f.min_y + f.max_y);
    return t.wheelContact(wheelAt(x, y, *t.height(x, y) - 0.02, 0.35, 0.3), 0.01, false).normal_force;
  };
  EXPECT_GT(press(course.feature("road")), 10.0 * press(course.feature("pond")));
}
