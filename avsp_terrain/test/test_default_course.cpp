// The embedded default course, on a reduced 300 m x 200 m course at 0.25 m (the smallest
// that holds every feature): bit-identical rebuilds, the seed changes hills and vegetation
// but not the layout, and each feature measured from the grid (slope from normals, ditch
// depth against its banks, level road and trail, pond below its rim, soils, objects and
// their strength), plus every bad option.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "avsp_terrain/default_course.hpp"

using namespace avsp::terrain;

namespace
{
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

CourseOptions reduced(std::uint64_t seed)
{
  CourseOptions o;
  o.seed = seed;
  o.cell_size = 0.25;
  o.length_x = 300.0;
  o.length_y = 200.0;
  return o;
}

/// Built once: every test below only reads it (push tests work on a copy of the objects).
const Course& course()
{
  static const Course c = makeDefaultCourse(reduced(7));
  return c;
}

/// Grid indices of the points inside [lo, hi] along one axis.
std::vector<std::size_t> pointsIn(double lo, double hi, double spacing, std::size_t count)
{
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < count; ++k)
  {
    const double p = static_cast<double>(k) * spacing;
    if (p >= lo - 1e-9 && p <= hi + 1e-9)
      out.push_back(k);
  }
  return out;
}

/// Calls f(i, j) for every grid point inside the box.
void forPointsIn(const Course& c, double min_x, double min_y, double max_x, double max_y,
                 const std::function<void(std::size_t, std::size_t)>& f)
{
  const ElevationGrid& g = c.heights;
  for (const std::size_t j : pointsIn(min_y, max_y, g.dy(), g.rows()))
    for (const std::size_t i : pointsIn(min_x, max_x, g.dx(), g.columns()))
      f(i, j);
}

const std::string& soilAt(const Course& c, std::size_t i, std::size_t j)
{
  return c.soil_names.at(c.soil_map.at(j * c.heights.columns() + i));
}

double height(const Course& c, double x, double y)
{
  const auto h = c.heights.height(x, y);
  EXPECT_TRUE(h.has_value()) << "no height at (" << x << ", " << y << ")";
  return h.value_or(std::numeric_limits<double>::quiet_NaN());
}

