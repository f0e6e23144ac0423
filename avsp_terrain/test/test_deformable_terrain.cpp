// Deformable terrain: probes leave no trace, elastic sinkage recovers and compaction stays
// (T2, T3, T6), flowed soil is conserved and forms berms with transport on and vanishes
// with it off (T4, T5), and the contact force grows with sinkage.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
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
DeformableTerrain flat(const SoilParameters& soil, bool transport, std::size_t n = 120, double cell = 0.05)
{
  return DeformableTerrain(ElevationGrid(0, 0, cell, cell, n, n, std::vector<float>(n * n, 0.f)), soil,
                           DeformableTerrain::Options{ transport });
}

DeformableTerrain flat(const std::string& soil, bool transport, std::size_t n = 120, double cell = 0.05)
{
  return flat(library().get(soil), transport, n, cell);
}

/// A library soil under the simple model (T2-T6, T12), whatever law the library gives it: the
/// tests of that model's own behaviour.
SoilParameters simpleSoil(const std::string& name)
{
  SoilParameters soil = library().get(name);
  soil.model = SinkageModel::kSimple;
  return soil;
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
  DeformableTerrain t = flat(simpleSoil("sandy_loam"), false);
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
  DeformableTerrain t = flat(simpleSoil("mud"), true);
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
  DeformableTerrain t = flat(simpleSoil("mud"), false);
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
  DeformableTerrain t = flat(simpleSoil("sandy_loam"), true);
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
  EXPECT_LT(f.longitudinal_force,
            area * t.soil(60, 60).cohesion + f.normal_force * std::tan(t.soil(60, 60).friction_angle));
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
  // Untouched: no deformed point, and nothing but the tile directory (8 B per 8x8 tile of the
  // 400 x 400 points: 2500 tiles, 20,000 B, allowing a page of bookkeeping).
  EXPECT_EQ(t.deformedPoints(), 0u);
  const std::size_t empty = t.deformationBytes();
  EXPECT_LE(empty, 2500u * 8u + 4096u);
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
                           { simpleSoil("clay"), simpleSoil("mud") }, std::move(map),
                           DeformableTerrain::Options{ transport });
}
}  // namespace

TEST(DeformableTerrain, SoilMapEachPointUsesItsOwnSoil)
{
  DeformableTerrain mixed = clayAndMud();
  DeformableTerrain clay = flat(simpleSoil("clay"), true), mud = flat(simpleSoil("mud"), true);
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
  // Every deformed point was under the wheel; the contact also counts the points beside its
  // edges whose cells it partly covers (they carry load but keep their state).
  EXPECT_LE(clay_points + mud_points, straddle.contact_points);
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
  DeformableTerrain single(grid, clay, {});
  EXPECT_THROW(single.soilIndex(n, 0), std::out_of_range);
  // Every point accessor refuses points outside the grid instead of reading past it.
  EXPECT_THROW(single.deformation(0, n), std::out_of_range);
  EXPECT_THROW(single.pointHeight(n + 100, 0), std::out_of_range);
  EXPECT_THROW(single.setDeformation(n, n, PointDeformation{}), std::out_of_range);
  EXPECT_THROW(single.soil(0, 1000000), std::out_of_range);
}

TEST(DeformableTerrain, SetSoilChangesThatPaletteEntryOnly)
{
  DeformableTerrain mixed = clayAndMud();
  DeformableTerrain clay = flat(simpleSoil("clay"), true);
  WheelPatch w = wheelAt(4.5, 3.0, -0.03);  // on the mud side
  mixed.setSoil(1, simpleSoil("clay"));
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
  // A 2 cm press: the road is rigid (the soil carries nothing, the contact reports the surface
  // for the tyre to deflect on), the pond's mud carries it and records it.
  const auto press = [&](const CourseFeature& f) {
    const double x = 0.5 * (f.min_x + f.max_x), y = 0.5 * (f.min_y + f.max_y);
    return t.wheelContact(wheelAt(x, y, *t.height(x, y) - 0.02, 0.35, 0.3), 0.01, false);
  };
  const ContactForces road = press(course.feature("road")), pond = press(course.feature("pond"));
  EXPECT_EQ(road.normal_force, 0.0);
  EXPECT_EQ(road.rigid_share, 1.0);
  ASSERT_GE(road.rigid_soil, 0);
  EXPECT_EQ(t.palette()[road.rigid_soil].name, "asphalt");
  EXPECT_GT(pond.normal_force, 0.0);
  EXPECT_EQ(pond.rigid_share, 0.0);
  EXPECT_EQ(pond.rigid_soil, -1);
}

TEST(DeformableTerrain, LoadedWidthIsTheWheelWidthAtAnyGridOffset)
{
  // Side-edge points carry the share of their cell under the wheel: sliding the wheel
  // sideways by a fraction of a cell leaves the force unchanged (without the shares it
  // jumps by a whole row, 1/5 of a 0.25 m wheel at 0.05 m cells), and the force is
  // proportional to the width (the simple model: its pressure does not depend on the width,
  // Bekker's k_c / b does).
  DeformableTerrain t = flat(simpleSoil("clay"), false);
  const double reference = t.wheelContact(wheelAt(3.0, 3.0, -0.02, 0.35, 0.25), 0.01, false).normal_force;
  for (int k = 1; k <= 10; ++k)
  {
    const double y = 3.0 + 0.005 * k;
    EXPECT_NEAR(t.wheelContact(wheelAt(3.0, y, -0.02, 0.35, 0.25), 0.01, false).normal_force, reference,
                1e-9 * reference)
        << "offset " << 0.005 * k;
    WheelPatch across = wheelAt(3.0 + 0.005 * k, 3.0, -0.02, 0.35, 0.25);
    across.heading = M_PI / 2;  // rolling along y: the width lies along x
    EXPECT_NEAR(t.wheelContact(across, 0.01, false).normal_force, reference, 1e-9 * reference);
  }
  for (const double width : { 0.13, 0.21, 0.37 })
    EXPECT_NEAR(t.wheelContact(wheelAt(3.0, 3.013, -0.02, 0.35, width), 0.01, false).normal_force,
                reference * width / 0.25, 1e-9 * reference);
  // Edges exactly on a row of points, where rounding puts the row a hair inside or outside:
  // 0.30 m centred on a row, and 0.20 m centred between rows, at several places.
  for (const double y : { 1.0, 2.0, 3.0, 4.45, 5.0 })
  {
    for (const double width : { 0.3, 0.2 })
    {
      const double centre = width == 0.3 ? y : y + 0.025;
      EXPECT_NEAR(t.wheelContact(wheelAt(3.0, centre, -0.02, 0.35, width), 0.01, false).normal_force,
                  reference * width / 0.25, 1e-9 * reference)
          << "y " << centre << " width " << width;
      WheelPatch across = wheelAt(centre, 3.0, -0.02, 0.35, width);
      across.heading = -M_PI / 2;
      EXPECT_NEAR(t.wheelContact(across, 0.01, false).normal_force, reference * width / 0.25, 1e-9 * reference)
          << "x " << centre << " width " << width;
    }
  }
}

