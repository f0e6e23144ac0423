#include <sys/stat.h>

#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <cpl_string.h>
#include <gdal.h>
#include <ogr_srs_api.h>
#include <png.h>

#include "avsp_terrain/dem_io.hpp"

using avsp::terrain::ClassRaster;
using avsp::terrain::DemError;
using avsp::terrain::fillNoData;
using avsp::terrain::HeightRaster;
using avsp::terrain::Png16Georef;
using avsp::terrain::readAsciiGrid;
using avsp::terrain::readGeoTiff;
using avsp::terrain::readPng16;
using avsp::terrain::readPng16Georef;
using avsp::terrain::writeAsciiGrid;
using avsp::terrain::writeClassGeoTiff;
using avsp::terrain::writeClassPng8;
using avsp::terrain::writeGeoTiff;
using avsp::terrain::writePng16;
using avsp::terrain::writePng16Georef;

namespace
{
const float kNaN = std::numeric_limits<float>::quiet_NaN();

std::uint32_t bitsOf(float f)
{
  std::uint32_t u = 0;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

void writeText(const std::string& path, const std::string& text)
{
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

std::string readBytes(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Runs f and checks that it throws DemError whose message names the file and the reason.
void expectDemError(const std::function<void()>& f, const std::string& path, const std::string& word)
{
  try
  {
    f();
    ADD_FAILURE() << "no DemError for " << path << " (expected reason '" << word << "')";
  }
  catch (const DemError& e)
  {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message lacks the path: " << msg;
    EXPECT_NE(msg.find(word), std::string::npos) << "message lacks '" << word << "': " << msg;
  }
}

/// Writes a PNG with libpng directly, independent of the code under test, so that the
/// reader's row order and format checks are tested against a known file layout.
/// `samples` holds one value per channel per pixel, pixel row 0 first (the north edge).
bool writeTestPngImpl(std::FILE* f, png_uint_32 width, png_uint_32 height, int bit_depth, int colour_type,
                      png_bytepp rows, png_colorp palette)
{
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png)))
  {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, f);
  png_set_IHDR(png, info, width, height, bit_depth, colour_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  if (palette != nullptr)
    png_set_PLTE(png, info, palette, 256);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

void writeTestPng(const std::string& path, png_uint_32 width, png_uint_32 height, int bit_depth, int colour_type,
                  const std::vector<unsigned>& samples)
{
  const int channels = colour_type == PNG_COLOR_TYPE_RGB ? 3 : 1;
  const int bytes = bit_depth == 16 ? 2 : 1;
  std::vector<png_byte> data;
  for (unsigned s : samples)
  {
    if (bytes == 2)
      data.push_back(static_cast<png_byte>(s >> 8));
    data.push_back(static_cast<png_byte>(s & 0xff));
  }
  ASSERT_EQ(data.size(), static_cast<std::size_t>(width) * height * channels * bytes);
  std::vector<png_bytep> rows(height);
  for (png_uint_32 r = 0; r < height; ++r)
    rows[r] = &data[static_cast<std::size_t>(r) * width * channels * bytes];
  std::vector<png_color> palette(256);
  for (int k = 0; k < 256; ++k)
    palette[k] = png_color{ static_cast<png_byte>(k), static_cast<png_byte>(k), static_cast<png_byte>(k) };
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  const bool ok = writeTestPngImpl(f, width, height, bit_depth, colour_type, rows.data(),
                                   colour_type == PNG_COLOR_TYPE_PALETTE ? palette.data() : nullptr);
  ASSERT_EQ(std::fclose(f), 0);
  ASSERT_TRUE(ok);
}

/// Writes a GeoTIFF with GDAL directly: `pixels` row 0 first (file order), geotransform `gt`.
void writeTestTiff(const std::string& path, int width, int height, GDALDataType type, const double gt[6],
                   const std::vector<double>& pixels, const double* nodata, int epsg)
{
  GDALAllRegister();
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  GDALDatasetH ds = GDALCreate(driver, path.c_str(), width, height, 1, type, nullptr);
  ASSERT_NE(ds, nullptr);
  if (gt != nullptr)
  {
    EXPECT_EQ(GDALSetGeoTransform(ds, const_cast<double*>(gt)), CE_None);
  }
  if (epsg != 0)
  {
    OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
    EXPECT_EQ(OSRImportFromEPSG(srs, epsg), OGRERR_NONE);
    EXPECT_EQ(GDALSetSpatialRef(ds, srs), CE_None);
    OSRDestroySpatialReference(srs);
  }
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  if (nodata != nullptr)
  {
    EXPECT_EQ(GDALSetRasterNoDataValue(band, *nodata), CE_None);
  }
  std::vector<double> copy = pixels;
  EXPECT_EQ(GDALRasterIO(band, GF_Write, 0, 0, width, height, copy.data(), width, height, GDT_Float64, 0, 0), CE_None);
  GDALClose(ds);
}

/// A raster whose heights vary with both i and j (so transposes and flips show), with an
/// irregular spread of magnitudes so that printing with too few digits shows too.
HeightRaster makeRaster(std::size_t columns, std::size_t rows, double ox, double oy, double cell)
{
  HeightRaster r;
  r.origin_x = ox;
  r.origin_y = oy;
  r.cell_size = cell;
  r.columns = columns;
  r.rows = rows;
  r.heights.resize(columns * rows);
  for (std::size_t j = 0; j < rows; ++j)
    for (std::size_t i = 0; i < columns; ++i)
      r.heights[j * columns + i] = static_cast<float>(100.0 + 7.3 * j + 0.011 * i + std::sin(1.7 * i + 0.3 * j));
  return r;
}
}  // namespace

class DemIo : public ::testing::Test
{
protected:
  void SetUp() override
  {
    char tmpl[] = "/tmp/avsp_dem_io_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override
  {
    if (!dir_.empty())
      std::filesystem::remove_all(dir_);
  }
  std::string file(const std::string& name) const { return dir_ + "/" + name; }

  std::string dir_;
};

// --------------------------------------------------------------------------------------
// PNG
// --------------------------------------------------------------------------------------

TEST_F(DemIo, Png16RoundTripWithinQuantisationAndKeepsRowOrder)
{
  const HeightRaster in = makeRaster(9, 6, 250.5, -40.25, 0.5);
  Png16Georef g;
  g.origin_x = in.origin_x;
  g.origin_y = in.origin_y;
  g.cell_size = in.cell_size;
  g.z_offset = 90.0;
  g.z_scale = 60.0;
  const std::string path = file("rt.png");
  writePng16(in, path, g);
  const HeightRaster out = readPng16(path, g);
  ASSERT_EQ(out.columns, in.columns);
  ASSERT_EQ(out.rows, in.rows);
  EXPECT_EQ(out.origin_x, g.origin_x);
  EXPECT_EQ(out.origin_y, g.origin_y);
  EXPECT_EQ(out.cell_size, g.cell_size);
  EXPECT_EQ(out.noDataCount(), 0u);
  // Rows differ by 7.3 m, far more than the quantisation step, so a flip would fail here.
  const double tol = g.z_scale / 65535.0 / 2.0 + 130.0 * std::numeric_limits<float>::epsilon();
  for (std::size_t k = 0; k < in.heights.size(); ++k)
    EXPECT_NEAR(out.heights[k], in.heights[k], tol) << "point " << k;
}

TEST_F(DemIo, Png16ReaderPutsFirstPixelRowNorthAndScalesValues)
{
  // 3 x 2 pixels written directly with libpng: the first (north) pixel row is bright.
  const std::string path = file("north.png");
  writeTestPng(path, 3, 2, 16, PNG_COLOR_TYPE_GRAY, { 65535, 32768, 1, 0, 100, 65534 });
  Png16Georef g;
  g.origin_x = 10.0;
  g.origin_y = 20.0;
  g.cell_size = 2.0;
  g.z_offset = -5.0;
  g.z_scale = 100.0;
  const HeightRaster r = readPng16(path, g);
  ASSERT_EQ(r.columns, 3u);
  ASSERT_EQ(r.rows, 2u);
  const auto z = [&](unsigned v) { return static_cast<float>(-5.0 + 100.0 * v / 65535.0); };
  // j = 0 is the south row, i.e. the file's last pixel row.
  EXPECT_FLOAT_EQ(r.heights[0], z(0));
  EXPECT_FLOAT_EQ(r.heights[1], z(100));
  EXPECT_FLOAT_EQ(r.heights[2], z(65534));
  EXPECT_FLOAT_EQ(r.heights[3], 95.0f);
  EXPECT_FLOAT_EQ(r.heights[4], z(32768));
  EXPECT_FLOAT_EQ(r.heights[5], z(1));
}

TEST_F(DemIo, Png16WriterRejectsNoDataOutOfRangeAndMismatchedGeoref)
{
  HeightRaster in = makeRaster(4, 3, 0.0, 0.0, 1.0);
  Png16Georef g;
  g.cell_size = 1.0;
  g.z_offset = 90.0;
  g.z_scale = 50.0;
  const std::string path = file("bad_write.png");
  HeightRaster with_hole = in;
  with_hole.heights[5] = kNaN;
  expectDemError([&] { writePng16(with_hole, path, g); }, path, "no-data");
  HeightRaster too_high = in;
  too_high.heights[2] = 140.01f;
  expectDemError([&] { writePng16(too_high, path, g); }, path, "outside the PNG range");
  Png16Georef shifted = g;
  shifted.origin_x = 0.5;
  expectDemError([&] { writePng16(in, path, shifted); }, path, "do not match");
  EXPECT_FALSE(std::filesystem::exists(path));
}

// --------------------------------------------------------------------------------------
// ESRI ASCII grid
// --------------------------------------------------------------------------------------

TEST_F(DemIo, AsciiRoundTripIsBitExactIncludingNoData)
{
  HeightRaster in = makeRaster(11, 7, 512345.123456789, -0.1, 0.3);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-20, 13);
  for (float& h : in.heights)
    h = std::ldexp(mantissa(rng), exponent(rng));  // magnitudes 1e-6 .. 8e3 need all 9 digits
  in.heights[0] = -0.0f;
  in.heights[3] = kNaN;
  in.heights[in.heights.size() - 1] = kNaN;
  in.heights[20] = std::numeric_limits<float>::denorm_min();
  // The plausible extremes (kMinPlausibleHeight, kMaxPlausibleHeight) read back exactly too.
  in.heights[21] = avsp::terrain::kMaxPlausibleHeight;
  in.heights[22] = avsp::terrain::kMinPlausibleHeight;
  in.heights[23] = std::nextafter(avsp::terrain::kMaxPlausibleHeight, 0.0f);
  const std::string path = file("rt.asc");
  writeAsciiGrid(in, path);
  const HeightRaster out = readAsciiGrid(path);
  ASSERT_EQ(out.columns, in.columns);
  ASSERT_EQ(out.rows, in.rows);
  EXPECT_EQ(out.origin_x, in.origin_x);
  EXPECT_EQ(out.origin_y, in.origin_y);
  EXPECT_EQ(out.cell_size, in.cell_size);
  EXPECT_EQ(out.noDataCount(), 2u);
  for (std::size_t k = 0; k < in.heights.size(); ++k)
  {
    if (std::isnan(in.heights[k]))
      EXPECT_TRUE(std::isnan(out.heights[k])) << k;
    else
      EXPECT_EQ(bitsOf(out.heights[k]), bitsOf(in.heights[k])) << k << ": " << in.heights[k];
  }
}

TEST_F(DemIo, AsciiCornerHeaderPutsGridPointsAtCellCentres)
{
  const std::string path = file("corner.asc");
  writeText(path,
            "ncols 3\nnrows 2\nxllcorner 100\nyllcorner 200\ncellsize 10\nNODATA_value -9999\n"
            "1 2 3\n"
            "4 5 -9999\n");
  const HeightRaster r = readAsciiGrid(path);
  ASSERT_EQ(r.columns, 3u);
  ASSERT_EQ(r.rows, 2u);
  EXPECT_EQ(r.origin_x, 105.0);
  EXPECT_EQ(r.origin_y, 205.0);
  EXPECT_EQ(r.cell_size, 10.0);
  // South-west point (105, 205) is the first value of the last text line.
  EXPECT_EQ(r.heights[0], 4.0f);
  EXPECT_EQ(r.heights[1], 5.0f);
  EXPECT_TRUE(std::isnan(r.heights[2]));
  EXPECT_EQ(r.heights[3], 1.0f);  // (105, 215)
  EXPECT_EQ(r.heights[5], 3.0f);  // (125, 215)
  EXPECT_EQ(r.noDataCount(), 1u);
}

TEST_F(DemIo, AsciiCenterHeaderIsTheOriginAndKeysAreCaseInsensitive)
{
  const std::string path = file("center.asc");
  // No NODATA_value: -9999 is then an ordinary height. CRLF line ends as from Windows tools.
  writeText(path,
            "NCOLS 2\r\nNRows 3\r\nXLLCENTER -50.5\r\nyllCenter 7.25\r\nCellSize 0.5\r\n"
            "1.5 2.5\r\n3.5 -9999\r\n5.5 6.5\r\n");
  const HeightRaster r = readAsciiGrid(path);
  ASSERT_EQ(r.columns, 2u);
  ASSERT_EQ(r.rows, 3u);
  EXPECT_EQ(r.origin_x, -50.5);
  EXPECT_EQ(r.origin_y, 7.25);
  EXPECT_EQ(r.cell_size, 0.5);
  EXPECT_EQ(r.heights[0], 5.5f);
  EXPECT_EQ(r.heights[1], 6.5f);
  EXPECT_EQ(r.heights[3], -9999.0f);
  EXPECT_EQ(r.heights[4], 1.5f);
  EXPECT_EQ(r.noDataCount(), 0u);
}

TEST_F(DemIo, AsciiWriterRejectsHeightEqualToNoDataValue)
{
  HeightRaster in = makeRaster(3, 3, 0.0, 0.0, 1.0);
  in.heights[4] = -9999.0f;
  const std::string path = file("collide.asc");
  expectDemError([&] { writeAsciiGrid(in, path); }, path, "NODATA_value");
}

// --------------------------------------------------------------------------------------
// GeoTIFF
// --------------------------------------------------------------------------------------

TEST_F(DemIo, GeoTiffRoundTripIsExactIncludingNoData)
{
  HeightRaster in = makeRaster(13, 8, 4321.7, -1234.3, 0.3);
  in.heights[0] = kNaN;
  in.heights[50] = kNaN;
  in.heights[77] = -0.0f;
  in.heights[78] = 1.0e-30f;
  const std::string path = file("rt.tif");
  writeGeoTiff(in, path);
  const HeightRaster out = readGeoTiff(path);
  ASSERT_EQ(out.columns, in.columns);
  ASSERT_EQ(out.rows, in.rows);
  EXPECT_EQ(out.cell_size, in.cell_size);
  // The file stores pixel edges (origin - half a cell); converting back may cost an ulp.
  EXPECT_NEAR(out.origin_x, in.origin_x, 1e-9);
  EXPECT_NEAR(out.origin_y, in.origin_y, 1e-9);
  EXPECT_EQ(out.noDataCount(), 2u);
  for (std::size_t k = 0; k < in.heights.size(); ++k)
  {
    if (std::isnan(in.heights[k]))
      EXPECT_TRUE(std::isnan(out.heights[k])) << k;
    else
      EXPECT_EQ(bitsOf(out.heights[k]), bitsOf(in.heights[k])) << k;
  }
}

TEST_F(DemIo, GeoTiffWriterStoresNorthRowFirstWithPixelEdgeGeotransform)
{
  const HeightRaster in = makeRaster(4, 3, 1000.0, 2000.0, 2.0);
  const std::string path = file("layout.tif");
  writeGeoTiff(in, path);
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
  ASSERT_NE(ds, nullptr);
  double gt[6] = {};
  ASSERT_EQ(GDALGetGeoTransform(ds, gt), CE_None);
  EXPECT_EQ(gt[0], 999.0);
  EXPECT_EQ(gt[1], 2.0);
  EXPECT_EQ(gt[3], 2005.0);  // north edge: top grid point 2004 plus half a cell
  EXPECT_EQ(gt[5], -2.0);
  EXPECT_EQ(GDALGetRasterDataType(GDALGetRasterBand(ds, 1)), GDT_Float32);
  int has_nodata = 0;
  EXPECT_TRUE(std::isnan(GDALGetRasterNoDataValue(GDALGetRasterBand(ds, 1), &has_nodata)));
  EXPECT_TRUE(has_nodata);
  float pixel = 0.0f;
  // File pixel (0, 2) is the last row, i.e. the south-west grid point.
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 0, 2, 1, 1, &pixel, 1, 1, GDT_Float32, 0, 0), CE_None);
  EXPECT_EQ(pixel, in.heights[0]);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 3, 0, 1, 1, &pixel, 1, 1, GDT_Float32, 0, 0), CE_None);
  EXPECT_EQ(pixel, in.heights[2 * 4 + 3]);
  GDALClose(ds);
}