Eigen::Vector3d normal(const Course& c, double x, double y)
{
  const auto n = c.heights.normal(x, y);
  EXPECT_TRUE(n.has_value()) << "no normal at (" << x << ", " << y << ")";
  return n.value_or(Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
}

/// Footprint of an object as an axis-aligned box.
CourseFeature footprint(const TerrainObject& o)
{
  double hx = 0.0, hy = 0.0;
  footprintHalfExtents(o, hx, hy);
  return CourseFeature{ toString(o.type), o.x - hx, o.y - hy, o.x + hx, o.y + hy };
}

bool overlaps(const CourseFeature& a, const CourseFeature& b)
{
  return a.min_x < b.max_x && b.min_x < a.max_x && a.min_y < b.max_y && b.min_y < a.max_y;
}

bool inside(const CourseFeature& inner, const CourseFeature& outer)
{
  return inner.min_x >= outer.min_x && inner.max_x <= outer.max_x && inner.min_y >= outer.min_y &&
         inner.max_y <= outer.max_y;
}

/// Objects of a type whose centre lies in the feature's box.
std::vector<TerrainObject> objectsIn(const Course& c, const std::string& feature, ObjectType type)
{
  const CourseFeature& f = c.feature(feature);
  std::vector<TerrainObject> out;
  for (const TerrainObject& o : c.objects.all())
    if (o.type == type && o.x >= f.min_x && o.x <= f.max_x && o.y >= f.min_y && o.y <= f.max_y)
      out.push_back(o);
  return out;
}

const std::vector<std::string> kRequiredFeatures = { "rolling_hills", "ditch", "side_slope",   "rough_patch",
                                                     "dirt_trail",    "road",  "staging_area", "barrier_course",
                                                     "fence_line",    "pond",  "woods" };

// The soils defined in config/soils.yaml.
const std::set<std::string> kKnownSoils = { "asphalt", "gravel", "dry_sand", "sandy_loam",
                                            "clay",    "mud",    "snow",     "grass_over_loam" };

void expectInvalidOptionNaming(const CourseOptions& o, const std::string& option)
{
  try
  {
    makeDefaultCourse(o);
    ADD_FAILURE() << "no exception; expected one naming " << option;
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find(option), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(DefaultCourse, GridFollowsTheOptions)
{
  const ElevationGrid& g = course().heights;
  EXPECT_EQ(g.columns(), 1201u);
  EXPECT_EQ(g.rows(), 801u);
  EXPECT_DOUBLE_EQ(g.dx(), 0.25);
  EXPECT_DOUBLE_EQ(g.dy(), 0.25);
  EXPECT_DOUBLE_EQ(g.originX(), 0.0);
  EXPECT_DOUBLE_EQ(g.originY(), 0.0);
  EXPECT_EQ(course().soil_map.size(), g.columns() * g.rows());
}

TEST(DefaultCourse, SameOptionsGiveBitIdenticalCourses)
{
  const Course a = makeDefaultCourse(reduced(7));
  const Course b = makeDefaultCourse(reduced(7));
  ASSERT_EQ(a.heights.columns(), b.heights.columns());
  ASSERT_EQ(a.heights.rows(), b.heights.rows());
  std::size_t different = 0;
  for (std::size_t j = 0; j < a.heights.rows(); ++j)
    for (std::size_t i = 0; i < a.heights.columns(); ++i)
      if (a.heights.pointHeight(i, j) != b.heights.pointHeight(i, j))
        ++different;
  EXPECT_EQ(different, 0u);
  EXPECT_EQ(a.soil_names, b.soil_names);
  EXPECT_TRUE(a.soil_map == b.soil_map);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t k = 0; k < a.objects.size(); ++k)
  {
    const TerrainObject& p = a.objects.all()[k];
    const TerrainObject& q = b.objects.all()[k];
    EXPECT_TRUE(p.id == q.id && p.type == q.type && p.x == q.x && p.y == q.y && p.yaw == q.yaw &&
                p.length == q.length && p.width == q.width && p.height == q.height && p.strength == q.strength &&
                p.rolling_resistance == q.rolling_resistance && p.toppled == q.toppled)
        << "object " << k << " differs";
  }
  ASSERT_EQ(a.features.size(), b.features.size());
  for (std::size_t k = 0; k < a.features.size(); ++k)
    EXPECT_TRUE(a.features[k].name == b.features[k].name && a.features[k].min_x == b.features[k].min_x &&
                a.features[k].max_y == b.features[k].max_y);
}

TEST(DefaultCourse, AnotherSeedChangesHillsAndVegetationButNotTheLayout)
{
  const Course& a = course();
  const Course b = makeDefaultCourse(reduced(8));
  const CourseFeature& hills = a.feature("rolling_hills");
  std::size_t points = 0, changed = 0;
  forPointsIn(a, hills.min_x, hills.min_y, hills.max_x, hills.max_y, [&](std::size_t i, std::size_t j) {
    ++points;
    if (std::abs(a.heights.pointHeight(i, j) - b.heights.pointHeight(i, j)) > 0.01)
      ++changed;
  });
  ASSERT_GT(points, 10000u);
  EXPECT_GT(changed, points * 9 / 10);

  std::vector<std::pair<double, double>> trees_a, trees_b;
  for (const TerrainObject& o : objectsIn(a, "woods", ObjectType::kTree))
    trees_a.emplace_back(o.x, o.y);
  for (const TerrainObject& o : objectsIn(b, "woods", ObjectType::kTree))
    trees_b.emplace_back(o.x, o.y);
  EXPECT_NE(trees_a, trees_b);

  ASSERT_EQ(a.features.size(), b.features.size());
  for (std::size_t k = 0; k < a.features.size(); ++k)
  {
    EXPECT_EQ(a.features[k].name, b.features[k].name);
    EXPECT_EQ(a.features[k].min_x, b.features[k].min_x);
    EXPECT_EQ(a.features[k].min_y, b.features[k].min_y);
    EXPECT_EQ(a.features[k].max_x, b.features[k].max_x);
    EXPECT_EQ(a.features[k].max_y, b.features[k].max_y);
  }
  // Structures are part of the layout: the first building stands in the same place.
  const auto buildings_a = objectsIn(a, "staging_area", ObjectType::kBuilding);
  const auto buildings_b = objectsIn(b, "staging_area", ObjectType::kBuilding);
  ASSERT_FALSE(buildings_a.empty());
  ASSERT_EQ(buildings_a.size(), buildings_b.size());
  EXPECT_EQ(buildings_a[0].x, buildings_b[0].x);
  EXPECT_EQ(buildings_a[0].y, buildings_b[0].y);
}

TEST(DefaultCourse, EveryFeatureExistsInsideTheGrid)
{
  const Course& c = course();
  const double max_x = static_cast<double>(c.heights.columns() - 1) * c.heights.dx();
  const double max_y = static_cast<double>(c.heights.rows() - 1) * c.heights.dy();
  for (const std::string& name : kRequiredFeatures)
  {
    SCOPED_TRACE(name);
    const CourseFeature& f = c.feature(name);
    EXPECT_EQ(f.name, name);
    EXPECT_LT(f.min_x, f.max_x);
    EXPECT_LT(f.min_y, f.max_y);
    EXPECT_GE(f.min_x, 0.0);
    EXPECT_GE(f.min_y, 0.0);
    EXPECT_LE(f.max_x, max_x);
    EXPECT_LE(f.max_y, max_y);
  }
  try
  {
    c.feature("volcano");
    ADD_FAILURE() << "no exception for an unknown feature";
  }
  catch (const std::out_of_range& e)
  {
    EXPECT_NE(std::string(e.what()).find("volcano"), std::string::npos) << e.what();
  }
}

TEST(DefaultCourse, FeaturesDoNotOverlapEachOther)
{
  const Course& c = course();
  for (std::size_t a = 0; a < c.features.size(); ++a)
    for (std::size_t b = a + 1; b < c.features.size(); ++b)
    {
      const CourseFeature& p = c.features[a];
      const CourseFeature& q = c.features[b];
      // The pad is part of the staging area by design.
      if ((p.name == "concrete_pad" && q.name == "staging_area") ||
          (q.name == "concrete_pad" && p.name == "staging_area"))
        continue;
      EXPECT_FALSE(overlaps(p, q)) << p.name << " overlaps " << q.name;
    }
  const CourseFeature& pad = c.feature("concrete_pad");
  EXPECT_TRUE(inside(pad, c.feature("staging_area")));
}

TEST(DefaultCourse, AllHeightsFiniteAndSoilsKnown)
{
  const Course& c = course();
  std::size_t non_finite = 0;
  for (std::size_t j = 0; j < c.heights.rows(); ++j)
    for (std::size_t i = 0; i < c.heights.columns(); ++i)
      if (!std::isfinite(c.heights.pointHeight(i, j)))
        ++non_finite;
  EXPECT_EQ(non_finite, 0u);
  for (const std::string& name : c.soil_names)
    EXPECT_EQ(kKnownSoils.count(name), 1u) << name;
  std::vector<std::size_t> used(c.soil_names.size(), 0);
  for (const std::uint8_t s : c.soil_map)
  {
    ASSERT_LT(s, c.soil_names.size());
    ++used[s];
  }
  for (const char* needed : { "sandy_loam", "grass_over_loam", "gravel", "asphalt", "mud", "dry_sand", "clay" })
  {
    const auto it = std::find(c.soil_names.begin(), c.soil_names.end(), needed);
    ASSERT_NE(it, c.soil_names.end()) << needed;
    EXPECT_GT(used[static_cast<std::size_t>(it - c.soil_names.begin())], 1000u) << needed;
  }
  // The soil patches hold their soil at their centre.
  const auto soilAtCentre = [&](const CourseFeature& f) {
    const ElevationGrid& g = c.heights;
    return soilAt(c, std::lround(0.5 * (f.min_x + f.max_x) / g.dx()), std::lround(0.5 * (f.min_y + f.max_y) / g.dy()));
  };
  EXPECT_EQ(soilAtCentre(c.feature("sand_patch")), "dry_sand");
  EXPECT_EQ(soilAtCentre(c.feature("clay_patch")), "clay");
}

TEST(DefaultCourse, RollingHillsAreGentleWithAFewMetresOfRelief)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("rolling_hills");
  double lowest = 1e9, highest = -1e9, steepest_deg = 0.0;
  for (double y = f.min_y; y <= f.max_y; y += 0.5)
    for (double x = f.min_x; x <= f.max_x; x += 0.5)
    {
      const double h = height(c, x, y);
      lowest = std::min(lowest, h);
      highest = std::max(highest, h);
      steepest_deg = std::max(steepest_deg, std::acos(normal(c, x, y).z()) * kRadToDeg);
    }
  EXPECT_GT(highest - lowest, 1.0);
  EXPECT_LT(highest - lowest, 10.0);
  EXPECT_GT(steepest_deg, 1.0);
  EXPECT_LT(steepest_deg, 12.0);
}

TEST(DefaultCourse, SideSlopeIsBetween15And20DegEverywhereInItsRegion)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("side_slope");
  EXPECT_GE(f.max_x - f.min_x, 30.0);
  EXPECT_GE(f.max_y - f.min_y, 20.0);
  int samples = 0;
  // Edges included, and off the grid lines, so every cell touching the region is visited.
  for (int b = 0; b <= 100; ++b)
    for (int a = 0; a <= 160; ++a)
    {
      const double x = f.min_x + (f.max_x - f.min_x) * a / 160.0;
      const double y = f.min_y + (f.max_y - f.min_y) * b / 100.0;
      const double slope_deg = std::acos(normal(c, x, y).z()) * kRadToDeg;
      ASSERT_GE(slope_deg, 15.0) << "at (" << x << ", " << y << ")";
      ASSERT_LE(slope_deg, 20.0) << "at (" << x << ", " << y << ")";
      ++samples;
    }
  EXPECT_EQ(samples, 161 * 101);
}

