#include "avsp_terrain/deformable_terrain.hpp"

#include <algorithm>
#include <cmath>
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
bool gridRange(double lo, double hi, double origin, double d, std::size_t count, std::size_t& first,
               std::size_t& last)
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

/// Share of a grid point's cell inside a band edge (point `inside` m within the edge, cells
/// `spacing` m apart across it): 1/2 on the edge, rising linearly; the outermost point inside
/// (inside < spacing) also takes the part of the next cell out, so a lattice line of points
/// across a band sums to exactly band width / spacing for any offset.
double edgeWeight(double inside, double spacing)
{
  return inside < (1.0 - kOnEdge) * spacing ? inside / spacing + 0.5 : 1.0;
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

/// Mean of (1 - exp(-s x / K)) over the strip [x0, x1] (meanShearStress() without its
/// strength factor), from s / K, K / (s (x1 - x0)) and e0 = exp(-s x0 / K), e1 = exp(-s x1 / K)
/// the caller has; for s x / K -> 0 the bracket vanishes like s: the limit form avoids the
/// cancellation.
double meanShearFactor(double s_over_k, double x0, double x1, double scale, double e0, double e1)
{
  if (s_over_k * x1 < 1e-8)
    return s_over_k * (x0 + x1) * 0.5;
  return 1.0 - scale * (e0 - e1);
}
}  // namespace

DeformableTerrain::DeformableTerrain(ElevationGrid base, SoilParameters soil, Options options)
  : base_(std::move(base))
  , palette_{ std::move(soil) }
  , contact_soils_(prepareSoils(palette_))
  , options_(options)
  , tiles_x_((base_.columns() + kTileSize - 1) / kTileSize)
  , tiles_(tiles_x_ * ((base_.rows() + kTileSize - 1) / kTileSize))
{
}

DeformableTerrain::DeformableTerrain(ElevationGrid base, std::vector<SoilParameters> palette,
                                     std::vector<std::uint8_t> soil_map, Options options)
  : base_(std::move(base))
  , palette_(std::move(palette))
  , contact_soils_(prepareSoils(palette_))
  , soil_map_(std::move(soil_map))
  , options_(options)
  , tiles_x_((base_.columns() + kTileSize - 1) / kTileSize)
  , tiles_(tiles_x_ * ((base_.rows() + kTileSize - 1) / kTileSize))
{
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
  double cx = 0.0, cy = 0.0, cz = 0.0;  ///< m: wheel centre, or the track face's centre
  double ca = 1.0, sa = 0.0;            ///< cos and sin of the heading
  double half_length = 0.0;             ///< m: the wheel's radius, or half the track patch's length
  double half_width = 0.0;              ///< m
  double bekker_b = 0.0;                ///< m, b of k_c / b: wheel width; a track's smaller dimension
  double track_length = 0.0;            ///< m, whole track's ground contact (tracks)
  double segment_offset = 0.0;          ///< m, patch centre from the whole track's centre, + forward
  double v_long = 0.0, v_lat = 0.0;     ///< m/s, in the footprint's frame
  double v_theoretical = 0.0;           ///< m/s, T9 or T10
  double travel = 1.0;                  ///< +1 moving forward, -1 backward
};

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
  for (const auto& [nx, ny] : { std::pair<double, double>{ a.ax, a.ay }, { -a.ay, a.ax }, { b.ax, b.ay },
                                { -b.ay, b.ax } })
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
  const Box footprint{ fp.cx + um * fp.ca - vm * fp.sa, fp.cy + um * fp.sa + vm * fp.ca, fp.ca, fp.sa,
                       0.5 * (u1 - u0), 0.5 * (v1 - v0) };
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

