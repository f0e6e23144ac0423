#include "avsp_terrain/default_course.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace avsp
{
namespace terrain
{
namespace
{
constexpr double kPi = 3.14159265358979323846;

// Soil indices into Course::soil_names; the names are those of config/soils.yaml.
enum SoilIndex : std::uint8_t
{
  kSandyLoam = 0,
  kGrassOverLoam,
  kGravel,
  kAsphalt,
  kMud,
  kDrySand,
  kClay,
  kSoilCount
};
const char* const kSoilNames[kSoilCount] = { "sandy_loam", "grass_over_loam", "gravel", "asphalt",
                                             "mud",        "dry_sand",        "clay" };

// Independent hash streams, so that e.g. adding a hills octave does not reshuffle the trees.
enum Stream : std::uint64_t
{
  kStreamHills0 = 1,
  kStreamHills1,
  kStreamHills2,
  kStreamSoilMottle,
  kStreamPatchWobble,
  kStreamBumps,
  kStreamWoods,
  kStreamWoodsGrass,
  kStreamScatter
};

// ---- Hills: three octaves of gradient noise (m of amplitude, m of wavelength). The sum
// stays within a few metres and below about 8 deg of slope (steeper where the
// rolling_hills gain applies).
constexpr double kHillsWavelength[3] = { 160.0, 70.0, 30.0 };
constexpr double kHillsAmplitude[3] = { 4.0, 1.6, 0.5 };
constexpr double kRollingHillsExtraGain = 0.6;  ///< hills x 1.6 inside rolling_hills
constexpr double kRollingHillsRamp = 15.0;      ///< m over which the gain fades out
constexpr double kSoilMottleWavelength = 60.0;  ///< m, sandy_loam / grass_over_loam patches

// ---- Feature sizes (m unless named otherwise). Positions are fractions of the extents.
constexpr double kRoadHalfWidth = 3.5;
constexpr double kRoadShoulder = 6.0;        ///< blend from the road level to the hills
constexpr double kRoadProfileWindow = 15.0;  ///< half window of the along-road smoothing
constexpr double kTrailHalfWidth = 1.75;
constexpr double kTrailShoulder = 4.0;
constexpr double kTrailProfileWindow = 10.0;
constexpr double kDitchLength = 40.0;
constexpr double kDitchDepth = 1.5;
constexpr double kDitchHalfWidth = 1.75;  ///< at the top of the walls
constexpr double kDitchBottomHalfWidth = 0.5;
constexpr double kDitchEndTaper = 3.0;  ///< depth ramps up over this at each end
constexpr double kDitchBank = 2.0;      ///< level bank beside each wall
constexpr double kDitchBlend = 3.0;
constexpr double kSlopeAngle_deg = 17.5;
constexpr double kSlopeLengthX = 40.0;
constexpr double kSlopeLengthY = 25.0;
constexpr double kSlopeBlend = 20.0;
constexpr double kRoughLengthX = 40.0;
constexpr double kRoughLengthY = 30.0;
constexpr double kBumpCell = 2.5;  ///< one bump per cell, so bumps never overlap
constexpr double kBumpMinHeight = 0.1, kBumpMaxHeight = 0.3;
constexpr double kBumpMinRadius = 0.6, kBumpMaxRadius = 1.1;
constexpr double kStagingLengthX = 50.0, kStagingLengthY = 36.0;
constexpr double kStagingBlend = 12.0;
constexpr double kBarrierGateSpacing = 12.0;
constexpr int kBarrierGates = 6;
constexpr double kBarrierLaneHalfWidth = 6.0;
constexpr double kBarrierBlend = 8.0;
constexpr double kFenceSegmentLength = 3.0;
constexpr int kFenceSegments = 12;
constexpr double kFenceStrength = 3500.0;  ///< N, chain-link panel torn off its poles
constexpr double kPoleStrength = 6000.0;   ///< N, thin steel line post bent over
constexpr double kPondSemiAxisX = 15.0, kPondSemiAxisY = 10.0;
constexpr double kPondDepth = 1.2;
constexpr double kPondRimEnd = 1.5;    ///< normalised radius up to which the rim is level
constexpr double kPondBlendEnd = 2.2;  ///< normalised radius where the hills take over
constexpr double kPatchWobble = 0.12;  ///< ragged edge of soil patches, normalised radius
// Small trees topple when the push reaches the bending strength of the trunk: modulus of
// rupture of green wood times the section modulus pi d^3 / 32, over the bumper height.
constexpr double kWoodModulusOfRupture = 40.0e6;  ///< Pa
constexpr double kPushLever = 0.6;                ///< m above the ground

// ---- Hashing: splitmix64's finaliser; integer-only, so identical on every platform.
std::uint64_t mix64(std::uint64_t z)
{
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::uint64_t hash(std::uint64_t seed, std::uint64_t stream, std::int64_t a, std::int64_t b)
{
  std::uint64_t h = mix64(seed ^ (stream * 0x9E3779B97F4A7C15ULL));
  h = mix64(h + static_cast<std::uint64_t>(a) * 0xD1B54A32D192ED03ULL);
  return mix64(h + static_cast<std::uint64_t>(b) * 0x8CB92BA72F3D8DD7ULL);
}

/// Uniform in [0, 1) from the top 53 bits.
double unitFromBits(std::uint64_t bits)
{
  return static_cast<double>(bits >> 11) * (1.0 / 9007199254740992.0);
}

/// A tiny counter-based generator (splitmix64): the same sequence everywhere, unlike the
/// <random> distributions.
class SplitMix
{
public:
  explicit SplitMix(std::uint64_t state) : state_(state) {}
  std::uint64_t next()
  {
    state_ += 0x9E3779B97F4A7C15ULL;
    return mix64(state_);
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unitFromBits(next()); }

private:
  std::uint64_t state_;
};

double clamp01(double t)
{
  return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
}

double smoothstep(double t)
{
  t = clamp01(t);
  return t * t * (3.0 - 2.0 * t);
}

/// Weight 1 at distance <= 0 from a flat zone, falling smoothly to 0 at `blend`.
double blendWeight(double distance, double blend)
{
  return distance <= 0.0 ? 1.0 : 1.0 - smoothstep(distance / blend);
}

/// (1 - w) a + w b: exactly b at w = 1, so flattened zones are exactly level.
double mixHeights(double a, double b, double w)
{
  return (1.0 - w) * a + w * b;
}

struct Box
{
  double min_x, min_y, max_x, max_y;
  Box grown(double m) const { return Box{ min_x - m, min_y - m, max_x + m, max_y + m }; }
  double centreX() const { return 0.5 * (min_x + max_x); }
  double centreY() const { return 0.5 * (min_y + max_y); }
  bool overlaps(const Box& o) const { return min_x < o.max_x && o.min_x < max_x && min_y < o.max_y && o.min_y < max_y; }
  /// Euclidean distance from (x, y) to the box, 0 inside.
  double distance(double x, double y) const
  {
    const double ox = std::max({ 0.0, min_x - x, x - max_x });
    const double oy = std::max({ 0.0, min_y - y, y - max_y });
    return std::sqrt(ox * ox + oy * oy);
  }
};

/**
 * 2-D gradient (Perlin) noise with one gradient per lattice node, precomputed over the
 * course so that a sample costs four dot products. Gradients come from a table of 16 unit
 * vectors written out, so no libm call decides the heights. Output within about +-0.71.
 */
class GradientNoise
{
public:
  GradientNoise(std::uint64_t seed, std::uint64_t stream, double wavelength, double extent_x, double extent_y)
    : inv_wavelength_(1.0 / wavelength),
      nx_(static_cast<std::size_t>(std::floor(extent_x / wavelength)) + 2),
      ny_(static_cast<std::size_t>(std::floor(extent_y / wavelength)) + 2),
      max_fx_(static_cast<double>(nx_ - 1)),
      max_fy_(static_cast<double>(ny_ - 1)),
      gradient_(nx_ * ny_)
  {
    static const double kDirections[16][2] = {
      { 1.0, 0.0 },
      { 0.9238795325112867, 0.3826834323650898 },
      { 0.7071067811865476, 0.7071067811865476 },
      { 0.3826834323650898, 0.9238795325112867 },
      { 0.0, 1.0 },
      { -0.3826834323650898, 0.9238795325112867 },
      { -0.7071067811865476, 0.7071067811865476 },
      { -0.9238795325112867, 0.3826834323650898 },
      { -1.0, 0.0 },
      { -0.9238795325112867, -0.3826834323650898 },
      { -0.7071067811865476, -0.7071067811865476 },
      { -0.3826834323650898, -0.9238795325112867 },
      { 0.0, -1.0 },
      { 0.3826834323650898, -0.9238795325112867 },
      { 0.7071067811865476, -0.7071067811865476 },
      { 0.9238795325112867, -0.3826834323650898 },
    };
    for (std::size_t j = 0; j < ny_; ++j)
      for (std::size_t i = 0; i < nx_; ++i)
      {
        const std::uint64_t h = hash(seed, stream, static_cast<std::int64_t>(i), static_cast<std::int64_t>(j));
        const double* d = kDirections[h >> 60];
        gradient_[j * nx_ + i] = { d[0], d[1] };
      }
  }

  double at(double x, double y) const
  {
    // Clamped into the lattice: callers stay on the course, this only guards rounding.
    const double fx = std::min(std::max(x * inv_wavelength_, 0.0), max_fx_);
    const double fy = std::min(std::max(y * inv_wavelength_, 0.0), max_fy_);
    const std::size_t i = std::min(static_cast<std::size_t>(fx), nx_ - 2);
    const std::size_t j = std::min(static_cast<std::size_t>(fy), ny_ - 2);
    const double tx = fx - static_cast<double>(i), ty = fy - static_cast<double>(j);
    const auto dot = [&](std::size_t gi, std::size_t gj, double ox, double oy) {
      const Gradient& g = gradient_[gj * nx_ + gi];
      return g.x * ox + g.y * oy;
    };
    const double n00 = dot(i, j, tx, ty), n10 = dot(i + 1, j, tx - 1.0, ty);
    const double n01 = dot(i, j + 1, tx, ty - 1.0), n11 = dot(i + 1, j + 1, tx - 1.0, ty - 1.0);
    const double u = fade(tx), v = fade(ty);
    const double a = n00 + u * (n10 - n00), b = n01 + u * (n11 - n01);
    return a + v * (b - a);
  }

  /// Precomputes the column terms of accumulateRow() for grid points x = i * cell.
  void prepareColumns(std::size_t columns, double cell)
  {
    column_cell_.resize(columns);
    column_t_.resize(columns);
    column_fade_.resize(columns);
    for (std::size_t c = 0; c < columns; ++c)
    {
      const double fx = std::min(std::max(static_cast<double>(c) * cell * inv_wavelength_, 0.0), max_fx_);
      const std::size_t i = std::min(static_cast<std::size_t>(fx), nx_ - 2);
      column_cell_[c] = i;
      column_t_[c] = fx - static_cast<double>(i);
      column_fade_[c] = fade(column_t_[c]);
    }
  }

  /**
   * out[c] += amplitude * at(c * cell, y) for every prepared column: the same arithmetic as
   * at(), with the per-column and per-row terms hoisted out of the loop over 24 M points.
   */
  void accumulateRow(double y, double amplitude, double* out) const
  {
    const double fy = std::min(std::max(y * inv_wavelength_, 0.0), max_fy_);
    const std::size_t j = std::min(static_cast<std::size_t>(fy), ny_ - 2);
    const double ty = fy - static_cast<double>(j), v = fade(ty);
    const Gradient* south = gradient_.data() + j * nx_;
    const Gradient* north = south + nx_;
    const std::size_t* cells = column_cell_.data();
    const double* ts = column_t_.data();
    const double* fades = column_fade_.data();
    const std::size_t n = column_cell_.size();
    for (std::size_t c = 0; c < n; ++c)
    {
      const std::size_t i = cells[c];
      const double tx = ts[c], u = fades[c];
      const double n00 = south[i].x * tx + south[i].y * ty;
      const double n10 = south[i + 1].x * (tx - 1.0) + south[i + 1].y * ty;
      const double n01 = north[i].x * tx + north[i].y * (ty - 1.0);
      const double n11 = north[i + 1].x * (tx - 1.0) + north[i + 1].y * (ty - 1.0);
      const double a = n00 + u * (n10 - n00), b = n01 + u * (n11 - n01);
      out[c] += amplitude * (a + v * (b - a));
    }
  }

private:
  struct Gradient
  {
    double x, y;
  };
  /// Quintic fade: continuous slope and curvature across lattice lines.
  static double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

  double inv_wavelength_;
  std::size_t nx_, ny_;
  double max_fx_, max_fy_;
  std::vector<Gradient> gradient_;
  std::vector<std::size_t> column_cell_;  ///< lattice column of each grid column
  std::vector<double> column_t_;          ///< position within it, [0, 1]
  std::vector<double> column_fade_;       ///< fade(column_t_)
};

/// Inclusive range of grid indices; empty when i0 > i1 or j0 > j1.
struct IndexBox
{
  std::size_t i0, i1, j0, j1;
  bool empty;
};

/// Where the features go, from the grid's extents only (never from the seed).
struct Layout
{
  Box road, trail, staging, pad, barriers, side_slope, rolling_hills, woods, ditch, pond, sand, clay, rough, fence;
  std::vector<Box> buildings;  ///< footprints (yaw 0) in the staging area
};

Layout makeLayout(double X, double Y)
{
  Layout l;
  const double road_y = 0.5 * Y;
  l.road = Box{ 0.0, road_y - kRoadHalfWidth, X, road_y + kRoadHalfWidth };
  // North half: staging area by the road, barrier lane east of it, side slope further east,
  // rolling hills in the north-east, woods along the north edge.
  const double sx = 0.04 * X, sy = road_y + 14.0;
  l.staging = Box{ sx, sy, sx + kStagingLengthX, sy + kStagingLengthY };
  l.pad = Box{ sx + 4.0, sy + 4.0, sx + 24.0, sy + 18.0 };
  l.buildings = { Box{ sx + 29.0, sy + 4.5, sx + 43.0, sy + 13.5 }, Box{ sx + 32.0, sy + 21.0, sx + 42.0, sy + 31.0 },
                  Box{ sx + 7.0, sy + 24.5, sx + 19.0, sy + 31.5 } };
  const double bx = l.staging.max_x + 20.0, by = road_y + 20.0;
  l.barriers =
      Box{ bx, by - kBarrierLaneHalfWidth, bx + kBarrierGates * kBarrierGateSpacing, by + kBarrierLaneHalfWidth };
  l.side_slope = Box{ 0.62 * X, 0.675 * Y, 0.62 * X + kSlopeLengthX, 0.675 * Y + kSlopeLengthY };
  l.rolling_hills = Box{ 0.84 * X, 0.6 * Y, 0.98 * X, 0.97 * Y };
  l.woods = Box{ 0.04 * X, 0.8 * Y, l.side_slope.min_x - 24.0, 0.98 * Y };
  // South half: ditch and sand in the west, pond, rough patch and fence in the middle, clay,
  // and the trail running north to the road in the east.
  l.ditch = Box{ 0.08 * X, 0.3 * Y - kDitchHalfWidth, 0.08 * X + kDitchLength, 0.3 * Y + kDitchHalfWidth };
  l.pond =
      Box{ 0.35 * X - kPondSemiAxisX, 0.2 * Y - kPondSemiAxisY, 0.35 * X + kPondSemiAxisX, 0.2 * Y + kPondSemiAxisY };
  const double patch_scale = 1.0 + kPatchWobble;  // the ragged edge reaches this far out
  l.sand = Box{ 0.2 * X - 12.0 * patch_scale, 0.1 * Y - 9.0 * patch_scale, 0.2 * X + 12.0 * patch_scale,
                0.1 * Y + 9.0 * patch_scale };
  l.clay = Box{ 0.75 * X - 12.0 * patch_scale, 0.12 * Y - 9.0 * patch_scale, 0.75 * X + 12.0 * patch_scale,
                0.12 * Y + 9.0 * patch_scale };
  l.rough = Box{ 0.55 * X, 0.1 * Y, 0.55 * X + kRoughLengthX, 0.1 * Y + kRoughLengthY };
  l.fence = Box{ 0.55 * X, 0.38 * Y - 0.5, 0.55 * X + kFenceSegments * kFenceSegmentLength, 0.38 * Y + 0.5 };
  const double tx = 0.88 * X;
  l.trail = Box{ tx - kTrailHalfWidth, 0.03 * Y, tx + kTrailHalfWidth, l.road.min_y };
  return l;
}

class CourseBuilder
{
public:
  CourseBuilder(const CourseOptions& o, std::size_t columns, std::size_t rows)
    : seed_(o.seed),
      cell_(o.cell_size),
      columns_(columns),
      rows_(rows),
      extent_x_(static_cast<double>(columns - 1) * o.cell_size),
      extent_y_(static_cast<double>(rows - 1) * o.cell_size),
      margin_(std::max(1.0, 2.0 * o.cell_size)),
      layout_(makeLayout(extent_x_, extent_y_)),
      hills_{ GradientNoise(seed_, kStreamHills0, kHillsWavelength[0], extent_x_, extent_y_),
              GradientNoise(seed_, kStreamHills1, kHillsWavelength[1], extent_x_, extent_y_),
              GradientNoise(seed_, kStreamHills2, kHillsWavelength[2], extent_x_, extent_y_) },
      mottle_(seed_, kStreamSoilMottle, kSoilMottleWavelength, extent_x_, extent_y_),
      wobble_(seed_, kStreamPatchWobble, 8.0, extent_x_, extent_y_),
      heights_(columns * rows),
      soil_(columns * rows)
  {
  }

  Course build()
  {
    groundAndSoil();
    soilPatch(layout_.sand, kDrySand);
    soilPatch(layout_.clay, kClay);
    roughPatch();
    ditch();
    pond();
    sideSlope();
    flatArea(layout_.staging, kStagingBlend);
    paintSoil(layout_.staging, kGravel);
    paintSoil(layout_.pad, kAsphalt);
    flatArea(layout_.barriers, kBarrierBlend);
    trail();
    road();  // last: its level zone wins where the trail and the yards' blends meet it

    ObjectSet objects;
    structures(objects);
    woods(objects);
    scatter(objects);

    std::vector<std::string> names(kSoilNames, kSoilNames + kSoilCount);
    const Layout& l = layout_;
    std::vector<CourseFeature> features = {
      feature("rolling_hills", l.rolling_hills),
      feature("ditch", l.ditch),
      feature("side_slope", l.side_slope),
      feature("rough_patch", l.rough),
      feature("dirt_trail", l.trail),
      feature("road", l.road),
      feature("staging_area", l.staging),
      feature("barrier_course", l.barriers),
      feature("fence_line", l.fence),
      feature("pond", l.pond),
      feature("woods", l.woods),
      feature("concrete_pad", l.pad),
      feature("sand_patch", l.sand),
      feature("clay_patch", l.clay),
    };
    return Course{ ElevationGrid(0.0, 0.0, cell_, cell_, columns_, rows_, std::move(heights_)), std::move(names),
                   std::move(soil_), std::move(objects), std::move(features) };
  }

private:
  static CourseFeature feature(const char* name, const Box& b)
  {
    return CourseFeature{ name, b.min_x, b.min_y, b.max_x, b.max_y };
  }

  double x(std::size_t i) const { return static_cast<double>(i) * cell_; }
  double y(std::size_t j) const { return static_cast<double>(j) * cell_; }
  std::size_t index(std::size_t i, std::size_t j) const { return j * columns_ + i; }

  /// Grid points inside the box (edges included), clipped to the grid.
  IndexBox indexBox(const Box& b) const
  {
    const double max_i = static_cast<double>(columns_ - 1), max_j = static_cast<double>(rows_ - 1);
    const double fi0 = std::max(0.0, std::ceil(b.min_x / cell_ - 1e-9));
    const double fi1 = std::min(max_i, std::floor(b.max_x / cell_ + 1e-9));
    const double fj0 = std::max(0.0, std::ceil(b.min_y / cell_ - 1e-9));
    const double fj1 = std::min(max_j, std::floor(b.max_y / cell_ + 1e-9));
    if (fi0 > fi1 || fj0 > fj1)
      return IndexBox{ 0, 0, 0, 0, true };
    return IndexBox{ static_cast<std::size_t>(fi0), static_cast<std::size_t>(fi1), static_cast<std::size_t>(fj0),
                     static_cast<std::size_t>(fj1), false };
  }

  /// Hills x the rolling_hills gain: the ground every feature starts from, m.
  double hills(double px, double py) const
  {
    double h = 0.0;
    for (int k = 0; k < 3; ++k)
      h += kHillsAmplitude[k] * hills_[k].at(px, py);
    return h * hillsGain(px, py);
  }

  double hillsGain(double px, double py) const
  {
    return 1.0 + kRollingHillsExtraGain * blendWeight(layout_.rolling_hills.distance(px, py), kRollingHillsRamp);
  }

  /// The pass over every grid point, row by row so the noise's column terms are reused.
  void groundAndSoil()
  {
    for (GradientNoise& n : hills_)
      n.prepareColumns(columns_, cell_);
    mottle_.prepareColumns(columns_, cell_);
    const Box gain_zone = layout_.rolling_hills.grown(kRollingHillsRamp);
    std::vector<double> hills_row(columns_), mottle_row(columns_);
    for (std::size_t j = 0; j < rows_; ++j)
    {
      const double py = y(j);
      std::fill(hills_row.begin(), hills_row.end(), 0.0);
      std::fill(mottle_row.begin(), mottle_row.end(), 0.0);
      for (int k = 0; k < 3; ++k)
        hills_[k].accumulateRow(py, kHillsAmplitude[k], hills_row.data());
      mottle_.accumulateRow(py, 1.0, mottle_row.data());
      // The gain is 1 away from rolling_hills; only its neighbourhood pays for the distance.
      if (py >= gain_zone.min_y && py <= gain_zone.max_y)
        for (std::size_t i = 0; i < columns_; ++i)
          if (x(i) >= gain_zone.min_x && x(i) <= gain_zone.max_x)
            hills_row[i] *= hillsGain(x(i), py);
      float* heights = heights_.data() + j * columns_;
      std::uint8_t* soil = soil_.data() + j * columns_;
      const double* h = hills_row.data();
      const double* m = mottle_row.data();
      for (std::size_t i = 0; i < columns_; ++i)
      {
        heights[i] = static_cast<float>(h[i]);
        soil[i] = m[i] > 0.0 ? kGrassOverLoam : kSandyLoam;
      }
    }
  }

  /// An elliptic patch inscribed in the box shrunk by the wobble, with a ragged noisy edge.
  void soilPatch(const Box& b, SoilIndex soil)
  {
    const double cx = b.centreX(), cy = b.centreY();
    const double ax = 0.5 * (b.max_x - b.min_x) / (1.0 + kPatchWobble);
    const double ay = 0.5 * (b.max_y - b.min_y) / (1.0 + kPatchWobble);
    const IndexBox r = indexBox(b);
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
      for (std::size_t i = r.i0; i <= r.i1; ++i)
      {
        const double qx = (x(i) - cx) / ax, qy = (y(j) - cy) / ay;
        const double q = std::sqrt(qx * qx + qy * qy);
        // |noise| <= 0.71 < 1, so the patch never reaches the box edge.
        if (q < 1.0 + kPatchWobble * wobble_.at(x(i), y(j)))
          soil_[index(i, j)] = soil;
      }
  }

  void paintSoil(const Box& b, SoilIndex soil)
  {
    const IndexBox r = indexBox(b);
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
      for (std::size_t i = r.i0; i <= r.i1; ++i)
        soil_[index(i, j)] = soil;
  }

  /// One bump per kBumpCell square, entirely inside it, so heights stay 0.1-0.3 m above the
  /// hills and bumps never pile up.
  void roughPatch()
  {
    const Box& b = layout_.rough;
    const int nx = static_cast<int>(std::floor((b.max_x - b.min_x) / kBumpCell + 1e-9));
    const int ny = static_cast<int>(std::floor((b.max_y - b.min_y) / kBumpCell + 1e-9));
    for (int cj = 0; cj < ny; ++cj)
      for (int ci = 0; ci < nx; ++ci)
      {
        SplitMix rng(hash(seed_, kStreamBumps, ci, cj));
        const double height = rng.uniform(kBumpMinHeight, kBumpMaxHeight);
        const double radius = rng.uniform(kBumpMinRadius, kBumpMaxRadius);
        const double cx = b.min_x + ci * kBumpCell + rng.uniform(radius, kBumpCell - radius);
        const double cy = b.min_y + cj * kBumpCell + rng.uniform(radius, kBumpCell - radius);
        const IndexBox r = indexBox(Box{ cx - radius, cy - radius, cx + radius, cy + radius });
        if (r.empty)
          continue;
        for (std::size_t j = r.j0; j <= r.j1; ++j)
          for (std::size_t i = r.i0; i <= r.i1; ++i)
          {
            const double dx = x(i) - cx, dy = y(j) - cy;
            const double d = std::sqrt(dx * dx + dy * dy);
            if (d < radius)
              heights_[index(i, j)] += static_cast<float>(height * (1.0 - smoothstep(d / radius)));
          }
      }
  }

  /// A level corridor along x (banks level across at the hills' height on the centre line),
  /// with a flat-bottomed trench cut into it; the depth ramps in over the ends.
  void ditch()
  {
    const Box& b = layout_.ditch;
    const double yc = b.centreY();
    const double level_half = kDitchHalfWidth + kDitchBank;
    const Box zone{ b.min_x - kDitchBlend - 2.0, yc - level_half - kDitchBlend, b.max_x + kDitchBlend + 2.0,
                    yc + level_half + kDitchBlend };
    const IndexBox r = indexBox(zone);
    if (r.empty)
      return;
    for (std::size_t i = r.i0; i <= r.i1; ++i)
    {
      const double px = x(i);
      const double ref = hills(px, yc);
      const double along = blendWeight(std::max(b.min_x - 2.0 - px, px - b.max_x - 2.0), kDitchBlend);
      const double taper = smoothstep(std::min(px - b.min_x, b.max_x - px) / kDitchEndTaper);
      for (std::size_t j = r.j0; j <= r.j1; ++j)
      {
        const double across = std::abs(y(j) - yc);
        const double w = along * blendWeight(across - level_half, kDitchBlend);
        double h = mixHeights(heights_[index(i, j)], ref, w);
        if (across < kDitchHalfWidth)
          h -= kDitchDepth * taper *
               (1.0 - smoothstep((across - kDitchBottomHalfWidth) / (kDitchHalfWidth - kDitchBottomHalfWidth)));
        heights_[index(i, j)] = static_cast<float>(h);
      }
    }
  }

  /// Elliptic hollow of mud below a level rim at the hills' height at its centre.
  void pond()
  {
    const Box& b = layout_.pond;
    const double cx = b.centreX(), cy = b.centreY();
    const double level = hills(cx, cy);
    const IndexBox r = indexBox(Box{ cx - kPondBlendEnd * kPondSemiAxisX, cy - kPondBlendEnd * kPondSemiAxisY,
                                     cx + kPondBlendEnd * kPondSemiAxisX, cy + kPondBlendEnd * kPondSemiAxisY });
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
      for (std::size_t i = r.i0; i <= r.i1; ++i)
      {
        const double qx = (x(i) - cx) / kPondSemiAxisX, qy = (y(j) - cy) / kPondSemiAxisY;
        const double q2 = qx * qx + qy * qy;
        const double q = std::sqrt(q2);
        if (q >= kPondBlendEnd)
          continue;
        // (1 - q^2)^2: deepest at the centre, meets the rim with zero slope.
        const double target = q < 1.0 ? level - kPondDepth * (1.0 - q2) * (1.0 - q2) : level;
        const double w = blendWeight(q - kPondRimEnd, kPondBlendEnd - kPondRimEnd);
        heights_[index(i, j)] = static_cast<float>(mixHeights(heights_[index(i, j)], target, w));
        if (q <= 1.1)
          soil_[index(i, j)] = kMud;
      }
  }

  /// A plane rising northwards; exact over the region grown by margin_, so every cell that
  /// touches the region is planar; held level beyond its edges and blended into the hills.
  void sideSlope()
  {
    const Box& b = layout_.side_slope;
    const Box exact = b.grown(margin_);
    const double level = hills(b.centreX(), b.centreY());
    const double grade = std::tan(kSlopeAngle_deg * kPi / 180.0);
    const IndexBox r = indexBox(exact.grown(kSlopeBlend));
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
    {
      const double py = y(j);
      const double plane = level + grade * (std::min(std::max(py, exact.min_y), exact.max_y) - b.centreY());
      for (std::size_t i = r.i0; i <= r.i1; ++i)
      {
        const double w = blendWeight(exact.distance(x(i), py), kSlopeBlend);
        heights_[index(i, j)] = static_cast<float>(mixHeights(heights_[index(i, j)], plane, w));
      }
    }
  }

  /// Level at the hills' height at the box centre over the box grown by margin_.
  void flatArea(const Box& b, double blend)
  {
    const Box level_zone = b.grown(margin_);
    const double level = hills(b.centreX(), b.centreY());
    const IndexBox r = indexBox(level_zone.grown(blend));
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
      for (std::size_t i = r.i0; i <= r.i1; ++i)
      {
        const double w = blendWeight(level_zone.distance(x(i), y(j)), blend);
        heights_[index(i, j)] = static_cast<float>(mixHeights(heights_[index(i, j)], level, w));
      }
  }

  /// Moving average (half window `window` m) of the hills sampled along a line; prefix sums
  /// in one fixed order, so the result is reproducible.
  std::vector<double> smoothedProfile(const std::vector<double>& samples, double window) const
  {
    const std::size_t n = samples.size();
    std::vector<double> prefix(n + 1, 0.0);
    for (std::size_t k = 0; k < n; ++k)
      prefix[k + 1] = prefix[k] + samples[k];
    const std::size_t half = static_cast<std::size_t>(std::floor(window / cell_));
    std::vector<double> out(n);
    for (std::size_t k = 0; k < n; ++k)
    {
      const std::size_t lo = k >= half ? k - half : 0, hi = std::min(n - 1, k + half);
      out[k] = (prefix[hi + 1] - prefix[lo]) / static_cast<double>(hi - lo + 1);
    }
    return out;
  }

  /// Gravel trail along y: level across at the smoothed hills on its centre line.
  void trail()
  {
    const Box& b = layout_.trail;
    const double xc = b.centreX();
    std::vector<double> samples(rows_);
    for (std::size_t j = 0; j < rows_; ++j)
      samples[j] = hills(xc, y(j));
    const std::vector<double> profile = smoothedProfile(samples, kTrailProfileWindow);
    const double level_half = kTrailHalfWidth + margin_;
    const IndexBox r = indexBox(Box{ xc - level_half - kTrailShoulder, b.min_y - kTrailShoulder,
                                     xc + level_half + kTrailShoulder, b.max_y + margin_ });
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
    {
      const double py = y(j);
      const double along = blendWeight(b.min_y - py, kTrailShoulder);
      for (std::size_t i = r.i0; i <= r.i1; ++i)
      {
        const double across = std::abs(x(i) - xc);
        const double w = along * blendWeight(across - level_half, kTrailShoulder);
        heights_[index(i, j)] = static_cast<float>(mixHeights(heights_[index(i, j)], profile[j], w));
        if (across <= kTrailHalfWidth + 1e-9 && py >= b.min_y - 1e-9)
          soil_[index(i, j)] = kGravel;
      }
    }
  }

  /// Asphalt road along x over the whole course: level across at the smoothed hills on its
  /// centre line.
  void road()
  {
    const Box& b = layout_.road;
    const double yc = b.centreY();
    std::vector<double> samples(columns_);
    for (std::size_t i = 0; i < columns_; ++i)
      samples[i] = hills(x(i), yc);
    const std::vector<double> profile = smoothedProfile(samples, kRoadProfileWindow);
    const double level_half = kRoadHalfWidth + margin_;
    const IndexBox r =
        indexBox(Box{ 0.0, yc - level_half - kRoadShoulder, extent_x_, yc + level_half + kRoadShoulder });
    if (r.empty)
      return;
    for (std::size_t j = r.j0; j <= r.j1; ++j)
    {
      const double across = std::abs(y(j) - yc);
      const double w = blendWeight(across - level_half, kRoadShoulder);
      const bool paved = across <= kRoadHalfWidth + 1e-9;
      for (std::size_t i = r.i0; i <= r.i1; ++i)
      {
        heights_[index(i, j)] = static_cast<float>(mixHeights(heights_[index(i, j)], profile[i], w));
        if (paved)
          soil_[index(i, j)] = kAsphalt;
      }
    }
  }

  static TerrainObject makeObject(ObjectType type, double px, double py, double length, double width, double height,
                                  double strength, double yaw = 0.0)
  {
    TerrainObject o;
    o.type = type;
    o.x = px;
    o.y = py;
    o.yaw = yaw;
    o.length = length;
    o.width = width;
    o.height = height;
    o.strength = strength;
    return o;
  }

  /// Buildings, barriers, fence: fixed placement, independent of the seed.
  void structures(ObjectSet& objects) const
  {
    const double rigid = std::numeric_limits<double>::infinity();
    const double building_height[3] = { 6.0, 4.5, 3.5 };
    for (std::size_t k = 0; k < layout_.buildings.size(); ++k)
    {
      const Box& f = layout_.buildings[k];
      objects.add(makeObject(ObjectType::kBuilding, f.centreX(), f.centreY(), f.max_x - f.min_x, f.max_y - f.min_y,
                             building_height[k % 3], rigid));
    }
    // Slalom: each gate is two 3 m barriers end to end across the lane, from 0.5 m short of
    // one edge to 0.5 m past the centre line, alternating sides, so a vehicle weaves
    // through 5.5 m gaps.
    const Box& lane = layout_.barriers;
    const double lane_y = lane.centreY();
    for (int g = 0; g < kBarrierGates; ++g)
    {
      const double gx = lane.min_x + (g + 0.5) * kBarrierGateSpacing;
      const double side = g % 2 == 0 ? 1.0 : -1.0;
      for (int k = 0; k < 2; ++k)
      {
        const double offset = -0.5 + 1.5 + 3.0 * k;  // centres 1.0 and 4.0 m from the centre line
        objects.add(makeObject(ObjectType::kBarrier, gx, lane_y + side * offset, 3.0, 0.6, 0.81, rigid, 0.5 * kPi));
      }
    }
    // Fence: poles at every joint, panels between them.
    const Box& fence = layout_.fence;
    const double fence_y = fence.centreY();
    const double pole_size = 0.08;
    for (int k = 0; k <= kFenceSegments; ++k)
      objects.add(makeObject(ObjectType::kPole, fence.min_x + k * kFenceSegmentLength, fence_y, pole_size, pole_size,
                             2.1, kPoleStrength));
    for (int k = 0; k < kFenceSegments; ++k)
      objects.add(makeObject(ObjectType::kFence, fence.min_x + (k + 0.5) * kFenceSegmentLength, fence_y,
                             kFenceSegmentLength - pole_size, 0.05, 1.8, kFenceStrength));
  }

  TerrainObject largeTree(SplitMix& rng, double px, double py) const
  {
    const double d = rng.uniform(0.3, 0.7);
    return makeObject(ObjectType::kTree, px, py, d, d, rng.uniform(10.0, 22.0),
                      std::numeric_limits<double>::infinity());
  }

  TerrainObject smallTree(SplitMix& rng, double px, double py) const
  {
    const double d = rng.uniform(0.06, 0.16);
    const double strength = kWoodModulusOfRupture * kPi * d * d * d / 32.0 / kPushLever;
    return makeObject(ObjectType::kTree, px, py, d, d, rng.uniform(3.0, 8.0), strength);
  }

  TerrainObject shrub(SplitMix& rng, double px, double py) const
  {
    const double size = rng.uniform(0.8, 2.0);
    return makeObject(ObjectType::kShrub, px, py, size, size * rng.uniform(0.7, 1.0), rng.uniform(0.5, 2.0),
                      rng.uniform(300.0, 1500.0));
  }

  TerrainObject rock(SplitMix& rng, double px, double py) const
  {
    const double length = rng.uniform(0.4, 1.5);
    return makeObject(ObjectType::kRock, px, py, length, length * rng.uniform(0.6, 1.0), rng.uniform(0.2, 0.8),
                      std::numeric_limits<double>::infinity(), rng.uniform(0.0, kPi));
  }

  /// Grass: strength 0, so any push flattens it; it only adds rolling resistance.
  TerrainObject grass(SplitMix& rng, double px, double py) const
  {
    TerrainObject o = makeObject(ObjectType::kGrass, px, py, rng.uniform(3.0, 6.0), rng.uniform(3.0, 6.0),
                                 rng.uniform(0.3, 0.8), 0.0, rng.uniform(0.0, kPi));
    o.rolling_resistance = rng.uniform(0.05, 0.1);
    return o;
  }

  /// Woods: one object per 5 m cell jittered inside it (centres >= 2.5 m apart, so trunks
  /// and shrubs do not overlap), grass patches on a coarser lattice.
  void woods(ObjectSet& objects) const
  {
    const Box& b = layout_.woods;
    const double cell = 5.0;
    const int nx = static_cast<int>(std::floor((b.max_x - b.min_x) / cell));
    const int ny = static_cast<int>(std::floor((b.max_y - b.min_y) / cell));
    for (int cj = 0; cj < ny; ++cj)
      for (int ci = 0; ci < nx; ++ci)
      {
        SplitMix rng(hash(seed_, kStreamWoods, ci, cj));
        const double pick = rng.uniform(0.0, 1.0);
        const double px = b.min_x + ci * cell + rng.uniform(1.25, 3.75);
        const double py = b.min_y + cj * cell + rng.uniform(1.25, 3.75);
        if (pick < 0.30)
          objects.add(largeTree(rng, px, py));
        else if (pick < 0.55)
          objects.add(smallTree(rng, px, py));
        else if (pick < 0.80)
          objects.add(shrub(rng, px, py));
        else if (pick < 0.90)
          objects.add(rock(rng, px, py));
      }
    const double grass_cell = 12.0;
    const int gx = static_cast<int>(std::floor((b.max_x - b.min_x) / grass_cell));
    const int gy = static_cast<int>(std::floor((b.max_y - b.min_y) / grass_cell));
    for (int cj = 0; cj < gy; ++cj)
      for (int ci = 0; ci < gx; ++ci)
      {
        SplitMix rng(hash(seed_, kStreamWoodsGrass, ci, cj));
        if (rng.uniform(0.0, 1.0) >= 0.6)
          continue;
        // Centre >= 4.5 m from the cell edge: a patch (half diagonal <= 4.3 m) stays in the woods.
        const double px = b.min_x + ci * grass_cell + rng.uniform(4.5, grass_cell - 4.5);
        const double py = b.min_y + cj * grass_cell + rng.uniform(4.5, grass_cell - 4.5);
        objects.add(grass(rng, px, py));
      }
  }

  /// A few objects on open ground: a jittered 20 m lattice, keeping clear of every feature.
  void scatter(ObjectSet& objects) const
  {
    const Layout& l = layout_;
    const std::vector<Box> keep_out = { l.road.grown(kRoadShoulder + 2.0),
                                        l.trail.grown(kTrailShoulder + 2.0),
                                        l.staging.grown(4.0),
                                        l.barriers.grown(4.0),
                                        l.side_slope.grown(4.0),
                                        l.woods.grown(4.0),
                                        l.ditch.grown(4.0),
                                        l.pond.grown(4.0),
                                        l.rough.grown(4.0),
                                        l.fence.grown(4.0),
                                        l.sand.grown(4.0),
                                        l.clay.grown(4.0) };
    const Box course{ 2.0, 2.0, extent_x_ - 2.0, extent_y_ - 2.0 };
    const double cell = 20.0;
    const int nx = static_cast<int>(std::floor(extent_x_ / cell));
    const int ny = static_cast<int>(std::floor(extent_y_ / cell));
    for (int cj = 0; cj < ny; ++cj)
      for (int ci = 0; ci < nx; ++ci)
      {
        SplitMix rng(hash(seed_, kStreamScatter, ci, cj));
        const double pick = rng.uniform(0.0, 1.0);
        if (pick >= 0.35)
          continue;
        const double px = ci * cell + rng.uniform(2.0, cell - 2.0);
        const double py = cj * cell + rng.uniform(2.0, cell - 2.0);
        TerrainObject o;
        if (pick < 0.12)
          o = rock(rng, px, py);
        else if (pick < 0.22)
          o = shrub(rng, px, py);
        else if (pick < 0.29)
          o = smallTree(rng, px, py);
        else
          o = grass(rng, px, py);
        double hx = 0.0, hy = 0.0;
        footprintHalfExtents(o, hx, hy);
        const Box footprint{ o.x - hx, o.y - hy, o.x + hx, o.y + hy };
        bool clear = footprint.min_x >= course.min_x && footprint.max_x <= course.max_x &&
                     footprint.min_y >= course.min_y && footprint.max_y <= course.max_y;
        for (const Box& k : keep_out)
          clear = clear && !footprint.overlaps(k);
        if (clear)
          objects.add(o);
      }
  }

  std::uint64_t seed_;
  double cell_;
  std::size_t columns_, rows_;
  double extent_x_, extent_y_;  ///< m, of the grid (at most the requested lengths)
  double margin_;               ///< m, level zones reach this far past their region
  Layout layout_;
  GradientNoise hills_[3];
  GradientNoise mottle_;
  GradientNoise wobble_;
  std::vector<float> heights_;
  std::vector<std::uint8_t> soil_;
};

void requirePositiveFinite(double value, const char* name)
{
  if (!std::isfinite(value) || !(value > 0.0))
  {
    std::ostringstream why;
    why << "makeDefaultCourse: " << name << " must be finite and > 0 (got " << value << ")";
    throw std::invalid_argument(why.str());
  }
}

}  // namespace

const CourseFeature& Course::feature(const std::string& name) const
{
  for (const CourseFeature& f : features)
    if (f.name == name)
      return f;
  throw std::out_of_range("Course::feature: no feature named '" + name + "'");
}

Course makeDefaultCourse(const CourseOptions& options)
{
  requirePositiveFinite(options.cell_size, "cell_size");
  requirePositiveFinite(options.length_x, "length_x");
  requirePositiveFinite(options.length_y, "length_y");
  std::ostringstream why;
  if (options.cell_size > 0.1 * std::min(options.length_x, options.length_y))
    why << "cell_size (" << options.cell_size << " m) must be at most a tenth of length_x and length_y";
  else if (options.length_x < kMinCourseLengthX)
    why << "length_x (" << options.length_x << " m) must be at least " << kMinCourseLengthX
        << " m to hold the fixed-size features";
  else if (options.length_y < kMinCourseLengthY)
    why << "length_y (" << options.length_y << " m) must be at least " << kMinCourseLengthY
        << " m to hold the fixed-size features";
  if (why.tellp() > 0)
    throw std::invalid_argument("makeDefaultCourse: " + why.str());

  // The grid ends on the last whole cell inside the requested lengths.
  const double fx = std::floor(options.length_x / options.cell_size + 1e-9);
  const double fy = std::floor(options.length_y / options.cell_size + 1e-9);
  if ((fx + 1.0) * (fy + 1.0) > 2147483648.0)
    throw std::invalid_argument("makeDefaultCourse: cell_size (" + std::to_string(options.cell_size) +
                                " m) gives more than 2^31 grid points");
  return CourseBuilder(options, static_cast<std::size_t>(fx) + 1, static_cast<std::size_t>(fy) + 1).build();
}

}  // namespace terrain
}  // namespace avsp
