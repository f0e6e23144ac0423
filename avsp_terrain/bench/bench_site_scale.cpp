// The test-site scale of docs/MODELS.md section 1: the founding report ran the 1.2 km x 1.9 km
// site as one grid of 11600 x 18800 cells at 0.1 m (218 M points). The terrain issue asks
// that such a grid loads with peak RSS under 1.5 GB, that a 10 km traverse of a vehicle
// adds under 200 MB, and that the bytes per deformed point are stated.
//
// The bench writes a site-size Float32 GeoTIFF (procedural hills with a few no-data voids,
// as surveyed DEMs have) into a fresh directory under TEMP_DIR, then measures in this
// process: readGeoTiff + fillNoData + ElevationGrid + DeformableTerrain (seconds, RSS, peak
// RSS from getrusage and /proc/self/status), and RSS growth while a 4-wheel vehicle drives
// KM kilometres over it through DeformableTerrain::wheelContact. The file is written by a
// child process, so that GDAL's write cache does not count in this process's peak RSS, and
// removed at the end.
//
// Usage: bench_site_scale SOILS.yaml [TEMP_DIR [CELLS_X CELLS_Y [KM]]]
//        defaults: /tmp, 11600 18800 cells, 10 km. Exit code 1 if a limit is exceeded.
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>

#include "avsp_terrain/deformable_terrain.hpp"
#include "avsp_terrain/dem_io.hpp"
#include "avsp_terrain/soil.hpp"

using namespace avsp::terrain;
using Clock = std::chrono::steady_clock;

