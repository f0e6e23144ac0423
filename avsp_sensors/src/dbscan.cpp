#include "avsp_sensors/dbscan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include <nanoflann.hpp>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/octree/octree_search.h>
#include <pcl/point_types.h>

#include "avsp_sensors/random.hpp"

namespace avsp
{
namespace sensors
{
namespace
{
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
/// Pairs within eps kept between the two steps (8 B each: 64 MB at most) before falling back
/// to enumerating them twice.
constexpr std::size_t kMaxStoredPairs = std::size_t{ 1 } << 23;

/// The squared distance every decision uses, computed the same way everywhere (and in the
/// brute-force reference of the tests): differences, squares, summed x + y + z.
inline double distance2(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  const double dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

/// Union-find with path halving; the lower index becomes the root.
struct Forest
{
  std::vector<std::uint32_t> parent;
  void reset(std::size_t n)
  {
    parent.resize(n);
    std::iota(parent.begin(), parent.end(), 0u);
  }
  std::uint32_t find(std::uint32_t a)
  {
    while (parent[a] != a)
    {
      parent[a] = parent[parent[a]];
      a = parent[a];
    }
    return a;
  }
  void unite(std::uint32_t a, std::uint32_t b)
  {
    a = find(a);
    b = find(b);
    if (a == b)
      return;
    if (a < b)
      parent[b] = a;
    else
      parent[a] = b;
  }
};

/**
 * The clustering proper, over "slots" (a permutation of the points: the grid's cell order, or
 * the points' own order), given a way to visit every pair of slots within eps exactly once:
 * count neighbours, then link cores and attach the others. Ties between equally near cores
 * go by the points' original index, so the slot order never shows in the result.
 */
struct Classifier
{
  std::size_t n = 0, min_points = 1;
  const std::uint32_t* original = nullptr;  ///< slot -> point index (null: the identity)
  std::vector<std::uint32_t> count;         ///< neighbours within eps, self excluded
  std::vector<char> core;
  Forest forest;
  std::vector<std::uint32_t> attach;  ///< nearest core slot of a non-core slot (kNone: noise)
  std::vector<double> attach_d2;
  std::vector<std::uint32_t> slot_of;  ///< point index -> slot
  std::vector<int> number;             ///< scratch of result(): cluster number by root

  /// Starts over for n points; the buffers keep their capacity from earlier runs.
  void reset(std::size_t n_, std::size_t m, const std::uint32_t* slot_to_point)
  {
    n = n_;
    min_points = m;
    original = slot_to_point;
    count.assign(n, 0);
    core.assign(n, 0);
    forest.reset(n);
    attach.assign(n, kNone);
    attach_d2.assign(n, std::numeric_limits<double>::infinity());
  }
  std::uint32_t point(std::uint32_t slot) const { return original ? original[slot] : slot; }
  void finishCounting()
  {
    // |N(p)| includes p itself.
    for (std::size_t i = 0; i < n; ++i)
      core[i] = count[i] + 1 >= min_points;
  }
  void offer(std::uint32_t i, std::uint32_t j, double d2)
  {
    // Non-core i takes its nearest core; equally near cores: the lowest point index.
    if (d2 < attach_d2[i] || (d2 == attach_d2[i] && (attach[i] == kNone || point(j) < point(attach[i]))))
    {
      attach_d2[i] = d2;
      attach[i] = j;
    }
  }
  void linkPair(std::uint32_t i, std::uint32_t j, double d2)
  {
    if (core[i] && core[j])
      forest.unite(i, j);
    else if (core[j])
      offer(i, j, d2);
    else if (core[i])
      offer(j, i, d2);
  }
  void result(DbscanResult& out)
  {
    out.labels.assign(n, kNoiseLabel);
    out.classes.assign(n, PointClass::kNoise);
    slot_of.resize(n);
    for (std::uint32_t s = 0; s < n; ++s)
      slot_of[point(s)] = s;
    // Clusters numbered in the order of their lowest-indexed member.
    number.assign(n, kNoiseLabel);  // by root slot
    int next = 0;
    for (std::size_t i = 0; i < n; ++i)
    {
      const std::uint32_t s = slot_of[i];
      std::uint32_t root;
      if (core[s])
      {
        root = forest.find(s);
        out.classes[i] = PointClass::kCore;
      }
      else if (attach[s] != kNone)
      {
        root = forest.find(attach[s]);
        out.classes[i] = PointClass::kBorder;
      }
      else
        continue;
      if (number[root] == kNoiseLabel)
        number[root] = next++;
      out.labels[i] = number[root];
    }
    out.clusters = static_cast<std::size_t>(next);
  }
};

// ---------------------------------------------------------------------------- uniform grid

/// Bits needed to hold values 0 .. v.
int bitWidth(std::uint64_t v)
{
  int b = 0;
  while (b < 64 && (v >> b) != 0)
    ++b;
  return b;
}

/**
 * Cells of side eps; points sorted by cell key (x, y, z cell, z fastest), so that a column of
 * cells (fixed x, y) is one contiguous run of points and the cells z-1 .. z+1 of a column one
 * contiguous sub-run. A point's neighbours lie in its own and the 8 surrounding columns, within
 * one cell of its z: each cell is paired with its own column's next cell and with 4 "forward"
 * columns, which with their mirror images covers every neighbouring cell pair once.
 */
class Grid
{
public:
  /// False when the cell keys and point indices do not fit 64 bits together (points spread over
  /// a huge number of eps): the caller then uses the kd-tree.
  bool build(const std::vector<Eigen::Vector3d>& points, double eps)
  {
    const std::size_t n = points.size();
    Eigen::Vector3d lo = points[0], hi = points[0];
    for (const auto& p : points)
    {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    // Cell coordinates are offset by 1 so that "one cell lower" is never negative.
    std::uint64_t top[3];
    for (int a = 0; a < 3; ++a)
    {
      const double cells = std::floor((hi[a] - lo[a]) / eps) + 3.0;
      if (!(cells < 1e15))
        return false;
      top[a] = static_cast<std::uint64_t>(cells);
      bits_[a] = std::max(1, bitWidth(top[a]));
    }
    const int index_bits = std::max(1, bitWidth(n - 1));
    if (bits_[0] + bits_[1] + bits_[2] + index_bits > 64)
      return false;
    std::vector<std::uint64_t>& composite = composite_;
    composite.resize(n);
    scratch_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
    {
      std::uint64_t key = 0;
      for (int a = 0; a < 3; ++a)
        key = (key << bits_[a]) | (static_cast<std::uint64_t>(std::floor((points[i][a] - lo[a]) / eps)) + 1);
      composite[i] = (key << index_bits) | i;
    }
    radixSort(composite, scratch_);
    x_.resize(n);
    y_.resize(n);
    z_.resize(n);
    index_.resize(n);
    key_.resize(n);
    const std::uint64_t index_mask = (index_bits == 64) ? ~0ull : ((std::uint64_t{ 1 } << index_bits) - 1);
    for (std::size_t k = 0; k < n; ++k)
    {
      const auto i = static_cast<std::uint32_t>(composite[k] & index_mask);
      key_[k] = composite[k] >> index_bits;
      x_[k] = points[i].x();
      y_[k] = points[i].y();
      z_[k] = points[i].z();
      index_[k] = i;
    }
    // Columns: (x, y) key -> [begin, end) of their points.
    columns_.clear();
    for (std::size_t k = 0; k < n; ++k)
      if (k == 0 || column(key_[k]) != column(key_[k - 1]))
        columns_.push_back({ column(key_[k]), static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(k + 1) });
      else
        columns_.back().end = static_cast<std::uint32_t>(k + 1);
    std::size_t cap = 16;
    while (cap < 2 * columns_.size())
      cap <<= 1;
    table_.assign(cap, kNone);
    mask_ = cap - 1;
    for (std::uint32_t c = 0; c < columns_.size(); ++c)
    {
      std::size_t h = mix64(columns_[c].key) & mask_;
      while (table_[h] != kNone)
        h = (h + 1) & mask_;
      table_[h] = c;
    }
    return true;
  }

  /// Point index of each slot (the grid's cell order).
  const std::uint32_t* slots() const { return index_.data(); }

  /// Squared distance of two slots, computed as distance2() computes it on the points.
  double distance2(std::uint32_t k, std::uint32_t l) const
  {
    const double dx = x_[k] - x_[l], dy = y_[k] - y_[l], dz = z_[k] - z_[l];
    return dx * dx + dy * dy + dz * dz;
  }

  /// Calls f(k, l) for every pair of slots within eps2 (k != l), once each, grouped by k.
  template <class F>
  void forEachPair(double eps2, F&& f)
  {
    const std::size_t n = key_.size();
    const std::uint64_t z_one = 1, y_one = std::uint64_t{ 1 } << bits_[2];
    for (std::size_t a0 = 0; a0 < n;)
    {
      const std::uint64_t key = key_[a0];
      std::size_t a1 = a0 + 1;
      while (a1 < n && key_[a1] == key)
        ++a1;
      // Ranges of candidate partners for every point of this cell.
      std::uint32_t range_begin[6], range_end[6];
      int ranges = 0;
      // The next cell up in the same column, if it is there (it follows this one directly).
      {
        std::size_t e = a1;
        while (e < n && key_[e] == key + z_one)
          ++e;
        if (e > a1)
        {
          range_begin[ranges] = static_cast<std::uint32_t>(a1);
          range_end[ranges++] = static_cast<std::uint32_t>(e);
        }
      }
      // Forward columns (dx, dy) = (0, 1), (1, -1), (1, 0), (1, 1): cells z-1 .. z+1 of each.
      const std::uint64_t x_one = std::uint64_t{ 1 } << (bits_[1] + bits_[2]);
      const std::uint64_t offsets[4] = { y_one, x_one - y_one, x_one, x_one + y_one };
      for (const std::uint64_t off : offsets)
      {
        const std::uint64_t target = key + off;  // same z: the middle of the three cells
        const std::uint32_t c = findColumn(column(target));
        if (c == kNone)
          continue;
        const Column& col = columns_[c];
        const auto first = std::lower_bound(key_.begin() + col.begin, key_.begin() + col.end, target - z_one);
        const auto last = std::upper_bound(first, key_.begin() + col.end, target + z_one);
        if (first != last)
        {
          range_begin[ranges] = static_cast<std::uint32_t>(first - key_.begin());
          range_end[ranges++] = static_cast<std::uint32_t>(last - key_.begin());
        }
      }
      std::size_t candidates = a1 - a0;
      for (int r = 0; r < ranges; ++r)
        candidates += range_end[r] - range_begin[r];
      if (hits_.size() < candidates)
        hits_.resize(candidates);
      std::uint32_t* hits = hits_.data();
      for (std::size_t k = a0; k < a1; ++k)
      {
        const double xk = x_[k], yk = y_[k], zk = z_[k];
        // Branch-free: every candidate is written, the count advances only for hits. About one
        // candidate in six is a hit, so a branch here would mispredict on most hits.
        std::size_t m = 0;
        auto test = [&](std::size_t l) {
          // The same arithmetic as distance2() on the original points (exact copies of them).
          const double dx = xk - x_[l], dy = yk - y_[l], dz = zk - z_[l];
          const double d2 = dx * dx + dy * dy + dz * dz;
          hits[m] = static_cast<std::uint32_t>(l);
          m += d2 <= eps2;
        };
        for (std::size_t l = k + 1; l < a1; ++l)
          test(l);
        for (int r = 0; r < ranges; ++r)
          for (std::size_t l = range_begin[r]; l < range_end[r]; ++l)
            test(l);
        for (std::size_t h = 0; h < m; ++h)
          f(static_cast<std::uint32_t>(k), hits[h]);
      }
      a0 = a1;
    }
  }

private:
  struct Column
  {
    std::uint64_t key;
    std::uint32_t begin, end;
  };

  std::uint64_t column(std::uint64_t key) const { return key >> bits_[2]; }

  std::uint32_t findColumn(std::uint64_t ckey) const
  {
    std::size_t h = mix64(ckey) & mask_;
    for (;;)
    {
      const std::uint32_t c = table_[h];
      if (c == kNone || columns_[c].key == ckey)
        return c;
      h = (h + 1) & mask_;
    }
  }

  /// LSD radix sort, 11-bit digits: linear in n, no comparisons.
  static void radixSort(std::vector<std::uint64_t>& v, std::vector<std::uint64_t>& tmp)
  {
    std::uint64_t all = 0;
    for (std::uint64_t x : v)
      all |= x;
    const int width = bitWidth(all);
    for (int shift = 0; shift < width; shift += 11)
    {
      std::uint32_t count[2049] = { 0 };
      for (std::uint64_t x : v)
        ++count[((x >> shift) & 2047) + 1];
      for (int d = 0; d < 2048; ++d)
        count[d + 1] += count[d];
      for (std::uint64_t x : v)
        tmp[count[(x >> shift) & 2047]++] = x;
      v.swap(tmp);
    }
  }

  int bits_[3] = { 0, 0, 0 };
  std::vector<std::uint64_t> composite_, scratch_;
  std::vector<std::uint64_t> key_;
  std::vector<double> x_, y_, z_;
  std::vector<std::uint32_t> index_;
  std::vector<Column> columns_;
  std::vector<std::uint32_t> hits_;  ///< scratch of forEachPair()
  std::vector<std::uint32_t> table_;
  std::size_t mask_ = 0;
};

// ---------------------------------------------------------------------------- kd-tree

/// nanoflann's view of the points.
struct Cloud
{
  const std::vector<Eigen::Vector3d>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return pts[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box& /*box*/) const
  {
    return false;  // let the tree compute it
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, std::uint32_t>;

/**
 * A nanoflann result set that calls visit(j, d2) for every point j > i with d2 <= eps^2 by our
 * own distance (so each pair is seen once, from its lower index). The tree prunes with a
 * slightly larger radius so that its rounding can never drop a point our test keeps.
 */
template <class Visit>
struct PairVisitor
{
  const std::vector<Eigen::Vector3d>& pts;
  std::uint32_t i;
  double eps2;
  double prune2;
  Visit& visit;

  double worstDist() const { return prune2; }
  bool full() const { return true; }
  bool addPoint(double /*tree_d2*/, std::uint32_t j)
  {
    if (j <= i)
      return true;
    const double d2 = distance2(pts[i], pts[j]);
    if (d2 <= eps2)
      visit(i, j, d2);
    return true;
  }
};

template <class F>
void kdTreePairs(const Tree& tree, const std::vector<Eigen::Vector3d>& pts, double eps2, F&& f)
{
  // Queries in the tree's own order (leaf by leaf), so consecutive ones run from cache.
  for (const std::uint32_t i : tree.vAcc)
  {
    PairVisitor<F> rs{ pts, i, eps2, eps2 * (1.0 + 1e-9) + std::numeric_limits<double>::min(), f };
    tree.findNeighbors(rs, pts[i].data(), nanoflann::SearchParams());
  }
}

// ---------------------------------------------------------------------------- PCL searches

/**
 * Radius of a PCL query that can miss no pair within eps by the double distance: PCL searches
 * float copies of the points (each coordinate rounded by up to |c| 2^-24) and compares float
 * squared distances, so the query is widened by those roundings; every candidate is then
 * re-tested in double (distance2()), which alone decides.
 */
double pclSearchRadius(const std::vector<Eigen::Vector3d>& pts, double eps)
{
  double extent = 0.0;
  for (const auto& p : pts)
    extent = std::max(extent, p.cwiseAbs().maxCoeff());
  return eps * (1.0 + 1e-5) + 8.0 * extent * std::ldexp(1.0, -24) + 1e-30;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr floatCloud(const std::vector<Eigen::Vector3d>& pts)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k)
    (*cloud)[k] =
        pcl::PointXYZ(static_cast<float>(pts[k].x()), static_cast<float>(pts[k].y()), static_cast<float>(pts[k].z()));
  return cloud;
}

/// Calls f(i, j) for every pair i < j within eps (double distance), once each, through PCL's
/// KdTreeFLANN or octree: one radiusSearch per point, in index order.
template <class F>
void pclPairs(NeighbourSearch search, const std::vector<Eigen::Vector3d>& pts, double eps, F&& f)
{
  const double eps2 = eps * eps, radius = pclSearchRadius(pts, eps);
  const pcl::PointCloud<pcl::PointXYZ>::Ptr cloud = floatCloud(pts);
  pcl::Indices found;
  std::vector<float> d2;
  auto visit = [&](std::uint32_t i) {
    for (const auto j : found)
      if (static_cast<std::uint32_t>(j) > i && distance2(pts[i], pts[static_cast<std::size_t>(j)]) <= eps2)
        f(i, static_cast<std::uint32_t>(j));
  };
  double span = 0.0;
  if (!pts.empty())
  {
    Eigen::Vector3d lo = pts[0], hi = pts[0];
    for (const auto& p : pts)
    {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    span = (hi - lo).maxCoeff();
  }
  if (search == NeighbourSearch::kPclKdTree || !(span / eps < std::ldexp(1.0, 30)))
  {
    pcl::KdTreeFLANN<pcl::PointXYZ> tree(false);  // unsorted results: the order is ours to fix
    tree.setInputCloud(cloud);
    for (std::uint32_t i = 0; i < pts.size(); ++i)
    {
      tree.radiusSearch(static_cast<pcl::index_t>(i), radius, found, d2);
      visit(i);
    }
  }
  else
  {
    // Leaves of eps: a query visits the leaves its ball touches. (Spreads beyond 2^30 eps, which
    // the octree's 32-bit keys cannot hold at that depth, are left to the kd-tree above.)
    pcl::octree::OctreePointCloudSearch<pcl::PointXYZ> tree(eps);
    tree.setInputCloud(cloud);
    tree.addPointsFromInputCloud();
    for (std::uint32_t i = 0; i < pts.size(); ++i)
    {
      tree.radiusSearch(static_cast<pcl::index_t>(i), radius, found, d2);
      visit(i);
    }
  }
}
}  // namespace

/// Everything a run allocates, kept for the next run.
struct Dbscan::Workspace
{
  struct Pair
  {
    std::uint32_t k, l;  ///< slots; the distance is recomputed when needed (cheaper than storing it)
  };
  Classifier classifier;
  Grid grid;
  std::vector<Pair> pairs;
  DbscanResult result;
};

Dbscan::Dbscan() : ws_(new Workspace)
{
}
Dbscan::~Dbscan() = default;
Dbscan::Dbscan(Dbscan&&) noexcept = default;
Dbscan& Dbscan::operator=(Dbscan&&) noexcept = default;

const DbscanResult& Dbscan::run(const std::vector<Eigen::Vector3d>& points, double eps, std::size_t min_points,
                                NeighbourSearch search)
{
  if (!(eps > 0.0) || !std::isfinite(eps))
    throw std::invalid_argument("dbscan: eps must be finite and > 0, got " + std::to_string(eps));
  if (min_points == 0)
    throw std::invalid_argument("dbscan: min_points must be >= 1");
  if (points.size() >= kNone)
    throw std::invalid_argument("dbscan: too many points");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw std::invalid_argument("dbscan: points[" + std::to_string(i) + "] is not finite");
  const std::size_t n = points.size();
  Classifier& c = ws_->classifier;
  if (n == 0)
  {
    c.reset(0, min_points, nullptr);
    c.result(ws_->result);
    return ws_->result;
  }
  const double eps2 = eps * eps;
  Grid& grid = ws_->grid;
  if (search == NeighbourSearch::kGrid && grid.build(points, eps))
  {
    c.reset(n, min_points, grid.slots());
    // One sweep that counts and keeps the pairs while they fit (each pair once: a few MB for
    // radar scenes); an input denser than that sweeps a second time instead of storing.
    auto& pairs = ws_->pairs;
    pairs.clear();
    bool kept = true;
    std::uint32_t* count = c.count.data();
    grid.forEachPair(eps2, [&](std::uint32_t k, std::uint32_t l) {
      ++count[k];
      ++count[l];
      if (kept)
      {
        if (pairs.size() < kMaxStoredPairs)
          pairs.push_back({ k, l });
        else
          kept = false;
      }
    });
    c.finishCounting();
    if (kept)
      for (const Workspace::Pair& p : pairs)
        c.linkPair(p.k, p.l, grid.distance2(p.k, p.l));
    else
    {
      pairs.clear();
      pairs.shrink_to_fit();
      grid.forEachPair(eps2, [&](std::uint32_t k, std::uint32_t l) { c.linkPair(k, l, grid.distance2(k, l)); });
    }
  }
  else if (search == NeighbourSearch::kPclKdTree || search == NeighbourSearch::kPclOctree)
  {
    // One search per point, the pairs kept between counting and linking (as the grid does,
    // so the comparison in bench_dbscan times the searches, not a second sweep).
    c.reset(n, min_points, nullptr);
    auto& pairs = ws_->pairs;
    pairs.clear();
    bool kept = true;
    pclPairs(search, points, eps, [&](std::uint32_t i, std::uint32_t j) {
      ++c.count[i];
      ++c.count[j];
      if (kept)
      {
        if (pairs.size() < kMaxStoredPairs)
          pairs.push_back({ i, j });
        else
          kept = false;
      }
    });
    c.finishCounting();
    if (kept)
      for (const Workspace::Pair& p : pairs)
        c.linkPair(p.k, p.l, distance2(points[p.k], points[p.l]));
    else
    {
      pairs.clear();
      pairs.shrink_to_fit();
      pclPairs(search, points, eps,
               [&](std::uint32_t i, std::uint32_t j) { c.linkPair(i, j, distance2(points[i], points[j])); });
    }
  }
  else
  {
    c.reset(n, min_points, nullptr);
    const Cloud cloud{ points };
    const Tree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    kdTreePairs(tree, points, eps2, [&](std::uint32_t i, std::uint32_t j, double) {
      ++c.count[i];
      ++c.count[j];
    });
    c.finishCounting();
    kdTreePairs(tree, points, eps2, [&](std::uint32_t i, std::uint32_t j, double d2) { c.linkPair(i, j, d2); });
  }
  c.result(ws_->result);
  return ws_->result;
}

const char* toString(NeighbourSearch search)
{
  switch (search)
  {
    case NeighbourSearch::kGrid:
      return "grid";
    case NeighbourSearch::kKdTree:
      return "kd-tree";
    case NeighbourSearch::kPclKdTree:
      return "pcl-kdtree";
    case NeighbourSearch::kPclOctree:
      return "pcl-octree";
  }
  return "unknown";
}

DbscanResult dbscan(const std::vector<Eigen::Vector3d>& points, double eps, std::size_t min_points,
                    NeighbourSearch search)
{
  Dbscan d;
  return d.run(points, eps, min_points, search);
}

}  // namespace sensors
}  // namespace avsp