TEST_F(DemIo, GeoTiffReaderIsNorthUpWithSouthWestValueAtOrigin)
{
  // 3 x 4 Int16 pixels, value 10 r + c, written with GDAL; nodata -32768 at pixel (2, 0).
  const double gt[6] = { 1000.0, 2.0, 0.0, 5000.0, 0.0, -2.0 };
  std::vector<double> pixels;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 3; ++c)
      pixels.push_back(10.0 * r + c);
  pixels[2] = -32768.0;
  const double nodata = -32768.0;
  const std::string path = file("north.tif");
  writeTestTiff(path, 3, 4, GDT_Int16, gt, pixels, &nodata, 0);
  const HeightRaster r = readGeoTiff(path);
  ASSERT_EQ(r.columns, 3u);
  ASSERT_EQ(r.rows, 4u);
  EXPECT_EQ(r.cell_size, 2.0);
  EXPECT_EQ(r.origin_x, 1001.0);   // centre of the west pixel column
  EXPECT_EQ(r.origin_y, 4993.0);   // centre of the south pixel row: 5000 - 4*2 + 1
  EXPECT_EQ(r.heights[0], 30.0f);  // south-west pixel (0, 3)
  EXPECT_EQ(r.heights[2], 32.0f);
  EXPECT_EQ(r.heights[3 * 3 + 0], 0.0f);  // north-west pixel (0, 0)
  EXPECT_TRUE(std::isnan(r.heights[3 * 3 + 2]));
  EXPECT_EQ(r.noDataCount(), 1u);
}