void DeformableTerrain::spreadFlow()
{
  // f(z_f, d) of T5: each point's flowed volume goes to its 8 neighbours weighted by 1/d, so
  // what leaves one point arrives exactly at others (volume leaving = volume arriving). The
  // arrivals of the whole contact are summed in a small window around the loaded points first
  // and applied once per receiving point: no tile lookups per share.
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
  // The sum of the 8 weights of an interior point, in the loop's order below.
  static const double kInteriorTotal = [] {
    double t = 0.0;
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di)
        if (di != 0 || dj != 0)
          t += (di != 0 && dj != 0) ? M_SQRT1_2 : 1.0;
    return t;
  }();
  const double area = base_.dx() * base_.dy();
  const long columns = static_cast<long>(base_.columns()), rows = static_cast<long>(base_.rows());
  double arrived = 0.0;  // summed here, not in the member: the loop would store it every share
  const long w = static_cast<long>(width);  // a window row
  for (const LoadedPoint& p : loaded_)
  {
    if (!(p.flow_volume > 0.0))
      continue;
    const long i = p.i, j = p.j;
    double* centre = arrivals_.data() + (j - static_cast<long>(wj0)) * w + (i - static_cast<long>(wi0));
    if (i > 0 && j > 0 && i + 1 < columns && j + 1 < rows)
    {
      // Per unit weight: volume (m^3) and height (m) at a neighbour; two divisions per point.
      const double volume = p.flow_volume / kInteriorTotal, height = volume / area;
      // The 8 neighbours in a fixed order, weights 1/sqrt(2) diagonally and 1 (x 1.0: exact) along.
      const double diagonal = height * M_SQRT1_2;
      double* south = centre - w;
      double* north = centre + w;
      south[-1] += diagonal;
      south[0] += height;
      south[1] += diagonal;
      centre[-1] += height;
      centre[1] += height;
      north[-1] += diagonal;
      north[0] += height;
      north[1] += diagonal;
      arrived += volume * kInteriorTotal;
      continue;
    }
    // On the grid's border only the neighbours that exist share the volume.
    const auto inside = [&](long ni, long nj) { return ni >= 0 && nj >= 0 && ni < columns && nj < rows; };
    double total = 0.0;
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di)
        if ((di != 0 || dj != 0) && inside(i + di, j + dj))
          total += (di != 0 && dj != 0) ? M_SQRT1_2 : 1.0;
    const double volume = p.flow_volume / total, height = volume / area;
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di)
        if ((di != 0 || dj != 0) && inside(i + di, j + dj))
          centre[dj * w + di] += height * ((di != 0 && dj != 0) ? M_SQRT1_2 : 1.0);
    arrived += volume * total;
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
  if (!(dt >= 0.0) || !std::isfinite(dt))
    rejectArgument(kFn, "dt", "finite and >= 0", dt);
  const double whole = track.track_length == 0.0 ? track.length : track.track_length;
  if (!(whole >= track.length) || !std::isfinite(whole))
    rejectArgument(kFn, "track.track_length", "0 (the patch is the whole track) or >= track.length",
                   track.track_length);
  // The patch must lie on the track (a rounding's worth of slack for segments laid end to end).
  if (std::abs(track.segment_offset) + 0.5 * track.length > 0.5 * whole * (1.0 + 1e-12))
    rejectArgument(kFn, "track.segment_offset", "such that the patch lies within track_length",
                   track.segment_offset);

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
  fp.travel = (std::abs(fp.v_long) > 1e-6) ? (fp.v_long < 0 ? -1.0 : 1.0) :
                                             (track.sprocket_spin_rate < 0 ? -1.0 : 1.0);
  ContactForces out;
  collect(fp, out);
  forcesAndDeform(fp, dt, deform, objects, out);
  return out;
}

