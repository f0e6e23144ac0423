#include "avsp_dynamics/dem/moving_patch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace
{
[[noreturn]] void fail(const std::string& key, const std::string& why)
{
  throw DemParameterError("dem.patch." + key + ": " + why);
}
}  // namespace

MovingPatch::MovingPatch(const BedTemplate& bed, terrain::DeformableTerrain& terrain, const PatchSpec& spec)
  : bed_(bed), terrain_(terrain), spec_(spec), rear_(spec.x_start)
{
  const double L = bed.length();
  const double blocks = spec.length / L;
  if (!(blocks >= 1.0 - 1e-9) || std::abs(blocks - std::round(blocks)) > 1e-6)
    fail("length",
         std::to_string(spec.length) + " m is not a whole number of template lengths (" + std::to_string(L) + " m)");
  if (!(spec.x_end - spec.x_start >= spec.length))
    fail("x_end", "the segment is shorter than the patch");
  if (!(spec.front_margin > 0.0 && spec.front_margin < spec.length))
    fail("front_margin", "must be in (0, length)");
  if (!(spec.clearance > 0.0))
    fail("clearance", "must be > 0");
  if (!(spec.domain_before >= 0.0 && std::isfinite(spec.domain_before)))
    fail("domain_before", "must be a finite number >= 0");
  if (!(spec.domain_after >= 0.0 && std::isfinite(spec.domain_after)))
    fail("domain_after", "must be a finite number >= 0");
  // The floor lies the template's depth below the highest ground along the strip; the lowest
  // ground must leave two largest radii of bed above it.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const double step = 0.5 * std::min(terrain.base().dx(), terrain.base().dy());
  for (double x = spec.x_start; x <= spec.x_end; x += step)
    for (double y = spec.y_min; y <= spec.y_min + bed.width(); y += step)
    {
      const auto h = terrain.height(x, y);
      if (!h)
        fail("x_end", "the strip leaves the terrain at (" + std::to_string(x) + ", " + std::to_string(y) + ")");
      lo = std::min(lo, *h);
      hi = std::max(hi, *h);
    }
  const double floor = hi - bed.depth();
  if (lo - floor < 2.0 * maxRadius(bed.parameters()))
    fail("ground", "relief of " + std::to_string(hi - lo) +
                       " m along the strip leaves less than two particle radii of bed "
                       "over the floor: settle a deeper template");
  const DemDomain d{ spec.x_start - spec.domain_before,
                     spec.x_end + spec.domain_after,
                     spec.y_min,
                     spec.y_min + bed.width(),
                     floor,
                     hi + spec.clearance };
  world_ = std::make_unique<DemWorld>(bed.parameters(), d, bed);
  const auto ground = [this](double x, double y) { return *terrain_.height(x, y); };
  world_->addBed(rear_, front(), ground, true, true);
  world_->setBedEnds(rear_, front());
}

void MovingPatch::writeBack(double x0, double x1)
{
  const auto& g = terrain_.base();
  const auto particles = world_->particles();
  const double rmax = maxRadius(bed_.parameters());
  const auto& d = world_->domain();
  // Points clear of the side walls by two largest radii (next to a wall the bed is not the soil's).
  const double y0 = d.y_min + 2.0 * rmax, y1 = d.y_max - 2.0 * rmax;
  const long i0 = static_cast<long>(std::ceil((x0 - g.originX()) / g.dx()));
  const long i1 = static_cast<long>(std::ceil((x1 - g.originX()) / g.dx()));
  const long j0 = static_cast<long>(std::ceil((y0 - g.originY()) / g.dy()));
  const long j1 = static_cast<long>(std::floor((y1 - g.originY()) / g.dy()));
  for (long j = std::max(0L, j0); j <= std::min<long>(j1, g.rows() - 1); ++j)
    for (long i = std::max(0L, i0); i < std::min<long>(i1, g.columns()); ++i)
    {
      const double x = g.originX() + i * g.dx(), y = g.originY() + j * g.dy();
      const double h = surfaceProbe(particles, x, y, 0.5 * rmax) - bed_.surfaceBias();
      if (!std::isfinite(h))
        continue;
      // Height = base - plastic - displaced: keep the plastic sinkage the soil had, let the
      // displaced part carry the DEM's surface (negative where the DEM piled soil up).
      auto def = terrain_.deformation(i, j);
      def.displaced = static_cast<float>(g.pointHeight(i, j) - def.plastic - h);
      terrain_.setDeformation(i, j, def);
      ++points_written_;
    }
}

bool MovingPatch::follow(double x)
{
  const double L = bed_.length();
  if (finished_ || x < front() - spec_.front_margin || front() + L > spec_.x_end + 1e-9)
    return false;
  writeBack(rear_, rear_ + L);
  world_->removeParticles(rear_, rear_ + L);
  const auto ground = [this](double u, double v) { return *terrain_.height(u, v); };
  world_->addBed(front(), front() + L, ground, false, true);
  rear_ += L;
  world_->setBedEnds(rear_, front());
  ++relocations_;
  return true;
}

void MovingPatch::finish()
{
  if (finished_)
    return;
  writeBack(rear_, front());
  world_->removeParticles(rear_, front());
  finished_ = true;
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