TEST(DefaultCourse, DitchIsAboutOneAndAHalfMetresBelowItsBanks)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("ditch");
  const double length = f.max_x - f.min_x, width = f.max_y - f.min_y;
  EXPECT_GE(length, 20.0);
  EXPECT_GE(width, 3.0);
  EXPECT_LE(width, 4.0);
  const double yc = 0.5 * (f.min_y + f.max_y);
  for (int k = 0; k <= 20; ++k)
  {
    const double x = f.min_x + length * (0.15 + 0.7 * k / 20.0);  // away from the tapered ends
    SCOPED_TRACE(x);
    const double bottom = height(c, x, yc);
    const double bank_s = height(c, x, f.min_y - 0.75), bank_n = height(c, x, f.max_y + 0.75);
    const double depth = 0.5 * (bank_s + bank_n) - bottom;
    EXPECT_GT(depth, 1.4);
    EXPECT_LT(depth, 1.6);
    // The ditch is no wider than its region: just outside its edges the ground is at bank level,
    // and 0.25 m inside them it is already below.
    EXPECT_NEAR(height(c, x, f.min_y - 0.3), bank_s, 0.02);
    EXPECT_NEAR(height(c, x, f.max_y + 0.3), bank_n, 0.02);
    EXPECT_LT(height(c, x, f.min_y + 0.5), bank_s - 0.05);
    EXPECT_LT(height(c, x, f.max_y - 0.5), bank_n - 0.05);
  }
}

