// export_course: the built executable is run (EXPORT_COURSE_BIN) and what it writes is read
// back with dem_io's readers (heights) and with GDAL / yaml-cpp directly (soil map, legend),
// then compared with makeDefaultCourse for the same options.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include <sys/wait.h>

#include <gtest/gtest.h>

#include <gdal.h>
#include <yaml-cpp/yaml.h>

#include "avsp_terrain/course_export.hpp"
#include "avsp_terrain/default_course.hpp"
#include "avsp_terrain/dem_io.hpp"

using namespace avsp::terrain;

namespace
{
std::uint32_t bitsOf(float f)
{
  std::uint32_t u = 0;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

std::string slurp(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

struct ToolRun
{
  int status = -1;  ///< exit code, -1 if it did not exit normally
  std::string out, err;
};

/// The small course every export test uses: 300 m x 200 m (the minimum) at 1 m.
CourseOptions smallCourse(std::uint64_t seed)
{
  CourseOptions o;
  o.seed = seed;
  o.cell_size = 1.0;
  o.length_x = 300.0;
  o.length_y = 200.0;
  return o;
}

/// Soil indices of a GeoTIFF or PNG read with GDAL, flipped to row 0 south.
std::vector<std::uint8_t> readSoilRaster(const std::string& path, int& width, int& height, double gt[6])
{
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
  EXPECT_NE(ds, nullptr) << path;
  if (ds == nullptr)
    return {};
  width = GDALGetRasterXSize(ds);
  height = GDALGetRasterYSize(ds);
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  EXPECT_EQ(GDALGetRasterDataType(band), GDT_Byte) << path;
  if (GDALGetGeoTransform(ds, gt) != CE_None)
    std::fill(gt, gt + 6, 0.0);
  std::vector<std::uint8_t> file_order(static_cast<std::size_t>(width) * height);
  EXPECT_EQ(GDALRasterIO(band, GF_Read, 0, 0, width, height, file_order.data(), width, height, GDT_Byte, 0, 0),
            CE_None);
  GDALClose(ds);
  std::vector<std::uint8_t> south_first(file_order.size());
  for (int r = 0; r < height; ++r)
    std::copy_n(&file_order[static_cast<std::size_t>(r) * width], width,
                &south_first[static_cast<std::size_t>(height - 1 - r) * width]);
  return south_first;
}
}  // namespace

class ExportCourse : public ::testing::Test
{
protected:
  static void SetUpTestSuite() { course_ = new Course(makeDefaultCourse(smallCourse(7))); }
  static void TearDownTestSuite()
  {
    delete course_;
    course_ = nullptr;
  }
  void SetUp() override
  {
    char tmpl[] = "/tmp/avsp_export_course_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string file(const std::string& name) const { return dir_ + "/" + name; }

  /// Runs export_course with `args` (shell words; the test's own paths have no spaces).
  ToolRun run(const std::string& args) const
  {
    const std::string out = file("stdout.txt"), err = file("stderr.txt");
    const std::string cmd = std::string("'") + EXPORT_COURSE_BIN + "' " + args + " >" + out + " 2>" + err;
    const int raw = std::system(cmd.c_str());
    ToolRun r;
    r.status = (raw != -1 && WIFEXITED(raw)) ? WEXITSTATUS(raw) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    std::filesystem::remove(out);
    std::filesystem::remove(err);
    return r;
  }

  /// Files in the test directory (what a failed run must not leave behind).
  std::vector<std::string> files() const
  {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir_))
      names.push_back(e.path().filename().string());
    return names;
  }

  static const std::string kSmall;  ///< the size options of smallCourse()
  static Course* course_;
  std::string dir_;
};
const std::string ExportCourse::kSmall = "--seed 7 --cell-size 1 --length-x 300 --length-y 200";
Course* ExportCourse::course_ = nullptr;

TEST_F(ExportCourse, AsciiGridIsTheCourseExactly)
{
  const ToolRun r = run("--out " + file("c.asc") + " " + kSmall);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find(file("c.asc")), std::string::npos) << r.out;
  const HeightRaster back = readAsciiGrid(file("c.asc"));
  const ElevationGrid& g = course_->heights;
  ASSERT_EQ(back.columns, 301u);
  ASSERT_EQ(back.rows, 201u);
  EXPECT_EQ(back.origin_x, 0.0);
  EXPECT_EQ(back.origin_y, 0.0);
  EXPECT_EQ(back.cell_size, 1.0);
  EXPECT_EQ(back.noDataCount(), 0u);
  for (std::size_t j = 0; j < back.rows; ++j)
    for (std::size_t i = 0; i < back.columns; ++i)
      ASSERT_EQ(bitsOf(back.heights[j * back.columns + i]), bitsOf(static_cast<float>(g.pointHeight(i, j))))
          << i << ", " << j;
}

