#include "avsp_terrain/deformable_terrain.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "avsp_terrain/terramechanics.hpp"

namespace avsp
{
namespace terrain
{
namespace
{
/// Stress at which a point is treated as the hard layer (no more deformation possible).
constexpr double kRigidStress = 1e8;  // Pa

struct LoadedPoint
{
  std::size_t i, j;
  double along;        // m, position along the direction of travel (wheel frame)
  double penetration;  // m, below the current unloaded surface
  double sigma;        // Pa
  double elastic;      // m
};
}  // namespace

DeformableTerrain::DeformableTerrain(ElevationGrid base, SoilParameters soil, Options options)
  : base_(std::move(base))
  , soil_(std::move(soil))
  , options_(options)
  , tiles_x_((base_.columns() + kTileSize - 1) / kTileSize)
  , tiles_(tiles_x_ * ((base_.rows() + kTileSize - 1) / kTileSize))
{
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

double DeformableTerrain::extraSinkage(const PointDeformation& state, double sigma) const
{
  const double sigma_max = std::max<double>(sigma, state.sigma_max);
  // T2: compaction follows the largest stress; T4 bearing flow likewise only for new stress.
  const double plastic = std::max(plasticSinkage(soil_, sigma_max) - state.plastic, 0.0);
  const double flow = soil_.b1 * std::max(sigma - state.sigma_max, 0.0);
  // T3 with z the point's deformation before this step (keeps the increment monotone in sigma).
  const double elastic = elasticSinkage(soil_, sigma, state.plastic + state.displaced);
  return plastic + flow + elastic;
}

double DeformableTerrain::stressForPenetration(const PointDeformation& state, double penetration) const
{
  double lo = 0.0, hi = 1e4;
  double f_lo = -penetration, f_hi = extraSinkage(state, hi) - penetration;
  while (f_hi < 0.0)
  {
    lo = hi;
    f_lo = f_hi;
    hi *= 4.0;
    if (hi > kRigidStress)
      return kRigidStress;  // compacted to the hard layer: carries whatever it must
    f_hi = extraSinkage(state, hi) - penetration;
  }
  // Illinois regula falsi on a monotone, nearly linear function: a few evaluations reach
  // 1e-10 m; the bracket keeps it safe where the compression curve has kinks.
  int side = 0;
  for (int k = 0; k < 60; ++k)
  {
    const double mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
    const double f_mid = extraSinkage(state, mid) - penetration;
    if (std::abs(f_mid) < 1e-10 || hi - lo < 1e-9 * hi)
      return mid;
    if ((f_mid < 0.0) == (f_lo < 0.0))
    {
      lo = mid;
      f_lo = f_mid;
      if (side == -1)
        f_hi *= 0.5;
      side = -1;
    }
    else
    {
      hi = mid;
      f_hi = f_mid;
      if (side == 1)
        f_lo *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (lo + hi);
}

void DeformableTerrain::spreadToNeighbours(std::size_t i, std::size_t j, double volume)
{
  // f(z_f, d) of T5: the flowed volume goes to the 8 neighbours weighted by 1/d, so what
  // leaves one point arrives exactly at others (volume leaving = volume arriving).
  struct Target
  {
    std::size_t i, j;
    double weight;
  };
  std::array<Target, 8> targets{};
  int count = 0;
  double total = 0.0;
  for (int dj = -1; dj <= 1; ++dj)
  {
    for (int di = -1; di <= 1; ++di)
    {
      if (di == 0 && dj == 0)
        continue;
      const long ni = static_cast<long>(i) + di, nj = static_cast<long>(j) + dj;
      if (ni < 0 || nj < 0 || ni >= static_cast<long>(base_.columns()) || nj >= static_cast<long>(base_.rows()))
        continue;
      const double w = (di != 0 && dj != 0) ? M_SQRT1_2 : 1.0;
      targets[count++] = { static_cast<std::size_t>(ni), static_cast<std::size_t>(nj), w };
      total += w;
    }
  }
  const double area = base_.dx() * base_.dy();
  for (int k = 0; k < count; ++k)
  {
    const double share = volume * targets[k].weight / total;
    touch(targets[k].i, targets[k].j).displaced -= static_cast<float>(share / area);
    arrived_volume_ += share;
  }
}

ContactForces DeformableTerrain::wheelContact(const WheelPatch& wheel, double dt, bool deform)
{
  ContactForces out;
  const double ca = std::cos(wheel.heading), sa = std::sin(wheel.heading);
  const double r = wheel.radius, half_w = 0.5 * wheel.width;
  // Axis-aligned bounds of the wheel's 2r x w footprint rectangle.
  const double ext_x = r * std::abs(ca) + half_w * std::abs(sa);
  const double ext_y = r * std::abs(sa) + half_w * std::abs(ca);
  const double dx = base_.dx(), dy = base_.dy();
  const long i0 = std::max(0L, static_cast<long>(std::ceil((wheel.centre.x() - ext_x - base_.originX()) / dx)));
  const long j0 = std::max(0L, static_cast<long>(std::ceil((wheel.centre.y() - ext_y - base_.originY()) / dy)));
  const long i1 = std::min(static_cast<long>(base_.columns()) - 1,
                           static_cast<long>(std::floor((wheel.centre.x() + ext_x - base_.originX()) / dx)));
  const long j1 = std::min(static_cast<long>(base_.rows()) - 1,
                           static_cast<long>(std::floor((wheel.centre.y() + ext_y - base_.originY()) / dy)));

  // Kinematics: T8 slip from T9's theoretical speed, slip angle from the lateral velocity.
  const double v_long = wheel.velocity.x() * ca + wheel.velocity.y() * sa;
  const double v_lat = -wheel.velocity.x() * sa + wheel.velocity.y() * ca;
  const double v_theoretical = wheelTheoreticalSpeed(r, wheel.spin_rate);
  out.slip = longitudinalSlip(v_theoretical, v_long);
  out.slip_angle = (std::abs(v_long) + std::abs(v_lat) > 1e-9) ? std::atan2(v_lat, std::abs(v_long)) : 0.0;
  const double travel = (std::abs(v_long) > 1e-6) ? (v_long < 0 ? -1.0 : 1.0) : (wheel.spin_rate < 0 ? -1.0 : 1.0);

  std::vector<LoadedPoint> loaded;
  for (long j = j0; j <= j1; ++j)
  {
    for (long i = i0; i <= i1; ++i)
    {
      const double px = base_.originX() + i * dx - wheel.centre.x();
      const double py = base_.originY() + j * dy - wheel.centre.y();
      const double u = px * ca + py * sa;
      const double v = -px * sa + py * ca;
      if (std::abs(u) >= r || std::abs(v) > half_w)
        continue;
      const double bottom = wheel.centre.z() - std::sqrt(r * r - u * u);
      const PointDeformation state = deformation(i, j);
      const double base_z = base_.pointHeight(i, j);
      const double penetration = base_z - state.plastic - state.displaced - bottom;
      if (!(penetration > 0.0))
        continue;
      const double sigma = stressForPenetration(state, penetration);
      const double elastic = elasticSinkage(soil_, sigma, state.plastic + state.displaced);
      loaded.push_back({ static_cast<std::size_t>(i), static_cast<std::size_t>(j), u * travel, penetration, sigma,
                         elastic });
      out.sinkage = std::max(out.sinkage, base_z - bottom);
      out.elastic_sinkage = std::max(out.elastic_sinkage, elastic);
    }
  }
  out.contact_points = static_cast<int>(loaded.size());
  if (loaded.empty())
    return out;

  // Normal force, and traction per strip with j = s x behind the leading edge (T7, T11).
  const double area = dx * dy;
  double front = -1e300, max_penetration = 0.0;
  for (const LoadedPoint& p : loaded)
  {
    front = std::max(front, p.along);
    max_penetration = std::max(max_penetration, p.penetration);
  }
  front += 0.5 * dx;
  const double lateral_slip = (1.0 - std::abs(out.slip)) * std::tan(out.slip_angle);
  const double slip_magnitude = std::hypot(out.slip, lateral_slip);
  for (const LoadedPoint& p : loaded)
  {
    out.normal_force += p.sigma * area;
    if (slip_magnitude > 0.0)
    {
      const double x = front - p.along;
      const double tau = meanShearStress(soil_, p.sigma, slip_magnitude, std::max(x - 0.5 * dx, 0.0), x + 0.5 * dx);
      out.longitudinal_force += travel * (out.slip / slip_magnitude) * tau * area;
      out.lateral_force -= (lateral_slip / slip_magnitude) * tau * area;
    }
  }
  // T12 with the mean stress of the patch and the depth of the soil ahead (largest penetration).
  const double contact_area = area * loaded.size();
  out.resistance_force =
      resistanceForce(soil_, out.normal_force / contact_area, wheel.width, max_penetration, contact_area);

  if (deform)
  {
    const double slip_speed = std::hypot(v_theoretical - v_long, v_lat);  // v_r of T4
    for (const LoadedPoint& p : loaded)
    {
      PointDeformation& state = touch(p.i, p.j);
      const float sigma_before = state.sigma_max;
      const double sigma_max = std::max<double>(p.sigma, sigma_before);
      const double flow = soil_.b1 * std::max(p.sigma - sigma_before, 0.0) + soil_.b2 * p.sigma * slip_speed * dt;
      state.plastic = std::max(state.plastic, static_cast<float>(plasticSinkage(soil_, sigma_max)));
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

}  // namespace terrain
}  // namespace avsp