TEST(DefaultCourse, RoadIsAsphaltAndLevelAcross)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("road");
  EXPECT_GE(f.max_y - f.min_y, 6.0);
  EXPECT_LE(f.max_y - f.min_y, 8.0);
  EXPECT_EQ(f.min_x, 0.0);  // runs across the course
  double worst_cross_deg = 0.0, worst_grade_deg = 0.0;
  for (double x = f.min_x; x <= f.max_x; x += 0.9)
    for (double y = f.min_y; y <= f.max_y; y += 0.35)
    {
      const Eigen::Vector3d n = normal(c, x, y);
      worst_cross_deg = std::max(worst_cross_deg, std::atan2(std::abs(n.y()), n.z()) * kRadToDeg);
      worst_grade_deg = std::max(worst_grade_deg, std::atan2(std::abs(n.x()), n.z()) * kRadToDeg);
    }
  EXPECT_LT(worst_cross_deg, 2.0);
  EXPECT_LT(worst_grade_deg, 10.0);  // smooth along its length too
  std::size_t points = 0, paved = 0;
  forPointsIn(c, f.min_x, f.min_y, f.max_x, f.max_y, [&](std::size_t i, std::size_t j) {
    ++points;
    paved += soilAt(c, i, j) == "asphalt";
  });
  ASSERT_GT(points, 0u);
  EXPECT_EQ(paved, points);
  // Not wider than its region: 1 m beyond either edge is no longer asphalt.
  const ElevationGrid& g = c.heights;
  for (std::size_t i = 0; i < g.columns(); i += 7)
  {
    EXPECT_NE(soilAt(c, i, std::lround((f.min_y - 1.0) / g.dy())), "asphalt");
    EXPECT_NE(soilAt(c, i, std::lround((f.max_y + 1.0) / g.dy())), "asphalt");
  }
}

