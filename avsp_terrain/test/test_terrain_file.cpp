// Save and load a deformed terrain with its objects bit-exactly; bad files name the file.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "avsp_terrain/terrain_file.hpp"

using namespace avsp::terrain;

namespace
{
const SoilLibrary& library()
{
  static const SoilLibrary lib = SoilLibrary::load(std::string(AVSP_CONFIG_DIR) + "/soils.yaml");
  return lib;
}

std::string scratchPath()
{
  char name[] = "/tmp/avsp_terrain_file_XXXXXX";
  const int fd = mkstemp(name);
  close(fd);
  return name;
}

/// A rutted patch of mud (with transport, so some points also received soil) and objects,
/// one of them toppled.
void makeScene(DeformableTerrain& t, ObjectSet& objects)
{
  for (double x = 1.0; x < 2.5; x += 0.004)
  {
    WheelPatch w;
    w.radius = 0.35;
    w.width = 0.25;
    w.centre = Eigen::Vector3d(x, 2.0, 0.35 - 0.04);
    w.velocity = Eigen::Vector3d(1.0, 0.0, 0.0);
    w.spin_rate = 1.3 / 0.35;
    t.wheelContact(w, 0.004, true);
  }
  TerrainObject shrub;
  shrub.type = ObjectType::kShrub;
  shrub.x = 3.0;
  shrub.y = 3.0;
  shrub.length = shrub.width = 0.8;
  shrub.height = 1.2;
  shrub.strength = 900.0;
  objects.push(objects.add(shrub), 1000.0, 0.7);
  TerrainObject rock = shrub;
  rock.type = ObjectType::kRock;
  rock.x = 0.5;
  rock.strength = std::numeric_limits<double>::infinity();
  objects.add(rock);
}

std::vector<char> bytesOf(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// FNV-1a 64 as the format specifies: lets a test write a file that is consistent but wrong.
std::uint64_t fnv1a(const char* data, std::size_t size)
{
  std::uint64_t h = 1469598103934665603ULL;
  for (std::size_t k = 0; k < size; ++k)
  {
    h ^= static_cast<unsigned char>(data[k]);
    h *= 1099511628211ULL;
  }
  return h;
}

/// Replaces the trailing checksum with the right one for the (edited) bytes before it.
void reseal(std::vector<char>& bytes)
{
  const std::size_t body = bytes.size() - sizeof(std::uint64_t);
  const std::uint64_t h = fnv1a(bytes.data(), body);
  std::memcpy(bytes.data() + body, &h, sizeof(h));
}

void writeBytes(const std::string& path, const std::vector<char>& bytes)
{
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
}

/// n x n points at 0.05 m on a bumpy base; three soils in diagonal bands.
DeformableTerrain multiSoil(std::size_t n)
{
  std::vector<float> h(n * n);
  std::vector<std::uint8_t> map(n * n);
  for (std::size_t k = 0; k < h.size(); ++k)
  {
    h[k] = 0.01f * static_cast<float>(k % 37);
    map[k] = static_cast<std::uint8_t>(((k % n) * 7 + (k / n) * 3) / 13 % 3);
  }
  return DeformableTerrain(ElevationGrid(0, 0, 0.05, 0.05, n, n, h),
                           paletteFromNames({ "sandy_loam", "mud", "clay" }, library()), std::move(map),
                           DeformableTerrain::Options{ true });
}
}  // namespace

TEST(TerrainFile, RoundTripIsBitExactIncludingToppledObjects)
{
  const std::size_t n = 100;
  std::vector<float> h(n * n);
  for (std::size_t k = 0; k < h.size(); ++k)
    h[k] = 0.01f * static_cast<float>(k % 37);
  DeformableTerrain t(ElevationGrid(0, 0, 0.05, 0.05, n, n, h), library().get("mud"),
                      DeformableTerrain::Options{ true });
  ObjectSet objects;
  makeScene(t, objects);
  ASSERT_GT(t.deformedPoints(), 100u);
  ASSERT_GT(t.arrivedVolume(), 0.0);

  const std::string path = scratchPath();
  saveTerrain(path, t, objects);
  const LoadedTerrain back = loadTerrain(path, library());
  for (std::size_t j = 0; j < n; ++j)
  {
    for (std::size_t i = 0; i < n; ++i)
    {
      const PointDeformation a = t.deformation(i, j), b = back.terrain.deformation(i, j);
      ASSERT_EQ(std::memcmp(&a, &b, sizeof(a)), 0) << i << "," << j;
      ASSERT_EQ(t.base().pointHeight(i, j), back.terrain.base().pointHeight(i, j));
    }
  }
  EXPECT_EQ(back.terrain.flowedVolume(), t.flowedVolume());
  EXPECT_EQ(back.terrain.arrivedVolume(), t.arrivedVolume());
  EXPECT_EQ(back.terrain.soil(0, 0).name, "mud");
  EXPECT_TRUE(back.terrain.options().transport);
  ASSERT_EQ(back.objects.size(), 2u);
  EXPECT_TRUE(back.objects.get(0).toppled);
  EXPECT_EQ(back.objects.get(0).fall_direction, 0.7);
  EXPECT_FALSE(back.objects.get(1).toppled);
  EXPECT_EQ(back.objects.get(1).strength, std::numeric_limits<double>::infinity());
  // Saving what was loaded gives the same bytes: nothing is lost or reordered.
  const std::string again = scratchPath();
  saveTerrain(again, back.terrain, back.objects);
  EXPECT_EQ(bytesOf(path), bytesOf(again));
  std::remove(path.c_str());
  std::remove(again.c_str());
}

TEST(TerrainFile, MultiSoilRoundTripIsBitExact)
{
  const std::size_t n = 100;
  DeformableTerrain t = multiSoil(n);
  ObjectSet objects;
  makeScene(t, objects);
  ASSERT_GT(t.deformedPoints(), 100u);
  const std::string path = scratchPath();
  saveTerrain(path, t, objects);
  const LoadedTerrain back = loadTerrain(path, library());
  ASSERT_EQ(back.terrain.palette().size(), 3u);
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_EQ(back.terrain.palette()[k].name, t.palette()[k].name);
  std::set<int> seen;
  for (std::size_t j = 0; j < n; ++j)
  {
    for (std::size_t i = 0; i < n; ++i)
    {
      ASSERT_EQ(back.terrain.soilIndex(i, j), t.soilIndex(i, j)) << i << "," << j;
      seen.insert(t.soilIndex(i, j));
      const PointDeformation a = t.deformation(i, j), b = back.terrain.deformation(i, j);
      ASSERT_EQ(std::memcmp(&a, &b, sizeof(a)), 0) << i << "," << j;
      ASSERT_EQ(t.base().pointHeight(i, j), back.terrain.base().pointHeight(i, j));
    }
  }
  EXPECT_EQ(seen.size(), 3u);
  EXPECT_EQ(back.terrain.flowedVolume(), t.flowedVolume());
  EXPECT_EQ(back.terrain.arrivedVolume(), t.arrivedVolume());
  // Saving what was loaded gives the same bytes, and the loaded terrain drives the same.
  const std::string again = scratchPath();
  saveTerrain(again, back.terrain, back.objects);
  EXPECT_EQ(bytesOf(path), bytesOf(again));
  LoadedTerrain resumed = loadTerrain(again, library());
  WheelPatch w;
  w.radius = 0.35;
  w.width = 0.25;
  w.centre = Eigen::Vector3d(2.2, 2.0, 0.35 + 0.3);
  w.velocity = Eigen::Vector3d(1.0, 0.0, 0.0);
  w.spin_rate = 1.2 / 0.35;
  for (double z = 0.36; z > 0.0; z -= 0.01)  // lower until it bears on the bumpy base
  {
    w.centre.z() = z;
    if (t.wheelContact(w, 0.01, false).contact_points > 20)
      break;
  }
  const ContactForces a = t.wheelContact(w, 0.01, true), b = resumed.terrain.wheelContact(w, 0.01, true);
  EXPECT_GT(a.contact_points, 20);
  EXPECT_EQ(a.normal_force, b.normal_force);
  EXPECT_EQ(a.longitudinal_force, b.longitudinal_force);
  std::remove(path.c_str());
  std::remove(again.c_str());
}

TEST(TerrainFile, SoilIndexOutsideThePaletteIsNamed)
{
  // A file whose checksum is right but whose soil map points past its palette.
  const std::size_t n = 12;
  DeformableTerrain t = multiSoil(n);
  const std::string path = scratchPath();
  saveTerrain(path, t, ObjectSet());
  std::vector<char> bytes = bytesOf(path);
  // The map is the n*n bytes after the heights; with no deformation and no objects only the
  // two counts (8 B each) and the checksum follow it.
  const std::size_t map_end = bytes.size() - 3 * sizeof(std::uint64_t);
  ASSERT_EQ(bytes[map_end - n * n - 1], 1) << "soil map kind byte not where expected";
  bytes[map_end - n * n + 5 * n + 4] = 9;  // point (4, 5)
  reseal(bytes);
  writeBytes(path, bytes);
  try
  {
    loadTerrain(path, library());
    ADD_FAILURE() << "loaded a soil index outside the palette";
  }
  catch (const TerrainFileError& e)
  {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("index 9 at grid point (4, 5) is not in the palette of 3"), std::string::npos)
        << e.what();
  }
  std::remove(path.c_str());
}

