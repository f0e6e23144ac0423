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

/// Share of a grid point's cell inside a band edge (point `inside` m within the edge, cells
/// `spacing` m apart across it): 1/2 on the edge, rising linearly; the outermost point inside
/// (inside < spacing) also takes the part of the next cell out, so a lattice line of points
/// across a band sums to exactly band width / spacing for any offset.
double edgeWeight(double inside, double spacing)
{
  return inside < spacing ? inside / spacing + 0.5 : 1.0;
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
/// strength factor), from e0 = exp(-s x0 / K) and e1 = exp(-s x1 / K) the caller has.
double meanShearFactor(double s, double k, double x0, double x1, double e0, double e1)
{
  if (s * x1 / k < 1e-8)
    return s * (x0 + x1) / (2.0 * k);
  return 1.0 - k / (s * (x1 - x0)) * (e0 - e1);
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
  if (i >= base_.columns() || j >= base_.rows())
    throw std::out_of_range("DeformableTerrain::soilIndex: point (" + std::to_string(i) + ", " + std::to_string(j) +
                            ") is outside the grid");
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
  std::unique_ptr<Tile>& tile = tiles_[tileIndex(i, j)];
  if (!tile)
  {
    tile = std::make_unique<Tile>();
    ++allocated_tiles_;
  }
  return (*tile)[(j % kTileSize) * kTileSize + i % kTileSize];
}

PointDeformation DeformableTerrain::deformation(std::size_t i, std::size_t j) const
{
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
  const auto cell = base_.cellAt(x, y);
  if (!cell)
    return std::nullopt;
  const double u = (x - base_.originX()) / base_.dx() - cell->i;
  const double v = (y - base_.originY()) / base_.dy() - cell->j;
  const std::size_t i = cell->i, j = cell->j;
  double h00 = base_.pointHeight(i, j), h10 = base_.pointHeight(i + 1, j);
  double h01 = base_.pointHeight(i, j + 1), h11 = base_.pointHeight(i + 1, j + 1);
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
      h00 = pointHeight(i, j);
      h10 = pointHeight(i + 1, j);
      h01 = pointHeight(i, j + 1);
      h11 = pointHeight(i + 1, j + 1);
    }
  }
  return ElevationGrid::bilinear(h00, h10, h01, h11, u, v);
}

void DeformableTerrain::spreadToNeighbours(std::size_t i, std::size_t j, double volume)
{
  // f(z_f, d) of T5: the flowed volume goes to the 8 neighbours weighted by 1/d, so what
  // leaves one point arrives exactly at others (volume leaving = volume arriving).
  const double area = base_.dx() * base_.dy();
  const bool interior = i > 0 && j > 0 && i + 1 < base_.columns() && j + 1 < base_.rows();
  double total = 0.0;
  if (interior)
  {
    // The sum of the 8 weights in the loop's order below (so it is the same double).
    static const double kInteriorTotal = [] {
      double t = 0.0;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
          if (di != 0 || dj != 0)
            t += (di != 0 && dj != 0) ? M_SQRT1_2 : 1.0;
      return t;
    }();
    total = kInteriorTotal;
  }
  else
  {
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di)
      {
        const long ni = static_cast<long>(i) + di, nj = static_cast<long>(j) + dj;
        if ((di != 0 || dj != 0) && ni >= 0 && nj >= 0 && ni < static_cast<long>(base_.columns()) &&
            nj < static_cast<long>(base_.rows()))
          total += (di != 0 && dj != 0) ? M_SQRT1_2 : 1.0;
      }
  }
  // Neighbours share a tile 36 times out of 64: keep the last tile's pointer.
  std::size_t cached = tiles_.size();
  Tile* tile = nullptr;
  for (int dj = -1; dj <= 1; ++dj)
  {
    for (int di = -1; di <= 1; ++di)
    {
      if (di == 0 && dj == 0)
        continue;
      const long ni = static_cast<long>(i) + di, nj = static_cast<long>(j) + dj;
      if (!interior &&
          (ni < 0 || nj < 0 || ni >= static_cast<long>(base_.columns()) || nj >= static_cast<long>(base_.rows())))
        continue;
      const std::size_t ti = tileIndex(static_cast<std::size_t>(ni), static_cast<std::size_t>(nj));
      if (ti != cached)
      {
        touch(static_cast<std::size_t>(ni), static_cast<std::size_t>(nj));  // allocates the tile if new
        cached = ti;
        tile = tiles_[ti].get();
      }
      const double w = (di != 0 && dj != 0) ? M_SQRT1_2 : 1.0;
      const double share = volume * w / total;
      (*tile)[(nj % kTileSize) * kTileSize + ni % kTileSize].displaced -= static_cast<float>(share / area);
      arrived_volume_ += share;
    }
  }
}