TEST(DefaultCourse, TrailIsGravelAndLevelAcross)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("dirt_trail");
  EXPECT_GE(f.max_x - f.min_x, 2.0);
  EXPECT_LE(f.max_x - f.min_x, 5.0);
  std::size_t points = 0, gravel = 0;
  forPointsIn(c, f.min_x, f.min_y, f.max_x, f.max_y - 0.5, [&](std::size_t i, std::size_t j) {
    ++points;
    gravel += soilAt(c, i, j) == "gravel";
  });
  ASSERT_GT(points, 0u);
  EXPECT_EQ(gravel, points);
  // Level across, away from where it meets the road's shoulder.
  double worst_cross_deg = 0.0;
  for (double y = f.min_y; y <= f.max_y - 8.0; y += 0.7)
    for (double x = f.min_x; x <= f.max_x; x += 0.3)
    {
      const Eigen::Vector3d n = normal(c, x, y);
      worst_cross_deg = std::max(worst_cross_deg, std::atan2(std::abs(n.x()), n.z()) * kRadToDeg);
    }
  EXPECT_LT(worst_cross_deg, 2.0);
  // The ground beside the trail is not gravel.
  const ElevationGrid& g = c.heights;
  const std::size_t j = std::lround(0.5 * (f.min_y + f.max_y) / g.dy());
  EXPECT_NE(soilAt(c, std::lround((f.min_x - 1.0) / g.dx()), j), "gravel");
  EXPECT_NE(soilAt(c, std::lround((f.max_x + 1.0) / g.dx()), j), "gravel");
}

