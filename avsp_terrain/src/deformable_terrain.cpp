#include "avsp_terrain/deformable_terrain.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "avsp_terrain/terramechanics.hpp"

namespace avsp
{
namespace terrain
{
namespace
{
[[noreturn]] void rejectArgument(const char* function, const char* field, const char* rule, double value)
{
  std::ostringstream why;
  why << function << ": " << field << " must be " << rule << ", got " << value;
  throw std::invalid_argument(why.str());
}

void requireFinite(const char* function, const char* field, double value)
{
  if (!std::isfinite(value))
    rejectArgument(function, field, "finite", value);
}

void requireFinite(const char* function, const char* field, const Eigen::Vector3d& value)
{
  for (int k = 0; k < 3; ++k)
    requireFinite(function, field, value[k]);
}

void requirePositive(const char* function, const char* field, double value)
{
  if (!(value > 0.0) || !std::isfinite(value))
    rejectArgument(function, field, "finite and > 0", value);
}

/// Grid indices first..last of the points with lo <= origin + k d <= hi along one axis,
/// clamped in floating point before converting (a far-away patch must not overflow a long).
bool gridRange(double lo, double hi, double origin, double d, std::size_t count, std::size_t& first, std::size_t& last)
{
  const double a = std::max(std::ceil((lo - origin) / d), 0.0);
  const double b = std::min(std::floor((hi - origin) / d), static_cast<double>(count) - 1.0);
  if (!(a <= b))
    return false;
  first = static_cast<std::size_t>(a);
  last = static_cast<std::size_t>(b);
  return true;
}

/// Largest |tan| of the rim angle used for a wheel's Bekker compaction resistance (75 deg):
/// beyond it the wheel is sunk near its axle, where a vertical-stress grid says nothing
/// sensible about the horizontal push (T13 itself holds only to z < D/6, i.e. 48 deg).
constexpr double kMaxRimSlope = 3.7320508075688772;

/// A point this close to an edge (m, relative to the spacing) is on it: far above the rounding
/// of a point's computed position (~1e-16 relative), far below any physical distance. Without
/// it an edge through a row of points could leave the row a hair outside while the next row
/// in sits a hair beyond one spacing, and neither would take the edge's share.
constexpr double kOnEdge = 1e-9;

/// Whether a point `inside` m within a footprint edge (negative: outside) belongs to it.
bool withinEdge(double inside, double spacing)
{
  return inside >= -kOnEdge * spacing;
}

/// The palette prepared for the contact; errors name the palette entry.
std::vector<ContactSoil> prepareSoils(const std::vector<SoilParameters>& palette)
{
  if (palette.empty() || palette.size() > DeformableTerrain::kMaxSoils)
    throw std::invalid_argument("DeformableTerrain: palette has " + std::to_string(palette.size()) +
                                " soils, needs 1 to " + std::to_string(DeformableTerrain::kMaxSoils));
  std::vector<ContactSoil> prepared;
  prepared.reserve(palette.size());
  for (std::size_t k = 0; k < palette.size(); ++k)
  {
    try
    {
      prepared.emplace_back(palette[k]);
    }
    catch (const std::invalid_argument& e)
    {
      throw std::invalid_argument("DeformableTerrain: palette[" + std::to_string(k) + "]: " + e.what());
    }
  }
  return prepared;
}

/// m, the length of each grid step (di, dj), at [(dj + 1) * 3 + di + 1]: fixed per grid, so
/// not recomputed per contact.
std::array<double, 9> stepLengths(const ElevationGrid& grid)
{
  std::array<double, 9> out{};
  for (int dj = -1; dj <= 1; ++dj)
    for (int di = -1; di <= 1; ++di)
      out[(dj + 1) * 3 + (di + 1)] = std::hypot(di * grid.dx(), dj * grid.dy());
  return out;
}

/// Below this s x / K the shear's strip means are summed as their series: 1 - K/(s D)(e0 - e1)
/// would lose a relative (1e-16 / (s x / K)) to cancellation (1e-4 at a creeping contact's slip).
constexpr double kShearSeriesLimit = 1e-3;

/// Mean of (1 - exp(-s x / K)) over the strip [x0, x1] (meanShearStress() without its
/// strength factor), from a = s / K, K / (s (x1 - x0)) and e0 = exp(-s x0 / K), e1 = exp(-s x1 / K)
/// the caller has, and its derivative in s (`slope`). For a x1 < kShearSeriesLimit the series
/// a M1 - a^2 M2 / 2 + a^3 M3 / 6 - a^4 M4 / 24 (M_k the strip's mean of x^k) to rounding.
double meanShearFactor(double s_over_k, double x0, double x1, double scale, double e0, double e1, double inv_k,
                       double& slope)
{
  const double a = s_over_k;
  if (a * x1 < kShearSeriesLimit)
  {
    double m[5];  // mean of x^k over [x0, x1], k = 1..4
    const double span = x1 - x0;
    double p0 = x0, p1 = x1;
    for (int k = 1; k <= 4; ++k)
    {
      p0 *= x0;
      p1 *= x1;
      m[k] = span > 0.0 ? (p1 - p0) / ((k + 1) * span) : p1 / x1;
    }
    slope = inv_k * (m[1] - a * m[2] + a * a * m[3] / 2.0 - a * a * a * m[4] / 6.0);
    return a * m[1] - a * a * m[2] / 2.0 + a * a * a * m[3] / 6.0 - a * a * a * a * m[4] / 24.0;
  }
  // d/ds of 1 - K / (s D) (e0 - e1): K / (s^2 D) (e0 - e1) + (x0 e0 - x1 e1) / (s D).
  const double s = a / inv_k;
  slope = scale / s * (e0 - e1) + (x0 * e0 - x1 * e1) / (s * (x1 - x0));
  return 1.0 - scale * (e0 - e1);
}
}  // namespace

DeformableTerrain::DeformableTerrain(ElevationGrid base, SoilParameters soil, Options options)
  : base_(std::move(base)),
    palette_{ std::move(soil) },
    contact_soils_(prepareSoils(palette_)),
    options_(options),
    tiles_x_((base_.columns() + kTileSize - 1) / kTileSize),
    tiles_(tiles_x_ * ((base_.rows() + kTileSize - 1) / kTileSize))
{
  step_length_ = stepLengths(base_);
}

DeformableTerrain::DeformableTerrain(ElevationGrid base, std::vector<SoilParameters> palette,
                                     std::vector<std::uint8_t> soil_map, Options options)
  : base_(std::move(base)),
    palette_(std::move(palette)),
    contact_soils_(prepareSoils(palette_)),
    soil_map_(std::move(soil_map)),
    options_(options),
    tiles_x_((base_.columns() + kTileSize - 1) / kTileSize),
    tiles_(tiles_x_ * ((base_.rows() + kTileSize - 1) / kTileSize))
{
  step_length_ = stepLengths(base_);
  const std::size_t points = base_.columns() * base_.rows();
  if (soil_map_.size() != points)
    throw std::invalid_argument("DeformableTerrain: soil_map has " + std::to_string(soil_map_.size()) +
                                " entries, expected columns * rows = " + std::to_string(points));
  // A bad index would read past the palette in every contact over it: refuse it here, once.
  const std::size_t first_bad =
      std::find_if(soil_map_.begin(), soil_map_.end(), [&](std::uint8_t s) { return s >= palette_.size(); }) -
      soil_map_.begin();
  if (first_bad < points)
    throw std::invalid_argument("DeformableTerrain: soil_map: index " + std::to_string(soil_map_[first_bad]) +
                                " at grid point (" + std::to_string(first_bad % base_.columns()) + ", " +
                                std::to_string(first_bad / base_.columns()) + ") is not in the palette of " +
                                std::to_string(palette_.size()) + " soils");
  if (palette_.size() == 1)
    std::vector<std::uint8_t>().swap(soil_map_);  // all zeros: not worth a byte per point
}

std::uint8_t DeformableTerrain::soilIndex(std::size_t i, std::size_t j) const
{
  checkPoint("soilIndex", i, j);
  return soil_map_.empty() ? 0 : soil_map_[j * base_.columns() + i];
}

void DeformableTerrain::setSoil(std::size_t index, SoilParameters soil)
{
  if (index >= palette_.size())
    throw std::invalid_argument("DeformableTerrain::setSoil: index " + std::to_string(index) +
                                " is not in the palette of " + std::to_string(palette_.size()) + " soils");
  ContactSoil prepared(soil);  // validates before anything changes
  palette_[index] = std::move(soil);
  contact_soils_[index] = prepared;
}

const PointDeformation* DeformableTerrain::find(std::size_t i, std::size_t j) const
{
  const Tile* tile = tiles_[tileIndex(i, j)].get();
  return tile ? &(*tile)[(j % kTileSize) * kTileSize + i % kTileSize] : nullptr;
}

PointDeformation& DeformableTerrain::touch(std::size_t i, std::size_t j)
{
  const std::size_t t = tileIndex(i, j);
  std::unique_ptr<Tile>& tile = tiles_[t];
  if (!tile)
  {
    tile = std::make_unique<Tile>();
    ++allocated_tiles_;
  }
  if (tracking_ && !before_[t])
  {
    // The first write to this tile in the interval: keep the tile as it was (in a buffer
    // from the last interval's, so a steady run allocates nothing).
    if (spare_tiles_.empty())
      before_[t] = std::make_unique<Tile>(*tile);
    else
    {
      before_[t] = std::move(spare_tiles_.back());
      spare_tiles_.pop_back();
      *before_[t] = *tile;
    }
    changed_tiles_.push_back(t);
  }
  return (*tile)[(j % kTileSize) * kTileSize + i % kTileSize];
}

void DeformableTerrain::setChangeTracking(bool on)
{
  tracking_ = on;
  before_.clear();
  changed_tiles_.clear();
  spare_tiles_.clear();
  if (on)
    before_.resize(tiles_.size());
}

namespace
{
bool sameDeformation(const PointDeformation& a, const PointDeformation& b)
{
  return a.plastic == b.plastic && a.displaced == b.displaced && a.sigma_max == b.sigma_max;
}
}  // namespace

std::vector<PointChange> DeformableTerrain::takeChanges()
{
  std::vector<PointChange> changes;
  takeChanges(changes);
  return changes;
}

void DeformableTerrain::takeChanges(std::vector<PointChange>& changes)
{
  changes.clear();
  if (!tracking_)
    return;
  std::sort(changed_tiles_.begin(), changed_tiles_.end());
  for (std::size_t t : changed_tiles_)
  {
    const Tile& now = *tiles_[t];
    const Tile& then = *before_[t];
    const std::size_t i0 = (t % tiles_x_) * kTileSize, j0 = (t / tiles_x_) * kTileSize;
    for (std::size_t k = 0; k < now.size(); ++k)
      if (!sameDeformation(now[k], then[k]))
      {
        PointChange c;
        c.i = static_cast<std::uint32_t>(i0 + k % kTileSize);
        c.j = static_cast<std::uint32_t>(j0 + k / kTileSize);
        c.before = then[k];
        c.after = now[k];
        changes.push_back(c);
      }
    spare_tiles_.push_back(std::move(before_[t]));
  }
  changed_tiles_.clear();
}

std::size_t DeformableTerrain::applyChanges(const std::vector<PointChange>& changes)
{
  for (const PointChange& c : changes)
  {
    checkPoint("applyChanges", c.i, c.j);
    for (const PointDeformation* d : { &c.before, &c.after })
      if (!std::isfinite(d->plastic) || !std::isfinite(d->displaced) || !std::isfinite(d->sigma_max))
        throw std::invalid_argument("DeformableTerrain::applyChanges: point (" + std::to_string(c.i) + ", " +
                                    std::to_string(c.j) + ") has a non-finite deformation");
  }
  std::size_t merged = 0;
  for (const PointChange& c : changes)
  {
    const std::size_t t = tileIndex(c.i, c.j), k = (c.j % kTileSize) * kTileSize + c.i % kTileSize;
    std::unique_ptr<Tile>& tile = tiles_[t];
    if (!tile)
    {
      tile = std::make_unique<Tile>();
      ++allocated_tiles_;
    }
    PointDeformation& state = (*tile)[k];
    if (sameDeformation(state, c.before))
    {
      state = c.after;
    }
    else
    {
      state.plastic = std::max(state.plastic, c.after.plastic);
      state.sigma_max = std::max(state.sigma_max, c.after.sigma_max);
      state.displaced += c.after.displaced - c.before.displaced;
      ++merged;
    }
    // Not this terrain's change: what it changes from here on counts from the merged state.
    if (tracking_ && before_[t])
      (*before_[t])[k] = state;
  }
  return merged;
}

void DeformableTerrain::checkPoint(const char* function, std::size_t i, std::size_t j) const
{
  if (i >= base_.columns() || j >= base_.rows())
    throw std::out_of_range(std::string("DeformableTerrain::") + function + ": point (" + std::to_string(i) + ", " +
                            std::to_string(j) + ") is outside the " + std::to_string(base_.columns()) + " x " +
                            std::to_string(base_.rows()) + " grid");
}

void DeformableTerrain::setDeformation(std::size_t i, std::size_t j, const PointDeformation& d)
{
  checkPoint("setDeformation", i, j);
  touch(i, j) = d;
}

PointDeformation DeformableTerrain::deformation(std::size_t i, std::size_t j) const
{
  checkPoint("deformation", i, j);
  const PointDeformation* p = find(i, j);
  return p ? *p : PointDeformation{};
}

double DeformableTerrain::pointHeight(std::size_t i, std::size_t j) const
{
  const PointDeformation d = deformation(i, j);
  return base_.pointHeight(i, j) - d.plastic - d.displaced;
}

std::optional<double> DeformableTerrain::height(double x, double y) const
{
  // Inline lookups (the running gear's ground normal asks four heights per contact per step):
  // the same cell, (u, v) and corner arithmetic as cellAt() and pointHeight(), bit for bit.
  std::size_t i = 0, j = 0;
  double u = 0.0, v = 0.0;
  if (!base_.cellOf(x, y, i, j, u, v))
    return std::nullopt;
  const std::size_t columns = base_.columns();
  const float* south = base_.pointHeights().data() + j * columns + i;
  const float* north = south + columns;
  double h00 = south[0], h10 = south[1];
  double h01 = north[0], h11 = north[1];
  if (allocated_tiles_ > 0)
  {
    const std::size_t ti = i % kTileSize, tj = j % kTileSize;
    if (ti + 1 < kTileSize && tj + 1 < kTileSize)
    {
      // All four corners in one tile (49 of 64 cells): one lookup instead of four.
      if (const Tile* found = tiles_[tileIndex(i, j)].get())
      {
        const Tile& tile = *found;
        const auto sink = [&](std::size_t a, std::size_t b) {
          const PointDeformation& d = tile[b * kTileSize + a];
          return static_cast<double>(d.plastic) + d.displaced;
        };
        h00 -= sink(ti, tj);
        h10 -= sink(ti + 1, tj);
        h01 -= sink(ti, tj + 1);
        h11 -= sink(ti + 1, tj + 1);
      }
    }
    else
    {
      // As pointHeight(): base - z_p - (z_f - z_n), untouched points at their base height.
      const auto lower = [&](double& h, std::size_t a, std::size_t b) {
        if (const PointDeformation* d = find(a, b))
          h = h - d->plastic - d->displaced;
      };
      lower(h00, i, j);
      lower(h10, i + 1, j);
      lower(h01, i, j + 1);
      lower(h11, i + 1, j + 1);
    }
  }
  return ElevationGrid::bilinear(h00, h10, h01, h11, u, v);
}

/// Where a wheel or track patch is, its shape, and how it moves (shared by both contacts).
struct DeformableTerrain::Footprint
{
  bool wheel = true;
  double cx = 0.0, cy = 0.0, cz = 0.0;       ///< m: wheel centre, or the track face's centre
  double ca = 1.0, sa = 0.0;                 ///< cos and sin of the heading
  double half_length = 0.0;                  ///< m: the wheel's radius, or half the track patch's length
  double half_width = 0.0;                   ///< m
  double slope_u = 0.0, slope_v = 0.0;       ///< a track face's dz/du, dz/dv (tilted to its normal)
  double bekker_b = 0.0;                     ///< m, b of k_c / b: wheel width; a track's smaller dimension
  double track_length = 0.0;                 ///< m, whole track's ground contact (tracks)
  double segment_offset = 0.0;               ///< m, patch centre from the whole track's centre, + forward
  double v_long = 0.0, v_lat = 0.0;          ///< m/s, in the footprint's frame
  double v_theoretical = 0.0;                ///< m/s, T9 or T10
  double travel = 1.0;                       ///< +1 moving forward, -1 backward
  double shear_long = 0.0, shear_lat = 0.0;  ///< shear slip (WheelPatch::shear_slip), footprint frame
  double shear_cap = std::numeric_limits<double>::infinity();  ///< m, WheelPatch::shear_cap
  double swept = 0.0;                                          ///< m the footprint travels over this step (|v_long| dt)
  double ground_slope = 0.0;                                   ///< a wheel's ground dz/du along its heading
};

namespace
{
/// The kinematic shear slip of a footprint moving at (v_long, v_lat) with running gear at v_t:
/// j = s x with s = (v_t - v_long, -v_lat) / max(|v_long|, |v_t|, v0) (Wong's T8 and the lateral
/// slip tan(alpha) (1 - s) when driving, tan(alpha) when skidding: a locked wheel still grips
/// sideways), finite at rest.
void kinematicShearSlip(double v_long, double v_lat, double v_t, double& s_long, double& s_lat)
{
  const double scale = std::max({ std::abs(v_long), std::abs(v_t), kSlipRegularisationSpeed });
  s_long = (v_t - v_long) / scale;
  s_lat = -v_lat / scale;
}

/// m/s: below this a wheel is not rolling over its rut (it is pressed, or at rest).
constexpr double kRollingSpeed = 0.01;

/// Two-point Gauss-Legendre abscissae on [-1, 1].
constexpr double kGauss = 0.57735026918962576451;
}  // namespace

namespace
{
/// An oriented rectangle: centre, unit axis along its length, half length and half width.
struct Box
{
  double x, y, ax, ay, half_length, half_width;