namespace
{
/// Depth (m) of the wheel's lowest point below the surface at which the wheel at (x, y)
/// carries `load` (N) on terrain t, by bisection on probes (the terrain is not changed).
double depthCarrying(DeformableTerrain& t, WheelPatch w, double load)
{
  double lo = 0.0, hi = 0.9 * w.radius;
  for (int k = 0; k < 60; ++k)
  {
    const double mid = 0.5 * (lo + hi);
    w.centre.z() = w.radius - mid;
    (t.wheelContact(w, 0.01, false).normal_force < load ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

const double kBekkerRadius = 0.546;  // m, FED-Alpha-class tyre as a rigid wheel (as test_terramechanics)
const double kBekkerWidth = 0.365;   // m
}  // namespace

TEST(DeformableTerrain, BekkerStaticSinkageMatchesRigidWheelTheory)
{
  // A wheel lowered onto dry sand (a `bekker` soil) until the grid carries W. At rest the
  // whole arc is loaded, front and back alike, each half carrying what the front arc of
  // rigidWheelOnBekkerSoil() carries at that sinkage: so the grid's sinkage under W is the
  // theory's sinkage under W / 2 (T13 and rigidWheelStaticSinkage() are for a rolling
  // wheel, whose rear has unloaded: see the rolling test below).
  //
  // Tolerance from the discretisation: across the wheel the side-edge shares make the
  // width exact for an axis-aligned wheel; along it the grid samples p(u) = k z(u)^n at
  // points h apart over a contact 2L long (L = 0.22 m here) and the sum misses or adds part
  // of a cell at each end. Summed over all phases of the grid against the contact, that
  // error stays below 1 % of the load at h = 0.05 m (h / L = 0.23) and 0.05 % at h = 0.01 m
  // for n = 1.1 (computed offline by the same lattice sum). The load grows as z^(n + 1/2),
  // so the sinkage error is the load error / 1.6: we allow 1 % and 0.1 %.
  const SoilParameters& sand = library().get("dry_sand");
  ASSERT_EQ(sand.model, SinkageModel::kBekker);
  const double load = 5000.0;
  const double theory = rigidWheelStaticSinkage(sand, kBekkerRadius, kBekkerWidth, 0.5 * load);
  for (const double cell : { 0.05, 0.01 })
  {
    const std::size_t n = static_cast<std::size_t>(std::lround(3.0 / cell)) + 1;
    DeformableTerrain t(ElevationGrid(0, 0, cell, cell, n, n, std::vector<float>(n * n, 0.f)), sand,
                        DeformableTerrain::Options{ true });
    const double tolerance = cell > 0.02 ? 0.01 : 0.001;
    for (const double phase : { 0.0, 0.3, 0.55, 0.8 })
    {
      for (const double heading : { 0.0, M_PI / 2 })
      {
        WheelPatch w = wheelAt(1.5 + phase * cell, 1.5 + 0.37 * phase * cell, 0.0, kBekkerRadius, kBekkerWidth);
        w.heading = heading;
        EXPECT_NEAR(depthCarrying(t, w, load), theory, tolerance * theory)
            << "cell " << cell << " phase " << phase << " heading " << heading;
      }
    }
    // Turned off the grid's axes the side shares are exact only on average; the same bound holds.
    WheelPatch turned = wheelAt(1.5, 1.5, 0.0, kBekkerRadius, kBekkerWidth);
    turned.heading = 0.5;
    EXPECT_NEAR(depthCarrying(t, turned, load), theory, tolerance * theory) << "cell " << cell << " turned";
    EXPECT_EQ(t.deformedPoints(), 0u);
  }
  // And Bekker's closed form T13 (for W / 2), within the 5 % T13 itself is good for at n = 1.1.
  const double t13 = bekkerStaticSinkageClosedForm(sand, 2.0 * kBekkerRadius, kBekkerWidth, 0.5 * load);
  EXPECT_NEAR(theory, t13, 0.05 * t13);
}

TEST(DeformableTerrain, BekkerRollingWheelSinksAsT13)
{
  // A towed wheel (no slip) rolled over dry sand at constant load W, deforming: each step the
  // wheel is lowered until the grid carries W, then the step is made permanent. Ahead of the
  // bottom the sand yields along k z^n; behind it, pressed to z0, it springs back by
  // p_max / k_unload and presses on the rim along its unloading line: the rolling wheel of
  // rollingWheelSinkage(). With k_unload -> infinity (rigid-plastic sand, no rebound) only the
  // front arc carries: rigidWheelStaticSinkage() and T13.
  //
  // Discretisation: the lattice cuts the loaded front arc near the bottom, where the
  // pressure is largest, somewhere within a cell; that misplaces at most half a cell of arc
  // at the peak pressure p_max, i.e. p_max b h / 2 of load, and the sinkage error is that
  // relative load error / (n + 1/2) (the quarter-point samples of the contact halve it, the
  // bound keeps the whole). The error is first order in h, so it must also shrink with the
  // cell. The compaction resistance, a sum of sigma tan(angle) that vanishes at both ends of
  // the loaded arc, has the static test's kind of error at the grid's own sinkage.
  const double load = 5000.0;
  for (const bool rigid_plastic : { false, true })
  {
    SoilParameters sand = library().get("dry_sand");
    if (rigid_plastic)
      sand.k_unload = 1e14;
    const double theory = rollingWheelSinkage(sand, kBekkerRadius, kBekkerWidth, load);
    if (rigid_plastic)
      EXPECT_NEAR(theory, rigidWheelStaticSinkage(sand, kBekkerRadius, kBekkerWidth, load), 1e-4 * theory);
    const double p_max = bekkerPressure(sand, kBekkerWidth, theory);
    std::vector<double> errors;
    for (const double cell : { 0.1, 0.05 })
    {
      const std::size_t columns = static_cast<std::size_t>(std::lround(4.0 / cell)) + 1;
      const std::size_t rows = static_cast<std::size_t>(std::lround(1.2 / cell)) + 1;
      DeformableTerrain t(ElevationGrid(0, 0, cell, cell, columns, rows, std::vector<float>(columns * rows, 0.f)), sand,
                          DeformableTerrain::Options{ true });
      const double step = cell / 5.0;
      double sinkage_sum = 0.0, resistance_sum = 0.0;
      int samples = 0;
      for (int k = 0;; ++k)
      {
        const double x = 0.8 + k * step;
        if (x > 3.3)
          break;
        WheelPatch w = wheelAt(x, 0.6, 0.0, kBekkerRadius, kBekkerWidth);
        w.velocity = Eigen::Vector3d(1.0, 0.0, 0.0);
        w.spin_rate = 1.0 / kBekkerRadius;  // towed: slip 0, no slip sinkage
        const double z = depthCarrying(t, w, load);
        w.centre.z() = kBekkerRadius - z;
        const ContactForces f = t.wheelContact(w, step, true);
        ASSERT_NEAR(f.slip, 0.0, 1e-12);
        if (x > 2.3)  // after several contact lengths: steady state, averaged over 1 m
        {
          sinkage_sum += z;
          resistance_sum += f.resistance_force;
          ++samples;
        }
      }
      const double sinkage = sinkage_sum / samples;
      const double bound = p_max * kBekkerWidth * 0.5 * cell / load / (sand.n + 0.5);
      errors.push_back(std::abs(sinkage / theory - 1.0));
      EXPECT_LT(errors.back(), bound) << "cell " << cell << ": sinkage " << sinkage << ", theory " << theory
                                      << (rigid_plastic ? " (rigid-plastic)" : "");
      const double compaction =
          rollingWheelOnBekkerSoil(sand, kBekkerRadius, kBekkerWidth, sinkage).compaction_resistance;
      EXPECT_NEAR(resistance_sum / samples, compaction, (cell > 0.07 ? 0.05 : 0.015) * compaction)
          << "cell " << cell << (rigid_plastic ? " (rigid-plastic)" : "");
      // The rut is as deep as the wheel went, less the springback.
      EXPECT_NEAR(-t.pointHeight(static_cast<std::size_t>(std::lround(2.0 / cell)), rows / 2),
                  sinkage - p_max / sand.k_unload, 0.05 * sinkage);
    }
    EXPECT_LT(errors[1], 0.7 * errors[0]) << "the error does not shrink with the cell";
  }
  // Bekker's closed form for the same wheel on rigid-plastic sand (T13's own accuracy at
  // n = 1.1 is 5 %).
  const SoilParameters& sand = library().get("dry_sand");
  const double t13 = bekkerStaticSinkageClosedForm(sand, 2.0 * kBekkerRadius, kBekkerWidth, load);
  EXPECT_NEAR(rigidWheelStaticSinkage(sand, kBekkerRadius, kBekkerWidth, load), t13, 0.05 * t13);
}

TEST(DeformableTerrain, BekkerSoilSlipSinksDeeperAndConservesVolume)
{
  // On a Bekker soil T4's slip-driven flow (b2) still moves soil. Removed (transport off), it
  // leaves the ground under the wheel lower and the wheel sinks to restore its load: slip
  // sinkage. Transported (T5), it is conserved, and the slip drags it backwards: a wheel
  // spinning forward throws the soil it shears behind it, never ahead.
  const double load = 2000.0, dt = 0.004;
  double sinkage[3] = { 0.0, 0.0, 0.0 };  // towed, slipping, slipping with transport
  for (const int run : { 0, 1, 2 })
  {
    DeformableTerrain t = flat("dry_sand", run == 2);
    for (double x = 1.0; x < 2.5; x += dt)
    {
      WheelPatch w = wheelAt(x, 3.0, 0.0);
      w.velocity = Eigen::Vector3d(1.0, 0, 0);
      w.spin_rate = (run > 0 ? 1.3 : 1.0) / w.radius;
      sinkage[run] = depthCarrying(t, w, load);
      w.centre.z() = w.radius - sinkage[run];
      t.wheelContact(w, dt, true);
    }
    if (run == 0)
    {
      EXPECT_EQ(t.flowedVolume(), 0.0);
      continue;
    }
    ASSERT_GT(t.flowedVolume(), 1e-5);
    if (run == 1)
    {
      EXPECT_EQ(t.arrivedVolume(), 0.0);
      continue;
    }
    EXPECT_NEAR(t.arrivedVolume(), t.flowedVolume(), 1e-9 * t.flowedVolume());
    EXPECT_LT(std::abs(netDisplacedVolume(t)), 1e-6 * t.flowedVolume());
    // Nothing arrived ahead of where the wheel's front ended (x = 2.5 + r) or beside its path.
    for (std::size_t j = 0; j < t.base().rows(); ++j)
      for (std::size_t i = 0; i < t.base().columns(); ++i)
        if (t.deformation(i, j).displaced < 0.f)
        {
          EXPECT_LT(i * t.base().dx(), 2.5 + 0.35) << i << "," << j;
          EXPECT_LT(std::abs(j * t.base().dy() - 3.0), 0.125 + t.base().dy()) << i << "," << j;
        }
  }
  // b2 = 5e-8 1/Pa: about 40 kPa x 0.3 m/s slip speed x 0.25 s under the wheel = 0.15 mm of
  // flow per pass, about half of it by the time the soil reaches the bottom of the wheel.
  EXPECT_GT(sinkage[1], sinkage[0] + 5e-5) << "towed " << sinkage[0] << " m, slipping " << sinkage[1] << " m";
}

namespace
{
/// A 2 m x 0.4 m track patch at (x, y) with its ground face z m above the flat ground.
TrackPatch trackAt(double x, double y, double z, double length = 2.0, double width = 0.4)
{
  TrackPatch t;
  t.centre = Eigen::Vector3d(x, y, z);
  t.length = length;
  t.width = width;
  t.sprocket_pitch = 0.152;  // m, M113-class track pitch
  t.sprocket_teeth = 10;
  t.velocity = Eigen::Vector3d::Zero();
  return t;
}

/// Depth (m) of the track's face below the ground at which it carries `load` (N).
double trackDepthCarrying(DeformableTerrain& t, TrackPatch track, double load)
{
  double lo = 0.0, hi = 0.5;
  for (int k = 0; k < 80; ++k)
  {
    const double mid = 0.5 * (lo + hi);
    track.centre.z() = -mid;
    (t.trackContact(track, 0.01, false).normal_force < load ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// Sprocket spin rate (rad/s) that gives longitudinal slip s at ground speed v (T10, T8).
double spinForSlip(const TrackPatch& t, double v, double s)
{
  return v / (1.0 - s) * 2.0 * M_PI / (t.sprocket_pitch * t.sprocket_teeth);
}
}  // namespace

TEST(DeformableTerrain, TrackSettlesWhereSummedPressureEqualsLoad)
{
  // A flat track on flat soil presses every point equally: the pressure is W / A and the
  // sinkage is the soil's own at that pressure. The track's ends and sides carry their cell
  // shares, so at any grid offset A is the track's L b and the closed forms hold to rounding.
  const double load = 30000.0;  // N, about a third of one M113 track's share
  // Off the cells' lines, ends and sides on rows of points (where rounding decides which side
  // a point falls), and halfway between rows.
  for (const auto& [x, y] : { std::pair<double, double>{ 3.013, 3.021 }, { 3.0, 3.0 }, { 2.975, 3.025 } })
  {
    const TrackPatch track = trackAt(x, y, 0.0);
    const double area = track.length * track.width;
    {
      // Bekker (dry sand): z = (W / (A k))^(1/n), k = k_c / b + k_phi, b = width (the smaller side).
      const SoilParameters& sand = library().get("dry_sand");
      DeformableTerrain t = flat("dry_sand", true);
      const double k = sand.k_c / track.width + sand.k_phi;
      const double expected = std::pow(load / (area * k), 1.0 / sand.n);
      const double z = trackDepthCarrying(t, track, load);
      EXPECT_NEAR(z, expected, 1e-9 * expected);
      TrackPatch settled = track;
      settled.centre.z() = -z;
      const ContactForces f = t.trackContact(settled, 0.01, false);
      EXPECT_NEAR(f.sinkage, z, 1e-9);
      // Bekker's track compaction resistance, b k z^(n+1) / (n + 1), on a towed track.
      EXPECT_NEAR(f.resistance_force, bekkerCompactionResistanceClosedForm(sand, track.width, z),
                  1e-9 * f.resistance_force);
    }
    {
      // Simple model (sandy loam): the sinkage T2 + T4(b1) + T3 give at sigma = W / A.
      const SoilParameters loam = simpleSoil("sandy_loam");
      DeformableTerrain t = flat(loam, true);
      const double sigma = load / area;
      const double expected = plasticSinkage(loam, sigma) + loam.b1 * sigma + elasticSinkage(loam, sigma, 0.0);
      EXPECT_NEAR(trackDepthCarrying(t, track, load), expected, 1e-9 * expected);
    }
  }
}

TEST(DeformableTerrain, TrackTractionIsJanosiClosedForm)
{
  // Uniform pressure under a flat track: T11's strip sum, each strip's exponential integrated
  // exactly, is Janosi-Hanamoto's closed form F = (A c + W tan phi)[1 - K/(s l)(1 - e^(-s l/K))].
  DeformableTerrain t = flat("sandy_loam", true);
  const SoilParameters& loam = library().get("sandy_loam");
  TrackPatch track = trackAt(3.013, 3.021, -0.02);
  const double area = track.length * track.width;
  const double v = 1.0;
  for (const double s : { 0.02, 0.1, 0.3, 0.7 })
  {
    track.velocity = Eigen::Vector3d(v, 0, 0);
    track.sprocket_spin_rate = spinForSlip(track, v, s);
    const ContactForces f = t.trackContact(track, 0.01, false);
    ASSERT_NEAR(f.slip, s, 1e-12);
    const double janosi = janosiTractiveEffort(loam, area, track.length, f.normal_force, s);
    EXPECT_NEAR(f.longitudinal_force, janosi, 0.01 * janosi) << "slip " << s;
    EXPECT_NEAR(f.longitudinal_force, janosi, 1e-9 * janosi) << "slip " << s << " (axis-aligned: exact)";

    // The same track as 4 segments of 0.5 m: shear keeps growing from the track's front.
    double segments = 0.0;
    for (int k = 0; k < 4; ++k)
    {
      TrackPatch segment = track;
      segment.length = 0.5;
      segment.track_length = track.length;
      segment.segment_offset = 0.75 - 0.5 * k;
      segment.centre.x() = track.centre.x() + segment.segment_offset;
      segments += t.trackContact(segment, 0.01, false).longitudinal_force;
    }
    EXPECT_NEAR(segments, janosi, 1e-9 * janosi) << "slip " << s << " in segments";

    // Turned off the grid's axes, the end and side shares are exact only on average: 1 %.
    TrackPatch turned = track;
    turned.heading = 0.6;
    turned.velocity = Eigen::Vector3d(v * std::cos(0.6), v * std::sin(0.6), 0);
    const ContactForces g = t.trackContact(turned, 0.01, false);
    EXPECT_NEAR(g.longitudinal_force, janosiTractiveEffort(loam, area, track.length, g.normal_force, s), 0.01 * janosi)
        << "slip " << s << " turned";
  }
  // Reversing: the leading edge is the rear end, the force points backwards.
  track.velocity = Eigen::Vector3d(-v, 0, 0);
  track.sprocket_spin_rate = -spinForSlip(track, v, 0.2);
  const ContactForces back = t.trackContact(track, 0.01, false);
  EXPECT_NEAR(back.longitudinal_force, -janosiTractiveEffort(loam, area, track.length, back.normal_force, 0.2),
              1e-9 * back.normal_force);
}

TEST(DeformableTerrain, TrackRutIsUniformAlongItsLength)
{
  // A 4 m track driven 6 m at 20 % slip, its face at a constant height: every point the whole
  // track passed over saw the same history (steps of a fifth of a cell, started off the
  // cells' edges), so the rut is uniform to rounding.
  const std::size_t columns = 240, rows = 60;  // 12 m x 3 m at 0.05 m
  DeformableTerrain t(ElevationGrid(0, 0, 0.05, 0.05, columns, rows, std::vector<float>(columns * rows, 0.f)),
                      simpleSoil("sandy_loam"), DeformableTerrain::Options{ true });
  TrackPatch track = trackAt(0.0, 1.5, -0.03, 4.0, 0.5);
  track.velocity = Eigen::Vector3d(1.0, 0, 0);
  track.sprocket_spin_rate = spinForSlip(track, 1.0, 0.2);
  const double step = 0.01;
  for (int k = 0; k <= 600; ++k)
  {
    track.centre.x() = 3.0025 + step * k;  // front from 5.0025 m to 11.0025 m
    t.trackContact(track, step, true);
  }
  ASSERT_GT(t.flowedVolume(), 0.0);
  // Passed over by the whole track: from the front's start to the rear's end, 5.0 .. 7.0 m.
  double shallowest = 1.0, deepest = 0.0;
  for (std::size_t i = 101; i < 140; ++i)
  {
    const double depth = -t.pointHeight(i, 30);
    shallowest = std::min(shallowest, depth);
    deepest = std::max(deepest, depth);
  }
  EXPECT_GT(shallowest, 0.01);  // a real rut (the face was 3 cm down; the elastic part recovered)
  // Uniform to the rounding of float storage: each point's deformation is a float summed
  // over the 400 steps it spends under the track.
  EXPECT_LT(deepest - shallowest, 400 * std::numeric_limits<float>::epsilon() * deepest)
      << shallowest << " .. " << deepest;
}

TEST(DeformableTerrain, BekkerSoilSpringsBackAndReloadsAlongItsUnloadingLine)
{
  // A flat plate pressed into dry sand to z1 loads every point alike: p1 = k z1^n (first
  // loading). Lifted, the sand springs back by p1 / k_unload; pressed again to z < z1 it carries
  // p = k_unload (z - (z1 - p1 / k_unload)) and does not yield, so a plate (or a parked wheel)
  // pressed to the same depth step after step leaves the soil exactly as it was.
  const SoilParameters& sand = library().get("dry_sand");
  DeformableTerrain t = flat("dry_sand", false);
  TrackPatch plate = trackAt(3.013, 3.021, 0.0, 1.0, 0.4);
  const double area = plate.length * plate.width, k = sand.k_c / plate.width + sand.k_phi;
  const double z1 = 0.03, p1 = k * std::pow(z1, sand.n);
  plate.centre.z() = -z1;
  const ContactForces first = t.trackContact(plate, 0.001, true);
  EXPECT_NEAR(first.normal_force, p1 * area, 1e-9 * p1 * area);
  EXPECT_NEAR(first.unload_stiffness, sand.k_unload * area, 1e-9 * sand.k_unload * area);
  EXPECT_NEAR(first.normal_stiffness, sand.n * p1 / z1 * area, 1e-9 * p1 / z1 * area);  // d(k z^n)/dz
  const std::size_t i = static_cast<std::size_t>(std::lround(3.0 / 0.05)), j = i;
  const float rebounded = t.deformation(i, j).plastic;
  EXPECT_NEAR(rebounded, z1 - p1 / sand.k_unload, 1e-7);
  EXPECT_NEAR(-t.pointHeight(i, j), z1 - p1 / sand.k_unload, 1e-7);
  // Reloaded part of the way: the unloading line, stiffness k_unload A, nothing yields.
  for (const double z : { z1 - 0.5 * p1 / sand.k_unload, z1 - 0.1 * p1 / sand.k_unload })
  {
    plate.centre.z() = -z;
    const ContactForces again = t.trackContact(plate, 0.001, true);
    const double expected = sand.k_unload * (z - rebounded) * area;
    EXPECT_NEAR(again.normal_force, expected, 1e-6 * expected) << z;
    EXPECT_NEAR(again.normal_stiffness, sand.k_unload * area, 1e-9 * sand.k_unload * area);
    EXPECT_EQ(t.deformation(i, j).plastic, rebounded);
  }
  // Parked: the same press, again and again, changes nothing.
  plate.centre.z() = -z1;
  for (int k_step = 0; k_step < 1000; ++k_step)
    t.trackContact(plate, 0.001, true);
  EXPECT_EQ(t.deformation(i, j).plastic, rebounded);
  // Deeper than z1 it yields again along k z^n.
  plate.centre.z() = -(z1 + 0.01);
  const ContactForces deeper = t.trackContact(plate, 0.001, true);
  EXPECT_NEAR(deeper.normal_force, k * std::pow(z1 + 0.01, sand.n) * area, 1e-6 * deeper.normal_force);
  EXPECT_GT(t.deformation(i, j).plastic, rebounded + 0.009f);
}

TEST(DeformableTerrain, NormalStiffnessIsTheSlopeOfTheNormalForce)
{
  // The loading stiffness the contact reports is d F / d z pressing deeper: a finite
  // difference of probes 1 um apart agrees for a wheel on both laws (new grid points entering
  // the footprint in that micrometre aside).
  for (const SoilParameters& soil : { library().get("dry_sand"), simpleSoil("sandy_loam") })
  {
    DeformableTerrain t = flat(soil, true);
    WheelPatch w = wheelAt(3.013, 3.021, -0.03);
    const ContactForces f = t.wheelContact(w, 0.001, false);
    w.centre.z() -= 1e-6;
    const double slope = (t.wheelContact(w, 0.001, false).normal_force - f.normal_force) / 1e-6;
    EXPECT_NEAR(f.normal_stiffness, slope, 0.02 * slope) << soil.name;
    EXPECT_GE(f.unload_stiffness, f.normal_stiffness) << soil.name;  // unloading is the stiffer
  }
}

TEST(DeformableTerrain, RigidSurfaceCarriesNothingAndSaysWhatItIs)
{
  // Pavement: the soil contact carries nothing and deforms nothing; it reports the share of
  // the footprint on the rigid surface and which it is, for the vehicle's tyre model.
  const std::size_t n = 120;
  std::vector<std::uint8_t> map(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      map[j * n + i] = i < 60 ? 0 : 1;  // asphalt west of x = 3 m, gravel east
  DeformableTerrain t(ElevationGrid(0, 0, 0.05, 0.05, n, n, std::vector<float>(n * n, 0.f)),
                      { library().get("asphalt"), library().get("gravel") }, std::move(map),
                      DeformableTerrain::Options{ true });
  WheelPatch w = wheelAt(1.5, 3.0, -0.02);
  w.velocity = Eigen::Vector3d(1.0, 0, 0);
  w.spin_rate = 1.2 / w.radius;
  const ContactForces on_asphalt = t.wheelContact(w, 0.001, true);
  EXPECT_EQ(on_asphalt.normal_force, 0.0);
  EXPECT_EQ(on_asphalt.longitudinal_force, 0.0);
  EXPECT_EQ(on_asphalt.contact_points, 0);
  EXPECT_EQ(on_asphalt.rigid_share, 1.0);
  EXPECT_EQ(on_asphalt.rigid_soil, 0);
  EXPECT_EQ(t.deformedPoints(), 0u);
  // Straddling the edge along its width: half on each (the width lies along x here).
  w.centre.x() = 3.0 - 0.025;  // between grid lines: the band covers 2.5 cells of each
  w.heading = M_PI / 2;
  w.velocity = Eigen::Vector3d(0, 1.0, 0);
  const ContactForces straddle = t.wheelContact(w, 0.001, false);
  EXPECT_NEAR(straddle.rigid_share, 0.5, 1e-9);
  EXPECT_GT(straddle.normal_force, 0.0);  // the gravel half carries
  EXPECT_EQ(straddle.rigid_soil, 0);
  // A rigid soil needs its adhesion; a sliding coefficient above the peak is refused.
  SoilParameters broken = library().get("asphalt");
  broken.friction_sliding = 0.95;
  EXPECT_THROW(t.setSoil(0, broken), std::invalid_argument);
}

TEST(DeformableTerrain, TiltedTrackFaceSinksEvenlyOnASlope)
{
  // A plate lying on a 15 deg slope with the slope's normal, its face z m below the surface
  // (vertically): every point is pressed alike, so it carries what a level plate z below level
  // ground carries (the projected area is the same grid area). Level on the slope, the same plate
  // would dig its uphill end in and float its downhill end.
  const double slope = std::tan(15.0 * M_PI / 180.0), z = 0.02;
  const std::size_t n = 120;
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(slope * (i * 0.05));
  DeformableTerrain sloped(ElevationGrid(0, 0, 0.05, 0.05, n, n, h), library().get("gravel"),
                           DeformableTerrain::Options{ true });
  DeformableTerrain level = flat("gravel", true);
  TrackPatch on_level = trackAt(3.013, 3.021, -z, 1.0, 0.4);
  TrackPatch tilted = on_level;
  tilted.centre.z() = *sloped.height(3.013, 3.021) - z;
  tilted.normal = Eigen::Vector3d(-slope, 0.0, 1.0).normalized();
  const ContactForces a = level.trackContact(on_level, 0.001, false), b = sloped.trackContact(tilted, 0.001, false);
  EXPECT_EQ(a.contact_points, b.contact_points);
  EXPECT_NEAR(b.normal_force, a.normal_force, 1e-3 * a.normal_force);
  TrackPatch flat_on_slope = tilted;
  flat_on_slope.normal = Eigen::Vector3d::UnitZ();
  const ContactForces dug_in = sloped.trackContact(flat_on_slope, 0.001, false);
  EXPECT_LT(dug_in.contact_points, 0.65 * a.contact_points);  // from 7.5 cm downhill of its centre up
  EXPECT_GT(dug_in.sinkage, 0.5 * slope * on_level.length);   // its uphill end buried 13 cm
  tilted.normal = Eigen::Vector3d(0.0, 0.99, 0.1);            // 84 deg from level
  EXPECT_THROW(sloped.trackContact(tilted, 0.001, false), std::invalid_argument);
}

TEST(DeformableTerrain, ShearFollowsItsSlipAndNeverExceedsTheStrength)
{
  DeformableTerrain t = flat("gravel", true);
  const SoilParameters& gravel = library().get("gravel");
  TrackPatch track = trackAt(3.013, 3.021, -0.02, 2.0, 0.4);
  const ContactForces rest = t.trackContact(track, 0.001, false);
  // The static limit: c A + N tan phi (uniform pressure under the flat face).
  EXPECT_NEAR(rest.shear_strength,
              gravel.cohesion * track.length * track.width + rest.normal_force * std::tan(gravel.friction_angle),
              1e-9 * rest.shear_strength);
  EXPECT_EQ(rest.longitudinal_force, 0.0);  // at rest, no displacement: no shear
  // A given shear slip sets the force's direction, and its size by T11 at |s|.
  track.shear_slip = Eigen::Vector2d(0.03, -0.04);
  track.shear_slip_given = true;
  const ContactForces given = t.trackContact(track, 0.001, false);
  EXPECT_NEAR(given.longitudinal_force / given.lateral_force, -0.75, 1e-12);
  const double magnitude = std::hypot(given.longitudinal_force, given.lateral_force);
  EXPECT_NEAR(magnitude,
              janosiTractiveEffort(gravel, track.length * track.width, track.length, given.normal_force, 0.05),
              1e-9 * magnitude);
  EXPECT_LT(magnitude, given.shear_strength);
  // Its slope in |s|, for the vehicle's implicit shear rows: a finite difference agrees.
  for (const double scale : { 1.0, 1e-6 })
  {
    track.shear_slip = scale * Eigen::Vector2d(0.03, -0.04);
    const ContactForces at = t.trackContact(track, 0.001, false);
    track.shear_slip *= 1.0 + 1e-6;
    const ContactForces further = t.trackContact(track, 0.001, false);
    const double slope = (std::hypot(further.longitudinal_force, further.lateral_force) -
                          std::hypot(at.longitudinal_force, at.lateral_force)) /
                         (1e-6 * 0.05 * scale);
    EXPECT_NEAR(at.shear_slope, slope, 1e-4 * slope) << "slip " << 0.05 * scale;
  }
  // Kinematic slip, braked: a locked track sliding forward and sideways still grips sideways
  // (T8 = -1 must not take the lateral force away).
  track.shear_slip_given = false;
  track.velocity = Eigen::Vector3d(1.0, 0.5, 0.0);
  track.sprocket_spin_rate = 0.0;
  const ContactForces skid = t.trackContact(track, 0.001, false);
  EXPECT_EQ(skid.slip, -1.0);
  EXPECT_LT(skid.longitudinal_force, 0.0);
  EXPECT_LT(skid.lateral_force, 0.0);
  EXPECT_NEAR(skid.lateral_force / skid.longitudinal_force, 0.5, 1e-12);  // along the sliding
  // At rest the slip is regularised: a creeping track reads a slip near 0, not +-1.
  track.velocity = Eigen::Vector3d(0.001, 0.0, 0.0);
  EXPECT_NEAR(t.trackContact(track, 0.001, false).slip, -0.01, 1e-12);
}

TEST(DeformableTerrain, BadTrackInputThrowsNamingTheField)
{
  DeformableTerrain t = flat("clay", true, 40);
  const auto expectRejected = [&](const TrackPatch& p, const char* field) {
    try
    {
      t.trackContact(p, 0.01, true);
      ADD_FAILURE() << "accepted a bad " << field;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  const TrackPatch good = trackAt(1.0, 1.0, -0.02, 1.0, 0.3);
  TrackPatch p = good;
  p.length = -1.0;
  expectRejected(p, "track.length");
  p = good;
  p.width = std::nan("");
  expectRejected(p, "track.width");
  p = good;
  p.sprocket_pitch = 0.0;
  expectRejected(p, "track.sprocket_pitch");
  p = good;
  p.sprocket_teeth = 0;
  expectRejected(p, "track.sprocket_teeth");
  p = good;
  p.sprocket_spin_rate = std::numeric_limits<double>::infinity();
  expectRejected(p, "track.sprocket_spin_rate");
  p = good;
  p.centre.y() = std::nan("");
  expectRejected(p, "track.centre");
  p = good;
  p.track_length = 0.5;  // shorter than the patch
  expectRejected(p, "track.track_length");
  p = good;
  p.track_length = 2.0;
  p.segment_offset = 0.6;  // 0.6 + 0.5 > 1.0: off the track's end
  expectRejected(p, "track.segment_offset");
  EXPECT_EQ(t.deformedPoints(), 0u);
}

namespace
{
TerrainObject objectAt(ObjectType type, double x, double y, double length, double width, double strength)
{
  TerrainObject o;
  o.type = type;
  o.x = x;
  o.y = y;
  o.length = length;
  o.width = width;
  o.height = 1.0;
  o.strength = strength;
  return o;
}

TerrainObject grassAt(double x, double y, double size, double f)
{
  TerrainObject o = objectAt(ObjectType::kGrass, x, y, size, size, 0.0);
  o.rolling_resistance = f;
  o.height = 0.4;
  return o;
}
}  // namespace

TEST(DeformableTerrain, GrassAddsItsCoefficientTimesTheNormalLoad)
{
  DeformableTerrain t = flat("sandy_loam", true);
  WheelPatch w = wheelAt(3.0, 3.0, -0.03);
  w.velocity = Eigen::Vector3d(1.0, 0, 0);
  w.spin_rate = 1.1 / w.radius;
  const ContactForces bare = t.wheelContact(w, 0.01, false);
  ObjectSet meadow;
  meadow.add(grassAt(3.0, 3.0, 4.0, 0.08));
  const ContactForces grassy = t.wheelContact(w, 0.01, false, &meadow);
  EXPECT_EQ(grassy.normal_force, bare.normal_force);
  EXPECT_EQ(grassy.longitudinal_force, bare.longitudinal_force);
  EXPECT_NEAR(grassy.grass_resistance, 0.08 * bare.normal_force, 1e-9 * bare.normal_force);
  EXPECT_NEAR(grassy.resistance_force - bare.resistance_force, 0.08 * bare.normal_force, 1e-9 * bare.normal_force);
  EXPECT_TRUE(grassy.toppled_objects.empty());
  EXPECT_TRUE(grassy.standing_objects.empty());  // grass never blocks
  EXPECT_FALSE(meadow.get(0).toppled);

  // Overlapping patches: the larger f, not the sum.
  meadow.add(grassAt(3.1, 2.9, 3.0, 0.05));
  EXPECT_NEAR(t.wheelContact(w, 0.01, false, &meadow).grass_resistance, 0.08 * bare.normal_force,
              1e-9 * bare.normal_force);

  // A patch whose edge runs under the wheel's axle (x = 3.0, y beyond the wheel): about half
  // of the load is on grass.
  ObjectSet edge;
  edge.add(grassAt(5.0, 3.0, 4.0, 0.08));
  const double half = t.wheelContact(w, 0.01, false, &edge).grass_resistance;
  EXPECT_GT(half, 0.3 * 0.08 * bare.normal_force);
  EXPECT_LT(half, 0.7 * 0.08 * bare.normal_force);

  // Under a track too.
  TrackPatch track = trackAt(3.0, 3.0, -0.02);
  const ContactForces track_bare = t.trackContact(track, 0.01, false);
  EXPECT_NEAR(t.trackContact(track, 0.01, false, &meadow).resistance_force - track_bare.resistance_force,
              0.08 * track_bare.normal_force, 1e-9 * track_bare.normal_force);
}

TEST(DeformableTerrain, ShrubInThePathTopplesBuildingDoesNot)
{
  DeformableTerrain t = flat("sandy_loam", true);
  ObjectSet objects;
  const std::uint32_t shrub = objects.add(objectAt(ObjectType::kShrub, 2.0, 2.0, 0.6, 0.6, 900.0));
  const std::uint32_t building =
      objects.add(objectAt(ObjectType::kBuilding, 6.0, 4.0, 3.0, 3.0, std::numeric_limits<double>::infinity()));
  const std::uint32_t aside = objects.add(objectAt(ObjectType::kShrub, 2.0, 2.6, 0.3, 0.3, 900.0));
  WheelPatch w = wheelAt(2.0, 2.0, -0.03);
  w.velocity = Eigen::Vector3d(1.0, 0, 0);
  w.spin_rate = 1.1 / w.radius;

  // A probe leaves objects as they were.
  const ContactForces probe = t.wheelContact(w, 0.01, false, &objects);
  ASSERT_GT(probe.normal_force, 900.0);  // the wheel's load exceeds the shrub's strength
  EXPECT_FALSE(objects.get(shrub).toppled);
  EXPECT_EQ(probe.standing_objects, std::vector<std::uint32_t>{ shrub });

  const ContactForces run = t.wheelContact(w, 0.01, true, &objects);
  EXPECT_EQ(run.toppled_objects, std::vector<std::uint32_t>{ shrub });
  EXPECT_TRUE(objects.get(shrub).toppled);
  EXPECT_NEAR(objects.get(shrub).fall_direction, 0.0, 1e-12);  // towards the direction of travel
  EXPECT_FALSE(objects.get(aside).toppled);                    // 0.45 m off the wheel's side: not hit

  // Into the building's wall (x = 4.5 m; the loaded patch reaches 0.17 m ahead of the axle):
  // it takes the same push and stands, reported for the dynamics.
  w.centre.x() = 4.45;
  w.centre.y() = 4.0;
  const ContactForces wall = t.wheelContact(w, 0.01, true, &objects);
  EXPECT_FALSE(objects.get(building).toppled);
  EXPECT_EQ(wall.standing_objects, std::vector<std::uint32_t>{ building });
  EXPECT_TRUE(wall.toppled_objects.empty());

  // Reversing over a small tree: it falls backwards.
  const std::uint32_t tree = objects.add(objectAt(ObjectType::kTree, 1.0, 1.0, 0.2, 0.2, 800.0));
  WheelPatch back = wheelAt(1.0, 1.0, -0.04);
  back.velocity = Eigen::Vector3d(-1.0, 0, 0);
  back.spin_rate = -1.0 / back.radius;
  ASSERT_GT(t.wheelContact(back, 0.01, true, &objects).normal_force, 800.0);
  EXPECT_TRUE(objects.get(tree).toppled);
  EXPECT_NEAR(std::abs(objects.get(tree).fall_direction), M_PI, 1e-12);
}

TEST(DeformableTerrain, PushIsTheWholeContactForce)
{
  // The push on what the wheel runs over is |(N, F_long, F_lat)|: a shrub 1 % weaker than
  // that falls, one 1 % stronger stands.
  DeformableTerrain t = flat("clay", true);
  WheelPatch w = wheelAt(3.0, 3.0, -0.03);
  w.velocity = Eigen::Vector3d(1.0, 0.1, 0);
  w.spin_rate = 1.2 / w.radius;
  const ContactForces f = t.wheelContact(w, 0.01, false);
  const double push = std::sqrt(f.normal_force * f.normal_force + f.longitudinal_force * f.longitudinal_force +
                                f.lateral_force * f.lateral_force);
  for (const double factor : { 0.99, 1.01 })
  {
    ObjectSet objects;
    objects.add(objectAt(ObjectType::kShrub, 3.05, 3.0, 0.3, 0.3, factor * push));
    DeformableTerrain fresh = flat("clay", true);
    fresh.wheelContact(w, 0.01, true, &objects);
    EXPECT_EQ(objects.get(0).toppled, factor < 1.0) << factor;
  }
}

TEST(DeformableTerrain, ThinPoleBetweenGridPointsIsStillHit)
{
  // A 4 cm pole at 0.1 m cells can sit between grid points: the footprint's overlap is tested
  // on the rectangles, not sampled at points. A track segment runs into it.
  DeformableTerrain t = flat("sandy_loam", true, 60, 0.1);
  ObjectSet objects;
  const std::uint32_t pole = objects.add(objectAt(ObjectType::kPole, 3.05, 3.05, 0.04, 0.04, 3000.0));
  TrackPatch track = trackAt(3.0, 3.0, -0.03, 1.0, 0.4);
  track.velocity = Eigen::Vector3d(0.0, 1.0, 0);
  track.heading = M_PI / 2;
  track.sprocket_spin_rate = spinForSlip(track, 1.0, 0.1);
  const ContactForces f = t.trackContact(track, 0.01, true, &objects);
  ASSERT_GT(f.normal_force, 3000.0);
  EXPECT_EQ(f.toppled_objects, std::vector<std::uint32_t>{ pole });
  EXPECT_NEAR(objects.get(pole).fall_direction, M_PI / 2, 1e-12);
}

namespace
{
/// A wheel driving along y = `y` at 1 m/s with 20 % slip, at x, sunk 3.5 cm below z = 0.
WheelPatch rollingWheel(double x, double y, double heading = 0.0)
{
  WheelPatch w = wheelAt(x, y, -0.035);
  w.heading = heading;
  w.velocity = Eigen::Vector3d(std::cos(heading), std::sin(heading), 0);
  w.spin_rate = 1.25 / w.radius;
  return w;
}

void expectSameTerrain(const DeformableTerrain& a, const DeformableTerrain& b, const char* what)
{
  for (std::size_t j = 0; j < a.base().rows(); ++j)
    for (std::size_t i = 0; i < a.base().columns(); ++i)
    {
      const PointDeformation da = a.deformation(i, j), db = b.deformation(i, j);
      ASSERT_EQ(std::memcmp(&da, &db, sizeof(da)), 0) << what << " at " << i << "," << j;
    }
}
}  // namespace

TEST(DeformableTerrain, ExchangedChangesGiveTheSingleProcessTerrainBitForBit)
{
  // Two "partitions" A and B each run one wheel and swap their changes every 10 steps; C runs
  // both wheels. Then B's wheel crosses the rut A's wheel made: its forces and every terrain
  // must equal the single-process run to the bit.
  DeformableTerrain a = flat("mud", true), b = flat("mud", true), c = flat("mud", true);
  a.setChangeTracking(true);
  b.setChangeTracking(true);
  const double dt = 0.004;
  std::size_t exchanged = 0;
  auto swap = [&] {
    const std::vector<PointChange> from_a = a.takeChanges(), from_b = b.takeChanges();
    exchanged += from_a.size() + from_b.size();
    EXPECT_EQ(b.applyChanges(from_a), 0u);
    EXPECT_EQ(a.applyChanges(from_b), 0u);
  };
  int step = 0;
  for (double x = 1.0; x < 5.0; x += 0.004, ++step)
  {
    a.wheelContact(rollingWheel(x, 1.5), dt, true);
    c.wheelContact(rollingWheel(x, 1.5), dt, true);
    b.wheelContact(rollingWheel(x, 4.5), dt, true);
    c.wheelContact(rollingWheel(x, 4.5), dt, true);
    if (step % 10 == 9)
      swap();
  }
  swap();
  EXPECT_GT(exchanged, 1000u);
  expectSameTerrain(a, c, "A after phase 1");
  expectSameTerrain(b, c, "B after phase 1");
  // Phase 2: B's wheel turns across A's rut (y = 1.5).
  for (double y = 4.0; y > 0.5; y -= 0.004, ++step)
  {
    const ContactForces fb = b.wheelContact(rollingWheel(3.0, y, -M_PI / 2), dt, true);
    const ContactForces fc = c.wheelContact(rollingWheel(3.0, y, -M_PI / 2), dt, true);
    ASSERT_EQ(fb.normal_force, fc.normal_force) << y;
    ASSERT_EQ(fb.longitudinal_force, fc.longitudinal_force) << y;
    ASSERT_EQ(fb.resistance_force, fc.resistance_force) << y;
    if (step % 10 == 9)
      swap();
  }
  swap();
  expectSameTerrain(a, c, "A after phase 2");
  expectSameTerrain(b, c, "B after phase 2");
  // Applied changes are not echoed back as the receiver's own.
  EXPECT_TRUE(a.takeChanges().empty());
  EXPECT_TRUE(b.takeChanges().empty());
}

TEST(DeformableTerrain, ChangesHeldOverManyStepsGoOutOnceAndGiveTheSameTerrain)
{
  // A partition may hold its changes back for many intervals: A's wheel ruts the soil for 500
  // steps and its changes are taken once, at the end. Each point goes out once, from its state
  // before the first step, and B, which only applies them, then holds A's terrain bit for bit.
  DeformableTerrain a = flat("mud", true), b = flat("mud", true);
  a.setChangeTracking(true);
  b.setChangeTracking(true);
  int steps = 0;
  for (double x = 1.0; x < 3.0; x += 0.004, ++steps)
    a.wheelContact(rollingWheel(x, 1.5), 0.004, true);
  EXPECT_GE(steps, 500);
  std::vector<PointChange> changes(3);  // a used buffer: its contents are replaced
  a.takeChanges(changes);
  ASSERT_GT(changes.size(), 100u);
  std::set<std::pair<std::uint32_t, std::uint32_t>> points;
  for (const PointChange& c : changes)
  {
    EXPECT_TRUE(points.insert({ c.i, c.j }).second) << "point " << c.i << "," << c.j << " sent twice";
    const PointDeformation before = b.deformation(c.i, c.j);  // B: untouched, as A was
    EXPECT_EQ(std::memcmp(&c.before, &before, sizeof(before)), 0) << c.i << "," << c.j;
  }
  EXPECT_EQ(b.applyChanges(changes), 0u);
  expectSameTerrain(a, b, "B after one long window");
  a.takeChanges(changes);
  EXPECT_TRUE(changes.empty());
}

TEST(DeformableTerrain, WithoutTheExchangeTheCrossingWheelFeelsNoRut)
{
  // The control for the test above: B never gets A's rut, so its wheel's forces differ.
  DeformableTerrain a = flat("mud", true), b = flat("mud", true);
  for (double x = 1.0; x < 5.0; x += 0.004)
    a.wheelContact(rollingWheel(x, 1.5), 0.004, true);
  bool differed = false;
  for (double y = 4.0; y > 0.5; y -= 0.004)
  {
    const ContactForces fa = a.wheelContact(rollingWheel(3.0, y, -M_PI / 2), 0.004, true);
    const ContactForces fb = b.wheelContact(rollingWheel(3.0, y, -M_PI / 2), 0.004, true);
    differed = differed || fa.normal_force != fb.normal_force;
  }
  EXPECT_TRUE(differed);
}

TEST(DeformableTerrain, ChangesToTheSamePointInOneIntervalAreMerged)
{
  DeformableTerrain a = flat("mud", true), b = flat("mud", true);
  a.setChangeTracking(true);
  b.setChangeTracking(true);
  a.wheelContact(rollingWheel(3.0, 3.0), 0.004, true);
  b.wheelContact(rollingWheel(3.02, 3.0), 0.004, true);  // overlapping patches
  const std::vector<PointChange> from_a = a.takeChanges(), from_b = b.takeChanges();
  ASSERT_FALSE(from_a.empty());
  ASSERT_FALSE(from_b.empty());
  const std::size_t merged = a.applyChanges(from_b);
  EXPECT_GT(merged, 0u);
  EXPECT_LT(merged, from_b.size() + 1);
  // Each merged point: the larger compaction and stress, both displacements.
  std::size_t checked = 0;
  for (const PointChange& c : from_b)
  {
    const auto mine =
        std::find_if(from_a.begin(), from_a.end(), [&](const PointChange& m) { return m.i == c.i && m.j == c.j; });
    if (mine == from_a.end())
      continue;
    const PointDeformation d = a.deformation(c.i, c.j);
    EXPECT_EQ(d.plastic, std::max(mine->after.plastic, c.after.plastic));
    EXPECT_EQ(d.sigma_max, std::max(mine->after.sigma_max, c.after.sigma_max));
    EXPECT_NEAR(d.displaced, mine->after.displaced + c.after.displaced - c.before.displaced, 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, merged);
}

TEST(DeformableTerrain, ChangeTrackingOffReportsNothingAndBadChangesAreRefused)
{
  DeformableTerrain t = flat("mud", true);
  t.wheelContact(rollingWheel(3.0, 3.0), 0.004, true);
  EXPECT_TRUE(t.takeChanges().empty());
  t.setChangeTracking(true);
  EXPECT_TRUE(t.takeChanges().empty());  // nothing since tracking began
  PointChange outside;
  outside.i = 120;  // the grid is 120 x 120
  outside.after.plastic = 0.01f;
  PointChange good;
  good.i = good.j = 5;
  good.after.plastic = 0.02f;
  try
  {
    t.applyChanges({ good, outside });
    FAIL() << "a point outside the grid was applied";
  }
  catch (const std::out_of_range& e)
  {
    EXPECT_NE(std::string(e.what()).find("(120, 0)"), std::string::npos) << e.what();
  }
  EXPECT_EQ(t.deformation(5, 5).plastic, 0.f);  // nothing applied
  PointChange nan = good;
  nan.after.displaced = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(t.applyChanges({ nan }), std::invalid_argument);
  EXPECT_EQ(t.deformation(5, 5).displaced, 0.f);
  EXPECT_EQ(t.applyChanges({ good }), 0u);
  EXPECT_EQ(t.deformation(5, 5).plastic, 0.02f);
  EXPECT_TRUE(t.takeChanges().empty());  // applied, not this terrain's own
}