// The reader goes row by row through GDAL's block cache and drops the cache after each row
// of blocks; tiled and multi-row-strip files of every band type must still come out exact,
// north row first, with nodata, scale and offset applied.
TEST_F(DemIo, GeoTiffReaderIsExactAcrossBlocksForEveryBandType)
{
  const int width = 37, height = 45;  // not multiples of the 16 x 16 tiles or 5-row strips
  const double gt[6] = { 500.0, 0.5, 0.0, 800.0, 0.0, -0.5 };
  struct Case
  {
    const char* name;
    GDALDataType type;
    std::vector<const char*> options;
    double scale, offset, nodata;
  };
  const std::vector<Case> cases = {
    { "f32_tiled.tif", GDT_Float32, { "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16" }, 1.0, 0.0, -9999.0 },
    { "f64_strips.tif", GDT_Float64, { "BLOCKYSIZE=5" }, 1.0, 0.0, -9999.1 },
    { "i16_tiled.tif", GDT_Int16, { "TILED=YES", "BLOCKXSIZE=16", "BLOCKYSIZE=16" }, 0.25, -100.0, -32768.0 },
    { "u16_strips.tif", GDT_UInt16, { "BLOCKYSIZE=5" }, 0.01, 20.0, 65535.0 },
  };
  for (const Case& c : cases)
  {
    SCOPED_TRACE(c.name);
    // File pixel (col, row): a value with a fraction for the float types (0.1 steps are not
    // exact in float, so Float64 shows whether it is rounded once, from the file value);
    // every 11th pixel is nodata.
    std::vector<double> pixels(static_cast<std::size_t>(width) * height);
    for (int r = 0; r < height; ++r)
      for (int col = 0; col < width; ++col)
      {
        const bool is_int = c.type == GDT_Int16 || c.type == GDT_UInt16;
        const double v = is_int ? static_cast<double>(100 * r + col) : 0.1 * (100 * r + col) - 7.0;
        pixels[static_cast<std::size_t>(r) * width + col] = (r * width + col) % 11 == 3 ? c.nodata : v;
      }
    const std::string path = file(c.name);
    {
      GDALAllRegister();
      std::vector<char*> options;
      for (const char* o : c.options)
        options.push_back(const_cast<char*>(o));
      options.push_back(nullptr);
      GDALDatasetH ds =
          GDALCreate(GDALGetDriverByName("GTiff"), path.c_str(), width, height, 1, c.type, options.data());
      ASSERT_NE(ds, nullptr);
      EXPECT_EQ(GDALSetGeoTransform(ds, const_cast<double*>(gt)), CE_None);
      GDALRasterBandH band = GDALGetRasterBand(ds, 1);
      EXPECT_EQ(GDALSetRasterNoDataValue(band, c.nodata), CE_None);
      if (c.scale != 1.0 || c.offset != 0.0)
      {
        EXPECT_EQ(GDALSetRasterScale(band, c.scale), CE_None);
        EXPECT_EQ(GDALSetRasterOffset(band, c.offset), CE_None);
      }
      EXPECT_EQ(GDALRasterIO(band, GF_Write, 0, 0, width, height, pixels.data(), width, height, GDT_Float64, 0, 0),
                CE_None);
      int bx = 0, by = 0;
      GDALGetBlockSize(band, &bx, &by);
      EXPECT_LT(by, height) << "the file must have several rows of blocks";
      GDALClose(ds);
    }
    const HeightRaster r = readGeoTiff(path);
    ASSERT_EQ(r.columns, static_cast<std::size_t>(width));
    ASSERT_EQ(r.rows, static_cast<std::size_t>(height));
    std::size_t nodata_pixels = 0;
    for (int row = 0; row < height; ++row)
      for (int col = 0; col < width; ++col)
      {
        const double raw = pixels[static_cast<std::size_t>(row) * width + col];
        // Raster row 0 is the file's last (southern) row.
        const float got = r.heights[static_cast<std::size_t>(height - 1 - row) * width + col];
        if (raw == c.nodata)
        {
          ++nodata_pixels;
          ASSERT_TRUE(std::isnan(got)) << col << ", " << row;
          continue;
        }
        // What the file holds (Float32 rounds once on write), then scale and offset in double.
        const double stored = c.type == GDT_Float32 ? static_cast<double>(static_cast<float>(raw)) : raw;
        const double z = (c.scale == 1.0 && c.offset == 0.0) ? stored : c.offset + c.scale * stored;
        ASSERT_EQ(bitsOf(got), bitsOf(static_cast<float>(z))) << col << ", " << row << ": " << got << " vs " << z;
      }
    EXPECT_EQ(r.noDataCount(), nodata_pixels);
  }
}