  bool contains(double px, double py) const
  {
    const double dx = px - x, dy = py - y;
    return std::abs(dx * ax + dy * ay) <= half_length && std::abs(-dx * ay + dy * ax) <= half_width;
  }
  /// Radius of the box projected on unit axis (nx, ny).
  double reach(double nx, double ny) const
  {
    return half_length * std::abs(ax * nx + ay * ny) + half_width * std::abs(-ay * nx + ax * ny);
  }
};

Box boxOf(const TerrainObject& o)
{
  return { o.x, o.y, std::cos(o.yaw), std::sin(o.yaw), 0.5 * o.length, 0.5 * o.width };
}

/// Separating-axis test of two rectangles (touching counts as overlapping): robust for a pole
/// thinner than a grid cell, which point sampling could miss.
bool overlap(const Box& a, const Box& b)
{
  const double dx = b.x - a.x, dy = b.y - a.y;
  for (const auto& [nx, ny] :
       { std::pair<double, double>{ a.ax, a.ay }, { -a.ay, a.ax }, { b.ax, b.ay }, { -b.ay, b.ax } })
    if (std::abs(dx * nx + dy * ny) > a.reach(nx, ny) + b.reach(nx, ny))
      return false;
  return true;
}
}  // namespace

void DeformableTerrain::vegetation(const Footprint& fp, bool deform, ObjectSet& objects, ContactForces& out) const
{
  if (loaded_.empty())
    return;
  // The loaded footprint: the rectangle spanned by the loaded points, each with half a cell
  // around it, within the wheel's or track's own outline.
  const double dx = base_.dx(), dy = base_.dy();
  const double along_half = 0.5 * (dx * std::abs(fp.ca) + dy * std::abs(fp.sa));
  const double across_half = 0.5 * (dx * std::abs(fp.sa) + dy * std::abs(fp.ca));
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  for (const LoadedPoint& p : loaded_)
  {
    const double px = base_.originX() + p.i * dx - fp.cx, py = base_.originY() + p.j * dy - fp.cy;
    const double u = px * fp.ca + py * fp.sa, v = -px * fp.sa + py * fp.ca;
    u0 = std::min(u0, u);
    u1 = std::max(u1, u);
    v0 = std::min(v0, v);
    v1 = std::max(v1, v);
  }
  u0 = std::max(u0 - along_half, -fp.half_length);
  u1 = std::min(u1 + along_half, fp.half_length);
  v0 = std::max(v0 - across_half, -fp.half_width);
  v1 = std::min(v1 + across_half, fp.half_width);
  const double um = 0.5 * (u0 + u1), vm = 0.5 * (v0 + v1);
  const Box footprint{
    fp.cx + um * fp.ca - vm * fp.sa, fp.cy + um * fp.sa + vm * fp.ca, fp.ca, fp.sa, 0.5 * (u1 - u0), 0.5 * (v1 - v0)
  };
  const double reach_x = footprint.reach(1.0, 0.0), reach_y = footprint.reach(0.0, 1.0);
  const std::vector<std::uint32_t> near =
      objects.query(footprint.x - reach_x, footprint.y - reach_y, footprint.x + reach_x, footprint.y + reach_y);
  if (near.empty())
    return;

  std::vector<std::pair<Box, double>> grass;  // patch, f
  const double push = std::sqrt(out.normal_force * out.normal_force + out.longitudinal_force * out.longitudinal_force +
                                out.lateral_force * out.lateral_force);
  const double direction = std::atan2(fp.sa * fp.travel, fp.ca * fp.travel);
  for (const std::uint32_t id : near)
  {
    const TerrainObject& o = objects.get(id);
    if (o.type == ObjectType::kGrass)
    {
      if (o.rolling_resistance > 0.0)
        grass.emplace_back(boxOf(o), o.rolling_resistance);
      continue;
    }
    if (o.toppled || !overlap(footprint, boxOf(o)))
      continue;
    if (deform && objects.push(id, push, direction))
      out.toppled_objects.push_back(id);
    else
      out.standing_objects.push_back(id);
  }
  if (grass.empty())
    return;
  // Grass: f of the patch times the load each loaded point carries inside it.
  const double area = dx * dy;
  for (const LoadedPoint& p : loaded_)
  {
    const double x = base_.originX() + p.i * dx, y = base_.originY() + p.j * dy;
    double f = 0.0;
    for (const auto& [box, coefficient] : grass)
      if (coefficient > f && box.contains(x, y))
        f = coefficient;
    out.grass_resistance += f * p.sigma * area * p.weight;
  }
  out.resistance_force += out.grass_resistance;
}

long DeformableTerrain::landingOf(long start, long a, long b, long width, long height)
{
  // L(x) = x where the drag leaves the window at the next step; else the next point, where
  // that one is not under the footprint; else L(next). Only points under the footprint are
  // passed through, and each keeps its L: every point of a contact is walked once, not once
  // per point behind it (a long track patch's rows would otherwise cost their length squared).
  landing_path_.clear();
  long at = start, result = start;
  for (;;)
  {
    if (landing_[at] >= 0)
    {
      result = landing_[at];
      break;
    }
    if (a + drag_di_ < 0 || a + drag_di_ >= width || b + drag_dj_ < 0 || b + drag_dj_ >= height)
    {
      result = at;
      break;
    }
    landing_path_.push_back(at);
    a += drag_di_;
    b += drag_dj_;
    const long next = at + drag_dj_ * width + drag_di_;
    if (!under_[next])
    {
      result = next;
      break;
    }
    at = next;
  }
  for (const long visited : landing_path_)
    landing_[visited] = result;
  return result;
}

void DeformableTerrain::spreadFlow()
{
  // f(z_f, d) of T5: each point's flowed volume goes to its neighbours weighted by 1/d, so
  // what leaves one point arrives exactly at others (volume leaving = volume arriving). Soil
  // squeezed from under the running gear goes to the free surface beside it: neighbours that
  // are themselves under the footprint get no share while the point has one that is not (an
  // interior point with none shares among all 8). The arrivals of the whole contact are summed
  // in a small window around the loaded points first and applied once per receiving point: no
  // tile lookups per share.
  std::size_t imin = base_.columns(), imax = 0, jmin = base_.rows(), jmax = 0;
  for (const LoadedPoint& p : loaded_)
  {
    imin = std::min<std::size_t>(imin, p.i);
    imax = std::max<std::size_t>(imax, p.i);
    jmin = std::min<std::size_t>(jmin, p.j);
    jmax = std::max<std::size_t>(jmax, p.j);
  }
  // Window: the loaded box plus one point around it, clipped to the grid.
  const std::size_t wi0 = imin > 0 ? imin - 1 : 0, wj0 = jmin > 0 ? jmin - 1 : 0;
  const std::size_t wi1 = std::min(imax + 1, base_.columns() - 1), wj1 = std::min(jmax + 1, base_.rows() - 1);
  const std::size_t width = wi1 - wi0 + 1;
  arrivals_.assign(width * (wj1 - wj0 + 1), 0.0);
  under_.assign(arrivals_.size(), 0);
  landing_.assign(arrivals_.size(), -1);
  for (const LoadedPoint& p : loaded_)
    under_[(p.j - wj0) * width + (p.i - wi0)] = 1;
  const double area = base_.dx() * base_.dy();
  const long columns = static_cast<long>(base_.columns()), rows = static_cast<long>(base_.rows());
  double arrived = 0.0;                     // summed here, not in the member: the loop would store it every share
  const long w = static_cast<long>(width);  // a window row
  // The 8 neighbours' 1/d weights and window offsets, k = (dj + 1) * 3 + (di + 1) (4: the point
  // itself). A point inside the grid has all 8: its weights and their total are these (summed
  // in the order the general case sums them, so the same to the bit).
  static constexpr double kNeighbour[9] = { M_SQRT1_2, 1.0, M_SQRT1_2, 1.0, 0.0, 1.0, M_SQRT1_2, 1.0, M_SQRT1_2 };
  const long neighbour_offset[9] = { -w - 1, -w, -w + 1, -1, 0, 1, w - 1, w, w + 1 };
  double inside_total = 0.0;
  for (int k = 0; k < 9; ++k)
    if (k != 4)
      inside_total += kNeighbour[k];
  for (const LoadedPoint& p : loaded_)
  {
    if (!(p.flow_volume > 0.0))
      continue;
    const long i = p.i, j = p.j;
    const long offset = (j - static_cast<long>(wj0)) * w + (i - static_cast<long>(wi0));
    double* centre = arrivals_.data() + offset;
    const std::uint8_t* mask = under_.data() + offset;
    // The neighbours that exist, and of those the ones beside the footprint.
    double weights[9] = {}, total = 0.0, free_total = 0.0;
    bool free_[9] = {};
    if (i > 0 && j > 0 && i + 1 < columns && j + 1 < rows)
    {
      total = inside_total;
      for (int k = 0; k < 9; ++k)
      {
        weights[k] = kNeighbour[k];
        free_[k] = k != 4 && mask[neighbour_offset[k]] == 0;
        if (free_[k])
          free_total += kNeighbour[k];
      }
    }
    else
    {
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
        {
          if ((di == 0 && dj == 0) || i + di < 0 || j + dj < 0 || i + di >= columns || j + dj >= rows)
            continue;
          const int k = (dj + 1) * 3 + (di + 1);
          weights[k] = kNeighbour[k];
          total += weights[k];
          free_[k] = mask[dj * w + di] == 0;
          if (free_[k])
            free_total += weights[k];
        }
    }
    // Sheared soil is dragged the way the slip goes, past the rest of the footprint, to the
    // first point beside it in that direction (the soil a spinning wheel digs out lands behind
    // it, not under the same wheel); the rest, pressed out, goes to the free surface around.
    double shear = 0.0;
    long drop = 0;  // window offset of where the sheared soil lands
    if (p.shear_fraction > 0.0 && (drag_di_ != 0 || drag_dj_ != 0))
    {
      const long landing = landingOf(offset, i - static_cast<long>(wi0), j - static_cast<long>(wj0), w,
                                     static_cast<long>(wj1 - wj0 + 1));
      if (landing != offset)
      {
        shear = p.shear_fraction * p.flow_volume;
        drop = landing - offset;
      }
    }
    const double pressed = p.flow_volume - shear;
    const bool outward = free_total > 0.0;
    const double pressed_height = pressed / (outward ? free_total : total) / area;
    for (int k = 0; k < 9; ++k)
      if (weights[k] > 0.0 && (!outward || free_[k]))
        centre[neighbour_offset[k]] += pressed_height * weights[k];
    centre[drop] += shear / area;
    arrived += p.flow_volume;
  }
  arrived_volume_ += arrived;
  for (std::size_t j = wj0; j <= wj1; ++j)
  {
    const double* row = arrivals_.data() + (j - wj0) * width - wi0;
    std::size_t tile_column = tiles_x_;  // none yet
    Tile* tile = nullptr;
    for (std::size_t i = wi0; i <= wi1; ++i)
    {
      if (row[i] == 0.0)
        continue;
      if (i / kTileSize != tile_column)
      {
        tile_column = i / kTileSize;
        touch(i, j);  // allocates the tile if it is new
        tile = tiles_[tileIndex(i, j)].get();
      }
      (*tile)[(j % kTileSize) * kTileSize + i % kTileSize].displaced -= static_cast<float>(row[i]);
    }
  }
}

ContactForces DeformableTerrain::wheelContact(const WheelPatch& wheel, double dt, bool deform, ObjectSet* objects)
{
  static const char* const kFn = "DeformableTerrain::wheelContact";
  requireFinite(kFn, "wheel.centre", wheel.centre);
  requireFinite(kFn, "wheel.velocity", wheel.velocity);
  requirePositive(kFn, "wheel.radius", wheel.radius);
  requirePositive(kFn, "wheel.width", wheel.width);
  requireFinite(kFn, "wheel.heading", wheel.heading);
  requireFinite(kFn, "wheel.spin_rate", wheel.spin_rate);
  if (!(dt >= 0.0) || !std::isfinite(dt))
    rejectArgument(kFn, "dt", "finite and >= 0", dt);

  Footprint fp;
  fp.cx = wheel.centre.x();
  fp.cy = wheel.centre.y();
  fp.cz = wheel.centre.z();
  fp.ca = std::cos(wheel.heading);
  fp.sa = std::sin(wheel.heading);
  fp.half_length = wheel.radius;
  fp.half_width = 0.5 * wheel.width;
  fp.bekker_b = wheel.width;  // T13's b for a wheel
  fp.v_long = wheel.velocity.x() * fp.ca + wheel.velocity.y() * fp.sa;
  fp.v_lat = -wheel.velocity.x() * fp.sa + wheel.velocity.y() * fp.ca;
  fp.v_theoretical = wheelTheoreticalSpeed(wheel.radius, wheel.spin_rate);  // T9
  fp.travel = (std::abs(fp.v_long) > 1e-6) ? (fp.v_long < 0 ? -1.0 : 1.0) : (wheel.spin_rate < 0 ? -1.0 : 1.0);
  if (wheel.travel != 0)
    fp.travel = wheel.travel > 0 ? 1.0 : -1.0;
  fp.swept = std::abs(fp.v_long) * dt;
  requireFinite(kFn, "wheel.ground_slope", wheel.ground_slope);
  fp.ground_slope = wheel.ground_slope;
  if (wheel.shear_slip_given)
  {
    requireFinite(kFn, "wheel.shear_slip", wheel.shear_slip.x());
    requireFinite(kFn, "wheel.shear_slip", wheel.shear_slip.y());
    fp.shear_long = wheel.shear_slip.x();
    fp.shear_lat = wheel.shear_slip.y();
    if (!(wheel.shear_cap >= 0.0))
      throw std::invalid_argument(std::string(kFn) + ": wheel.shear_cap must be >= 0 (or +inf), got " +
                                  std::to_string(wheel.shear_cap));
    fp.shear_cap = wheel.shear_cap;
  }
  else
  {
    kinematicShearSlip(fp.v_long, fp.v_lat, fp.v_theoretical, fp.shear_long, fp.shear_lat);
  }
  ContactForces out;
  collect(fp, out);
  forcesAndDeform(fp, dt, deform, objects, out);
  return out;
}

ContactForces DeformableTerrain::trackContact(const TrackPatch& track, double dt, bool deform, ObjectSet* objects)
{
  static const char* const kFn = "DeformableTerrain::trackContact";
  requireFinite(kFn, "track.centre", track.centre);
  requireFinite(kFn, "track.velocity", track.velocity);
  requirePositive(kFn, "track.length", track.length);
  requirePositive(kFn, "track.width", track.width);
  requireFinite(kFn, "track.heading", track.heading);
  requirePositive(kFn, "track.sprocket_pitch", track.sprocket_pitch);
  if (track.sprocket_teeth <= 0)
    rejectArgument(kFn, "track.sprocket_teeth", "> 0", track.sprocket_teeth);
  requireFinite(kFn, "track.sprocket_spin_rate", track.sprocket_spin_rate);
  requireFinite(kFn, "track.segment_offset", track.segment_offset);
  requireFinite(kFn, "track.normal", track.normal);
  if (!(std::abs(track.normal.norm() - 1.0) < 1e-6) || !(track.normal.z() >= 0.25))
    rejectArgument(kFn, "track.normal", "a unit vector with z >= 0.25 (a face at most 75 deg from level); its z is",
                   track.normal.z());
  if (!(dt >= 0.0) || !std::isfinite(dt))
    rejectArgument(kFn, "dt", "finite and >= 0", dt);
  const double whole = track.track_length == 0.0 ? track.length : track.track_length;
  if (!(whole >= track.length) || !std::isfinite(whole))
    rejectArgument(kFn, "track.track_length", "0 (the patch is the whole track) or >= track.length",
                   track.track_length);
  // The patch must lie on the track (a rounding's worth of slack for segments laid end to end).
  if (std::abs(track.segment_offset) + 0.5 * track.length > 0.5 * whole * (1.0 + 1e-12))
    rejectArgument(kFn, "track.segment_offset", "such that the patch lies within track_length", track.segment_offset);

  Footprint fp;
  fp.wheel = false;
  fp.cx = track.centre.x();
  fp.cy = track.centre.y();
  fp.cz = track.centre.z();
  fp.ca = std::cos(track.heading);
  fp.sa = std::sin(track.heading);
  fp.half_length = 0.5 * track.length;
  fp.half_width = 0.5 * track.width;
  fp.bekker_b = std::min(whole, track.width);  // Bekker: the smaller dimension of the contact
  fp.track_length = whole;
  fp.segment_offset = track.segment_offset;
  fp.v_long = track.velocity.x() * fp.ca + track.velocity.y() * fp.sa;
  fp.v_lat = -track.velocity.x() * fp.sa + track.velocity.y() * fp.ca;
  fp.v_theoretical = trackTheoreticalSpeed(track.sprocket_pitch, track.sprocket_teeth, track.sprocket_spin_rate);
  fp.travel = (std::abs(fp.v_long) > 1e-6) ? (fp.v_long < 0 ? -1.0 : 1.0) : (track.sprocket_spin_rate < 0 ? -1.0 : 1.0);
  if (track.travel != 0)
    fp.travel = track.travel > 0 ? 1.0 : -1.0;
  // The face through the centre with normal n: z = cz - (n_x dx + n_y dy) / n_z.
  fp.slope_u = -(track.normal.x() * fp.ca + track.normal.y() * fp.sa) / track.normal.z();
  fp.slope_v = -(-track.normal.x() * fp.sa + track.normal.y() * fp.ca) / track.normal.z();
  if (track.shear_slip_given)
  {
    requireFinite(kFn, "track.shear_slip", track.shear_slip.x());
    requireFinite(kFn, "track.shear_slip", track.shear_slip.y());
    fp.shear_long = track.shear_slip.x();
    fp.shear_lat = track.shear_slip.y();
    if (!(track.shear_cap >= 0.0))
      throw std::invalid_argument(std::string(kFn) + ": track.shear_cap must be >= 0 (or +inf), got " +
                                  std::to_string(track.shear_cap));
    fp.shear_cap = track.shear_cap;
  }
  else
  {
    kinematicShearSlip(fp.v_long, fp.v_lat, fp.v_theoretical, fp.shear_long, fp.shear_lat);
  }
  ContactForces out;
  collect(fp, out);
  forcesAndDeform(fp, dt, deform, objects, out);
  return out;
}

void DeformableTerrain::fillWindow(std::size_t i0, std::size_t i1, std::size_t j0, std::size_t j1)
{
  window_i0_ = i0;
  window_j0_ = j0;
  window_columns_ = i1 - i0 + 1;
  window_rows_ = j1 - j0 + 1;
  window_.resize(window_columns_ * window_rows_);
  WindowPoint* out = window_.data();
  double top = -std::numeric_limits<double>::infinity(), least_plastic = std::numeric_limits<double>::infinity();
  for (std::size_t j = j0; j <= j1; ++j)
  {
    const float* base_row = base_.pointHeights().data() + j * base_.columns();
    const std::size_t tile_row = (j / kTileSize) * tiles_x_, in_row = (j % kTileSize) * kTileSize;
    std::size_t tile_column = tiles_x_;  // none yet
    const Tile* tile = nullptr;
    for (std::size_t i = i0; i <= i1; ++i, ++out)
    {
      if (i / kTileSize != tile_column)
      {
        tile_column = i / kTileSize;
        tile = tiles_[tile_row + tile_column].get();
      }
      const PointDeformation d = tile ? (*tile)[in_row + i % kTileSize] : PointDeformation{};
      *out = WindowPoint{ base_row[i], d.plastic, d.displaced, d.sigma_max };
      top = std::max(top, out->base - out->displaced);
      least_plastic = std::min(least_plastic, out->plastic);
    }
  }
  window_top_ = top - least_plastic;
}

// Inline: a wheel's contact asks it for every sample of its rim (the inner loop).
[[gnu::always_inline]] inline DeformableTerrain::WindowPoint DeformableTerrain::windowState(double x, double y,
                                                                                            double behind,
                                                                                            bool with_sigma) const
{
  // Bilinear between the four window points around (x, y); clamped to the window (a sample
  // within half a cell of the grid's edge takes the edge's cell).
  const double gx = (x - base_.originX()) / base_.dx() - static_cast<double>(window_i0_);
  const double gy = (y - base_.originY()) / base_.dy() - static_cast<double>(window_j0_);
  const double max_x = static_cast<double>(window_columns_ - 1), max_y = static_cast<double>(window_rows_ - 1);
  const double cx = std::clamp(gx, 0.0, max_x), cy = std::clamp(gy, 0.0, max_y);
  const std::size_t a = std::min(static_cast<std::size_t>(cx), window_columns_ > 1 ? window_columns_ - 2 : 0);
  const std::size_t b = std::min(static_cast<std::size_t>(cy), window_rows_ > 1 ? window_rows_ - 2 : 0);
  const double u = window_columns_ > 1 ? cx - static_cast<double>(a) : 0.0;
  const double v = window_rows_ > 1 ? cy - static_cast<double>(b) : 0.0;
  const std::size_t da = window_columns_ > 1 ? 1 : 0, db = window_rows_ > 1 ? window_columns_ : 0;
  const WindowPoint* corner[4] = { window_.data() + b * window_columns_ + a, nullptr, nullptr, nullptr };
  corner[1] = corner[0] + da;
  corner[2] = corner[0] + db;
  corner[3] = corner[0] + da + db;
  double weight[4] = { (1.0 - u) * (1.0 - v), u * (1.0 - v), (1.0 - u) * v, u * v };
  if (behind != 0.0)
  {
    // A rolling wheel's bottom parts soil it has pressed (behind) from soil only its front arc
    // has (ahead). A sample behind the bottom (behind > 0) interpolated across it would find
    // the rut's floor shallower than the imprint (a spurious support right behind the bottom);
    // a sample ahead of it (behind < 0) would find soil pressed deeper than the rim is there
    // (a front arc losing its pressure, the wheel sinking deeper and resisting less on a
    // coarse grid). Each is interpolated from the grid points on its own side alone.
    double kept = 0.0;
    for (int k = 0; k < 4; ++k)
    {
      const double along = corner[k]->along;
      if (behind > 0.0 ? along > 0.0 : along < 0.0)
        weight[k] = 0.0;
      kept += weight[k];
    }
    if (kept > 0.0)
    {
      const double inv = 1.0 / kept;
      for (double& w : weight)
        w *= inv;
    }
    else
      weight[0] = weight[1] = weight[2] = weight[3] = 0.25;
  }
  WindowPoint out;
  out.plastic_min = std::numeric_limits<double>::infinity();
  if (behind < 0.0)  // only the front arc's cap reads it
    for (int k = 0; k < 4; ++k)
      if (weight[k] > 0.0)
        out.plastic_min = std::min(out.plastic_min, static_cast<double>(corner[k]->plastic));
  for (int k = 0; k < 4; ++k)
  {
    out.base += weight[k] * corner[k]->base;
    out.plastic += weight[k] * corner[k]->plastic;
    out.displaced += weight[k] * corner[k]->displaced;
  }
  if (with_sigma)  // only the simple model reads it
    for (int k = 0; k < 4; ++k)
      out.sigma_max += weight[k] * corner[k]->sigma_max;
  return out;
}

/// What collect() works out once per contact and every point of it reads.
struct DeformableTerrain::Sweep
{
  double ca = 1.0, sa = 0.0;                          ///< the footprint's heading
  double dx = 0.0, dy = 0.0, ox = 0.0, oy = 0.0;      ///< the grid's spacing and origin
  double lateral_spacing = 0.0, along_spacing = 0.0;  ///< m, grid points across and along the footprint
  double half_cell = 0.0;                             ///< m, half along_spacing
  double reach = 0.0;                                 ///< m, how far along the footprint its points reach
  double r = 0.0, r2 = 0.0;                           ///< m, the wheel's radius (a track patch's half length)
  bool rolling = false;                               ///< a wheel rolling over its rut (not pressed at rest)
  double pressing = 0.0;                       ///< m, only cells this near the bottom along the footprint can press
  std::size_t i0 = 0, i1 = 0, j0 = 0, j1 = 0;  ///< the grid points the footprint may cover
};

bool DeformableTerrain::sweepOf(const Footprint& fp, Sweep& sw)
{
  sw.ca = fp.ca;
  sw.sa = fp.sa;
  const double ca = fp.ca, sa = fp.sa;
  const double dx = sw.dx = base_.dx(), dy = sw.dy = base_.dy();
  // Spacing of grid points across and along the footprint (exact when it is axis-aligned).
  sw.lateral_spacing = dx * std::abs(sa) + dy * std::abs(ca);
  sw.along_spacing = dx * std::abs(ca) + dy * std::abs(sa);
  sw.half_cell = 0.5 * sw.along_spacing;
  // A wheel's points reach half a cell beyond its rim: their cells are partly under it.
  sw.reach = fp.wheel ? fp.half_length + sw.half_cell : fp.half_length;
  // Axis-aligned bounds of the footprint rectangle (the wheel's is 2r x w), widened by the
  // on-edge tolerance so that the index range keeps a row of points lying on an edge.
  const double across_reach = fp.half_width + 0.5 * sw.lateral_spacing;  // cells partly under the band
  const double ext_x = sw.reach * std::abs(ca) + across_reach * std::abs(sa) + kOnEdge * (dx + dy);
  const double ext_y = sw.reach * std::abs(sa) + across_reach * std::abs(ca) + kOnEdge * (dx + dy);
  const double ox = sw.ox = base_.originX(), oy = sw.oy = base_.originY();
  if (!gridRange(fp.cx - ext_x, fp.cx + ext_x, ox, dx, base_.columns(), sw.i0, sw.i1) ||
      !gridRange(fp.cy - ext_y, fp.cy + ext_y, oy, dy, base_.rows(), sw.j0, sw.j1))
    return false;
  sw.r = fp.half_length;
  sw.r2 = sw.r * sw.r;
  sw.rolling = std::abs(fp.v_long) > kRollingSpeed;
  // A wheel presses nowhere its rim is above the window's highest surface: only cells within
  // `pressing` of the bottom along the footprint can (the exact per-cell test is in loadPoint).
  sw.pressing = sw.reach;
  if (!fp.wheel)
    return true;
  fillWindow(sw.i0 > 0 ? sw.i0 - 1 : 0, std::min(sw.i1 + 1, base_.columns() - 1), sw.j0 > 0 ? sw.j0 - 1 : 0,
             std::min(sw.j1 + 1, base_.rows() - 1));
  WindowPoint* w = window_.data();
  for (std::size_t b = 0; b < window_rows_; ++b)
  {
    const double y = oy + static_cast<double>(window_j0_ + b) * dy - fp.cy;
    for (std::size_t a = 0; a < window_columns_; ++a, ++w)
    {
      const double x = ox + static_cast<double>(window_i0_ + a) * dx - fp.cx;
      w->along = (x * ca + y * sa) * fp.travel;
    }
  }
  const double clear = fp.cz - window_top_;
  sw.pressing = clear >= sw.r ? -1.0 : (clear > 0.0 ? std::sqrt(sw.r2 - clear * clear) : sw.r);
  return true;
}

void DeformableTerrain::collect(const Footprint& fp, ContactForces& out)
{
  // Kinematics: T8 slip from the theoretical speed (T9/T10), regularised near rest, and the
  // slip angle from the lateral velocity.
  out.slip = regularisedSlip(fp.v_theoretical, fp.v_long);
  out.slip_angle = std::atan2(fp.v_lat, std::max(std::abs(fp.v_long), kSlipRegularisationSpeed));

  loaded_.clear();
  Sweep sw;
  if (!sweepOf(fp, sw))
    return;
  const double ca = sw.ca, sa = sw.sa, r = sw.r;
  double rigid_weight = 0.0, soil_weight = 0.0, rigid_best = 0.0;
  for (std::size_t j = sw.j0; j <= sw.j1; ++j)
  {
    const double py = sw.oy + j * sw.dy - fp.cy;
    const double py_sa = py * sa, py_ca = py * ca;
    const std::size_t tile_row = (j / kTileSize) * tiles_x_, in_row = (j % kTileSize) * kTileSize;
    const std::uint8_t* soil_row = soil_map_.empty() ? nullptr : soil_map_.data() + j * base_.columns();
    const float* base_row = base_.pointHeights().data() + j * base_.columns();  // (i, j) is in the grid
    std::size_t tile_column = tiles_x_;                                         // none yet
    const Tile* tile = nullptr;
    for (std::size_t i = sw.i0; i <= sw.i1; ++i)
    {
      const double px = sw.ox + i * sw.dx - fp.cx;
      const double u = px * ca + py_sa;
      const double v = -px * sa + py_ca;
      // Across the running gear each point carries the share of its cell (v +- half a spacing)
      // the band covers: the shares of a lattice line sum to the width / spacing at any offset,
      // also for a band narrower than a cell (a small robot's wheel on a 0.1 m grid). A point
      // whose cell is partly under the band records the pressing (the next step must find that
      // soil pressed, or the same wheel would keep bearing on virgin soil there); its share of
      // any flow is its share of the cell.
      const double across = std::min(fp.half_width, std::abs(v) + 0.5 * sw.lateral_spacing) -
                            std::max(-fp.half_width, std::abs(v) - 0.5 * sw.lateral_spacing);
      if (!(across > kOnEdge * sw.lateral_spacing) ||
          (fp.wheel ? std::abs(u) >= sw.reach : !withinEdge(r - std::abs(u), sw.along_spacing)))
        continue;
      const double lateral_weight = std::min(across / sw.lateral_spacing, 1.0);
      const std::uint8_t soil_index = soil_row ? soil_row[i] : 0;
      const bool rigid = contact_soils_[soil_index].model() == SinkageModel::kRigid;
      // Rigid or soil under the running gear's bottom (a wheel's lowest half radius, a plate).
      if (!fp.wheel || std::abs(u) <= 0.5 * r)
      {
        if (rigid)
        {
          rigid_weight += lateral_weight;
          if (lateral_weight > rigid_best)
          {
            rigid_best = lateral_weight;
            out.rigid_soil = soil_index;
          }
        }
        else
        {
          soil_weight += lateral_weight;
        }
      }
      if (rigid)
        continue;  // pavement: nothing sinks, the tyre deflects (the vehicle's contact)
      if (std::abs(u) - sw.half_cell > sw.pressing)
        continue;  // the rim clears this cell
      // The point's tile changes every kTileSize columns: one directory lookup per tile.
      if (i / kTileSize != tile_column)
      {
        tile_column = i / kTileSize;
        tile = tiles_[tile_row + tile_column].get();
      }
      const PointDeformation state = tile ? (*tile)[in_row + i % kTileSize] : PointDeformation{};
      loadPoint(fp, sw, i, j, u, v, lateral_weight, soil_index, state, base_row[i], out);
    }
  }
  if (rigid_weight > 0.0)
    out.rigid_share = rigid_weight / (rigid_weight + soil_weight);
  out.contact_points = static_cast<int>(loaded_.size());
  if (loaded_.empty())
    return;
  if (fp.wheel)
  {
    // A wheel's contact starts where the soil does: strips behind the foremost loaded stretch.
    double front = -1e300, back = 1e300;
    for (const LoadedPoint& p : loaded_)
    {
      front = std::max(front, p.along1);
      back = std::min(back, p.along0);
    }
    for (LoadedPoint& p : loaded_)
    {
      p.x0 = front - p.along1;
      p.x1 = front - p.along0;
    }
    out.contact_length = front - back;
  }
  else
  {
    out.contact_length = fp.track_length;
  }
}

void DeformableTerrain::loadPoint(const Footprint& fp, const Sweep& sw, std::size_t i, std::size_t j, double u,
                                  double v, double lateral_weight, std::uint8_t soil_index,
                                  const PointDeformation& state, double base_z, ContactForces& out)
{
  const ContactSoil& soil = contact_soils_[soil_index];
  const double surface = base_z - state.plastic - state.displaced;
  const double deformation = state.plastic + state.displaced;  // float sum, as T3's z
  const bool bekker = soil.model() == SinkageModel::kBekker;
  const double modulus = bekker ? soil.bekkerModulus(fp.bekker_b) : 0.0;
  const auto load = [&](double penetration) {
    return bekker ? soil.bekkerLoad(modulus, state.plastic, penetration)
                  : soil.simpleLoad(state.plastic, deformation, state.sigma_max, penetration);
  };
  // Built in place (the point is dropped again where it carries nothing): no copy of it.
  LoadedPoint& p = loaded_.emplace_back();
  p.i = static_cast<std::uint32_t>(i);
  p.j = static_cast<std::uint32_t>(j);
  p.soil = soil_index;
  p.weight = lateral_weight;
  p.pressed = 1.0;
  double bottom = 0.0;
  bool kept = true;
  if (fp.wheel)
  {
    bottom = fp.cz - std::sqrt(std::max(sw.r2 - u * u, 0.0));
    p.penetration = std::abs(u) < sw.r ? surface - bottom : 0.0;
    p.deforms = p.penetration > 0.0;
    // If the rim's bottom passed over the point during the step, the point records the
    // bottom's depth (not the rim's flank where it is now): a rut's floor then has no ripple
    // of the step's travel, on which the next wheel would bounce.
    const double along = u * fp.travel;
    const double recorded =
        p.deforms && along <= 0.0 && along + fp.swept >= 0.0 ? surface - (fp.cz - sw.r) : p.penetration;
    const PointLoad at_point = p.deforms ? load(recorded) : PointLoad{};
    p.sigma_point = at_point.sigma;
    p.virgin = at_point.virgin;
    p.depth = state.plastic + recorded;
    kept = loadWheelCell(fp, sw, p, u, surface, soil, modulus);
  }
  else
  {
    bottom = fp.cz + fp.slope_u * u + fp.slope_v * v;
    p.penetration = surface - bottom;
    kept = p.penetration > 0.0;
    if (kept)
    {
      p.deforms = true;
      const PointLoad at_point = load(p.penetration);
      p.sigma = p.sigma_point = at_point.sigma;
      p.slope = at_point.slope;
      p.unload = at_point.unload;
      p.virgin = at_point.virgin;
      placeTrackStrip(fp, sw, p, u);
    }
  }
  if (!kept || !(p.sigma > 0.0))
  {
    loaded_.pop_back();
    return;
  }
  if (!fp.wheel)
    p.depth = state.plastic + p.penetration;
  p.elastic = bekker ? (soil.k_unload > 0.0 ? p.sigma_point / soil.k_unload : 0.0)
                     : soil.elasticSinkage(p.sigma_point, deformation);
  // Sinkage where the gear carries load, pressing on (deforming) or resting on soil it has
  // pressed before (a parked wheel's point at its own imprint).
  if (p.deforms || (p.sigma > 0.0 && (!fp.wheel || std::abs(u) < sw.r)))
    out.sinkage = std::max(out.sinkage, base_z - bottom);
  out.elastic_sinkage = std::max(out.elastic_sinkage, p.elastic);
}

void DeformableTerrain::placeTrackStrip(const Footprint& fp, const Sweep& sw, LoadedPoint& p, double u) const
{
  // A track's strip, m behind the whole track's leading edge (T11's j = s x keeps growing
  // over segments); the points nearest the patch's ends reach to them.
  const double along = u * fp.travel;
  const double x = 0.5 * fp.track_length - (fp.segment_offset * fp.travel + along);
  const double to_lead = sw.r - along, to_trail = sw.r + along;
  const double near_end = (1.0 - kOnEdge) * sw.along_spacing;
  p.x0 = to_lead < near_end ? x - to_lead : x - 0.5 * sw.along_spacing;
  p.x1 = to_trail < near_end ? x + to_trail : x + 0.5 * sw.along_spacing;
  p.weight *= (p.x1 - p.x0) / sw.along_spacing;
}

bool DeformableTerrain::rimClearsCell(const Footprint& fp, const Sweep& sw, const LoadedPoint& p, double lo,
                                      double hi) const
{
  // Every sample of the point's cell interpolates between the window points (i +- 1, j +- 1),
  // so its surface is at most max(base - displaced) - min(plastic) over them (the front arc's
  // cap only lowers plastic to at least the least of its corners); if the rim's lowest point
  // over the cell is above that, nothing there presses, as the samples would find.
  const std::size_t wi = p.i - window_i0_, wj = p.j - window_j0_;
  const std::size_t a0 = wi > 0 ? wi - 1 : 0, a1 = std::min(wi + 1, window_columns_ - 1);
  const std::size_t b0 = wj > 0 ? wj - 1 : 0, b1 = std::min(wj + 1, window_rows_ - 1);
  double top = -std::numeric_limits<double>::infinity(), least_plastic = std::numeric_limits<double>::infinity();
  for (std::size_t wb = b0; wb <= b1; ++wb)
    for (std::size_t wa = a0; wa <= a1; ++wa)
    {
      const WindowPoint& w = window_[wb * window_columns_ + wa];
      top = std::max(top, w.base - w.displaced);
      least_plastic = std::min(least_plastic, w.plastic);
    }
  const double nearest = lo > 0.0 ? lo : (hi < 0.0 ? -hi : 0.0);
  const double rim_low = fp.cz - std::sqrt(std::max(sw.r2 - nearest * nearest, 0.0));
  return rim_low > top - least_plastic;
}

bool DeformableTerrain::loadWheelCell(const Footprint& fp, const Sweep& sw, LoadedPoint& p, double u, double surface,
                                      const ContactSoil& soil, double modulus) const
{
  // The point stands for its cell, u +- half a cell along the footprint: the cell carries the
  // mean pressure over it, integrated by two Gauss points on each stretch between the places
  // where the pressure has a kink (the rim's bottom, behind which the soil has been pressed
  // already, and where the rim meets the point's surface), each with the soil's state
  // interpolated (bilinearly) between the grid points around it and the rim's own height
  // there. A rut's floor between points then follows the imprint the points record, and the
  // wheel's edge cuts a cell where it really does: a 0.1 m grid integrates a wheel's pressure
  // about as finely as a fine one, instead of each point taking its whole cell at its own
  // pressure or nothing.
  const double r = sw.r, r2 = sw.r2;
  const double gx = sw.ox + p.i * sw.dx, gy = sw.oy + p.j * sw.dy;
  const double lo = std::max(u - sw.half_cell, -r), hi = std::min(u + sw.half_cell, r);
  // Quick exit for the cells the rim clears (most of a wheel's upper arc): exact, the same
  // result without the samples.
  if (!p.deforms && rimClearsCell(fp, sw, p, lo, hi))
    return false;
  const bool bekker = soil.model() == SinkageModel::kBekker;
  double breaks[5] = { lo, 0.0, 0.0, 0.0, hi };
  int count = 1;
  const double below_axle = fp.cz - surface;
  const double edge = below_axle > 0.0 && below_axle < r ? std::sqrt(r2 - below_axle * below_axle) : r;
  for (const double at : { -edge, 0.0, edge })
    if (at > lo && at < hi)
      breaks[count++] = at;
  breaks[count] = hi;
  std::sort(breaks + 1, breaks + count);
  double pressed = 0.0, pressed_lo = hi, pressed_hi = lo;  // the pressed stretch, u
  for (int k = 0; k < count; ++k)
  {
    const double mid = 0.5 * (breaks[k] + breaks[k + 1]), half = 0.5 * (breaks[k + 1] - breaks[k]);
    if (!(half > 0.0))
      continue;
    const double at_sample[2] = { mid - kGauss * half, mid + kGauss * half };
    double pens[2];
    for (int g = 0; g < 2; ++g)
    {
      const double us = at_sample[g];
      const double offset = us - u;
      // Behind the bottom of a rolling wheel the soil was pressed by the bottom itself; a
      // wheel at rest (pressed straight down) is the same front and back.
      const double side = sw.rolling ? (us * fp.travel < 0.0 ? 1.0 : -1.0) : 0.0;
      const WindowPoint w = windowState(gx + offset * sw.ca, gy + offset * sw.sa, side, !bekker);
      // Ahead of a rolling wheel's bottom, between a point its front arc has pressed and one
      // it has not reached, the linear interpolant runs above the arc's imprint (the imprint
      // ends at the arc's leading edge): the soil there has been pressed at most where the
      // rim was a step ago, unless it was deeper before (the least of the points around it).
      // Without the cap a coarse grid's front arc loses its pressure near the leading edge:
      // the wheel sinks deeper and resists less with the bottom mid-cell.
      double plastic = w.plastic;
      if (side < 0.0)
      {
        const double back = us + fp.travel * fp.swept;
        const double imprint = std::abs(back) < r ? w.base - w.displaced - (fp.cz - std::sqrt(r2 - back * back)) : 0.0;
        plastic = std::min(plastic, std::max(imprint, w.plastic_min));
      }
      const double rim_depth = std::sqrt(r2 - us * us);  // the rim below the axle here
      pens[g] = w.base - plastic - w.displaced - (fp.cz - rim_depth);
      if (!(pens[g] > 0.0))
        continue;
      const PointLoad at = bekker ? soil.bekkerLoad(modulus, plastic, pens[g])
                                  : soil.simpleLoad(plastic, plastic + w.displaced, w.sigma_max, pens[g]);
      const double share = half / sw.along_spacing;  // of the cell, this sample's
      p.sigma += share * at.sigma;
      p.slope += share * at.slope;
      p.unload += share * at.unload;
      // The rim's push along / across the ground where this sample presses (Bekker
      // compaction): tan(theta - beta), theta the rim's angle from the vertical, beta the
      // ground's slope, both along the travel.
      if (bekker)
      {
        const double rim = us * fp.travel / rim_depth, ground = fp.ground_slope * fp.travel;
        p.rim_slope +=
            share * at.sigma * std::clamp((rim - ground) / (1.0 + rim * ground), -kMaxRimSlope, kMaxRimSlope);
      }
    }
    // The pressed part of this stretch: all of it, or up to where the penetration crosses 0
    // between the samples (linearly): the contact's edges at sub-sample resolution.
    const bool in0 = pens[0] > 0.0, in1 = pens[1] > 0.0;
    if (in0 || in1)
    {
      double from = breaks[k], to = breaks[k + 1];
      if (in0 != in1)
      {
        const double root = at_sample[0] + (at_sample[1] - at_sample[0]) * pens[0] / (pens[0] - pens[1]);
        (in0 ? to : from) = std::clamp(root, breaks[k], breaks[k + 1]);
      }
      pressed += (to - from) / sw.along_spacing;
      pressed_lo = std::min(pressed_lo, from);
      pressed_hi = std::max(pressed_hi, to);
    }
  }
  if (!(p.sigma > 0.0) && !p.deforms)
    return false;
  p.pressed = std::min(pressed, 1.0);
  if (p.sigma > 0.0)
    p.rim_slope /= p.sigma;
  // Its strip along the travel is the stretch the rim presses (a cell the contact's leading
  // edge crosses counts from that edge: the shear displacement j = s x starts there).
  if (!(pressed_hi > pressed_lo))
    pressed_lo = pressed_hi = u;
  p.along0 = fp.travel > 0.0 ? pressed_lo : -pressed_hi;
  p.along1 = fp.travel > 0.0 ? pressed_hi : -pressed_lo;
  return true;
}

namespace
{
/// exp(-s x / K) at a strip's ends from its value at the centre: one exp per point, and one per
/// soil and strip length for the half-strip factor, kept in a small cache: a footprint's rows
/// alternate between a few strip lengths (interior, and the shorter ones at its edges).
struct StripConstants
{
  int soil = -1;
  double half = -1.0, inv_k = 0.0, half_factor = 1.0, inv_half_factor = 1.0, scale = 0.0;
  /// exp(-cap / K): the same for every strip of the soil past the cap; NaN until needed.
  double cap_factor = std::numeric_limits<double>::quiet_NaN();
};

/// The last few StripConstants of one contact, looked up by soil and half strip length.
class StripCache
{
public:
  explicit StripCache(double slip_magnitude) : slip_magnitude_(slip_magnitude) {}

