#include "avsp_terrain/terrain_file.hpp"

#include "avsp_terrain/input_file.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <vector>

namespace avsp
{
namespace terrain
{
namespace
{
constexpr char kMagic[8] = { 'A', 'V', 'S', 'P', 'T', 'R', 'N', '1' };
/// 1: one soil name; 2: a palette of soil names and a soil map (1 is still read).
constexpr std::uint32_t kVersion = 2;
/// How the soil map is stored: one soil everywhere (nothing follows), or one byte per point.
constexpr std::uint8_t kUniformSoil = 0, kSoilPerPoint = 1;

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

/// Appends plain values to a byte buffer (the machines we run on are little-endian).
class Writer
{
public:
  template <class T>
  void put(const T& v)
  {
    static_assert(std::is_trivially_copyable<T>::value, "plain values only");
    const char* p = reinterpret_cast<const char*>(&v);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void putString(const std::string& s)
  {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  std::vector<char>& bytes() { return bytes_; }

private:
  std::vector<char> bytes_;
};

/// Reads plain values with bounds checks; every failure names the file.
class Reader
{
public:
  Reader(const std::string& bytes, std::size_t end, std::string path) : bytes_(bytes), end_(end), path_(std::move(path))
  {
  }
  [[noreturn]] void fail(const std::string& why) const { throw TerrainFileError(path_ + ": " + why); }
  template <class T>
  T get(const char* what)
  {
    if (end_ - pos_ < sizeof(T))
      fail(std::string("truncated while reading ") + what);
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string getString(const char* what)
  {
    const auto n = get<std::uint32_t>(what);
    if (n > 4096 || end_ - pos_ < n)
      fail(std::string("bad length while reading ") + what);
    std::string s(bytes_.data() + pos_, n);
    pos_ += n;
    return s;
  }
  std::size_t remaining() const { return end_ - pos_; }

private:
  const std::string& bytes_;
  std::size_t end_;
  std::size_t pos_ = sizeof(kMagic) + sizeof(std::uint32_t);
  std::string path_;
};
}  // namespace

void saveTerrain(const std::string& path, const DeformableTerrain& terrain, const ObjectSet& objects)
{
  const ElevationGrid& g = terrain.base();
  Writer w;
  w.bytes().insert(w.bytes().end(), kMagic, kMagic + sizeof(kMagic));
  w.put<std::uint32_t>(kVersion);
  w.put(g.originX());
  w.put(g.originY());
  w.put(g.dx());
  w.put(g.dy());
  w.put<std::uint64_t>(g.columns());
  w.put<std::uint64_t>(g.rows());
  w.put<std::uint32_t>(static_cast<std::uint32_t>(terrain.palette().size()));
  for (const SoilParameters& soil : terrain.palette())
    w.putString(soil.name);
  w.put<std::uint8_t>(terrain.options().transport ? 1 : 0);
  w.put(terrain.flowedVolume());
  w.put(terrain.arrivedVolume());
  for (std::size_t j = 0; j < g.rows(); ++j)
    for (std::size_t i = 0; i < g.columns(); ++i)
      w.put(static_cast<float>(g.pointHeight(i, j)));
  const bool uniform = terrain.palette().size() == 1;
  w.put<std::uint8_t>(uniform ? kUniformSoil : kSoilPerPoint);
  if (!uniform)
    for (std::size_t j = 0; j < g.rows(); ++j)
      for (std::size_t i = 0; i < g.columns(); ++i)
        w.put<std::uint8_t>(terrain.soilIndex(i, j));
  const auto points = terrain.statefulPoints();
  w.put<std::uint64_t>(points.size());
  for (const auto& [i, j] : points)
  {
    const PointDeformation d = terrain.deformation(i, j);
    w.put<std::uint64_t>(j * g.columns() + i);
    w.put(d.plastic);
    w.put(d.displaced);
    w.put(d.sigma_max);
  }
  w.put<std::uint64_t>(objects.size());
  for (const TerrainObject& o : objects.all())
  {
    w.put<std::uint8_t>(static_cast<std::uint8_t>(o.type));
    for (const double v :
         { o.x, o.y, o.yaw, o.length, o.width, o.height, o.strength, o.rolling_resistance, o.fall_direction })
      w.put(v);
    w.put<std::uint8_t>(o.toppled ? 1 : 0);
  }
  w.put(fnv1a(w.bytes().data(), w.bytes().size()));

  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    throw TerrainFileError(path + ": cannot open for writing");
  out.write(w.bytes().data(), static_cast<std::streamsize>(w.bytes().size()));
  out.close();  // the last buffered bytes are written here: a full disk shows now
  if (!out)
    throw TerrainFileError(path + ": write failed (disk full?)");
}

std::uint64_t maxTerrainFileBytes(std::uint64_t max_points)
{
  // Per point at most: a height (4), a soil index (1), a stateful point (index 8 + 3 floats).
  return (64u << 20) + 25u * max_points;
}

LoadedTerrain loadTerrain(const std::string& path, const SoilLibrary& soils, std::uint64_t max_points)
{
  std::string bytes;
  try
  {
    bytes = readInputFile(path, maxTerrainFileBytes(max_points),
                          "a terrain file of at most " + std::to_string(max_points) + " points (max_cells)");
  }
  catch (const InputFileRefused& e)
  {
    throw TerrainFileError(path + ": " + e.what());
  }
  const std::size_t header = sizeof(kMagic) + sizeof(std::uint32_t);
  if (bytes.size() < header + sizeof(std::uint64_t) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    throw TerrainFileError(path + ": not an AVSP terrain file (bad magic or too short)");
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + sizeof(kMagic), sizeof(version));
  if (version != 1 && version != kVersion)
    throw TerrainFileError(path + ": terrain file version " + std::to_string(version) +
                           " is not supported (1 and 2 are)");
  const std::size_t body = bytes.size() - sizeof(std::uint64_t);
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + body, sizeof(stored));
  if (fnv1a(bytes.data(), body) != stored)
    throw TerrainFileError(path + ": checksum mismatch (truncated or corrupted)");

  Reader r(bytes, body, path);
  const auto ox = r.get<double>("origin"), oy = r.get<double>("origin");
  const auto dx = r.get<double>("spacing"), dy = r.get<double>("spacing");
  const auto columns = r.get<std::uint64_t>("columns"), rows = r.get<std::uint64_t>("rows");
  if (columns >= 2 && rows >= 2 && columns <= (1ULL << 31) / rows && columns * rows > max_points)
    r.fail("grid of " + std::to_string(columns) + " x " + std::to_string(rows) + " points, more than max_cells " +
           std::to_string(max_points));
  if (columns < 2 || rows < 2 || columns > (1ULL << 31) / rows || r.remaining() / sizeof(float) < columns * rows)
    r.fail("grid size " + std::to_string(columns) + " x " + std::to_string(rows) + " does not fit the file");
  const std::uint32_t palette_size = version == 1 ? 1 : r.get<std::uint32_t>("palette size");
  if (palette_size < 1 || palette_size > DeformableTerrain::kMaxSoils)
    r.fail("palette of " + std::to_string(palette_size) + " soils (1 to 256 allowed)");
  std::vector<SoilParameters> palette;
  for (std::uint32_t k = 0; k < palette_size; ++k)
  {
    const std::string soil_name = r.getString("soil name");
    if (!soils.contains(soil_name))
      r.fail("soil '" + soil_name + "' is not in the soil library");
    palette.push_back(soils.get(soil_name));
  }
  const bool transport = r.get<std::uint8_t>("transport flag") != 0;
  const auto flowed = r.get<double>("flowed volume"), arrived = r.get<double>("arrived volume");
  std::vector<float> heights(columns * rows);
  for (float& h : heights)
    h = r.get<float>("heights");
  std::vector<std::uint8_t> soil_map(columns * rows, 0);
  const std::uint8_t map_kind = version == 1 ? kUniformSoil : r.get<std::uint8_t>("soil map kind");
  if (map_kind == kSoilPerPoint)
  {
    if (r.remaining() < soil_map.size())
      r.fail("truncated while reading the soil map");
    for (std::uint8_t& s : soil_map)
      s = r.get<std::uint8_t>("soil map");
  }
  else if (map_kind != kUniformSoil)
    r.fail("unknown soil map kind " + std::to_string(map_kind));
  std::optional<DeformableTerrain> terrain;
  try
  {
    terrain.emplace(ElevationGrid(ox, oy, dx, dy, columns, rows, std::move(heights)), std::move(palette),
                    std::move(soil_map), DeformableTerrain::Options{ transport });
  }
  catch (const std::invalid_argument& e)
  {
    r.fail(e.what());  // e.g. a soil index outside the palette
  }
  catch (const GridError& e)
  {
    r.fail(e.what());
  }
  LoadedTerrain out{ std::move(*terrain), ObjectSet() };
  const auto points = r.get<std::uint64_t>("point count");
  if (points > columns * rows)
    r.fail("more stateful points than grid points");
  for (std::uint64_t k = 0; k < points; ++k)
  {
    const auto index = r.get<std::uint64_t>("point index");
    if (index >= columns * rows)
      r.fail("point index outside the grid");
    PointDeformation d;
    d.plastic = r.get<float>("plastic");
    d.displaced = r.get<float>("displaced");
    d.sigma_max = r.get<float>("sigma_max");
    out.terrain.setDeformation(index % columns, index / columns, d);
  }
  out.terrain.setVolumes(flowed, arrived);
  const auto count = r.get<std::uint64_t>("object count");
  for (std::uint64_t k = 0; k < count; ++k)
  {
    TerrainObject o;
    const auto type = r.get<std::uint8_t>("object type");
    if (type > static_cast<std::uint8_t>(ObjectType::kBuilding))
      r.fail("unknown object type " + std::to_string(type));
    o.type = static_cast<ObjectType>(type);
    for (double* v :
         { &o.x, &o.y, &o.yaw, &o.length, &o.width, &o.height, &o.strength, &o.rolling_resistance, &o.fall_direction })
      *v = r.get<double>("object");
    o.toppled = r.get<std::uint8_t>("toppled flag") != 0;
    try
    {
      out.objects.add(o);
    }
    catch (const std::invalid_argument& e)
    {
      r.fail(std::string("object ") + std::to_string(k) + ": " + e.what());
    }
  }
  if (r.remaining() != 0)
    r.fail("unexpected bytes after the objects");
  return out;
}

}  // namespace terrain
}  // namespace avsp