TEST_F(DemIo, GeoTiffReaderRejectsUnsupportedGeoreferenceAndTypes)
{
  const std::vector<double> px = { 1, 2, 3, 4, 5, 6 };
  const double rotated[6] = { 0.0, 1.0, 0.2, 10.0, 0.0, -1.0 };
  const double south_up[6] = { 0.0, 1.0, 0.0, 0.0, 0.0, 1.0 };
  const double rect[6] = { 0.0, 1.0, 0.0, 10.0, 0.0, -2.0 };
  const double ok[6] = { 0.0, 1.0, 0.0, 10.0, 0.0, -1.0 };
  const double all_nodata_value = 7.0;
  const std::vector<double> all_nodata(6, all_nodata_value);
  struct Case
  {
    std::string name;
    const double* gt;
    GDALDataType type;
    const std::vector<double>* pixels;
    const double* nodata;
    int epsg;
    std::string word;
  };
  const std::vector<Case> cases = {
    { "rotated.tif", rotated, GDT_Float32, &px, nullptr, 0, "rotated" },
    { "south_up.tif", south_up, GDT_Float32, &px, nullptr, 0, "north-up" },
    { "rect.tif", rect, GDT_Float32, &px, nullptr, 0, "non-square" },
    { "byte.tif", ok, GDT_Byte, &px, nullptr, 0, "data type" },
    { "nogt.tif", nullptr, GDT_Float32, &px, nullptr, 0, "geotransform" },
    { "degrees.tif", ok, GDT_Float32, &px, nullptr, 4326, "geographic" },
    { "feet.tif", ok, GDT_Float32, &px, nullptr, 2227, "not metres" },  // California zone 3, US ft
    { "all_nodata.tif", ok, GDT_Float64, &all_nodata, &all_nodata_value, 0, "no-data" },
  };
  for (const Case& c : cases)
  {
    SCOPED_TRACE(c.name);
    const std::string path = file(c.name);
    writeTestTiff(path, 3, 2, c.type, c.gt, *c.pixels, c.nodata, c.epsg);
    expectDemError([&] { readGeoTiff(path); }, path, c.word);
  }
  // Control: the same file with a metric projected CRS (UTM 32N) loads.
  const std::string good = file("utm.tif");
  writeTestTiff(good, 3, 2, GDT_UInt16, ok, px, nullptr, 32632);
  EXPECT_EQ(readGeoTiff(good).heights[0], 4.0f);
}