TEST(TerrainFile, VersionOneFilesStillLoad)
{
  // Version 1 as it was written before soil maps: one soil name, no map.
  const std::size_t n = 4;
  std::vector<char> bytes;
  const auto put = [&](const auto& v) {
    const char* p = reinterpret_cast<const char*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(v));
  };
  bytes.insert(bytes.end(), { 'A', 'V', 'S', 'P', 'T', 'R', 'N', '1' });
  put(std::uint32_t{ 1 });
  for (const double v : { 0.0, 0.0, 0.5, 0.5 })
    put(v);
  put(std::uint64_t{ n });
  put(std::uint64_t{ n });
  put(std::uint32_t{ 3 });
  bytes.insert(bytes.end(), { 'm', 'u', 'd' });
  put(std::uint8_t{ 1 });
  put(0.25);   // flowed
  put(0.125);  // arrived
  for (std::size_t k = 0; k < n * n; ++k)
    put(static_cast<float>(k));
  put(std::uint64_t{ 1 });  // one stateful point: (2, 1)
  put(std::uint64_t{ 1 * n + 2 });
  for (const float v : { 0.01f, -0.002f, 12345.f })
    put(v);
  put(std::uint64_t{ 0 });  // no objects
  put(std::uint64_t{ 0 });  // checksum placeholder
  reseal(bytes);
  const std::string path = scratchPath();
  writeBytes(path, bytes);
  const LoadedTerrain back = loadTerrain(path, library());
  ASSERT_EQ(back.terrain.palette().size(), 1u);
  EXPECT_EQ(back.terrain.soil(3, 3).name, "mud");
  EXPECT_EQ(back.terrain.base().pointHeight(3, 2), 11.f);
  EXPECT_EQ(back.terrain.deformation(2, 1).sigma_max, 12345.f);
  EXPECT_EQ(back.terrain.flowedVolume(), 0.25);
  EXPECT_TRUE(back.terrain.options().transport);
  std::remove(path.c_str());
}

