#include "avsp_sensors/scene.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "avsp_sensors/parallel.hpp"
#include "avsp_terrain/terrain_objects.hpp"

namespace avsp
{
namespace sensors
{
std::vector<Primitive> objectPrimitives(const terrain::ObjectSet& objects, const HeightField& ground,
                                        const Reflectivities& reflectivities)
{
  std::vector<Primitive> out;
  out.reserve(objects.size());
  for (const terrain::TerrainObject& o : objects.all())
  {
    if (o.type == terrain::ObjectType::kGrass)
      continue;
    Primitive p;
    switch (o.type)
    {
      case terrain::ObjectType::kRock:
        p.shape = Shape::kEllipsoid;
        break;
      case terrain::ObjectType::kTree:
      case terrain::ObjectType::kShrub:
      case terrain::ObjectType::kPole:
        p.shape = Shape::kCylinder;
        break;
      default:
        p.shape = Shape::kBox;
        break;
    }
    // The same minimum height as the RViz markers, so that a flat object still has a volume.
    const double height = std::max(o.height, 0.02);
    p.half_extents = Eigen::Vector3d(0.5 * o.length, 0.5 * o.width, 0.5 * height);
    double z0 = 0.0;
    ground.heightAt(o.x, o.y, z0);
    if (!o.toppled)
    {
      p.rotation = Eigen::AngleAxisd(o.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      p.centre = Eigen::Vector3d(o.x, o.y, z0 + 0.5 * height);
    }
    else
    {
      // Lying along the fall direction f: its height axis (own z) along f, its thinner
      // footprint side vertical, the other across f; columns are the images of own x, y, z.
      const Eigen::Vector3d f(std::cos(o.fall_direction), std::sin(o.fall_direction), 0.0);
      const Eigen::Vector3d across(-f.y(), f.x(), 0.0);
      const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
      if (o.length <= o.width)
        p.rotation << up, -across, f;
      else
        p.rotation << across, up, f;
      p.centre = Eigen::Vector3d(o.x, o.y, z0 + 0.5 * std::min(o.length, o.width)) + 0.5 * height * f;
    }
    p.id = o.id;
    p.reflectivity = reflectivities.objects[static_cast<std::size_t>(o.type)];
    out.push_back(p);
  }
  return out;
}

Scene::Scene(HeightField terrain, Reflectivities reflectivities)
  : terrain_(std::move(terrain)), reflectivities_(reflectivities)
{
  auto check = [](float r, const std::string& name) {
    if (!(r >= 0.f && r <= 1.f))
      throw std::invalid_argument("Scene: reflectivities." + name + " must be in [0, 1]");
  };
  check(reflectivities_.terrain, "terrain");
  for (std::size_t k = 0; k < reflectivities_.objects.size(); ++k)
    check(reflectivities_.objects[k], "objects[" + std::to_string(k) + "]");
}

void Scene::setObjects(const terrain::ObjectSet& objects)
{
  setStaticPrimitives(objectPrimitives(objects, terrain_, reflectivities_));
}

void Scene::setStaticPrimitives(std::vector<Primitive> primitives)
{
  objects_ = PrimitiveBvh(std::move(primitives));
}

void Scene::setBodies(std::vector<Body> bodies)
{
  std::vector<Primitive> prims;
  prims.reserve(bodies.size());
  for (const Body& b : bodies)
  {
    validatePrimitive(b.primitive, "Scene::setBodies");
    if (!b.velocity.allFinite())
      throw std::invalid_argument("Scene::setBodies: body id " + std::to_string(b.primitive.id) +
                                  ": velocity is not finite");
    if (!b.angular_velocity.allFinite())
      throw std::invalid_argument("Scene::setBodies: body id " + std::to_string(b.primitive.id) +
                                  ": angular_velocity is not finite");
    prims.push_back(b.primitive);
  }
  body_bvh_ = PrimitiveBvh(std::move(prims));
  bodies_ = std::move(bodies);
}

void Scene::setTerrainReflectivity(std::vector<std::uint8_t> soil_map, std::vector<float> palette)
{
  if (soil_map.empty())
  {
    soil_map_.clear();
    soil_reflectivity_.clear();
    return;
  }
  if (soil_map.size() != terrain_.columns() * terrain_.rows())
    throw std::invalid_argument("Scene::setTerrainReflectivity: soil_map has " + std::to_string(soil_map.size()) +
                                " entries, the grid " + std::to_string(terrain_.columns() * terrain_.rows()));
  for (std::size_t k = 0; k < palette.size(); ++k)
    if (!(palette[k] >= 0.f && palette[k] <= 1.f))
      throw std::invalid_argument("Scene::setTerrainReflectivity: palette[" + std::to_string(k) +
                                  "] must be in [0, 1]");
  for (std::size_t k = 0; k < soil_map.size(); ++k)
    if (soil_map[k] >= palette.size())
      throw std::invalid_argument("Scene::setTerrainReflectivity: soil_map[" + std::to_string(k) +
                                  "] = " + std::to_string(soil_map[k]) + " is not in the palette of " +
                                  std::to_string(palette.size()));
  soil_map_ = std::move(soil_map);
  soil_reflectivity_ = std::move(palette);
}

float Scene::terrainReflectivity(std::size_t i, std::size_t j, const Eigen::Vector3d& p) const
{
  // The grid point nearest the hit (of the cell's four corners).
  const double fx = (p.x() - terrain_.originX()) / terrain_.dx() - static_cast<double>(i);
  const double fy = (p.y() - terrain_.originY()) / terrain_.dy() - static_cast<double>(j);
  const std::size_t pi = i + (fx >= 0.5 ? 1 : 0), pj = j + (fy >= 0.5 ? 1 : 0);
  return soil_reflectivity_[soil_map_[pj * terrain_.columns() + pi]];
}

namespace
{
/// Rays of a batch are cast on threads in chunks of this many (fans never span two chunks).
constexpr std::size_t kBatchGrain = 1024;
/// Two rays of a fan differ in slope (dz / horizontal) by more than this: far above rounding,
/// far below any two lidar channels (0.1 deg apart: 1.7e-3).
constexpr double kFanSlopeMargin = 1e-6;
/// m: a fan's next ray starts this much before the previous one's hit, for the rounding of
/// that hit (the start only saves steps; the cell it falls in is still tested whole).
constexpr double kFanBackOff = 1e-6;
/// Fans of fewer rays are cast ray by ray: collecting their candidate primitives would cost
/// more than the BVH walks it saves.
constexpr std::size_t kFanMinRays = 4;
/// m: a fan's candidate primitives are those whose footprint, widened by this (plus 2e-9 of
/// the fan's reach), meets its ground line (fanCandidates()).
constexpr double kFanMargin = 1e-6;

/// The checks of Scene::validateRay without building a message.
bool rayValid(const Ray& ray)
{
  return ray.origin.allFinite() && ray.direction.allFinite() && std::abs(ray.direction.squaredNorm() - 1.0) <= 2e-6 &&
         ray.max_range >= 0.0 && std::isfinite(ray.max_range);
}
}  // namespace

void Scene::validateRay(const Ray& ray, const char* context)
{
  if (!ray.origin.allFinite())
    throw std::invalid_argument(std::string(context) + ": ray origin is not finite");
  if (!ray.direction.allFinite() || std::abs(ray.direction.squaredNorm() - 1.0) > 2e-6)
    throw std::invalid_argument(std::string(context) + ": ray direction must be a finite unit vector");
  if (!(ray.max_range >= 0.0) || !std::isfinite(ray.max_range))
    throw std::invalid_argument(std::string(context) + ": ray max_range must be finite and >= 0, got " +
                                std::to_string(ray.max_range));
}

RayHit Scene::cast(const Ray& ray) const
{
  validateRay(ray, "Scene::cast");
  return castUnchecked(ray);
}

bool Scene::occluded(const Ray& ray) const
{
  validateRay(ray, "Scene::occluded");
  // cast() finds a hit iff the terrain is hit within max_range or a solid is entered in
  // (0, max_range] (solids are searched up to the terrain hit, but a terrain hit is a hit).
  // The terrain first: a shadow ray the ground blocks ends there without a look at the BVH (a
  // ray along the ground would cross many of its boxes), and one that clears the ground leaves
  // the height range after a few coarse blocks.
  TerrainHit th;
  return terrain_.intersect(ray.origin, ray.direction, ray.max_range, th) ||
         objects_.occluded(ray.origin, ray.direction, 0.0, ray.max_range) ||
         body_bvh_.occluded(ray.origin, ray.direction, 0.0, ray.max_range, ray.ignore_body);
}

namespace
{
/// Horizontal length of a direction.
double horizontal(const Eigen::Vector3d& d)
{
  return std::sqrt(d.x() * d.x() + d.y() * d.y());
}

/**
 * Whether rays a and b (ha, hb: horizontal lengths of their directions, sa, sb: their slopes
 * dz / horizontal) lie in one vertical half-plane (same origin bit for bit, horizontal
 * directions parallel to 1e-12, not vertical) with clearly different slopes: +1 when b points
 * higher than a, -1 when lower, 0 when they are not such a pair.
 */
int fanStep(const Ray& a, const Ray& b, double ha, double hb, double sa, double sb)
{
  // Component by component: Eigen's != reduces all three even when x already differs.
  if (a.origin.x() != b.origin.x() || a.origin.y() != b.origin.y() || a.origin.z() != b.origin.z())
    return 0;
  const Eigen::Vector3d &da = a.direction, &db = b.direction;
  if (!(ha > 0.0 && hb > 0.0))
    return 0;
  if (std::abs(da.x() * db.y() - da.y() * db.x()) > 1e-12 * ha * hb || da.x() * db.x() + da.y() * db.y() <= 0.0)
    return 0;
  if (sb > sa + kFanSlopeMargin)
    return 1;
  if (sb < sa - kFanSlopeMargin)
    return -1;
  return 0;
}
}  // namespace

void Scene::cast(const std::vector<Ray>& rays, std::vector<RayHit>& hits, unsigned threads) const
{
  for (std::size_t k = 0; k < rays.size(); ++k)
    if (!rayValid(rays[k]))  // the message (a string per ray) only for the ray that fails
      validateRay(rays[k], ("Scene::cast: rays[" + std::to_string(k) + "]").c_str());
  hits.resize(rays.size());
  // Chunks handed out as threads come free: rays differ in cost by orders of magnitude (a
  // steep ray hits at once, a grazing one crosses the course), so a fixed split idles a thread.
  //
  // Coherence: consecutive rays from one origin in one vertical half-plane (a lidar column)
  // form a fan. Over a height field, a ray of the fan cannot meet the ground before a lower
  // one did: up to that one's terrain hit (or, if it has none, its whole range) the lower ray
  // stays above the ground, and the higher one above it. So a fan is cast from its lowest
  // ray up, each ray's terrain traversal starting where the one below it met
  // the ground (HeightField::intersectFrom), which skips the approach from the sensor. Each
  // hit is the one a single cast() gives, bit for bit; fans are found within a chunk only,
  // and chunk bounds are fixed multiples of the grain, so nothing depends on the schedule.
  parallelForDynamic(rays.size(), threads, kBatchGrain, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> scratch;
    std::vector<FanCandidate> candidates;
    // Per ray, once: the horizontal length of its direction and its slope dz / horizontal
    // (meaningless for vertical rays, which fanStep() refuses before looking at it).
    std::vector<double> hz(end - begin), slope(end - begin);
    for (std::size_t k = begin; k < end; ++k)
    {
      hz[k - begin] = horizontal(rays[k].direction);
      slope[k - begin] = rays[k].direction.z() / hz[k - begin];
    }
    auto step = [&](std::size_t a, std::size_t b) {
      return fanStep(rays[a], rays[b], hz[a - begin], hz[b - begin], slope[a - begin], slope[b - begin]);
    };
    std::size_t k = begin;
    while (k < end)
    {
      std::size_t r = k + 1;
      const int order = r < end ? step(k, r) : 0;
      if (order != 0)
        for (++r; r < end && step(r - 1, r) == order;)
          ++r;
      if (r - k < kFanMinRays)
      {
        for (; k < r; ++k)
          hits[k] = castUnchecked(rays[k]);
        continue;
      }
      // The fan's rays all run above one ground line: the static primitives whose footprint
      // meets it are collected once, each ray then tests those (mostly none or a few).
      fanCandidates(rays, hz.data() + (k - begin), k, r, scratch, candidates);
      double s_clear = 0.0;  // m, horizontal: the ground is not met before it in this fan
      for (std::size_t m = 0; m < r - k; ++m)
      {
        const std::size_t idx = order >= 0 ? k + m : r - 1 - m;  // lowest first
        const Ray& ray = rays[idx];
        const double h = hz[idx - begin];
        double reach = 0.0;
        const double t_clear = m > 0 ? std::max(0.0, s_clear / h - kFanBackOff) : 0.0;
        castFanRay(ray, h, t_clear, reach, candidates, hits[idx]);
        s_clear = reach * h;
      }
      k = r;
    }
  });
}

void Scene::fanCandidates(const std::vector<Ray>& rays, const double* hz, std::size_t begin, std::size_t end,
                          std::vector<std::uint32_t>& scratch, std::vector<FanCandidate>& out) const
{
  out.clear();
  const Ray& first = rays[begin];
  const double h0 = hz[0];
  const double ux = first.direction.x() / h0, uy = first.direction.y() / h0;
  double length = 0.0;  // m: the farthest any ray of the fan gets from the origin horizontally
  for (std::size_t k = begin; k < end; ++k)
    length = std::max(length, rays[k].max_range * hz[k - begin]);
  // The rays' own horizontal directions differ from (ux, uy) by <= 1e-12 rad per step of the
  // fan (fanStep), and a fan has at most kBatchGrain = 1024 rays (it never spans two chunks), so
  // their paths stay within ~1.02e-9 * length of the line; 1 um more absorbs rounding of the hit
  // points against primitiveBounds().
  const double margin = kFanMargin + 2e-9 * length;
  objects_.collectAlongSegment(first.origin.x(), first.origin.y(), ux, uy, length, margin, scratch);
  for (std::uint32_t p : scratch)
  {
    const Eigen::Vector3d &lo = objects_.boundsLo(p), &hi = objects_.boundsHi(p);
    double s0 = 0.0, s1 = length;
    auto axis = [&](double o, double u, double l, double h) {
      if (u == 0.0)
        return;  // collectAlongSegment found o within [l, h]
      double a = (l - margin - o) / u, b = (h + margin - o) / u;
      if (a > b)
        std::swap(a, b);
      s0 = std::max(s0, a);
      s1 = std::min(s1, b);
    };
    axis(first.origin.x(), ux, lo.x(), hi.x());
    axis(first.origin.y(), uy, lo.y(), hi.y());
    // Widened once more for the rounding of s0, s1 themselves (the rays' t = s / h).
    out.push_back(FanCandidate{ p, std::max(0.0, s0 - margin), s1 + margin, lo.z() - margin, hi.z() + margin });
  }
}

// Inlined into both casts: a call per ray cost ~4 % of bench_raycast.
__attribute__((always_inline)) inline double Scene::castTerrain(const Ray& ray, double t_clear, double& terrain_reach,
                                                                RayHit& out) const
{
  double best = ray.max_range;
  TerrainHit th;
  terrain_reach = ray.max_range;
  if (terrain_.intersectFrom(ray.origin, ray.direction, t_clear, best, th))
  {
    terrain_reach = th.t;
    best = th.t;
    out.kind = HitKind::kTerrain;
    out.range = th.t;
    out.point = th.point;
    out.normal = th.normal;
    // The uniform case without a call: it is most scenes' and most rays'.
    out.reflectivity = soil_map_.empty() ? reflectivities_.terrain : terrainReflectivity(th.i, th.j, th.point);
  }
  return best;
}

void Scene::castFanRay(const Ray& ray, double h, double t_clear, double& terrain_reach,
                       const std::vector<FanCandidate>& candidates, RayHit& out) const
{
  out = RayHit();
  const double best = castTerrain(ray, t_clear, terrain_reach, out);
  // Most fans meet no primitive and most scenes have no bodies: no call then.
  if (!candidates.empty() || !bodies_.empty())
    castSolids(ray, h, best, out, &candidates);
}

RayHit Scene::castUnchecked(const Ray& ray) const
{
  double reach = 0.0;
  return castUnchecked(ray, 0.0, reach);
}

RayHit Scene::castUnchecked(const Ray& ray, double t_clear, double& terrain_reach) const
{
  RayHit out;
  const double best = castTerrain(ray, t_clear, terrain_reach, out);
  castSolids(ray, 0.0, best, out, nullptr);
  return out;
}

void Scene::castSolids(const Ray& ray, double h, double best, RayHit& out,
                       const std::vector<FanCandidate>* candidates) const
{
  PrimitiveHit ph;
  bool found = false;
  if (candidates == nullptr)
    found = objects_.intersect(ray.origin, ray.direction, 0.0, best, ph);
  else
  {
    // What PrimitiveBvh::intersect finds, among the candidates: the nearest entry in (0, best],
    // ties to the lower index (candidates ascend, so the first found of equal t stays).
    const double inv_h = 1.0 / h;
    const double oz = ray.origin.z(), dz = ray.direction.z();
    const std::vector<Primitive>& prims = objects_.primitives();
    for (const FanCandidate& c : *candidates)
    {
      const double ta = c.s0 * inv_h;
      if (ta > best)
        continue;  // the ray ends (terrain or range) before it reaches the footprint
      const double tb = std::min(c.s1 * inv_h, best);
      const double za = oz + ta * dz, zb = oz + tb * dz;
      if (std::min(za, zb) > c.z_hi || std::max(za, zb) < c.z_lo)
        continue;  // above or below the primitive all along its footprint
      PrimitiveHit h_c;
      if (intersectPrimitive(prims[c.index], ray.origin, ray.direction, 0.0, best, h_c) && (h_c.t < best || !found))
      {
        best = h_c.t;
        ph = h_c;
        ph.index = c.index;
        found = true;
      }
    }
  }
  if (found)
  {
    best = ph.t;
    const Primitive& p = objects_.primitives()[ph.index];
    out.kind = HitKind::kObject;
    out.range = ph.t;
    out.point = ray.origin + ph.t * ray.direction;
    out.normal = ph.normal;
    out.id = p.id;
    out.reflectivity = p.reflectivity;
  }
  if (!bodies_.empty() && body_bvh_.intersect(ray.origin, ray.direction, 0.0, best, ph, ray.ignore_body))
  {
    const Body& b = bodies_[ph.index];
    out.kind = HitKind::kBody;
    out.range = ph.t;
    out.point = ray.origin + ph.t * ray.direction;
    out.normal = ph.normal;
    out.id = b.primitive.id;
    out.reflectivity = b.primitive.reflectivity;
    out.velocity = b.velocity + b.angular_velocity.cross(out.point - b.primitive.centre);
  }
}

}  // namespace sensors
}  // namespace avsp