// --------------------------------------------------------------------------------------
// PNG georeference sidecar and class rasters
// --------------------------------------------------------------------------------------

TEST_F(DemIo, Png16GeorefSidecarRoundTripsBitExactly)
{
  Png16Georef g;
  g.origin_x = 4321.0 / 3.0;  // no short decimal form: 17 digits are needed
  g.origin_y = -1e-7 / 7.0;
  g.cell_size = 0.1;
  g.z_offset = -12.345678901234567;
  g.z_scale = 1.0 / 3.0;
  const std::string path = file("map.png.yaml");
  writePng16Georef(g, path, "map.png");
  EXPECT_NE(readBytes(path).find("map.png"), std::string::npos);
  const Png16Georef back = readPng16Georef(path);
  EXPECT_EQ(back.origin_x, g.origin_x);
  EXPECT_EQ(back.origin_y, g.origin_y);
  EXPECT_EQ(back.cell_size, g.cell_size);
  EXPECT_EQ(back.z_offset, g.z_offset);
  EXPECT_EQ(back.z_scale, g.z_scale);

  Png16Georef bad = g;
  bad.z_scale = 0.0;
  expectDemError([&] { writePng16Georef(bad, file("bad.yaml"), "x.png"); }, file("bad.yaml"), "z_scale");
}

TEST_F(DemIo, BadPng16GeorefSidecarsNameFileAndKey)
{
  const std::string full = "origin_x: 1\norigin_y: 2\ncell_size: 0.5\nz_offset: -3\nz_scale: 10\n";
  struct Case
  {
    std::string name, text, words;
  };
  const std::vector<Case> cases = {
    { "missing.yaml", "origin_x: 1\norigin_y: 2\ncell_size: 0.5\nz_offset: -3\n", "key 'z_scale'" },
    { "typo.yaml", full + "z_scal: 3\n", "key 'z_scal'" },
    { "word.yaml", "origin_x: east\norigin_y: 2\ncell_size: 0.5\nz_offset: -3\nz_scale: 10\n", "key 'origin_x'" },
    { "zero.yaml", "origin_x: 1\norigin_y: 2\ncell_size: 0\nz_offset: -3\nz_scale: 10\n", "key 'cell_size'" },
    { "negative.yaml", "origin_x: 1\norigin_y: 2\ncell_size: 1\nz_offset: -3\nz_scale: -10\n", "key 'z_scale'" },
    { "nan.yaml", "origin_x: .nan\norigin_y: 2\ncell_size: 1\nz_offset: -3\nz_scale: 10\n", "finite" },
    { "list.yaml", "- 1\n- 2\n", "map" },
    { "broken.yaml", "origin_x: [1, 2\n", "YAML" },
  };
  for (const Case& c : cases)
  {
    SCOPED_TRACE(c.name);
    const std::string path = file(c.name);
    writeText(path, c.text);
    expectDemError([&] { readPng16Georef(path); }, path, c.words);
  }
  writeText(file("ok.yaml"), full);
  EXPECT_EQ(readPng16Georef(file("ok.yaml")).z_scale, 10.0);
  expectDemError([&] { readPng16Georef(file("absent.yaml")); }, file("absent.yaml"), "not found");
}

TEST_F(DemIo, ClassRasterWritersStoreNorthRowFirstAndRejectInconsistentRasters)
{
  ClassRaster c;
  c.origin_x = 10.0;
  c.origin_y = 20.0;
  c.cell_size = 2.0;
  c.columns = 3;
  c.rows = 2;
  c.values = { 1, 2, 3, 4, 5, 255 };  // row 0 (south) = 1 2 3
  for (const std::string name : { "classes.png", "classes.tif" })
  {
    SCOPED_TRACE(name);
    const std::string path = file(name);
    if (name == "classes.png")
      writeClassPng8(c, path);
    else
      writeClassGeoTiff(c, path);
    GDALAllRegister();
    GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
    ASSERT_NE(ds, nullptr);
    GDALRasterBandH band = GDALGetRasterBand(ds, 1);
    EXPECT_EQ(GDALGetRasterDataType(band), GDT_Byte);
    std::uint8_t px[6] = {};
    ASSERT_EQ(GDALRasterIO(band, GF_Read, 0, 0, 3, 2, px, 3, 2, GDT_Byte, 0, 0), CE_None);
    const std::uint8_t north_first[6] = { 4, 5, 255, 1, 2, 3 };
    for (int k = 0; k < 6; ++k)
      EXPECT_EQ(px[k], north_first[k]) << k;
    if (name == "classes.tif")
    {
      double gt[6] = {};
      ASSERT_EQ(GDALGetGeoTransform(ds, gt), CE_None);
      EXPECT_EQ(gt[0], 9.0);
      EXPECT_EQ(gt[3], 23.0);  // north grid point 22 plus half a cell
      EXPECT_EQ(gt[5], -2.0);
    }
    GDALClose(ds);
  }
  ClassRaster short_values = c;
  short_values.values.pop_back();
  expectDemError([&] { writeClassPng8(short_values, file("s.png")); }, file("s.png"), "values");
  expectDemError([&] { writeClassGeoTiff(short_values, file("s.tif")); }, file("s.tif"), "values");
  ClassRaster no_cell = c;
  no_cell.cell_size = 0.0;
  expectDemError([&] { writeClassGeoTiff(no_cell, file("n.tif")); }, file("n.tif"), "cell size");
}

// --------------------------------------------------------------------------------------
// Bad files
// --------------------------------------------------------------------------------------