TEST(DefaultCourse, PondIsMudBelowItsRim)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("pond");
  const double cx = 0.5 * (f.min_x + f.max_x), cy = 0.5 * (f.min_y + f.max_y);
  const double hx = 0.5 * (f.max_x - f.min_x), hy = 0.5 * (f.max_y - f.min_y);
  // The inner half of the box lies inside the inscribed ellipse.
  std::size_t points = 0, mud = 0;
  double highest_inside = -1e9;
  forPointsIn(c, cx - 0.5 * hx, cy - 0.5 * hy, cx + 0.5 * hx, cy + 0.5 * hy, [&](std::size_t i, std::size_t j) {
    ++points;
    mud += soilAt(c, i, j) == "mud";
    highest_inside = std::max(highest_inside, c.heights.pointHeight(i, j));
  });
  ASSERT_GT(points, 0u);
  EXPECT_EQ(mud, points);
  double lowest_rim = 1e9;
  for (int k = 0; k < 200; ++k)
  {
    const double t = k / 200.0;
    lowest_rim = std::min({ lowest_rim, height(c, f.min_x - 1.0 + t * (2 * hx + 2.0), f.min_y - 1.0),
                            height(c, f.min_x - 1.0 + t * (2 * hx + 2.0), f.max_y + 1.0),
                            height(c, f.min_x - 1.0, f.min_y - 1.0 + t * (2 * hy + 2.0)),
                            height(c, f.max_x + 1.0, f.min_y - 1.0 + t * (2 * hy + 2.0)) });
  }
  EXPECT_LT(highest_inside, lowest_rim - 0.2);
  EXPECT_LT(height(c, cx, cy), lowest_rim - 0.8);
}

TEST(DefaultCourse, RoughPatchHasBumpsOfTenToThirtyCentimetres)
{
  const Course& c = course();
  const ElevationGrid& g = c.heights;
  // Range of the residual from a least-squares quadratic surface over a 5 m square: bumps
  // stand out, the hills (nearly quadratic over 5 m) do not.
  const auto residualRange = [&](double x0, double y0) {
    const std::vector<std::size_t> is = pointsIn(x0, x0 + 5.0, g.dx(), g.columns());
    const std::vector<std::size_t> js = pointsIn(y0, y0 + 5.0, g.dy(), g.rows());
    Eigen::MatrixXd a(is.size() * js.size(), 6);
    Eigen::VectorXd h(is.size() * js.size());
    Eigen::Index row = 0;
    for (const std::size_t j : js)
      for (const std::size_t i : is)
      {
        // Local coordinates keep the normal equations well conditioned.
        const double u = i * g.dx() - x0 - 2.5, v = j * g.dy() - y0 - 2.5;
        a.row(row) << 1.0, u, v, u * u, u * v, v * v;
        h(row++) = g.pointHeight(i, j);
      }
    const Eigen::VectorXd fit = a.colPivHouseholderQr().solve(h);
    const Eigen::VectorXd residual = h - a * fit;
    return residual.maxCoeff() - residual.minCoeff();
  };
  const CourseFeature& f = c.feature("rough_patch");
  double smallest = 1e9, largest = 0.0;
  for (double y = f.min_y; y + 5.0 <= f.max_y; y += 5.0)
    for (double x = f.min_x; x + 5.0 <= f.max_x; x += 5.0)
    {
      const double r = residualRange(x, y);
      smallest = std::min(smallest, r);
      largest = std::max(largest, r);
    }
  EXPECT_GT(smallest, 0.1);
  EXPECT_LT(largest, 0.40);
  EXPECT_GT(largest, 0.2);
  const CourseFeature& h = c.feature("rolling_hills");
  for (double y = h.min_y; y + 5.0 <= h.max_y; y += 10.0)
    for (double x = h.min_x; x + 5.0 <= h.max_x; x += 10.0)
      EXPECT_LT(residualRange(x, y), 0.03) << "hills at (" << x << ", " << y << ")";
}