TEST(TerrainFile, ResumingOnSavedRutsDrivesTheSame)
{
  // The same wheel pass after save+load gives the same forces as on the original.
  const std::size_t n = 80;
  DeformableTerrain t(ElevationGrid(0, 0, 0.05, 0.05, n, n, std::vector<float>(n * n, 0.f)), library().get("clay"),
                      DeformableTerrain::Options{ true });
  ObjectSet objects;
  makeScene(t, objects);
  const std::string path = scratchPath();
  saveTerrain(path, t, objects);
  LoadedTerrain back = loadTerrain(path, library());
  WheelPatch w;
  w.radius = 0.35;
  w.width = 0.25;
  w.centre = Eigen::Vector3d(1.8, 2.0, 0.35 - 0.06);
  w.velocity = Eigen::Vector3d(1.0, 0.0, 0.0);
  w.spin_rate = 1.2 / 0.35;
  const ContactForces a = t.wheelContact(w, 0.01, true);
  const ContactForces b = back.terrain.wheelContact(w, 0.01, true);
  EXPECT_EQ(a.normal_force, b.normal_force);
  EXPECT_EQ(a.longitudinal_force, b.longitudinal_force);
  EXPECT_EQ(t.pointHeight(36, 40), back.terrain.pointHeight(36, 40));
  std::remove(path.c_str());
}