TEST_F(DemIo, MissingFilesAndDirectoriesAreNamed)
{
  const std::string missing = file("does_not_exist.dem");
  Png16Georef g;
  g.cell_size = 1.0;
  g.z_scale = 1.0;
  expectDemError([&] { readAsciiGrid(missing); }, missing, "not found");
  expectDemError([&] { readPng16(missing, g); }, missing, "not found");
  expectDemError([&] { readGeoTiff(missing); }, missing, "not found");
  expectDemError([&] { readAsciiGrid(dir_); }, dir_, "directory");
  expectDemError([&] { readPng16(dir_, g); }, dir_, "directory");
  expectDemError([&] { readGeoTiff(dir_); }, dir_, "directory");
}

TEST_F(DemIo, BadAsciiGridsAreRejectedWithTheReason)
{
  const std::string hdr = "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n";
  struct Case
  {
    std::string name, text, word;
  };
  const std::vector<Case> cases = {
    { "truncated.asc", hdr + "1 2 3\n4 5\n", "truncated" },
    { "cut_header.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner", "no value" },
    { "cellsize0.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0\n1 2 3\n4 5 6\n", "cellsize" },
    { "cellsize_neg.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize -2\n1 2 3\n4 5 6\n", "cellsize" },
    { "all_nodata.asc", hdr + "NODATA_value -1\n-1 -1 -1\n-1 -1 -1\n", "every point is no-data" },
    { "nan.asc", hdr + "1 nan 3\n4 5 6\n", "not finite" },
    { "inf.asc", hdr + "1 2 3\n4 5 -inf\n", "not finite" },
    { "overflow.asc", hdr + "1 2 3\n4 5 1e39\n", "not finite" },
    { "non_numeric.asc", hdr + "1 2 3\n4 5x 6\n", "non-numeric" },
    { "word.asc", hdr + "1 2 abc\n4 5 6\n", "non-numeric" },
    { "no_ncols.asc", "nrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n4 5 6\n", "missing header key 'ncols'" },
    { "no_cellsize.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\n1 2 3\n4 5 6\n", "'cellsize'" },
    { "empty.asc", "", "missing header key" },
    { "ncols0.asc", "ncols 0\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n", "must be > 0" },
    { "ncols_neg.asc", "ncols -3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n", "must be > 0" },
    { "ncols_frac.asc", "ncols 2.5\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n", "non-numeric" },
    { "huge.asc", "ncols 100000\nnrows 100000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1\n", "2^31" },
    { "big_small_file.asc", "ncols 15000\nnrows 15000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1\n", "truncated" },
    // Issue 21: within 2^31 points, but beyond the default budget of 250 M (from the header).
    { "over_budget.asc", "ncols 20000\nnrows 20000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1\n",
      "400000000 grid points exceed the budget of 250000000" },
    { "cell_1e30.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1e30\n1 2 3\n4 5 6\n",
      "outside the plausible range [0.001000, 10000.000000] m" },
    { "cell_1e-9.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1e-9\n1 2 3\n4 5 6\n", "cell size" },
    { "far_origin.asc", "ncols 3\nnrows 2\nxllcorner 1e12\nyllcorner 0\ncellsize 1\n1 2 3\n4 5 6\n",
      "beyond the plausible" },
    { "height_3e38.asc", hdr + "1 2 3\n4 5 3.4e38\n", "height 339999995" },
    { "height_12km_deep.asc", hdr + "1 2 3\n4 5 -12000.5\n", "at grid point (2, 0) is outside the plausible range" },
    { "extra.asc", hdr + "1 2 3\n4 5 6\n7\n", "more values" },
    { "twice.asc", "ncols 3\nncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n4 5 6\n", "twice" },
    { "both.asc", hdr + "xllcenter 0\n1 2 3\n4 5 6\n", "both" },
    { "unknown.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ndx 1\n1 2 3\n4 5 6\n", "unknown header key" },
    { "nan_cellsize.asc", "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize nan\n1 2 3\n4 5 6\n", "cellsize" },
    { "binary.asc", hdr + std::string(100, '\x01') + "\n", "64 characters" },
  };
  for (const Case& c : cases)
  {
    SCOPED_TRACE(c.name);
    const std::string path = file(c.name);
    writeText(path, c.text);
    expectDemError([&] { readAsciiGrid(path); }, path, c.word);
  }
}