TEST(DefaultCourse, StagingAreaIsFlatWithAPadAndRigidBuildings)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("staging_area");
  const CourseFeature& pad = c.feature("concrete_pad");
  double lowest = 1e9, highest = -1e9;
  std::size_t pad_points = 0, pad_asphalt = 0;
  forPointsIn(c, f.min_x, f.min_y, f.max_x, f.max_y, [&](std::size_t i, std::size_t j) {
    lowest = std::min(lowest, c.heights.pointHeight(i, j));
    highest = std::max(highest, c.heights.pointHeight(i, j));
  });
  forPointsIn(c, pad.min_x, pad.min_y, pad.max_x, pad.max_y, [&](std::size_t i, std::size_t j) {
    ++pad_points;
    pad_asphalt += soilAt(c, i, j) == "asphalt";
  });
  EXPECT_LT(highest - lowest, 1e-3);
  ASSERT_GT(pad_points, 0u);
  EXPECT_EQ(pad_asphalt, pad_points);
  const auto buildings = objectsIn(c, "staging_area", ObjectType::kBuilding);
  ASSERT_GE(buildings.size(), 2u);
  ObjectSet objects = c.objects;
  for (const TerrainObject& b : buildings)
  {
    EXPECT_TRUE(inside(footprint(b), f));
    EXPECT_FALSE(overlaps(footprint(b), pad));
    EXPECT_TRUE(std::isinf(b.strength));
    EXPECT_FALSE(objects.push(b.id, 1e9, 0.0));
  }
}

TEST(DefaultCourse, BarriersAreRigidAndFormASlalom)
{
  const Course& c = course();
  const CourseFeature& f = c.feature("barrier_course");
  auto barriers = objectsIn(c, "barrier_course", ObjectType::kBarrier);
  ASSERT_GE(barriers.size(), 6u);
  ObjectSet objects = c.objects;
  for (const TerrainObject& b : barriers)
  {
    EXPECT_TRUE(inside(footprint(b), f));
    EXPECT_FALSE(objects.push(b.id, 1e9, 0.0));
  }
  // Along the lane, the side of the centre line that blocks alternates from gate to gate.
  std::sort(barriers.begin(), barriers.end(), [](const TerrainObject& a, const TerrainObject& b) { return a.x < b.x; });
  const double yc = 0.5 * (f.min_y + f.max_y);
  std::vector<double> gate_side;
  for (std::size_t k = 0; k < barriers.size(); ++k)
  {
    const double side = barriers[k].y > yc ? 1.0 : -1.0;
    if (k > 0 && std::abs(barriers[k].x - barriers[k - 1].x) < 1.0)
      EXPECT_EQ(side, gate_side.back()) << "a gate's barriers are on one side";
    else
      gate_side.push_back(side);
  }
  ASSERT_GE(gate_side.size(), 4u);
  for (std::size_t k = 1; k < gate_side.size(); ++k)
    EXPECT_EQ(gate_side[k], -gate_side[k - 1]) << "gate " << k;
}

TEST(DefaultCourse, FenceSegmentsToppleAtTheirStrengthAndHavePoles)
{
  const Course& c = course();
  const auto segments = objectsIn(c, "fence_line", ObjectType::kFence);
  const auto poles = objectsIn(c, "fence_line", ObjectType::kPole);
  ASSERT_GE(segments.size(), 5u);
  EXPECT_GE(poles.size(), segments.size());
  ObjectSet objects = c.objects;
  for (const TerrainObject& s : segments)
  {
    EXPECT_GE(s.strength, 2000.0);
    EXPECT_LE(s.strength, 5000.0);
    EXPECT_FALSE(objects.push(s.id, 0.9 * s.strength, 1.0));
    EXPECT_TRUE(objects.push(s.id, 5000.0, 1.0));
    EXPECT_TRUE(objects.get(s.id).toppled);
  }
}