void DeformableTerrain::collect(const Footprint& fp, ContactForces& out)
{
  // Kinematics: T8 slip from the theoretical speed (T9/T10), slip angle from the lateral velocity.
  out.slip = longitudinalSlip(fp.v_theoretical, fp.v_long);
  out.slip_angle =
      (std::abs(fp.v_long) + std::abs(fp.v_lat) > 1e-9) ? std::atan2(fp.v_lat, std::abs(fp.v_long)) : 0.0;

  loaded_.clear();
  const double ca = fp.ca, sa = fp.sa;
  // Axis-aligned bounds of the footprint rectangle (the wheel's is 2r x w), widened by the
  // on-edge tolerance so that the index range keeps a row of points lying on an edge.
  const double dx = base_.dx(), dy = base_.dy();
  const double ext_x = fp.half_length * std::abs(ca) + fp.half_width * std::abs(sa) + kOnEdge * (dx + dy);
  const double ext_y = fp.half_length * std::abs(sa) + fp.half_width * std::abs(ca) + kOnEdge * (dx + dy);
  const double ox = base_.originX(), oy = base_.originY();
  std::size_t i0 = 0, i1 = 0, j0 = 0, j1 = 0;
  if (!gridRange(fp.cx - ext_x, fp.cx + ext_x, ox, dx, base_.columns(), i0, i1) ||
      !gridRange(fp.cy - ext_y, fp.cy + ext_y, oy, dy, base_.rows(), j0, j1))
    return;
  const double r = fp.half_length, r2 = r * r;
  // Spacing of grid points across and along the footprint (exact when it is axis-aligned).
  const double lateral_spacing = dx * std::abs(sa) + dy * std::abs(ca);
  const double along_spacing = dx * std::abs(ca) + dy * std::abs(sa);
  for (std::size_t j = j0; j <= j1; ++j)
  {
    const double py = oy + j * dy - fp.cy;
    const double py_sa = py * sa, py_ca = py * ca;
    const std::size_t tile_row = (j / kTileSize) * tiles_x_, in_row = (j % kTileSize) * kTileSize;
    const std::uint8_t* soil_row = soil_map_.empty() ? nullptr : soil_map_.data() + j * base_.columns();
    const float* base_row = base_.pointHeights().data() + j * base_.columns();  // (i, j) is in the grid
    std::size_t tile_column = tiles_x_;  // none yet
    const Tile* tile = nullptr;
    for (std::size_t i = i0; i <= i1; ++i)
    {
      const double px = ox + i * dx - fp.cx;
      const double u = px * ca + py_sa;
      const double v = -px * sa + py_ca;
      if (!withinEdge(fp.half_width - std::abs(v), lateral_spacing) ||
          (fp.wheel ? std::abs(u) >= r : !withinEdge(r - std::abs(u), along_spacing)))
        continue;
      // The point's tile changes every kTileSize columns: one directory lookup per tile.
      if (i / kTileSize != tile_column)
      {
        tile_column = i / kTileSize;
        tile = tiles_[tile_row + tile_column].get();
      }
      const PointDeformation state = tile ? (*tile)[in_row + i % kTileSize] : PointDeformation{};
      const double base_z = base_row[i];
      const double surface = base_z - state.plastic - state.displaced;
      if (fp.wheel)
      {
        // Most of a wheel's 2r x w box is not under its rim: rule those points out on squares
        // (the rim is above a surface h below the axle where r^2 - u^2 <= h^2) before the sqrt.
        const double below_axle = fp.cz - surface;
        if (below_axle > 0.0 && below_axle * below_axle >= r2 - u * u)
          continue;
      }
      const double bottom = fp.wheel ? fp.cz - std::sqrt(r2 - u * u) : fp.cz;
      const double penetration = surface - bottom;
      if (!(penetration > 0.0))
        continue;
      const std::uint8_t soil_index = soil_row ? soil_row[i] : 0;
      const ContactSoil& soil = contact_soils_[soil_index];
      LoadedPoint p{ static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j), soil_index,
                     edgeWeight(fp.half_width - std::abs(v), lateral_spacing), u * fp.travel, 0.0, 0.0, penetration,
                     0.0, 0.0, 0.0, 0.0, 0.0 };
      if (!fp.wheel)
      {
        // A track's strip, m behind the whole track's leading edge (T11's j = s x keeps growing
        // over segments); the points nearest the patch's ends reach to them (edgeWeight).
        const double x = 0.5 * fp.track_length - (fp.segment_offset * fp.travel + p.along);
        const double to_lead = r - p.along, to_trail = r + p.along;
        const double near_end = (1.0 - kOnEdge) * along_spacing;
        p.x0 = to_lead < near_end ? x - to_lead : x - 0.5 * along_spacing;
        p.x1 = to_trail < near_end ? x + to_trail : x + 0.5 * along_spacing;
        p.weight *= (p.x1 - p.x0) / along_spacing;
      }
      if (soil.model() == SinkageModel::kBekker)
      {
        // Rigid-plastic Bekker: the pressure of the sinkage reached.
        p.depth = state.plastic + penetration;
        p.sigma = soil.bekkerPressure(soil.bekkerModulus(fp.bekker_b), p.depth);
        if (fp.wheel)
          p.rim_slope = std::clamp(p.along / std::sqrt(r2 - u * u), -kMaxRimSlope, kMaxRimSlope);
      }
      else
      {
        const double deformation = state.plastic + state.displaced;  // float sum, as T3's z
        p.sigma = soil.stressForPenetration(state.plastic, deformation, state.sigma_max, penetration);
        p.elastic = soil.elasticSinkage(p.sigma, deformation);
      }
      loaded_.push_back(p);
      out.sinkage = std::max(out.sinkage, base_z - bottom);
      out.elastic_sinkage = std::max(out.elastic_sinkage, p.elastic);
    }
  }
  out.contact_points = static_cast<int>(loaded_.size());
  if (fp.wheel && !loaded_.empty())
  {
    // A wheel's contact starts where the soil does: strips behind the foremost loaded point.
    double front = -1e300;
    for (const LoadedPoint& p : loaded_)
      front = std::max(front, p.along);
    front += 0.5 * dx;
    for (LoadedPoint& p : loaded_)
    {
      const double x = front - p.along;
      p.x0 = std::max(x - 0.5 * dx, 0.0);
      p.x1 = x + 0.5 * dx;
    }
  }
}