TEST_F(DemIo, BadPngsAreRejectedWithTheReason)
{
  Png16Georef g;
  g.cell_size = 1.0;
  g.z_scale = 10.0;
  const std::string grey8 = file("grey8.png");
  writeTestPng(grey8, 2, 2, 8, PNG_COLOR_TYPE_GRAY, { 1, 2, 3, 4 });
  expectDemError([&] { readPng16(grey8, g); }, grey8, "bit depth 8");
  const std::string rgb16 = file("rgb16.png");
  writeTestPng(rgb16, 2, 1, 16, PNG_COLOR_TYPE_RGB, { 1, 2, 3, 4, 5, 6 });
  expectDemError([&] { readPng16(rgb16, g); }, rgb16, "colour type RGB");
  const std::string palette = file("palette.png");
  writeTestPng(palette, 2, 2, 8, PNG_COLOR_TYPE_PALETTE, { 1, 2, 3, 4 });
  expectDemError([&] { readPng16(palette, g); }, palette, "colour type palette");
  const std::string text = file("text.png");
  writeText(text, "this is not a png file at all");
  expectDemError([&] { readPng16(text, g); }, text, "not a PNG");

  // A valid, fairly incompressible PNG cut at several places (mid image data, just before
  // IEND, inside the header) must never load.
  HeightRaster noisy = makeRaster(64, 48, 0.0, 0.0, 1.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  for (float& h : noisy.heights)
    h = u(rng);
  const std::string full = file("full.png");
  writePng16(noisy, full, g);
  ASSERT_NO_THROW(readPng16(full, g));
  const std::string bytes = readBytes(full);
  for (std::size_t keep :
       { bytes.size() / 2, bytes.size() - 12, bytes.size() - 1, std::size_t{ 40 }, std::size_t{ 5 } })
  {
    SCOPED_TRACE(keep);
    const std::string cut = file("cut_" + std::to_string(keep) + ".png");
    writeText(cut, bytes.substr(0, keep));
    expectDemError([&] { readPng16(cut, g); }, cut, "truncated");
  }

  Png16Georef no_scale = g;
  no_scale.z_scale = 0.0;
  expectDemError([&] { readPng16(full, no_scale); }, full, "z_scale");
}

TEST_F(DemIo, BadGeoTiffsAreRejectedWithTheReason)
{
  const std::string text = file("text.tif");
  writeText(text, "ncols 3\nnot a tiff\n");
  expectDemError([&] { readGeoTiff(text); }, text, "not a readable GeoTIFF");

  const std::string full = file("full.tif");
  writeGeoTiff(makeRaster(64, 48, 0.0, 0.0, 1.0), full);
  const std::string bytes = readBytes(full);
  for (std::size_t keep : { bytes.size() / 2, std::size_t{ 6 } })
  {
    SCOPED_TRACE(keep);
    const std::string cut = file("cut_" + std::to_string(keep) + ".tif");
    writeText(cut, bytes.substr(0, keep));
    expectDemError([&] { readGeoTiff(cut); }, cut, "truncated");
  }
  // Cut inside the tag data: the file opens but lacks its georeference, which is the reason
  // given; only rejection naming the file is checked.
  const std::string cut = file("cut_tags.tif");
  writeText(cut, bytes.substr(0, 300));
  expectDemError([&] { readGeoTiff(cut); }, cut, cut);
}

// --------------------------------------------------------------------------------------
// No-data filling
// --------------------------------------------------------------------------------------

TEST(FillNoData, TakesTheNearestValidPointByFourNeighbourSteps)
{
  // 5 x 4 points, valid only at the south-west (1 m) and north-east (2 m) corners: a point
  // is nearer the south-west corner iff i + j < (4 - i) + (3 - j), i.e. i + j <= 3 (no ties).
  HeightRaster r;
  r.columns = 5;
  r.rows = 4;
  r.cell_size = 1.0;
  r.heights.assign(20, kNaN);
  r.heights[0] = 1.0f;
  r.heights[19] = 2.0f;
  EXPECT_EQ(fillNoData(r, "pattern"), 18u);
  EXPECT_EQ(r.noDataCount(), 0u);
  for (std::size_t j = 0; j < 4; ++j)
    for (std::size_t i = 0; i < 5; ++i)
      EXPECT_EQ(r.heights[j * 5 + i], i + j <= 3 ? 1.0f : 2.0f) << i << "," << j;
}

TEST(FillNoData, WallOfValuesStopsTheFarSideFromLeakingThrough)
{
  // Row 1 is a valid wall of 5 m except column 0 (3 m); row 0 is all no-data, row 2 has a
  // single 9 m point at its east end. Row 0 must copy the wall directly above it.
  HeightRaster r;
  r.columns = 4;
  r.rows = 3;
  r.cell_size = 1.0;
  r.heights = { kNaN, kNaN, kNaN, kNaN, 3.0f, 5.0f, 5.0f, 5.0f, kNaN, kNaN, kNaN, 9.0f };
  EXPECT_EQ(fillNoData(r, "wall"), 7u);
  const std::vector<float> expected = { 3, 5, 5, 5, 3, 5, 5, 5, 3, 5, 5, 9 };
  for (std::size_t k = 0; k < expected.size(); ++k)
    EXPECT_EQ(r.heights[k], expected[k]) << k;
}

namespace
{
/// The breadth-first fill as first written: every valid point seeded, in index order.
void referenceFill(HeightRaster& r)
{
  const std::size_t n = r.heights.size(), cols = r.columns;
  std::vector<std::size_t> queue;
  std::vector<bool> known(n, false);
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isnan(r.heights[k]))
    {
      known[k] = true;
      queue.push_back(k);
    }
  for (std::size_t head = 0; head < queue.size(); ++head)
  {
    const std::size_t k = queue[head], i = k % cols, j = k / cols;
    for (const long long step : { -1LL, 1LL, -static_cast<long long>(cols), static_cast<long long>(cols) })
    {
      if ((step == -1 && i == 0) || (step == 1 && i + 1 == cols) || (step < -1 && j == 0) ||
          (step > 1 && j + 1 == r.rows))
        continue;
      const std::size_t nk = static_cast<std::size_t>(static_cast<long long>(k) + step);
      if (!known[nk])
      {
        known[nk] = true;
        r.heights[nk] = r.heights[k];
        queue.push_back(nk);
      }
    }
  }
}
}  // namespace

TEST(FillNoData, SeedingOnlyTheRimsGivesTheSameFillAsSeedingEveryPoint)
{
  // Random masks from nearly empty to nearly full, on distinct heights, so that any change
  // of which valid point wins a tie shows as a different value.
  std::mt19937 rng(11);
  for (const double void_fraction : { 0.02, 0.3, 0.7, 0.97 })
    for (int trial = 0; trial < 5; ++trial)
    {
      SCOPED_TRACE(void_fraction);
      HeightRaster r = makeRaster(23 + trial, 17 + 2 * trial, 0.0, 0.0, 1.0);
      std::bernoulli_distribution hole(void_fraction);
      for (float& h : r.heights)
        if (hole(rng))
          h = kNaN;
      if (r.noDataCount() == r.heights.size())
        r.heights[5] = 1.0f;
      HeightRaster expected = r;
      referenceFill(expected);
      const std::size_t voids = r.noDataCount();
      EXPECT_EQ(fillNoData(r, "mask"), voids);
      for (std::size_t k = 0; k < r.heights.size(); ++k)
        ASSERT_EQ(bitsOf(r.heights[k]), bitsOf(expected.heights[k])) << k;
    }
}

TEST(FillNoData, NothingToFillAndAllNoData)
{
  HeightRaster full = makeRaster(3, 3, 0.0, 0.0, 1.0);
  const std::vector<float> before = full.heights;
  EXPECT_EQ(fillNoData(full, "full"), 0u);
  EXPECT_EQ(full.heights, before);

  HeightRaster empty;
  empty.columns = 3;
  empty.rows = 2;
  empty.cell_size = 1.0;
  empty.heights.assign(6, kNaN);
  expectDemError([&] { fillNoData(empty, "/data/hole.asc"); }, "/data/hole.asc", "every point is no-data");
  HeightRaster wrong = full;
  wrong.heights.pop_back();
  expectDemError([&] { fillNoData(wrong, "src"); }, "src", "heights");
}

// --------------------------------------------------------------------------------------
// Fuzz
// --------------------------------------------------------------------------------------