ContactForces DeformableTerrain::wheelContact(const WheelPatch& wheel, double dt, bool deform)
{
  static const char* const kFn = "DeformableTerrain::wheelContact";
  for (int k = 0; k < 3; ++k)
  {
    requireFinite(kFn, "wheel.centre", wheel.centre[k]);
    requireFinite(kFn, "wheel.velocity", wheel.velocity[k]);
  }
  requirePositive(kFn, "wheel.radius", wheel.radius);
  requirePositive(kFn, "wheel.width", wheel.width);
  requireFinite(kFn, "wheel.heading", wheel.heading);
  requireFinite(kFn, "wheel.spin_rate", wheel.spin_rate);
  if (!(dt >= 0.0) || !std::isfinite(dt))
    rejectArgument(kFn, "dt", "finite and >= 0", dt);

  ContactForces out;
  const double ca = std::cos(wheel.heading), sa = std::sin(wheel.heading);
  const double r = wheel.radius, half_w = 0.5 * wheel.width;
  // Axis-aligned bounds of the wheel's 2r x w footprint rectangle.
  const double ext_x = r * std::abs(ca) + half_w * std::abs(sa);
  const double ext_y = r * std::abs(sa) + half_w * std::abs(ca);
  const double dx = base_.dx(), dy = base_.dy();
  const double ox = base_.originX(), oy = base_.originY();
  const double cx = wheel.centre.x(), cy = wheel.centre.y(), cz = wheel.centre.z();

  // Kinematics: T8 slip from T9's theoretical speed, slip angle from the lateral velocity.
  const double v_long = wheel.velocity.x() * ca + wheel.velocity.y() * sa;
  const double v_lat = -wheel.velocity.x() * sa + wheel.velocity.y() * ca;
  const double v_theoretical = wheelTheoreticalSpeed(r, wheel.spin_rate);
  out.slip = longitudinalSlip(v_theoretical, v_long);
  out.slip_angle = (std::abs(v_long) + std::abs(v_lat) > 1e-9) ? std::atan2(v_lat, std::abs(v_long)) : 0.0;
  const double travel = (std::abs(v_long) > 1e-6) ? (v_long < 0 ? -1.0 : 1.0) : (wheel.spin_rate < 0 ? -1.0 : 1.0);

  loaded_.clear();
  std::size_t i0 = 0, i1 = 0, j0 = 0, j1 = 0;
  if (!gridRange(cx - ext_x, cx + ext_x, ox, dx, base_.columns(), i0, i1) ||
      !gridRange(cy - ext_y, cy + ext_y, oy, dy, base_.rows(), j0, j1))
    return out;
  const double r2 = r * r;
  // Spacing of grid points across the wheel (exact when it is axis-aligned).
  const double lateral_spacing = dx * std::abs(sa) + dy * std::abs(ca);
  for (std::size_t j = j0; j <= j1; ++j)
  {
    const double py = oy + j * dy - cy;
    const double py_sa = py * sa, py_ca = py * ca;
    const std::size_t tile_row = (j / kTileSize) * tiles_x_, in_row = (j % kTileSize) * kTileSize;
    const std::uint8_t* soil_row = soil_map_.empty() ? nullptr : soil_map_.data() + j * base_.columns();
    std::size_t tile_column = tiles_x_;  // none yet
    const Tile* tile = nullptr;
    for (std::size_t i = i0; i <= i1; ++i)
    {
      const double px = ox + i * dx - cx;
      const double u = px * ca + py_sa;
      const double v = -px * sa + py_ca;
      if (std::abs(u) >= r || std::abs(v) > half_w)
        continue;
      const double bottom = cz - std::sqrt(r2 - u * u);
      // The point's tile changes every kTileSize columns: one directory lookup per tile.
      if (i / kTileSize != tile_column)
      {
        tile_column = i / kTileSize;
        tile = tiles_[tile_row + tile_column].get();
      }
      const PointDeformation state = tile ? (*tile)[in_row + i % kTileSize] : PointDeformation{};
      const double base_z = base_.pointHeight(i, j);
      const double penetration = base_z - state.plastic - state.displaced - bottom;
      if (!(penetration > 0.0))
        continue;
      const std::uint8_t soil_index = soil_row ? soil_row[i] : 0;
      const ContactSoil& soil = contact_soils_[soil_index];
      LoadedPoint p{ static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j), soil_index,
                     edgeWeight(half_w - std::abs(v), lateral_spacing), u * travel, penetration, 0.0, 0.0, 0.0, 0.0 };
      if (soil.model() == SinkageModel::kBekker)
      {
        // Rigid-plastic Bekker: the pressure of the sinkage reached, b = wheel width (T13).
        p.depth = state.plastic + penetration;
        p.sigma = soil.bekkerPressure(soil.bekkerModulus(wheel.width), p.depth);
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
  if (loaded_.empty())
    return out;

  // Normal force, and traction per strip with j = s x behind the leading edge (T7, T11).
  const double area = dx * dy;
  double front = -1e300, max_penetration = 0.0;
  for (const LoadedPoint& p : loaded_)
  {
    front = std::max(front, p.along);
    max_penetration = std::max(max_penetration, p.penetration);
  }
  front += 0.5 * dx;
  const double lateral_slip = (1.0 - std::abs(out.slip)) * std::tan(out.slip_angle);
  const double slip_magnitude = std::hypot(out.slip, lateral_slip);
  // exp(-s x / K) at a strip's ends from its value at the centre: one exp per point (and
  // one per change of soil along the loop for the strip's half-width factor).
  int strip_soil = -1;
  double half_strip = 1.0;
  // T12 per point so that each soil brings its own strength and f: bulldozing shared in
  // proportion to the loaded area, (c + sigma tan phi) w z_rel A_k / A; rolling f sigma A_k.
  // Bekker points instead push back on the rim: compaction resistance sigma A_k tan(angle).
  double bulldozing = 0.0, rolling = 0.0, compaction = 0.0, total_weight = 0.0;
  for (const LoadedPoint& p : loaded_)
  {
    const ContactSoil& soil = contact_soils_[p.soil];
    const double strength = soil.cohesion + std::max(p.sigma, 0.0) * soil.tan_phi;
    const double load = p.sigma * area * p.weight;
    out.normal_force += load;
    total_weight += p.weight;
    if (soil.model() == SinkageModel::kBekker)
    {
      compaction += load * p.rim_slope;
    }
    else
    {
      bulldozing += strength * p.weight;
      rolling += soil.rolling_resistance * load;
    }
    if (slip_magnitude > 0.0)
    {
      const double k = soil.shear_modulus;
      if (p.soil != strip_soil)
      {
        strip_soil = p.soil;
        half_strip = std::exp(slip_magnitude * 0.5 * dx / k);
      }
      const double x = front - p.along;
      const double x0 = std::max(x - 0.5 * dx, 0.0), x1 = x + 0.5 * dx;
      const double e_mid = std::exp(-slip_magnitude * x / k);
      const double e0 = x0 > 0.0 ? e_mid * half_strip : 1.0;
      const double mean = meanShearFactor(slip_magnitude, k, x0, x1, e0, e_mid / half_strip);
      const double tau = strength * mean;
      out.longitudinal_force += travel * (out.slip / slip_magnitude) * tau * area * p.weight;
      out.lateral_force -= (lateral_slip / slip_magnitude) * tau * area * p.weight;
    }
  }
  // T12 with the depth of the soil ahead (largest penetration): for one simple soil this is
  // (c + mean sigma tan phi) w z_rel + f A mean sigma. A wheel pressed into Bekker soil at rest
  // is pushed back as much as forward: no net compaction resistance, never a negative one.
  out.resistance_force =
      bulldozing / total_weight * wheel.width * max_penetration + rolling + std::max(compaction, 0.0);

  if (deform)
  {
    const double slip_speed = std::hypot(v_theoretical - v_long, v_lat);  // v_r of T4
    for (const LoadedPoint& p : loaded_)
    {
      const ContactSoil& soil = contact_soils_[p.soil];
      PointDeformation& state = touch(p.i, p.j);
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
      flowed_volume_ += static_cast<double>(static_cast<float>(flow)) * area;
      if (options_.transport && flow > 0.0)
        spreadToNeighbours(p.i, p.j, static_cast<double>(static_cast<float>(flow)) * area);
    }
  }
  return out;
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
