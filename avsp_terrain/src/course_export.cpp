#include "avsp_terrain/course_export.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "avsp_terrain/dem_io.hpp"

namespace avsp
{
namespace terrain
{
namespace
{
enum class Format
{
  kAscii,
  kPng,
  kGeoTiff
};

const char* const kFlags[] = { "--cell-size", "--length-x", "--length-y", "--out", "--seed", "--soil-map" };

std::string knownFlags()
{
  std::string s;
  for (const char* f : kFlags)
    s += (s.empty() ? "" : ", ") + std::string(f);
  return s + ", --help";
}

/// Lower-case extension of the file name in `path` ("" when it has none).
std::string extensionOf(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/');
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) || dot + 1 == path.size())
    return "";
  std::string ext = path.substr(dot + 1);
  for (char& c : ext)
    if (c >= 'A' && c <= 'Z')
      c = static_cast<char>(c - 'A' + 'a');
  return ext;
}

/// The format --out / --soil-map asks for; `allowed_ascii` false for the 8-bit soil map.
Format formatOf(const std::string& flag, const std::string& path, bool allowed_ascii)
{
  const std::string ext = extensionOf(path);
  if (ext == "png")
    return Format::kPng;
  if (ext == "tif" || ext == "tiff")
    return Format::kGeoTiff;
  if (ext == "asc" && allowed_ascii)
    return Format::kAscii;
  const std::string known = allowed_ascii ? ".asc, .png, .tif or .tiff" : ".png, .tif or .tiff: an 8-bit raster";
  throw UsageError(flag + " '" + path + "': " +
                   (ext.empty() ? "no file extension" : "unknown extension '." + ext + "'") + " (need " + known + ")");
}

/// A complete, finite, positive decimal number, else UsageError naming the flag.
double parsePositive(const std::string& flag, const std::string& text)
{
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0])) || end != text.c_str() + text.size())
    throw UsageError(flag + ": '" + text + "' is not a number");
  if (!std::isfinite(v) || errno == ERANGE)
    throw UsageError(flag + ": '" + text + "' is not a finite number");
  if (!(v > 0.0))
    throw UsageError(flag + ": must be > 0 (got '" + text + "')");
  return v;
}

std::uint64_t parseSeed(const std::string& flag, const std::string& text)
{
  // strtoull would accept a sign ("-1" wraps to 2^64 - 1) and leading blanks: digits only.
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
    throw UsageError(flag + ": '" + text + "' is not a whole number >= 0");
  errno = 0;
  const unsigned long long v = std::strtoull(text.c_str(), nullptr, 10);
  if (errno == ERANGE)
    throw UsageError(flag + ": '" + text + "' is larger than 2^64 - 1");
  return static_cast<std::uint64_t>(v);
}

[[noreturn]] void writeFailed(const std::string& path, const std::string& reason)
{
  throw DemError("exportCourse: '" + path + "': " + reason);
}

/// The soil legend: the raster's georeference and index -> soil name.
void writeSoilLegend(const std::string& path, const std::string& raster_path, const Course& course)
{
  const ElevationGrid& g = course.heights;
  YAML::Emitter yaml;
  yaml.SetDoublePrecision(17);
  yaml << YAML::BeginMap;
  yaml << YAML::Key << "origin_x" << YAML::Value << g.originX();
  yaml << YAML::Key << "origin_y" << YAML::Value << g.originY();
  yaml << YAML::Key << "cell_size" << YAML::Value << g.dx();
  yaml << YAML::Key << "columns" << YAML::Value << g.columns();
  yaml << YAML::Key << "rows" << YAML::Value << g.rows();
  yaml << YAML::Key << "soils" << YAML::Value << YAML::BeginMap;
  for (std::size_t k = 0; k < course.soil_names.size(); ++k)
    yaml << YAML::Key << k << YAML::Value << course.soil_names[k];
  yaml << YAML::EndMap << YAML::EndMap;
  if (!yaml.good())
    writeFailed(path, "cannot format the legend: " + yaml.GetLastError());

  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    writeFailed(path, std::string("cannot open file for writing: ") + std::strerror(errno));
  out << "# Soil map legend of '" << raster_path << "' (avsp_terrain export_course).\n"
      << "# Pixel value = index into 'soils' (names as in config/soils.yaml). One pixel per grid\n"
      << "# point; pixel row 0 is the north edge; grid point (0, 0) is at (origin_x, origin_y), m.\n"
      << yaml.c_str() << "\n";
  out.close();
  if (!out)
  {
    std::remove(path.c_str());
    writeFailed(path, "write error (disk full or I/O error?)");
  }
}
/// makeDefaultCourse, with its size errors turned into UsageError naming the flag: it
/// names the option (cell_size, length_x, length_y) that breaks a rule first in its message.
Course buildCourse(const CourseOptions& options)
{
  try
  {
    return makeDefaultCourse(options);
  }
  catch (const std::invalid_argument& e)
  {
    const std::string what = e.what();
    const std::pair<const char*, const char*> names[] = { { "cell_size", "--cell-size" },
                                                          { "length_x", "--length-x" },
                                                          { "length_y", "--length-y" } };
    std::size_t first = std::string::npos;
    std::string flag = "--cell-size/--length-x/--length-y";
    for (const auto& [option, option_flag] : names)
    {
      const std::size_t at = what.find(option);
      if (at < first)
      {
        first = at;
        flag = option_flag;
      }
    }
    throw UsageError(flag + ": " + what);
  }
}
}  // namespace