TEST_F(DemIo, AsciiReaderSurvivesRandomByteEdits)
{
  HeightRaster base = makeRaster(6, 5, 10.0, 20.0, 0.5);
  base.heights[7] = kNaN;
  const std::string valid_path = file("valid.asc");
  writeAsciiGrid(base, valid_path);
  const std::string valid = readBytes(valid_path);
  ASSERT_NO_THROW(readAsciiGrid(valid_path));

  std::mt19937 rng(20240611u);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> edit_kind(0, 2);
  std::uniform_int_distribution<int> edit_count(1, 3);
  const std::string path = file("fuzz.asc");
  const int attempts = 400;
  int loaded = 0, rejected = 0;
  for (int n = 0; n < attempts; ++n)
  {
    std::string text = valid;
    for (int e = edit_count(rng); e > 0 && !text.empty(); --e)
    {
      const std::size_t pos = std::uniform_int_distribution<std::size_t>(0, text.size() - 1)(rng);
      const char c = static_cast<char>(byte(rng));
      switch (edit_kind(rng))
      {
        case 0:
          text[pos] = c;
          break;
        case 1:
          text.insert(text.begin() + static_cast<std::ptrdiff_t>(pos), c);
          break;
        default:
          text.erase(pos, 1);
      }
    }
    writeText(path, text);
    try
    {
      const HeightRaster r = readAsciiGrid(path);
      ++loaded;
      // Whatever loads must be self-consistent.
      ASSERT_GT(r.columns, 0u);
      ASSERT_GT(r.rows, 0u);
      ASSERT_EQ(r.heights.size(), r.columns * r.rows);
      ASSERT_GT(r.cell_size, 0.0);
      ASSERT_TRUE(std::isfinite(r.origin_x) && std::isfinite(r.origin_y));
      ASSERT_LT(r.noDataCount(), r.heights.size());
      for (float h : r.heights)
        ASSERT_FALSE(std::isinf(h));
    }
    catch (const DemError& e)
    {
      ++rejected;
      ASSERT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(loaded + rejected, attempts);
  EXPECT_GT(rejected, attempts / 2) << "loaded " << loaded;
  EXPECT_GT(loaded, 0);  // the edits are not all fatal, so the accepting path ran too
}

namespace
{
/// CRC-32 of PNG chunks (ISO 3309), so the test can declare any size in an IHDR.
std::uint32_t pngCrc(const unsigned char* data, std::size_t n)
{
  std::uint32_t c = 0xffffffffu;
  for (std::size_t k = 0; k < n; ++k)
  {
    c ^= data[k];
    for (int b = 0; b < 8; ++b)
      c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return c ^ 0xffffffffu;
}
}  // namespace

/// Issue 21, finding 6: a 0.78 MB PNG declaring 20000 x 20000 took terrain_node past 8 GB, a
/// sparse 40000 x 40000 GeoTIFF too, and devices were read. The header is now checked against
/// the point budget before any allocation, and only regular files are read.
TEST_F(DemIo, OversizedHeadersAndDevicesAreRefusedBeforeAllocation)
{
  // A 16-bit greyscale PNG's signature and IHDR declaring 20000 x 20000, then nothing.
  const std::string png = file("declares_20000.png");
  {
    std::vector<unsigned char> b = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R' };
    const std::uint32_t w = 20000, h = 20000;
    for (std::uint32_t v : { w, h })
      for (int shift = 24; shift >= 0; shift -= 8)
        b.push_back(static_cast<unsigned char>(v >> shift));
    for (unsigned char v : { 16, 0, 0, 0, 0 })  // bit depth 16, greyscale, deflate, filter 0, no interlace
      b.push_back(v);
    const std::uint32_t crc = pngCrc(&b[12], 17);
    for (int shift = 24; shift >= 0; shift -= 8)
      b.push_back(static_cast<unsigned char>(crc >> shift));
    // A short IDAT (libpng reads the header up to the first IDAT) and IEND.
    for (const std::string& chunk : { std::string("IDAT\x78\x9c", 6), std::string("IEND") })
    {
      const std::uint32_t n = static_cast<std::uint32_t>(chunk.size() - 4);
      for (int shift = 24; shift >= 0; shift -= 8)
        b.push_back(static_cast<unsigned char>(n >> shift));
      const std::size_t at = b.size();
      b.insert(b.end(), chunk.begin(), chunk.end());
      const std::uint32_t c = pngCrc(&b[at], chunk.size());
      for (int shift = 24; shift >= 0; shift -= 8)
        b.push_back(static_cast<unsigned char>(c >> shift));
    }
    std::ofstream(png, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  }
  Png16Georef g;
  g.cell_size = 1.0;
  g.z_scale = 100.0;
  expectDemError([&] { readPng16(png, g); }, png,
                 "20000 x 20000 = 400000000 grid points exceed the budget of 250000000");
  // A smaller budget refuses smaller headers; a larger one lets this header through to the
  // next check (the file is far too small for the image it declares).
  expectDemError([&] { readPng16(png, g, avsp::terrain::DemLimits{ 1000 }); }, png, "exceed the budget of 1000");
  expectDemError([&] { readPng16(png, g, avsp::terrain::DemLimits{ 500000000 }); }, png, "cannot fit");

  // A sparse GeoTIFF of 40000 x 40000 Float32 pixels: a few hundred bytes on disk.
  const std::string tif = file("sparse_40000.tif");
  {
    GDALAllRegister();
    char** options = nullptr;
    options = CSLSetNameValue(options, "SPARSE_OK", "TRUE");
    options = CSLSetNameValue(options, "TILED", "YES");
    GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), tif.c_str(), 40000, 40000, 1, GDT_Float32, options);
    CSLDestroy(options);
    ASSERT_NE(ds, nullptr);
    double gt[6] = { 0.0, 1.0, 0.0, 40000.0, 0.0, -1.0 };
    GDALSetGeoTransform(ds, gt);
    GDALClose(ds);
  }
  EXPECT_LT(std::filesystem::file_size(tif), 1u << 20);
  expectDemError([&] { readGeoTiff(tif); }, tif, "1600000000 grid points exceed the budget of 250000000");

  // A pipe would be read until it ends (/dev/zero never does).
  const std::string fifo = file("pipe.asc");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  expectDemError([&] { readAsciiGrid(fifo); }, fifo, "not a regular file");
  expectDemError([&] { readAsciiGrid("/dev/zero"); }, "/dev/zero", "not a regular file");
}