TEST(TerrainFile, BadFilesNameTheFileAndReason)
{
  const std::size_t n = 20;
  DeformableTerrain t(ElevationGrid(0, 0, 0.1, 0.1, n, n, std::vector<float>(n * n, 1.f)), library().get("clay"),
                      DeformableTerrain::Options{ false });
  ObjectSet objects;
  const std::string path = scratchPath();
  saveTerrain(path, t, objects);
  const std::vector<char> good = bytesOf(path);
  const auto expectError = [&](const std::vector<char>& bytes, const char* reason) {
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
    try
    {
      loadTerrain(path, library());
      ADD_FAILURE() << "loaded: " << reason;
    }
    catch (const TerrainFileError& e)
    {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
  };
  expectError(std::vector<char>(good.begin(), good.begin() + good.size() / 2), "checksum");
  std::vector<char> flipped = good;
  flipped[100] ^= 0x10;
  expectError(flipped, "checksum");
  std::vector<char> magic = good;
  magic[0] = 'X';
  expectError(magic, "not an AVSP terrain file");
  std::vector<char> version = good;
  version[8] = 7;
  expectError(version, "version 7");
  expectError({}, "not an AVSP terrain file");
  std::remove(path.c_str());
  EXPECT_THROW(loadTerrain("/nonexistent/terrain.avsp", library()), TerrainFileError);
}

TEST(TerrainFile, UnknownSoilIsNamed)
{
  const std::size_t n = 10;
  SoilParameters lava = library().get("clay");
  lava.name = "lava";
  DeformableTerrain t(ElevationGrid(0, 0, 0.1, 0.1, n, n, std::vector<float>(n * n, 0.f)), lava,
                      DeformableTerrain::Options{ false });
  const std::string path = scratchPath();
  saveTerrain(path, t, ObjectSet());
  try
  {
    loadTerrain(path, library());
    ADD_FAILURE() << "loaded a terrain whose soil is not in the library";
  }
  catch (const TerrainFileError& e)
  {
    EXPECT_NE(std::string(e.what()).find("soil 'lava'"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

// Input files: a grid over the point budget is refused from its header, and only regular files
// are read (/dev/zero would read forever) — for the terrain file and for every YAML config.
TEST(TerrainFile, OnlyRegularFilesWithinThePointBudgetAreRead)
{
  const std::string path = scratchPath();
  saveTerrain(path, multiSoil(12), ObjectSet());
  auto error = [](const std::function<void()>& f) {
    try
    {
      f();
    }
    catch (const std::exception& e)
    {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error([&] { loadTerrain(path, library(), 143); }),
            path + ": grid of 12 x 12 points, more than max_cells 143");
  EXPECT_EQ(error([&] { loadTerrain(path, library(), 144); }), "no error");
  EXPECT_EQ(error([&] { loadTerrain("/dev/zero", library()); }),
            "/dev/zero: is a character device, not a regular file: refused without reading it");
  EXPECT_EQ(error([&] { loadTerrain("/tmp", library()); }),
            "/tmp: is a directory, not a regular file: refused without reading it");
  EXPECT_EQ(error([] { SoilLibrary::load("/dev/zero"); }),
            "/dev/zero: is a character device, not a regular file: refused without reading it");
  EXPECT_EQ(maxTerrainFileBytes(1000), (64u << 20) + 25000u);
  std::remove(path.c_str());
}