TEST_F(ExportCourse, GeoTiffIsExactAndThePngSoilMapMatchesWithItsLegend)
{
  const ToolRun r = run("--out " + file("c.tif") + " --soil-map " + file("soil.png") + " " + kSmall);
  ASSERT_EQ(r.status, 0) << r.err;
  const HeightRaster back = readGeoTiff(file("c.tif"));
  const ElevationGrid& g = course_->heights;
  ASSERT_EQ(back.columns, g.columns());
  ASSERT_EQ(back.rows, g.rows());
  EXPECT_NEAR(back.origin_x, 0.0, 1e-12);
  EXPECT_NEAR(back.origin_y, 0.0, 1e-12);
  EXPECT_EQ(back.cell_size, 1.0);
  EXPECT_EQ(back.heights, g.pointHeights());

  int width = 0, height = 0;
  double gt[6];
  const std::vector<std::uint8_t> soil = readSoilRaster(file("soil.png"), width, height, gt);
  ASSERT_EQ(width, 301);
  ASSERT_EQ(height, 201);
  EXPECT_EQ(soil, course_->soil_map);
  // The course has several soils (road, trail, mud, patches); a constant map would pass the
  // comparison above only if the course itself were broken.
  EXPECT_GE(std::set<std::uint8_t>(soil.begin(), soil.end()).size(), 5u);

  const YAML::Node legend = YAML::LoadFile(file("soil.png.yaml"));
  EXPECT_EQ(legend["origin_x"].as<double>(), 0.0);
  EXPECT_EQ(legend["origin_y"].as<double>(), 0.0);
  EXPECT_EQ(legend["cell_size"].as<double>(), 1.0);
  EXPECT_EQ(legend["columns"].as<std::size_t>(), 301u);
  EXPECT_EQ(legend["rows"].as<std::size_t>(), 201u);
  ASSERT_TRUE(legend["soils"].IsMap());
  EXPECT_EQ(legend["soils"].size(), course_->soil_names.size());
  for (std::size_t k = 0; k < course_->soil_names.size(); ++k)
    EXPECT_EQ(legend["soils"][k].as<std::string>(), course_->soil_names[k]) << k;
}

TEST_F(ExportCourse, PngReadsBackWithinQuantisationThroughItsSidecarAndTheTiffSoilMapIsGeoreferenced)
{
  const ToolRun r = run("--out " + file("c.PNG") + " --soil-map " + file("soil.tiff") + " " + kSmall);
  ASSERT_EQ(r.status, 0) << r.err;
  const Png16Georef georef = readPng16Georef(file("c.PNG.yaml"));
  const std::vector<float>& ref = course_->heights.pointHeights();
  const auto [lo, hi] = std::minmax_element(ref.begin(), ref.end());
  // The PNG spans exactly the course's range, so the step is as fine as 16 bits allow.
  EXPECT_EQ(georef.z_offset, static_cast<double>(*lo));
  EXPECT_EQ(georef.z_scale, static_cast<double>(*hi) - *lo);
  EXPECT_EQ(georef.origin_x, 0.0);
  EXPECT_EQ(georef.cell_size, 1.0);
  const HeightRaster back = readPng16(file("c.PNG"), georef);
  ASSERT_EQ(back.columns, 301u);
  ASSERT_EQ(back.rows, 201u);
  const double half_step = 0.5 * georef.z_scale / 65535.0;
  double worst = 0.0;
  for (std::size_t k = 0; k < ref.size(); ++k)
    worst = std::max(worst, std::abs(static_cast<double>(back.heights[k]) - ref[k]));
  EXPECT_LE(worst, half_step + 1e-5) << "step " << 2 * half_step << " m";
  EXPECT_GT(worst, 0.0) << "a 16-bit PNG cannot hold float heights exactly; zero error means the wrong file";

  int width = 0, height = 0;
  double gt[6];
  const std::vector<std::uint8_t> soil = readSoilRaster(file("soil.tiff"), width, height, gt);
  EXPECT_EQ(soil, course_->soil_map);
  // Pixel edges half a cell outside the grid points, north-up, like writeGeoTiff.
  EXPECT_EQ(gt[0], -0.5);
  EXPECT_EQ(gt[1], 1.0);
  EXPECT_EQ(gt[3], 200.5);
  EXPECT_EQ(gt[5], -1.0);
  EXPECT_TRUE(std::filesystem::exists(file("soil.tiff.yaml")));
}