void DeformableTerrain::forcesAndDeform(const Footprint& fp, double dt, bool deform, ObjectSet* objects,
                                        ContactForces& out)
{
  if (loaded_.empty())
    return;
  // Normal force, and traction per strip with j = s x behind the leading edge (T7, T11).
  const double area = base_.dx() * base_.dy();
  double max_penetration = 0.0;
  for (const LoadedPoint& p : loaded_)
    max_penetration = std::max(max_penetration, p.penetration);
  const double lateral_slip = (1.0 - std::abs(out.slip)) * std::tan(out.slip_angle);
  const double slip_magnitude = std::hypot(out.slip, lateral_slip);
  // exp(-s x / K) at a strip's ends from its value at the centre: one exp per point, and one
  // per soil and strip length for the half-strip factor, kept in a small cache: a footprint's
  // rows alternate between a few strip lengths (interior, and the shorter ones at its edges).
  struct StripConstants
  {
    int soil = -1;
    double half = -1.0, inv_k = 0.0, half_factor = 1.0, inv_half_factor = 1.0, scale = 0.0;
  };
  std::array<StripConstants, 4> strips{};
  std::size_t strip_next = 0;
  const StripConstants* strip = nullptr;
  // T12 per point so that each soil brings its own strength and f: bulldozing shared in
  // proportion to the loaded area, (c + sigma tan phi) w z_rel A_k / A; rolling f sigma A_k.
  // Bekker points instead resist by compaction: a wheel's rim pushes back with
  // sigma A_k tan(angle); a track does the compaction work b k z^(n+1) / (n + 1) per metre,
  // shared over its length.
  double bulldozing = 0.0, rolling = 0.0, compaction = 0.0, total_weight = 0.0;
  for (const LoadedPoint& p : loaded_)
  {
    const ContactSoil& soil = contact_soils_[p.soil];
    const double strength = soil.cohesion + std::max(p.sigma, 0.0) * soil.tan_phi;
    const double load = p.sigma * area * p.weight;
    out.normal_force += load;
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
      compaction += area * p.weight / fp.track_length * p.sigma * p.depth / (soil.n + 1.0);
    }
    if (slip_magnitude > 0.0)
    {
      const double half = 0.5 * (p.x1 - p.x0);
      if (!strip || p.soil != strip->soil || half != strip->half)
      {
        strip = nullptr;
        for (const StripConstants& c : strips)
          if (c.soil == p.soil && c.half == half)
            strip = &c;
        if (!strip)
        {
          StripConstants& c = strips[strip_next];
          strip_next = (strip_next + 1) % strips.size();
          const double k = soil.shear_modulus;
          c.soil = p.soil;
          c.half = half;
          c.inv_k = 1.0 / k;
          c.half_factor = std::exp(slip_magnitude * half * c.inv_k);
          c.inv_half_factor = 1.0 / c.half_factor;
          c.scale = k / (slip_magnitude * 2.0 * half);
          strip = &c;
        }
      }
      const double inv_k = strip->inv_k;
      const double e_mid = std::exp(-slip_magnitude * (p.x0 + half) * inv_k);
      const double e0 = p.x0 > 0.0 ? e_mid * strip->half_factor : 1.0;
      const double mean =
          meanShearFactor(slip_magnitude * inv_k, p.x0, p.x1, strip->scale, e0, e_mid * strip->inv_half_factor);
      const double tau = strength * mean;
      out.longitudinal_force += fp.travel * (out.slip / slip_magnitude) * tau * area * p.weight;
      out.lateral_force -= (lateral_slip / slip_magnitude) * tau * area * p.weight;
    }
  }
  // T12 with the depth of the soil ahead (largest penetration): for one simple soil this is
  // (c + mean sigma tan phi) w z_rel + f A mean sigma. A wheel pressed into Bekker soil at rest
  // is pushed back as much as forward: no net compaction resistance, never a negative one.
  out.resistance_force =
      bulldozing / total_weight * (2.0 * fp.half_width) * max_penetration + rolling + std::max(compaction, 0.0);

  if (objects)
    vegetation(fp, deform, *objects, out);

  if (!deform)
    return;
  const double slip_speed = std::hypot(fp.v_theoretical - fp.v_long, fp.v_lat);  // v_r of T4
  // loaded_ runs row by row: its points change tile every few points, so touch() (allocation,
  // change tracking) once per run of one tile and index the tile directly.
  std::size_t tile_index = tiles_.size();  // none yet
  Tile* tile = nullptr;
  for (LoadedPoint& p : loaded_)
  {
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
    const double sigma_max = std::max<double>(p.sigma, sigma_before);
    double flow = soil.b2 * p.sigma * slip_speed * dt;
    if (soil.model() == SinkageModel::kBekker)
    {
      state.plastic = std::max(state.plastic, static_cast<float>(p.depth));  // the sinkage stays
    }
    else
    {
      flow += soil.b1 * std::max(p.sigma - sigma_before, 0.0);
      state.plastic = std::max(state.plastic, static_cast<float>(soil.plasticSinkage(sigma_max)));
    }
    state.sigma_max = static_cast<float>(sigma_max);
    state.displaced += static_cast<float>(flow);
    // What the point lost, as stored (float), is what transport hands on.
    p.flow_volume = static_cast<double>(static_cast<float>(flow)) * area;
    flowed_volume_ += p.flow_volume;
  }
  if (options_.transport)
    spreadFlow();
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