namespace
{
constexpr double kCell = 0.1;             // m
constexpr double kPeakLimitMb = 1500.0;   // issue: loading peak RSS under 1.5 GB
constexpr double kGrowthLimitMb = 200.0;  // issue: a 10 km traverse adds under 200 MB

double seconds(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// A "VmXXX:  N kB" line of /proc/self/status, in MB (1e6 B); -1 if absent.
double procStatusMb(const char* key)
{
  std::ifstream status("/proc/self/status");
  std::string line;
  const std::size_t n = std::strlen(key);
  while (std::getline(status, line))
    if (line.compare(0, n, key) == 0 && line.size() > n && line[n] == ':')
      return std::strtod(line.c_str() + n + 1, nullptr) * 1024.0 / 1e6;
  return -1.0;
}

/// Peak resident set from getrusage (ru_maxrss is in KiB on Linux), MB.
double maxRssMb()
{
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss * 1024.0 / 1e6;
}

/**
 * Heights of the procedural site, m: rolling hills as sums of separable sinusoids (sin(a+b)
 * = sin a cos b + cos a sin b), so a row costs a few multiply-adds per point with the
 * column terms precomputed, plus a small hashed roughness. Relief about +-25 m.
 */
class SiteHeights
{
public:
  explicit SiteHeights(std::size_t columns) : columns_(columns)
  {
    for (const Wave& w : kWaves)
    {
      std::vector<double> s(columns), c(columns);
      for (std::size_t i = 0; i < columns; ++i)
      {
        const double a = 2.0 * M_PI * w.kx * (i * kCell);
        s[i] = std::sin(a);
        c[i] = std::cos(a);
      }
      col_sin_.push_back(std::move(s));
      col_cos_.push_back(std::move(c));
    }
  }

  /// Row j (map y = j * kCell, row 0 south) into out[0 .. columns).
  void row(std::size_t j, float* out) const
  {
    const double y = j * kCell;
    std::vector<double> acc(columns_, 0.0);
    for (std::size_t w = 0; w < kWaveCount; ++w)
    {
      const double b = 2.0 * M_PI * kWaves[w].ky * y;
      const double amp_cos = kWaves[w].amplitude * std::cos(b), amp_sin = kWaves[w].amplitude * std::sin(b);
      const double* s = col_sin_[w].data();
      const double* c = col_cos_[w].data();
      for (std::size_t i = 0; i < columns_; ++i)
        acc[i] += s[i] * amp_cos + c[i] * amp_sin;
    }
    for (std::size_t i = 0; i < columns_; ++i)
    {
      std::uint64_t h = (static_cast<std::uint64_t>(j) << 32) ^ i;
      h = (h ^ (h >> 31)) * 0x9E3779B97F4A7C15ULL;
      const double rough = 0.02 * (static_cast<double>(h >> 40) / 16777216.0 - 0.5);  // +-1 cm
      out[i] = static_cast<float>(acc[i] + rough);
    }
  }

private:
  struct Wave
  {
    double kx, ky, amplitude;  // 1/m, 1/m, m
  };
  static constexpr std::size_t kWaveCount = 4;
  static constexpr Wave kWaves[kWaveCount] = {
    { 1.0 / 900.0, 1.0 / 1300.0, 15.0 },
    { 1.0 / 310.0, -1.0 / 270.0, 6.0 },
    { -1.0 / 95.0, 1.0 / 120.0, 1.5 },
    { 1.0 / 23.0, 1.0 / 31.0, 0.25 },
  };
  std::size_t columns_;
  std::vector<std::vector<double>> col_sin_, col_cos_;
};
constexpr SiteHeights::Wave SiteHeights::kWaves[SiteHeights::kWaveCount];

/// No-data voids (map m: centre x, centre y, half sizes), like survey shadows and water.
struct Void
{
  double x, y, hx, hy;
};
const Void kVoids[] = { { 300.0, 400.0, 15.0, 10.0 }, { 800.0, 1500.0, 25.0, 12.0 }, { 150.0, 1200.0, 5.0, 40.0 } };

/// Writes the site GeoTIFF row by row (never the whole raster in memory); returns an error
/// message or "" on success. Runs in the child process.
std::string writeSite(const std::string& path, std::size_t cols, std::size_t rows)
{
  GDALAllRegister();
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  if (driver == nullptr)
    return "GDAL has no GTiff driver";
  // BIGTIFF: the file is close to 1 GB, and a slightly larger site would pass 4 GB.
  char* options[] = { const_cast<char*>("BIGTIFF=IF_SAFER"), nullptr };
  GDALDatasetH ds =
      GDALCreate(driver, path.c_str(), static_cast<int>(cols), static_cast<int>(rows), 1, GDT_Float32, options);
  if (ds == nullptr)
    return std::string("cannot create: ") + CPLGetLastErrorMsg();
  // The same georeference writeGeoTiff() gives: grid point (0, 0) at map (0, 0), pixel centres.
  double gt[6] = { -0.5 * kCell, kCell, 0.0, (static_cast<double>(rows) - 0.5) * kCell, 0.0, -kCell };
  bool ok = GDALSetGeoTransform(ds, gt) == CE_None;
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  ok = ok && GDALSetRasterNoDataValue(band, std::numeric_limits<double>::quiet_NaN()) == CE_None;
  ok = ok && GDALSetRasterUnitType(band, "metre") == CE_None;
  const SiteHeights site(cols);
  std::vector<float> line(cols);
  for (std::size_t r = 0; ok && r < rows; ++r)
  {
    const std::size_t j = rows - 1 - r;  // file row 0 is the northern one
    site.row(j, line.data());
    const double y = j * kCell;
    for (const Void& v : kVoids)
      if (std::abs(y - v.y) <= v.hy)
        for (std::size_t i = 0; i < cols; ++i)
          if (std::abs(i * kCell - v.x) <= v.hx)
            line[i] = std::numeric_limits<float>::quiet_NaN();
    ok = GDALRasterIO(band, GF_Write, 0, static_cast<int>(r), static_cast<int>(cols), 1, line.data(),
                      static_cast<int>(cols), 1, GDT_Float32, 0, 0) == CE_None;
  }
  CPLErrorReset();
  GDALClose(ds);
  if (!ok || CPLGetLastErrorType() == CE_Failure)
    return std::string("write failed: ") + CPLGetLastErrorMsg();
  return "";
}

/// A temporary directory and the file in it, removed however the bench ends.
struct TempSite
{
  std::string dir, file;
  ~TempSite()
  {
    if (!file.empty())
      std::remove(file.c_str());
    if (!dir.empty())
      ::rmdir(dir.c_str());
  }
};

WheelPatch wheel(const DeformableTerrain& t, double x, double y, double sink, double speed)
{
  WheelPatch w;
  w.radius = 0.35;
  w.width = 0.3;
  const double ground = t.height(x, y).value_or(0.0);
  w.centre = Eigen::Vector3d(x, y, ground + w.radius - sink);
  w.velocity = Eigen::Vector3d(speed, 0, 0);
  w.spin_rate = 1.1 * speed / w.radius;  // 10 % driving slip
  return w;
}

std::size_t parseCount(const char* text, const char* what)
{
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text, &end, 10);
  if (end == text || *end != '\0' || v < 400 || v > 40000)
    throw std::invalid_argument(std::string(what) + " must be an integer in [400, 40000] (got '" + text + "')");
  return static_cast<std::size_t>(v);
}
/// Writes the site's GeoTIFF in a child process (the parent's memory figures stay its own).
void writeSiteInChild(const TempSite& site, std::size_t cells_x, std::size_t cells_y)
{
  const std::size_t cols = cells_x + 1, rows = cells_y + 1;
  auto t0 = Clock::now();
  std::fflush(nullptr);
  const pid_t child = ::fork();
  if (child < 0)
    throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (child == 0)
  {
    const std::string error = writeSite(site.file, cols, rows);
    if (!error.empty())
      std::fprintf(stderr, "bench_site_scale: '%s': %s\n", site.file.c_str(), error.c_str());
    std::fflush(nullptr);
    ::_exit(error.empty() ? 0 : 1);  // no destructors: the parent owns the temp files
  }
  int status = 0;
  if (::waitpid(child, &status, 0) != child || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("writing '" + site.file + "' failed (see above)");
  const double write_s = seconds(t0);
  struct stat st
  {
  };
  ::stat(site.file.c_str(), &st);
  std::printf("site grid: %zu x %zu cells at %.1f m (%zu x %zu = %.1f M points, %.2f km x %.2f km)\n", cells_x, cells_y,
              kCell, cols, rows, cols * rows / 1e6, cells_x * kCell / 1e3, cells_y * kCell / 1e3);
  std::printf("GeoTIFF: Float32, uncompressed, %.1f MB, written in %.1f s by a child process\n", st.st_size / 1e6,
              write_s);
}

/// Loads the site as a scenario does (read, fill voids, grid, deformable terrain), printing
/// times and memory; `peak_mb` is the larger of the two peak RSS readings.
DeformableTerrain loadSite(const std::string& file, const SoilLibrary& soils, std::size_t cols, std::size_t rows,
                           double& peak_mb)
{
  const std::string& site_file = file;
  const double rss_before = procStatusMb("VmRSS");
  auto t0 = Clock::now();
  HeightRaster raster = readGeoTiff(site_file);
  const double read_s = seconds(t0);
  const double rss_read = procStatusMb("VmRSS");
  const double peak_read = procStatusMb("VmHWM");
  auto t1 = Clock::now();
  const std::size_t voids = raster.noDataCount();
  const std::size_t filled = fillNoData(raster, site_file);
  const double fill_s = seconds(t1);
  t1 = Clock::now();
  // Moved, not copied, all the way: the heights exist once.
  ElevationGrid grid(raster.origin_x, raster.origin_y, raster.cell_size, raster.cell_size, raster.columns, raster.rows,
                     std::move(raster.heights));
  DeformableTerrain terrain(std::move(grid), soils.get("sandy_loam"), DeformableTerrain::Options{ true });
  const double build_s = seconds(t1);
  const double load_s = seconds(t0);
  const double rss_loaded = procStatusMb("VmRSS");
  const double peak_hwm = procStatusMb("VmHWM");
  const double peak_ru = maxRssMb();
  const double base_bytes = static_cast<double>(cols) * rows * sizeof(float);
  std::printf(
      "load: %.2f s (readGeoTiff %.2f s, fillNoData %.2f s for %zu void points (filled %zu), grid + "
      "terrain %.2f s)\n",
      load_s, read_s, fill_s, voids, filled, build_s);
  std::printf(
      "RSS: %.1f MB before, %.1f MB after reading (peak so far %.1f MB), %.1f MB loaded; peak %.1f MB "
      "(VmHWM) / %.1f MB (ru_maxrss)  (limit %.0f MB: %s)\n",
      rss_before, rss_read, peak_read, rss_loaded, peak_hwm, peak_ru, kPeakLimitMb,
      std::max(peak_hwm, peak_ru) < kPeakLimitMb ? "met" : "EXCEEDED");
  std::printf("base heights: %.1f MB (%zu B per point); deformation tile directory: %.1f MB (fixed)\n",
              base_bytes / 1e6, sizeof(float), terrain.directoryBytes() / 1e6);
  peak_mb = std::max(peak_hwm, peak_ru);
  return terrain;
}

/// The traverse over the loaded site: a 4-wheel vehicle (wheelbase 3.3 m, track 1.9 m) at 2 m/s,
/// 0.1 m a step, in lanes along x 5 m apart, each lane a fresh strip of ground; prints its
/// figures and returns the RSS growth, MB.
double traverseSite(DeformableTerrain& terrain, std::size_t cells_x, std::size_t cells_y, double km)
{
  const double rss_pre = procStatusMb("VmRSS");
  const double lane_length = cells_x * kCell - 10.0;
  const double length_m = 1000.0 * km;
  const double step = 0.1, dt = 0.05, speed = step / dt;
  auto t0 = Clock::now();
  double driven = 0.0;
  long contacts = 0;
  while (driven < length_m)
  {
    const int lane = static_cast<int>(driven / lane_length);
    const double x = 5.0 + std::fmod(driven, lane_length);
    const double y = 10.0 + 5.0 * lane;
    if (y > cells_y * kCell - 10.0)
      throw std::runtime_error("the site is too small for " + std::to_string(km) + " km of lanes");
    for (const double dxw : { 1.65, -1.65 })
      for (const double dyw : { 0.95, -0.95 })
        contacts += terrain.wheelContact(wheel(terrain, x + dxw, y + dyw, 0.03, speed), dt, true).contact_points;
    driven += step;
  }
  const double drive_s = seconds(t0);
  const double growth = procStatusMb("VmRSS") - rss_pre;
  const std::size_t deformed = terrain.deformedPoints();
  const std::size_t state = terrain.deformationBytes();
  std::printf(
      "traverse: %.1f km in %.1f s (%.0f wheel contacts, %.1f loaded points each); RSS growth %.1f MB "
      "(limit %.0f MB: %s)\n",
      km, drive_s, 4.0 * driven / step, contacts / (4.0 * driven / step), growth, kGrowthLimitMb,
      growth < kGrowthLimitMb ? "met" : "EXCEEDED");
  std::printf(
      "deformed points: %zu; deformation state %.2f MB = %.1f B per deformed point (tiles of %d x %d "
      "points, %zu B per point slot)\n",
      deformed, state / 1e6, static_cast<double>(state) / std::max<std::size_t>(deformed, 1),
      DeformableTerrain::kTileSize, DeformableTerrain::kTileSize, sizeof(PointDeformation));
  std::printf("peak RSS of the whole run: %.1f MB (VmHWM)\n", procStatusMb("VmHWM"));
  return growth;
}

}  // namespace

int main(int argc, char** argv)
{
  if (argc < 2 || argc == 4 || argc > 6)
  {
    std::fprintf(stderr, "usage: bench_site_scale SOILS.yaml [TEMP_DIR [CELLS_X CELLS_Y [KM]]]\n");
    return 2;
  }
  try
  {
    const SoilLibrary soils = SoilLibrary::load(argv[1]);
    const std::string temp_root = argc > 2 ? argv[2] : "/tmp";
    const std::size_t cells_x = argc > 4 ? parseCount(argv[3], "CELLS_X") : 11600;
    const std::size_t cells_y = argc > 4 ? parseCount(argv[4], "CELLS_Y") : 18800;
    char* km_end = nullptr;
    const double km = argc > 5 ? std::strtod(argv[5], &km_end) : 10.0;
    if (argc > 5 && (*km_end != '\0' || !(km > 0.0 && km <= 100.0)))
      throw std::invalid_argument(std::string("KM must be a number in (0, 100] (got '") + argv[5] + "')");
    const std::size_t cols = cells_x + 1, rows = cells_y + 1;

    TempSite site;
    std::string pattern = temp_root + "/avsp_site_scale_XXXXXX";
    if (::mkdtemp(pattern.data()) == nullptr)
      throw std::runtime_error("cannot create a directory under '" + temp_root + "': " + std::strerror(errno));
    site.dir = pattern;
    site.file = site.dir + "/site.tif";

    writeSiteInChild(site, cells_x, cells_y);
    double peak_mb = 0.0;
    DeformableTerrain terrain = loadSite(site.file, soils, cols, rows, peak_mb);
    const double growth = traverseSite(terrain, cells_x, cells_y, km);
    const bool ok = peak_mb < kPeakLimitMb && growth < kGrowthLimitMb;
    return ok ? 0 : 1;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_site_scale: %s\n", e.what());
    return 1;
  }
}