  StripConstants& get(int soil, double half, double shear_modulus)
  {
    if (strip_ && soil == strip_->soil && half == strip_->half)
      return *strip_;
    strip_ = nullptr;
    for (StripConstants& c : strips_)
      if (c.soil == soil && c.half == half)
        strip_ = &c;
    if (strip_)
      return *strip_;
    StripConstants& c = strips_[next_];
    next_ = (next_ + 1) % strips_.size();
    const double k = shear_modulus;
    c.soil = soil;
    c.half = half;
    c.inv_k = 1.0 / k;
    c.half_factor = std::exp(slip_magnitude_ * half * c.inv_k);
    c.inv_half_factor = 1.0 / c.half_factor;
    c.scale = k / (slip_magnitude_ * 2.0 * half);
    c.cap_factor = std::numeric_limits<double>::quiet_NaN();
    strip_ = &c;
    return c;
  }

private:
  double slip_magnitude_;
  std::array<StripConstants, 4> strips_{};
  std::size_t next_ = 0;
  StripConstants* strip_ = nullptr;
};

/// A strip's mean shear factor 1 - exp(-j / K) over [x0, x1] with j = min(|s| x, cap), and its
/// slopes in |s| (dmean) and in the cap (dcap).
struct StripShear
{
  double mean = 0.0, dmean = 0.0, dcap = 0.0;
};

StripShear stripShear(StripConstants& strip, double slip_magnitude, double shear_cap, double x0, double x1)
{
  StripShear out;
  const double half = 0.5 * (x1 - x0), inv_k = strip.inv_k;
  if (slip_magnitude * x1 <= shear_cap)
  {
    const double e_mid = std::exp(-slip_magnitude * (x0 + half) * inv_k);
    const double e0 = x0 > 0.0 ? e_mid * strip.half_factor : 1.0;
    out.mean = meanShearFactor(slip_magnitude * inv_k, x0, x1, strip.scale, e0, e_mid * strip.inv_half_factor, inv_k,
                               out.dmean);
    return out;
  }
  // Behind x_c = cap / |s| the soil is displaced by the cap (it has been under the contact all
  // along); ahead of it by |s| x. Means over the strip, and their slopes in |s| and in the cap
  // (the boundary terms cancel).
  const double xc = std::max(shear_cap / slip_magnitude, x0), span = x1 - x0;
  if (std::isnan(strip.cap_factor))
    strip.cap_factor = std::exp(-shear_cap * inv_k);
  const double ec = strip.cap_factor;
  double part = 0.0, dpart = 0.0;
  if (!(span > 1e-12))
  {
    out.mean = 1.0 - ec;  // a point strip, all of it at the cap
    out.dcap = inv_k * ec;
  }
  else if (xc > x0)
  {
    const double e0 = std::exp(-slip_magnitude * x0 * inv_k);
    const double k = 1.0 / inv_k;
    part = (xc - x0) - k / slip_magnitude * (e0 - ec);
    dpart = (x0 * e0 - xc * ec) / slip_magnitude + k / (slip_magnitude * slip_magnitude) * (e0 - ec);
  }
  if (span > 1e-12)
  {
    out.mean = (part + (x1 - xc) * (1.0 - ec)) / span;
    out.dmean = dpart / span;
    out.dcap = (x1 - xc) * inv_k * ec / span;
  }
  return out;
}
}  // namespace

void DeformableTerrain::forcesAndDeform(const Footprint& fp, double dt, bool deform, ObjectSet* objects,
                                        ContactForces& out)
{
  if (loaded_.empty())
    return;
  sumForces(fp, out);
  if (objects)
    vegetation(fp, deform, *objects, out);
  if (!deform)
    return;
  deformLoaded(fp, dt);
  if (options_.transport)
  {
    chooseDragStep(fp);
    spreadFlow();
  }
}

void DeformableTerrain::sumForces(const Footprint& fp, ContactForces& out) const
{
  // Normal force, and traction per strip with j = s x behind the leading edge (T7, T11).
  const double area = base_.dx() * base_.dy();
  double max_penetration = 0.0;
  for (const LoadedPoint& p : loaded_)
    max_penetration = std::max(max_penetration, p.penetration);
  const double slip_magnitude = std::hypot(fp.shear_long, fp.shear_lat);
  StripCache strips(slip_magnitude);
  // T12 per point so that each soil brings its own strength and f: bulldozing shared in
  // proportion to the loaded area, (c + sigma tan phi) w z_rel A_k / A; rolling f sigma A_k.
  // Bekker points instead resist by compaction: a wheel's rim pushes back with
  // sigma A_k tan(angle); a track does the compaction work b k z^(n+1) / (n + 1) per metre,
  // shared over its length.
  double bulldozing = 0.0, rolling = 0.0, compaction = 0.0, total_weight = 0.0;
  for (const LoadedPoint& p : loaded_)
  {
    const ContactSoil& soil = contact_soils_[p.soil];
    // Cohesion over the part of the cell the gear presses, friction on the cell's mean pressure.
    const double strength = soil.cohesion * p.pressed + std::max(p.sigma, 0.0) * soil.tan_phi;
    const double cell = area * p.weight;
    const double load = p.sigma * cell;
    out.normal_force += load;
    out.shear_strength += strength * cell;
    out.shear_elastic_slope += strength / soil.shear_modulus * cell;
    out.normal_stiffness += p.slope * cell;
    out.unload_stiffness += p.unload * cell;
    total_weight += p.weight;
    if (soil.model() == SinkageModel::kSimple)
    {
      bulldozing += strength * p.weight;
      rolling += soil.rolling_resistance * load;
    }
    else if (fp.wheel)
    {
      compaction += load * p.rim_slope;
    }
    else
    {
      compaction += cell / fp.track_length * p.sigma * p.depth / (soil.n + 1.0);
    }
    if (!(slip_magnitude > 0.0))
    {
      // At s = 0 the slopes of the two limits: all soil displaced by |s| x (rolling), or all by
      // the cap (at rest); a caller between them takes the lesser.
      out.shear_slope += strength * 0.5 * (p.x0 + p.x1) / soil.shear_modulus * cell;  // d|F|/ds at s = 0
      if (std::isfinite(fp.shear_cap))
        out.shear_cap_slope += strength / soil.shear_modulus * cell;
    }
    if (slip_magnitude > 0.0)
    {
      StripConstants& strip = strips.get(p.soil, 0.5 * (p.x1 - p.x0), soil.shear_modulus);
      const StripShear shear = stripShear(strip, slip_magnitude, fp.shear_cap, p.x0, p.x1);
      const double tau = strength * shear.mean * cell / slip_magnitude;
      out.longitudinal_force += fp.shear_long * tau;
      out.lateral_force += fp.shear_lat * tau;
      out.shear_slope += strength * shear.dmean * cell;
      out.shear_cap_slope += strength * shear.dcap * cell;
    }
  }
  // T12 with the depth of the soil ahead (largest penetration): for one simple soil this is
  // (c + mean sigma tan phi) w z_rel + f A mean sigma. A wheel pressed into Bekker soil at rest
  // is pushed back as much as forward: no net compaction resistance. Its size, whichever way the
  // wheel is about to move (at rest the travel's sign is a rounding's), is what the soil resists
  // with.
  out.resistance_force =
      bulldozing / total_weight * (2.0 * fp.half_width) * max_penetration + rolling + std::abs(compaction);
}

void DeformableTerrain::deformLoaded(const Footprint& fp, double dt)
{
  const double area = base_.dx() * base_.dy();
  const double slip_speed = std::hypot(fp.v_theoretical - fp.v_long, fp.v_lat);  // v_r of T4
  // loaded_ runs row by row: its points change tile every few points, so touch() (allocation,
  // change tracking) once per run of one tile and index the tile directly.
  std::size_t tile_index = tiles_.size();  // none yet
  Tile* tile = nullptr;
  for (LoadedPoint& p : loaded_)
  {
    p.flow_volume = 0.0;
    if (!p.deforms)
      continue;  // only part of its cell is under the rim: the point itself is not pressed
    const ContactSoil& soil = contact_soils_[p.soil];
    const std::size_t t = tileIndex(p.i, p.j);
    if (t != tile_index)
    {
      touch(p.i, p.j);
      tile_index = t;
      tile = tiles_[t].get();
    }
    PointDeformation& state = (*tile)[(p.j % kTileSize) * kTileSize + p.i % kTileSize];
    const float sigma_before = state.sigma_max;
    const double sigma_max = std::max<double>(p.sigma_point, sigma_before);
    const double shear_flow = soil.b2 * p.sigma_point * slip_speed * dt * std::min(p.weight, 1.0);
    double flow = shear_flow;
    if (soil.model() == SinkageModel::kBekker)
    {
      // A yielding point keeps its depth less the elastic springback; a reloaded one keeps its
      // state (it is back at its rebounded surface once the wheel has gone).
      if (p.virgin)
        state.plastic = std::max(state.plastic, static_cast<float>(p.depth - p.elastic));
    }
    else
    {
      flow += soil.b1 * std::max(p.sigma_point - sigma_before, 0.0) * std::min(p.weight, 1.0);
      state.plastic = std::max(state.plastic, static_cast<float>(soil.plasticSinkage(sigma_max)));
    }
    state.sigma_max = static_cast<float>(sigma_max);
    state.displaced += static_cast<float>(flow);
    // What the point lost, as stored (float), is what transport hands on.
    p.flow_volume = static_cast<double>(static_cast<float>(flow)) * area;
    p.shear_fraction = flow > 0.0 ? shear_flow / flow : 0.0;
    flowed_volume_ += p.flow_volume;
  }
}

void DeformableTerrain::chooseDragStep(const Footprint& fp)
{
  // Sheared soil is dragged along with the running gear's slip over the ground: a wheel or
  // track spinning forward throws it back (ruts deepen under slip, soil lands behind).
  const double slip_long = fp.v_long - fp.v_theoretical, slip_lat = fp.v_lat;
  const double magnitude = std::hypot(slip_long, slip_lat);
  const double fx = magnitude > 0.0 ? (slip_long * fp.ca - slip_lat * fp.sa) / magnitude : 0.0;
  const double fy = magnitude > 0.0 ? (slip_long * fp.sa + slip_lat * fp.ca) / magnitude : 0.0;
  // The grid step (one of the 8) nearest that direction.
  drag_di_ = drag_dj_ = 0;
  double best = 0.0;
  for (int dj = -1; dj <= 1; ++dj)
    for (int di = -1; di <= 1; ++di)
    {
      if (di == 0 && dj == 0)
        continue;
      const double cosine = (di * base_.dx() * fx + dj * base_.dy() * fy) / step_length_[(dj + 1) * 3 + (di + 1)];
      if (cosine > best)
      {
        best = cosine;
        drag_di_ = di;
        drag_dj_ = dj;
      }
    }
}

std::size_t DeformableTerrain::deformedPoints() const
{
  std::size_t count = 0;
  for (const auto& tile : tiles_)
    if (tile)
      for (const PointDeformation& p : *tile)
        count += (p.plastic != 0.f || p.displaced != 0.f || p.sigma_max != 0.f);
  return count;
}

std::size_t DeformableTerrain::deformationBytes() const
{
  // The allocated tiles; the directory (one pointer per tile, touched or not) is a fixed
  // cost of the grid like its base heights: see directoryBytes().
  return allocated_tiles_ * sizeof(Tile);
}

std::vector<std::pair<std::size_t, std::size_t>> DeformableTerrain::statefulPoints() const
{
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t t = 0; t < tiles_.size(); ++t)
  {
    if (!tiles_[t])
      continue;
    const std::size_t i0 = (t % tiles_x_) * kTileSize, j0 = (t / tiles_x_) * kTileSize;
    for (std::size_t b = 0; b < kTileSize; ++b)
      for (std::size_t a = 0; a < kTileSize; ++a)
        if (i0 + a < base_.columns() && j0 + b < base_.rows())
          out.emplace_back(i0 + a, j0 + b);
  }
  return out;
}

std::size_t DeformableTerrain::directoryBytes() const
{
  return tiles_.size() * sizeof(std::unique_ptr<Tile>);
}

std::vector<SoilParameters> paletteFromNames(const std::vector<std::string>& names, const SoilLibrary& library)
{
  std::vector<SoilParameters> palette;
  palette.reserve(names.size());
  for (const std::string& name : names)
    palette.push_back(library.get(name));
  return palette;
}

}  // namespace terrain
}  // namespace avsp