std::string exportUsage()
{
  const CourseOptions d;
  std::ostringstream u;
  u << "usage: export_course --out FILE [--soil-map FILE] [--seed N] [--cell-size M] [--length-x M] [--length-y M]\n"
    << "Builds the default course and writes its heights; the format follows the extension:\n"
    << "  .asc        ESRI ASCII grid (exact)\n"
    << "  .tif/.tiff  Float32 GeoTIFF (exact)\n"
    << "  .png        16-bit greyscale over the course's height range, plus FILE.yaml with the\n"
    << "              georeference and z_offset/z_scale (readPng16Georef + readPng16 read it back)\n"
    << "  --soil-map FILE  soil index per grid point as an 8-bit .png or .tif, plus FILE.yaml with\n"
    << "              the georeference and the legend (index -> soil name in config/soils.yaml)\n"
    << "  --seed N         hills, soil mottling, vegetation (default " << d.seed << ")\n"
    << "  --cell-size M    grid spacing, m (default " << d.cell_size << ")\n"
    << "  --length-x M     east-west extent, m, >= " << kMinCourseLengthX << " (default " << d.length_x << ")\n"
    << "  --length-y M     north-south extent, m, >= " << kMinCourseLengthY << " (default " << d.length_y << ")\n"
    << "Example: export_course --out course.tif --soil-map soil.png --cell-size 0.5\n"
    << "Exit status: 0 written, 1 a file could not be written, 2 bad arguments.\n";
  return u.str();
}

ExportOptions parseExportArguments(const std::vector<std::string>& args)
{
  ExportOptions o;
  std::set<std::string> seen;
  for (std::size_t k = 0; k < args.size(); ++k)
  {
    const std::string& arg = args[k];
    if (arg == "--help" || arg == "-h")
    {
      o.help = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0)
      throw UsageError("unexpected argument '" + arg + "' (every value follows its flag; see --help)");
    std::string flag = arg, value;
    bool has_value = false;
    const std::size_t eq = arg.find('=');
    if (eq != std::string::npos)
    {
      flag = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      has_value = true;
    }
    if (std::find(std::begin(kFlags), std::end(kFlags), flag) == std::end(kFlags))
      throw UsageError(flag + ": unknown flag (known: " + knownFlags() + ")");
    if (!seen.insert(flag).second)
      throw UsageError(flag + ": given more than once");
    if (!has_value)
    {
      // A following flag is not a value: "--out --seed 2" forgot the path.
      if (k + 1 >= args.size() || args[k + 1].rfind("--", 0) == 0)
        throw UsageError(flag + ": missing value");
      value = args[++k];
    }
    if (value.empty())
      throw UsageError(flag + ": missing value");

    if (flag == "--out")
      o.out = value;
    else if (flag == "--soil-map")
      o.soil_map = value;
    else if (flag == "--seed")
      o.course.seed = parseSeed(flag, value);
    else if (flag == "--cell-size")
      o.course.cell_size = parsePositive(flag, value);
    else if (flag == "--length-x")
      o.course.length_x = parsePositive(flag, value);
    else if (flag == "--length-y")
      o.course.length_y = parsePositive(flag, value);
  }
  if (o.help)
    return o;
  if (o.out.empty())
    throw UsageError("--out: required (the heights file: .asc, .png, .tif or .tiff)");
  formatOf("--out", o.out, true);
  if (!o.soil_map.empty())
  {
    formatOf("--soil-map", o.soil_map, false);
    if (o.soil_map == o.out)
      throw UsageError("--soil-map '" + o.soil_map + "': same file as --out");
  }
  return o;
}

std::vector<std::string> exportCourse(const ExportOptions& options)
{
  const Format format = formatOf("--out", options.out, true);
  const Course course = buildCourse(options.course);
  const ElevationGrid& g = course.heights;
  std::vector<std::string> written;

  HeightRaster raster;
  raster.origin_x = g.originX();
  raster.origin_y = g.originY();
  raster.cell_size = g.dx();
  raster.columns = g.columns();
  raster.rows = g.rows();
  raster.heights = g.pointHeights();
  switch (format)
  {
    case Format::kAscii:
      writeAsciiGrid(raster, options.out);
      written.push_back(options.out);
      break;
    case Format::kGeoTiff:
      writeGeoTiff(raster, options.out);
      written.push_back(options.out);
      break;
    case Format::kPng:
    {
      // The full 16 bits over exactly the course's range: the finest step the PNG allows.
      const auto [lo, hi] = std::minmax_element(raster.heights.begin(), raster.heights.end());
      Png16Georef georef;
      georef.origin_x = raster.origin_x;
      georef.origin_y = raster.origin_y;
      georef.cell_size = raster.cell_size;
      georef.z_offset = *lo;
      georef.z_scale = *hi > *lo ? static_cast<double>(*hi) - *lo : 1.0;  // a flat course still needs a scale
      writePng16(raster, options.out, georef);
      writePng16Georef(georef, options.out + ".yaml", options.out);
      written.push_back(options.out);
      written.push_back(options.out + ".yaml");
      break;
    }
  }

  if (!options.soil_map.empty())
  {
    ClassRaster soil;
    soil.origin_x = raster.origin_x;
    soil.origin_y = raster.origin_y;
    soil.cell_size = raster.cell_size;
    soil.columns = raster.columns;
    soil.rows = raster.rows;
    soil.values = course.soil_map;
    if (formatOf("--soil-map", options.soil_map, false) == Format::kPng)
      writeClassPng8(soil, options.soil_map);
    else
      writeClassGeoTiff(soil, options.soil_map);
    writeSoilLegend(options.soil_map + ".yaml", options.soil_map, course);
    written.push_back(options.soil_map);
    written.push_back(options.soil_map + ".yaml");
  }
  return written;
}

}  // namespace terrain
}  // namespace avsp
