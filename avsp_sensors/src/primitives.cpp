#include "avsp_sensors/primitives.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Slab interval of the ray o + t d against |x_k| <= e_k for every axis k; false if empty.
bool slabs(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& e, double& t_in, double& t_out,
           int& axis_in, double& sign_in)
{
  t_in = -kInf;
  t_out = kInf;
  axis_in = -1;
  sign_in = 0.0;
  for (int k = 0; k < 3; ++k)
  {
    if (d[k] == 0.0)
    {
      if (o[k] < -e[k] || o[k] > e[k])
        return false;
      continue;
    }
    double ta = (-e[k] - o[k]) / d[k], tb = (e[k] - o[k]) / d[k];
    // The ray enters through the face it meets first: -e when moving in +k, +e otherwise.
    double face = -1.0;
    if (ta > tb)
    {
      std::swap(ta, tb);
      face = 1.0;
    }
    if (ta > t_in)
    {
      t_in = ta;
      axis_in = k;
      sign_in = face;
    }
    t_out = std::min(t_out, tb);
  }
  return t_in <= t_out;
}

/// Smallest root >= 0 of a t^2 + 2 b t + c = 0 for a ray starting outside (c > 0), stable form.
bool entryRoot(double a, double b, double c, double& t)
{
  if (a <= 0.0)
    return false;
  const double disc = b * b - a * c;
  if (disc < 0.0 || b >= 0.0)
    return false;  // no real roots, or both roots behind the origin (c > 0 keeps their signs equal)
  // Entry root: (-b - sqrt(disc)) / a == c / (-b + sqrt(disc)), the latter without cancellation.
  t = c / (-b + std::sqrt(disc));
  return true;
}
}  // namespace

bool intersectPrimitive(const Primitive& p, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        double t_min, double t_max, PrimitiveHit& hit)
{
  // Into the primitive's frame; t is unchanged because the rotation preserves lengths.
  const Eigen::Vector3d o = p.rotation.transpose() * (origin - p.centre);
  const Eigen::Vector3d d = p.rotation.transpose() * direction;
  const Eigen::Vector3d& e = p.half_extents;
  double t = 0.0;
  Eigen::Vector3d n_local;
  switch (p.shape)
  {
    case Shape::kBox:
    {
      double t_in, t_out, sign;
      int axis;
      if (!slabs(o, d, e, t_in, t_out, axis, sign) || axis < 0 || t_in < 0.0)
        return false;  // missed, or started inside (t_in < 0 <= t_out)
      t = t_in;
      n_local.setZero();
      n_local[axis] = sign;
      break;
    }
    case Shape::kEllipsoid:
    {
      // Scaled to the unit sphere: |o' + t d'|^2 = 1 with o' = o / e, d' = d / e.
      const Eigen::Vector3d os = o.cwiseQuotient(e), ds = d.cwiseQuotient(e);
      const double c = os.squaredNorm() - 1.0;
      if (c <= 0.0 || !entryRoot(ds.squaredNorm(), os.dot(ds), c, t))
        return false;
      const Eigen::Vector3d pl = o + t * d;
      n_local = pl.cwiseQuotient(e.cwiseProduct(e));
      break;
    }
    case Shape::kCylinder:
    {
      // Intersection of the infinite elliptic cylinder's interval with the caps' slab.
      const double ox = o.x() / e.x(), oy = o.y() / e.y(), dx = d.x() / e.x(), dy = d.y() / e.y();
      const double a = dx * dx + dy * dy, b = ox * dx + oy * dy, c = ox * ox + oy * oy - 1.0;
      double side_in, side_out;
      if (a == 0.0)
      {
        if (c > 0.0)
          return false;  // parallel to the axis, outside the ellipse
        side_in = -kInf;
        side_out = kInf;
      }
      else
      {
        const double disc = b * b - a * c;
        if (disc < 0.0)
          return false;
        const double sq = std::sqrt(disc);
        const double q = -(b + std::copysign(sq, b));
        double r1 = q / a, r2 = q != 0.0 ? c / q : (-b) / a;
        if (r1 > r2)
          std::swap(r1, r2);
        side_in = r1;
        side_out = r2;
      }
      double cap_in, cap_out, cap_sign = 0.0;
      if (d.z() == 0.0)
      {
        if (std::abs(o.z()) > e.z())
          return false;
        cap_in = -kInf;
        cap_out = kInf;
      }
      else
      {
        cap_in = (-e.z() - o.z()) / d.z();
        cap_out = (e.z() - o.z()) / d.z();
        cap_sign = -1.0;
        if (cap_in > cap_out)
        {
          std::swap(cap_in, cap_out);
          cap_sign = 1.0;
        }
      }
      const double t_in = std::max(side_in, cap_in), t_out = std::min(side_out, cap_out);
      if (t_in > t_out || t_in < 0.0)
        return false;
      t = t_in;
      if (cap_in >= side_in)
        n_local = Eigen::Vector3d(0.0, 0.0, cap_sign);
      else
      {
        const Eigen::Vector3d pl = o + t * d;
        n_local = Eigen::Vector3d(pl.x() / (e.x() * e.x()), pl.y() / (e.y() * e.y()), 0.0);
      }
      break;
    }
  }
  if (!(t > t_min) || t > t_max)
    return false;
  hit.t = t;
  hit.normal = (p.rotation * n_local).normalized();
  return true;
}