TEST(DefaultCourse, WoodsHoldTreesShrubsGrassAndRocks)
{
  const Course& c = course();
  const CourseFeature& woods = c.feature("woods");
  ObjectSet objects = c.objects;
  std::size_t rigid_trees = 0, toppleable_trees = 0;
  for (const TerrainObject& t : objectsIn(c, "woods", ObjectType::kTree))
  {
    EXPECT_TRUE(inside(footprint(t), woods));
    if (std::isinf(t.strength))
    {
      ++rigid_trees;
      EXPECT_GE(t.width, 0.3);  // the large ones
      EXPECT_FALSE(objects.push(t.id, 1e9, 0.0));
    }
    else
    {
      ++toppleable_trees;
      EXPECT_LT(t.width, 0.3);
      EXPECT_TRUE(objects.push(t.id, t.strength, 0.0));
    }
  }
  EXPECT_GT(rigid_trees, 10u);
  EXPECT_GT(toppleable_trees, 10u);
  const auto shrubs = objectsIn(c, "woods", ObjectType::kShrub);
  ASSERT_GT(shrubs.size(), 10u);
  for (const TerrainObject& s : shrubs)
  {
    EXPECT_TRUE(std::isfinite(s.strength));
    EXPECT_TRUE(objects.push(s.id, 1e5, 0.0));
  }
  const auto grass = objectsIn(c, "woods", ObjectType::kGrass);
  ASSERT_GT(grass.size(), 3u);
  for (const TerrainObject& p : grass)
  {
    EXPECT_TRUE(inside(footprint(p), woods));
    EXPECT_GT(p.rolling_resistance, 0.0);
    EXPECT_GE(p.rolling_resistance, 0.05);
    EXPECT_LE(p.rolling_resistance, 0.1);
    EXPECT_EQ(p.strength, 0.0);  // never blocks: any push flattens it
  }
  const auto rocks = objectsIn(c, "woods", ObjectType::kRock);
  ASSERT_GT(rocks.size(), 3u);
  for (const TerrainObject& r : rocks)
    EXPECT_FALSE(objects.push(r.id, 1e9, 0.0));
}

TEST(DefaultCourse, ObjectsKeepOffTheRoadThePondAndTheDrivingFeatures)
{
  const Course& c = course();
  ASSERT_GT(c.objects.size(), 100u);
  for (const TerrainObject& o : c.objects.all())
  {
    const CourseFeature box = footprint(o);
    for (const char* name : { "road", "pond", "side_slope", "ditch", "rough_patch", "dirt_trail" })
      EXPECT_FALSE(overlaps(box, c.feature(name)))
          << toString(o.type) << " " << o.id << " at (" << o.x << ", " << o.y << ") is in the " << name;
  }
  // Some vegetation also stands on open ground, outside every feature.
  std::size_t open_ground = 0;
  for (const TerrainObject& o : c.objects.all())
  {
    bool in_feature = false;
    for (const CourseFeature& f : c.features)
      in_feature = in_feature || (f.name != "rolling_hills" && overlaps(footprint(o), f));
    open_ground += !in_feature;
  }
  EXPECT_GT(open_ground, 5u);
}

TEST(DefaultCourse, BadOptionsThrowNamingTheOption)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const double bad : { 0.0, -0.1, nan, inf })
  {
    CourseOptions o = reduced(1);
    o.cell_size = bad;
    expectInvalidOptionNaming(o, "cell_size");
    o = reduced(1);
    o.length_x = bad;
    expectInvalidOptionNaming(o, "length_x");
    o = reduced(1);
    o.length_y = bad;
    expectInvalidOptionNaming(o, "length_y");
  }
  CourseOptions o = reduced(1);
  o.cell_size = 25.0;  // more than a tenth of 200 m
  expectInvalidOptionNaming(o, "cell_size");
  o = reduced(1);
  o.length_x = 250.0;  // too small for the features
  expectInvalidOptionNaming(o, "length_x");
  o = reduced(1);
  o.length_y = 150.0;
  expectInvalidOptionNaming(o, "length_y");
  o = reduced(1);
  o.cell_size = 0.001;  // 300 000 x 200 000 points
  expectInvalidOptionNaming(o, "cell_size");
}
