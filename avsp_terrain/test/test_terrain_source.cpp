// loadTerrainSource(): each kind of source gives the ground its own loader gives (bit for
// bit), and every bad source is refused naming the field or the file.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "avsp_terrain/dem_io.hpp"
#include "avsp_terrain/terrain_file.hpp"
#include "avsp_terrain/terrain_source.hpp"

using namespace avsp::terrain;

namespace
{
const SoilLibrary& soils()
{
  static const SoilLibrary lib = SoilLibrary::load(std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  return lib;
}

std::string tempPath(const std::string& name)
{
  return "/tmp/avsp_terrain_source_" + std::to_string(getpid()) + "_" + name;
}

/// The error loadTerrainSource() throws for `source` (empty if it loads).
std::string errorOf(const TerrainSource& source)
{
  try
  {
    loadTerrainSource(source, soils());
  }
  catch (const std::exception& e)
  {
    return e.what();
  }
  return "";
}

CourseOptions smallCourse()
{
  CourseOptions c;
  c.seed = 3;
  c.cell_size = 1.0;
  c.length_x = kMinCourseLengthX;
  c.length_y = kMinCourseLengthY;
  return c;
}
}  // namespace

TEST(TerrainSource, FlatSquareOfOneSoilCentredOnTheOrigin)
{
  TerrainSource s;
  s.flat_soil = "gravel";
  s.flat_size = 20.0;
  s.flat_cell_size = 0.5;
  const LoadedSource out = loadTerrainSource(s, soils());
  const ElevationGrid& g = out.terrain->base();
  EXPECT_EQ(g.columns(), 41u);
  EXPECT_EQ(g.rows(), 41u);
  EXPECT_DOUBLE_EQ(g.originX(), -10.0);
  EXPECT_DOUBLE_EQ(g.originY(), -10.0);
  EXPECT_EQ(*out.terrain->height(3.3, -7.1), 0.0);
  EXPECT_EQ(out.terrain->soil(7, 30).name, "gravel");
  EXPECT_EQ(out.objects.size(), 0u);
  EXPECT_NE(out.description.find("gravel"), std::string::npos);
}

TEST(TerrainSource, DefaultCourseIsMakeDefaultCourseBitForBit)
{
  TerrainSource s;
  s.course = smallCourse();
  const LoadedSource out = loadTerrainSource(s, soils());
  const Course course = makeDefaultCourse(s.course);
  const ElevationGrid& g = out.terrain->base();
  ASSERT_EQ(g.columns(), course.heights.columns());
  ASSERT_EQ(g.rows(), course.heights.rows());
  for (std::size_t j = 0; j < g.rows(); j += 7)
    for (std::size_t i = 0; i < g.columns(); i += 5)
    {
      ASSERT_EQ(g.pointHeight(i, j), course.heights.pointHeight(i, j)) << i << ", " << j;
      ASSERT_EQ(out.terrain->soil(i, j).name, course.soil_names[course.soil_map[j * g.columns() + i]]);
    }
  EXPECT_EQ(out.objects.size(), course.objects.size());
  EXPECT_GT(out.objects.size(), 0u);
}

TEST(TerrainSource, DemAndSavedTerrainFilesRoundTrip)
{
  HeightRaster raster;
  raster.origin_x = 100.0;
  raster.origin_y = -50.0;
  raster.cell_size = 2.0;
  raster.columns = 12;
  raster.rows = 9;
  for (std::size_t k = 0; k < raster.columns * raster.rows; ++k)
    raster.heights.push_back(k == 17 ? NAN : 0.25f * static_cast<float>(k % 13));
  const std::string asc = tempPath("dem.asc");
  writeAsciiGrid(raster, asc);
  TerrainSource s;
  s.dem_file = asc;
  s.soil = "clay";
  const LoadedSource dem = loadTerrainSource(s, soils());
  std::remove(asc.c_str());
  EXPECT_EQ(dem.filled_no_data, 1u);
  EXPECT_EQ(dem.terrain->base().pointHeight(3, 2), raster.heights[2 * 12 + 3]);
  EXPECT_EQ(dem.terrain->soil(0, 0).name, "clay");
  EXPECT_DOUBLE_EQ(dem.terrain->base().originX(), 100.0);

  const std::string saved = tempPath("saved.avspterrain");
  saveTerrain(saved, *dem.terrain, dem.objects);
  TerrainSource f;
  f.terrain_file = saved;
  const LoadedSource back = loadTerrainSource(f, soils());
  std::remove(saved.c_str());
  for (std::size_t j = 0; j < raster.rows; ++j)
    for (std::size_t i = 0; i < raster.columns; ++i)
      ASSERT_EQ(back.terrain->base().pointHeight(i, j), dem.terrain->base().pointHeight(i, j));
  EXPECT_EQ(back.description, saved);
}

TEST(TerrainSource, BadSourcesNameTheFieldOrFile)
{
  TerrainSource two;
  two.flat_soil = "gravel";
  two.dem_file = "/tmp/x.asc";
  EXPECT_NE(errorOf(two).find("give at most one"), std::string::npos) << errorOf(two);

  TerrainSource unknown_flat;
  unknown_flat.flat_soil = "marmalade";
  EXPECT_NE(errorOf(unknown_flat).find("flat_soil"), std::string::npos) << errorOf(unknown_flat);

  TerrainSource small;
  small.flat_soil = "gravel";
  small.flat_size = 0.5;
  EXPECT_EQ(errorOf(small).rfind("flat_size", 0), 0u) << errorOf(small);
  small.flat_size = NAN;
  EXPECT_EQ(errorOf(small).rfind("flat_size", 0), 0u) << errorOf(small);

  TerrainSource coarse;
  coarse.flat_soil = "gravel";
  coarse.flat_size = 10.0;
  coarse.flat_cell_size = 5.0;
  EXPECT_EQ(errorOf(coarse).rfind("flat_cell_size", 0), 0u) << errorOf(coarse);

  for (const std::string dem : { "/tmp/x.asc", "" })
  {
    TerrainSource dem_soil;
    dem_soil.dem_file = dem;
    dem_soil.soil = "marmalade";
    EXPECT_EQ(errorOf(dem_soil).rfind("soil:", 0), 0u) << errorOf(dem_soil);
  }

  TerrainSource jpg;
  jpg.dem_file = "/tmp/heights.JPG";
  EXPECT_NE(errorOf(jpg).find("unknown extension '.jpg'"), std::string::npos) << errorOf(jpg);

  TerrainSource png;
  png.dem_file = "/tmp/heights.png";
  EXPECT_NE(errorOf(png).find("png.cell_size"), std::string::npos) << errorOf(png);

  TerrainSource missing;
  missing.dem_file = tempPath("none.asc");
  EXPECT_NE(errorOf(missing).find(missing.dem_file), std::string::npos) << errorOf(missing);
  TerrainSource missing_file;
  missing_file.terrain_file = tempPath("none.avspterrain");
  EXPECT_NE(errorOf(missing_file).find(missing_file.terrain_file), std::string::npos) << errorOf(missing_file);

  TerrainSource course;
  course.course = smallCourse();
  course.course.length_x = 10.0;
  EXPECT_EQ(errorOf(course).rfind("course_*", 0), 0u) << errorOf(course);
}

TEST(TerrainSource, FileExtensionIsLowerCaseWithItsDot)
{
  EXPECT_EQ(fileExtension("/a/b/heights.TIF"), ".tif");
  EXPECT_EQ(fileExtension("/a.b/heights"), "");
  EXPECT_EQ(fileExtension("x.asc"), ".asc");
  EXPECT_EQ(fileExtension(""), "");
}

/// Issue 21: the point budget (~max_cells) holds for every source, checked before the grid is
/// built: a course at 1 mm (600 M x 400 M points) once started allocating.
TEST(TerrainSource, EverySourceKeepsToThePointBudget)
{
  TerrainSource s;
  s.course = smallCourse();  // 301 x 201 points at 1 m
  s.max_cells = 301 * 201;
  EXPECT_EQ(errorOf(s), "");
  s.max_cells = 301 * 201 - 1;
  EXPECT_NE(errorOf(s).find("course_cell_size: 301.000000 x 201.000000 = 60501.000000 grid points exceed the budget "
                            "max_cells = 60500"),
            std::string::npos)
      << errorOf(s);
  s = TerrainSource();
  s.course.cell_size = 0.001;  // the default budget: 600 001 x 400 001 points refused at once
  EXPECT_NE(errorOf(s).find("exceed the budget max_cells = 250000000"), std::string::npos) << errorOf(s);

  s = TerrainSource();
  s.flat_soil = "gravel";
  s.flat_size = 100.0;
  s.flat_cell_size = 1.0;  // 101 x 101
  s.max_cells = 101 * 101;
  EXPECT_EQ(errorOf(s), "");
  s.max_cells = 10000;
  EXPECT_NE(errorOf(s).find("flat_cell_size: 101.000000 x 101.000000"), std::string::npos) << errorOf(s);

  // A DEM: the reader checks its header against the same budget.
  s = TerrainSource();
  s.dem_file = tempPath("budget.asc");
  {
    std::ofstream f(s.dem_file);
    f << "ncols 4\nnrows 3\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2 3 4\n5 6 7 8\n9 10 11 12\n";
  }
  s.max_cells = 12;
  EXPECT_EQ(errorOf(s), "");
  s.max_cells = 11;
  EXPECT_NE(errorOf(s).find("4 x 3 = 12 grid points exceed the budget of 11"), std::string::npos) << errorOf(s);
  std::remove(s.dem_file.c_str());
}