void primitiveBounds(const Primitive& p, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  const Eigen::Matrix3d& R = p.rotation;
  const Eigen::Vector3d& e = p.half_extents;
  Eigen::Vector3d r;
  for (int k = 0; k < 3; ++k)
  {
    const Eigen::Vector3d row = R.row(k).transpose().cwiseProduct(e);
    switch (p.shape)
    {
      case Shape::kBox:  // corners: sum of |R_kj| e_j
        r[k] = row.cwiseAbs().sum();
        break;
      case Shape::kEllipsoid:  // support function of an ellipsoid along map axis k
        r[k] = row.norm();
        break;
      case Shape::kCylinder:  // elliptic disc (x, y) plus the axis segment (z)
        r[k] = std::hypot(row.x(), row.y()) + std::abs(row.z());
        break;
    }
  }
  lo = p.centre - r;
  hi = p.centre + r;
}

void validatePrimitive(const Primitive& p, const char* context)
{
  const std::string where = std::string(context) + ": primitive id " + std::to_string(p.id) + ": ";
  if (!p.centre.allFinite())
    throw std::invalid_argument(where + "centre is not finite");
  for (int k = 0; k < 3; ++k)
    if (!(p.half_extents[k] > 0.0) || !std::isfinite(p.half_extents[k]))
      throw std::invalid_argument(where + "half_extents must be finite and > 0");
  if (!p.rotation.allFinite())
    throw std::invalid_argument(where + "rotation is not finite");
  if ((p.rotation.transpose() * p.rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
      p.rotation.determinant() < 0.0)
    throw std::invalid_argument(where + "rotation is not a rotation matrix (orthonormal, det +1)");
  if (!(p.reflectivity >= 0.f && p.reflectivity <= 1.f))
    throw std::invalid_argument(where + "reflectivity must be in [0, 1]");
}

PrimitiveBvh::PrimitiveBvh(std::vector<Primitive> primitives) : primitives_(std::move(primitives))
{
  const std::size_t n = primitives_.size();
  if (n >= std::numeric_limits<std::uint32_t>::max() / 2)
    throw std::invalid_argument("PrimitiveBvh: too many primitives");
  if (n == 0)
    return;
  std::vector<Eigen::Vector3d> lo(n), hi(n), centre(n);
  for (std::size_t k = 0; k < n; ++k)
  {
    validatePrimitive(primitives_[k], "PrimitiveBvh");
    primitiveBounds(primitives_[k], lo[k], hi[k]);
    centre[k] = 0.5 * (lo[k] + hi[k]);
  }
  order_.resize(n);
  for (std::size_t k = 0; k < n; ++k)
    order_[k] = static_cast<std::uint32_t>(k);
  nodes_.reserve(2 * n);
  build(0, static_cast<std::uint32_t>(n), lo, hi, centre, 0);
  lo_ = std::move(lo);
  hi_ = std::move(hi);
}

namespace
{
/// Whether the segment (x0, y0) + s (ux, uy), s in [0, length], meets the box [lo, hi] (x, y).
bool segmentMeetsBox2d(double x0, double y0, double ux, double uy, double length, double lox, double loy, double hix,
                       double hiy)
{
  double s0 = 0.0, s1 = length;
  auto axis = [&](double p, double u, double lo, double hi) {
    if (u == 0.0)
      return p >= lo && p <= hi;
    double a = (lo - p) / u, b = (hi - p) / u;
    if (a > b)
      std::swap(a, b);
    s0 = std::max(s0, a);
    s1 = std::min(s1, b);
    return s0 <= s1;
  };
  return axis(x0, ux, lox, hix) && axis(y0, uy, loy, hiy);
}
}  // namespace

void PrimitiveBvh::collectAlongSegment(double x0, double y0, double ux, double uy, double length, double margin,
                                       std::vector<std::uint32_t>& out) const
{
  out.clear();
  if (nodes_.empty())
    return;
  std::uint32_t stack[kMaxDepth + 2];
  int top = 0;
  stack[top++] = 0;
  while (top > 0)
  {
    const Node& nd = nodes_[stack[--top]];
    // Node boxes are float, rounded outwards: they contain their primitives' double bounds.
    if (!segmentMeetsBox2d(x0, y0, ux, uy, length, nd.lo[0] - margin, nd.lo[1] - margin, nd.hi[0] + margin,
                           nd.hi[1] + margin))
      continue;
    if (nd.count > 0)
    {
      for (std::uint32_t k = nd.first; k < nd.first + nd.count; ++k)
      {
        const std::uint32_t p = order_[k];
        if (segmentMeetsBox2d(x0, y0, ux, uy, length, lo_[p].x() - margin, lo_[p].y() - margin, hi_[p].x() + margin,
                              hi_[p].y() + margin))
          out.push_back(p);
      }
      continue;
    }
    stack[top++] = nd.first;
    stack[top++] = static_cast<std::uint32_t>(&nd - nodes_.data()) + 1;
  }
  std::sort(out.begin(), out.end());
}

std::uint32_t PrimitiveBvh::build(std::uint32_t begin, std::uint32_t end, std::vector<Eigen::Vector3d>& lo,
                                  std::vector<Eigen::Vector3d>& hi, std::vector<Eigen::Vector3d>& centre, int depth)
{
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back(Node{});
  Eigen::Vector3d blo = Eigen::Vector3d::Constant(kInf), bhi = Eigen::Vector3d::Constant(-kInf);
  Eigen::Vector3d clo = blo, chi = bhi;
  for (std::uint32_t k = begin; k < end; ++k)
  {
    const std::uint32_t p = order_[k];
    blo = blo.cwiseMin(lo[p]);
    bhi = bhi.cwiseMax(hi[p]);
    clo = clo.cwiseMin(centre[p]);
    chi = chi.cwiseMax(centre[p]);
  }
  // Float boxes rounded outwards, so a float box never cuts a double solid.
  for (int k = 0; k < 3; ++k)
  {
    nodes_[index].lo[k] = std::nextafter(static_cast<float>(blo[k]), -std::numeric_limits<float>::infinity());
    nodes_[index].hi[k] = std::nextafter(static_cast<float>(bhi[k]), std::numeric_limits<float>::infinity());
  }
  const std::uint32_t count = end - begin;
  auto makeLeaf = [&]() {
    nodes_[index].first = begin;
    nodes_[index].count = count;
    return index;
  };
  // Depth is capped so the traversal's fixed stack (depth + 1 entries) cannot overflow; a
  // pathological input then gets larger leaves instead.
  if (count <= 4 || depth >= kMaxDepth)
    return makeLeaf();
  // Binned SAH along the axis of largest centroid spread.
  int axis = 0;
  const Eigen::Vector3d extent = chi - clo;
  extent.maxCoeff(&axis);
  if (!(extent[axis] > 0.0))
    return makeLeaf();  // all centres coincide: no split separates them
  constexpr int kBins = 12;
  struct Bin
  {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = Eigen::Vector3d::Constant(-kInf);
    std::uint32_t n = 0;
  };
  Bin bins[kBins];
  auto binOf = [&](std::uint32_t p) {
    const int b = static_cast<int>(kBins * (centre[p][axis] - clo[axis]) / extent[axis]);
    return std::min(std::max(b, 0), kBins - 1);
  };
  for (std::uint32_t k = begin; k < end; ++k)
  {
    const std::uint32_t p = order_[k];
    Bin& b = bins[binOf(p)];
    b.lo = b.lo.cwiseMin(lo[p]);
    b.hi = b.hi.cwiseMax(hi[p]);
    ++b.n;
  }
  auto area = [](const Eigen::Vector3d& l, const Eigen::Vector3d& h) {
    const Eigen::Vector3d e = h - l;
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  };
  double best = kInf;
  int best_split = -1;
  for (int s = 1; s < kBins; ++s)
  {
    Eigen::Vector3d l0 = Eigen::Vector3d::Constant(kInf), h0 = -l0, l1 = l0, h1 = h0;
    std::uint32_t n0 = 0, n1 = 0;
    for (int b = 0; b < s; ++b)
      if (bins[b].n)
      {
        l0 = l0.cwiseMin(bins[b].lo);
        h0 = h0.cwiseMax(bins[b].hi);
        n0 += bins[b].n;
      }
    for (int b = s; b < kBins; ++b)
      if (bins[b].n)
      {
        l1 = l1.cwiseMin(bins[b].lo);
        h1 = h1.cwiseMax(bins[b].hi);
        n1 += bins[b].n;
      }
    if (n0 == 0 || n1 == 0)
      continue;
    const double cost = area(l0, h0) * n0 + area(l1, h1) * n1;
    if (cost < best)
    {
      best = cost;
      best_split = s;
    }
  }
  if (best_split < 0)
    return makeLeaf();
  // Stable partition keeps the build deterministic for a given input order.
  const auto mid_it = std::stable_partition(order_.begin() + begin, order_.begin() + end,
                                            [&](std::uint32_t p) { return binOf(p) < best_split; });
  const auto mid = static_cast<std::uint32_t>(mid_it - order_.begin());
  build(begin, mid, lo, hi, centre, depth + 1);
  const std::uint32_t right = build(mid, end, lo, hi, centre, depth + 1);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

bool PrimitiveBvh::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min,
                             double t_max, PrimitiveHit& hit, std::uint32_t skip_id) const
{
  return traverse(origin, direction, t_min, t_max, hit, skip_id, false);
}

bool PrimitiveBvh::occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                            std::uint32_t skip_id) const
{
  PrimitiveHit hit;
  return traverse(origin, direction, t_min, t_max, hit, skip_id, true);
}