TEST_F(ExportCourse, SeedAndCellSizeReachTheFile)
{
  ASSERT_EQ(run("--out=" + file("a.asc") + " --seed=8 --cell-size=2 --length-x=300 --length-y=200").status, 0);
  const HeightRaster back = readAsciiGrid(file("a.asc"));
  CourseOptions o = smallCourse(8);
  o.cell_size = 2.0;
  const Course expected = makeDefaultCourse(o);
  ASSERT_EQ(back.columns, 151u);
  ASSERT_EQ(back.rows, 101u);
  EXPECT_EQ(back.cell_size, 2.0);
  EXPECT_EQ(back.heights, expected.heights.pointHeights());
  // And seed 8 is not seed 7: the same points of the seed-7 course differ.
  std::size_t differ = 0;
  for (std::size_t j = 0; j < back.rows; ++j)
    for (std::size_t i = 0; i < back.columns; ++i)
      differ += back.heights[j * back.columns + i] != course_->heights.pointHeight(2 * i, 2 * j) ? 1 : 0;
  EXPECT_GT(differ, back.heights.size() / 2);
}

TEST_F(ExportCourse, BadArgumentsExitWithTwoNamingTheFlagOrPathAndWriteNothing)
{
  const std::string out = file("x.asc");
  struct Case
  {
    std::string args;
    std::vector<std::string> words;  ///< all must appear on stderr
  };
  const std::vector<Case> cases = {
    { "--out " + out + " --bogus 1", { "--bogus", "unknown flag" } },
    { "--out", { "--out", "missing value" } },
    { "--out " + out + " --seed", { "--seed", "missing value" } },
    { "--out --seed 3", { "--out", "missing value" } },
    { "--out " + out + " --cell-size abc", { "--cell-size", "'abc' is not a number" } },
    { "--out " + out + " --cell-size 1.5x", { "--cell-size", "not a number" } },
    { "--out " + out + " --length-x -5", { "--length-x", "must be > 0" } },
    { "--out " + out + " --length-y inf", { "--length-y", "finite" } },
    { "--out " + out + " --seed -1", { "--seed", "whole number" } },
    { "--out " + out + " --seed 99999999999999999999999", { "--seed", "2^64" } },
    { "--out " + file("x.jpg"), { file("x.jpg"), "unknown extension '.jpg'" } },
    { "--out " + file("noext"), { file("noext"), "no file extension" } },
    { "--out " + out + " --soil-map " + file("s.asc"), { "--soil-map", file("s.asc"), "extension" } },
    { "--out " + file("same.png") + " --soil-map " + file("same.png"), { "--soil-map", "same file" } },
    { "--seed 3", { "--out", "required" } },
    { "--out " + out + " --out " + out, { "--out", "more than once" } },
    { "--out " + out + " stray", { "unexpected argument 'stray'" } },
    { "--out " + out + " --length-x 100", { "--length-x", "at least 300" } },
    { "--out " + out + " --cell-size 25 --length-x 300 --length-y 200", { "--cell-size", "tenth" } },
  };
  for (const Case& c : cases)
  {
    SCOPED_TRACE(c.args);
    const ToolRun r = run(c.args);
    EXPECT_EQ(r.status, 2) << r.err;
    for (const std::string& w : c.words)
      EXPECT_NE(r.err.find(w), std::string::npos) << "stderr lacks '" << w << "': " << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_TRUE(files().empty()) << "a refused run wrote " << files().front();
  }
}

TEST_F(ExportCourse, UnwritableOutputExitsWithOneNamingTheFile)
{
  const std::string path = file("no_such_dir/c.tif");
  const ToolRun r = run("--out " + path + " " + kSmall);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
}

TEST_F(ExportCourse, HelpPrintsUsageAndExitsZero)
{
  const ToolRun r = run("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("usage: export_course --out FILE"), std::string::npos) << r.out;
  EXPECT_TRUE(files().empty());
}

TEST(ExportArguments, DefaultsAndBothValueForms)
{
  const ExportOptions d = parseExportArguments({ "--out", "a.tif" });
  const CourseOptions defaults;
  EXPECT_EQ(d.out, "a.tif");
  EXPECT_TRUE(d.soil_map.empty());
  EXPECT_EQ(d.course.seed, defaults.seed);
  EXPECT_EQ(d.course.cell_size, defaults.cell_size);
  EXPECT_EQ(d.course.length_x, defaults.length_x);
  EXPECT_EQ(d.course.length_y, defaults.length_y);
  const ExportOptions o =
      parseExportArguments({ "--seed=18446744073709551615", "--cell-size", "0.25", "--length-x=350.5", "--length-y",
                             "2e2", "--soil-map", "dir.v2/soil.TIF", "--out=x.Asc" });
  EXPECT_EQ(o.course.seed, 18446744073709551615ULL);
  EXPECT_EQ(o.course.cell_size, 0.25);
  EXPECT_EQ(o.course.length_x, 350.5);
  EXPECT_EQ(o.course.length_y, 200.0);
  EXPECT_EQ(o.soil_map, "dir.v2/soil.TIF");
  EXPECT_EQ(o.out, "x.Asc");
  // A dot in a directory name is not an extension.
  EXPECT_THROW(parseExportArguments({ "--out", "dir.asc/heights" }), UsageError);
  EXPECT_TRUE(parseExportArguments({ "-h" }).help);
}