bool PrimitiveBvh::traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min, double t_max,
                            PrimitiveHit& hit, std::uint32_t skip_id, bool any) const
{
  if (nodes_.empty())
    return false;
  const double inv[3] = { 1.0 / direction.x(), 1.0 / direction.y(), 1.0 / direction.z() };
  const double org[3] = { origin.x(), origin.y(), origin.z() };
  // Slab test of a node's box against the current [t_min, best] interval.
  auto boxEntry = [&](const Node& nd, double limit, double& t_enter) {
    double t0 = t_min, t1 = limit;
    for (int k = 0; k < 3; ++k)
    {
      double ta = (nd.lo[k] - org[k]) * inv[k], tb = (nd.hi[k] - org[k]) * inv[k];
      if (ta > tb)
        std::swap(ta, tb);
      // NaN (0 * inf when the ray lies in a slab's plane) must not empty the interval.
      if (ta > t0)
        t0 = ta;
      if (tb < t1)
        t1 = tb;
    }
    t_enter = t0;
    return t0 <= t1;
  };
  double best = t_max;
  bool found = false;
  std::uint32_t stack[kMaxDepth + 2];
  int top = 0;
  double t_enter = 0.0;
  if (!boxEntry(nodes_[0], best, t_enter))
    return false;
  stack[top++] = 0;
  while (top > 0)
  {
    const std::uint32_t node = stack[--top];
    const Node& nd = nodes_[node];
    if (nd.count > 0)
    {
      for (std::uint32_t k = nd.first; k < nd.first + nd.count; ++k)
      {
        PrimitiveHit h;
        const std::uint32_t p = order_[k];
        if (primitives_[p].id == skip_id && skip_id != kNoId)
          continue;
        if (intersectPrimitive(primitives_[p], origin, direction, t_min, best, h) &&
            (h.t < best || (h.t == best && (!found || p < hit.index))))
        {
          best = h.t;
          hit = h;
          hit.index = p;
          found = true;
          if (any)
            return true;
        }
      }
      continue;
    }
    const std::uint32_t left = node + 1, right = nd.first;
    double tl = 0.0, tr = 0.0;
    const bool hl = boxEntry(nodes_[left], best, tl), hr = boxEntry(nodes_[right], best, tr);
    // Push the farther child first so the nearer one is searched first and shrinks `best`.
    if (hl && hr)
    {
      if (tl <= tr)
      {
        stack[top++] = right;
        stack[top++] = left;
      }
      else
      {
        stack[top++] = left;
        stack[top++] = right;
      }
    }
    else if (hl)
      stack[top++] = left;
    else if (hr)
      stack[top++] = right;
  }
  return found;
}

}  // namespace sensors
}  // namespace avsp
