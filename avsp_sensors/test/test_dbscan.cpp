// DBSCAN against a brute-force O(n^2) reference written here from docs/MODELS.md 4's definition
// (and dbscan.hpp's rule for contested border points), on random and adversarial inputs.
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <pcl/point_types.h>

#include "avsp_sensors/dbscan.hpp"
#include "avsp_sensors/point_types.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;

namespace
{
/// Brute force: all pairwise distances; cores by count; clusters by flood fill over cores;
/// each border point to its nearest core (ties: lowest index); clusters numbered by their
/// lowest-indexed member.
DbscanResult reference(const std::vector<Vector3d>& p, double eps, std::size_t min_points)
{
  const std::size_t n = p.size();
  auto d2 = [&](std::size_t a, std::size_t b) {
    const double dx = p[a].x() - p[b].x(), dy = p[a].y() - p[b].y(), dz = p[a].z() - p[b].z();
    return dx * dx + dy * dy + dz * dz;
  };
  const double e2 = eps * eps;
  std::vector<bool> core(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    std::size_t count = 0;
    for (std::size_t j = 0; j < n; ++j)
      count += d2(i, j) <= e2;
    core[i] = count >= min_points;
  }
  std::vector<int> comp(n, -1);
  int ncomp = 0;
  for (std::size_t s = 0; s < n; ++s)
  {
    if (!core[s] || comp[s] >= 0)
      continue;
    std::vector<std::size_t> stack{ s };
    comp[s] = ncomp;
    while (!stack.empty())
    {
      const std::size_t a = stack.back();
      stack.pop_back();
      for (std::size_t b = 0; b < n; ++b)
        if (core[b] && comp[b] < 0 && d2(a, b) <= e2)
        {
          comp[b] = ncomp;
          stack.push_back(b);
        }
    }
    ++ncomp;
  }
  DbscanResult r;
  r.labels.assign(n, -1);
  r.classes.assign(n, PointClass::kNoise);
  std::vector<int> raw(n, -1);
  for (std::size_t i = 0; i < n; ++i)
  {
    if (core[i])
    {
      raw[i] = comp[i];
      r.classes[i] = PointClass::kCore;
      continue;
    }
    double best = 1e300;
    std::size_t best_j = n;
    for (std::size_t j = 0; j < n; ++j)
      if (core[j] && d2(i, j) <= e2 && d2(i, j) < best)  // strict: the first (lowest) j wins ties
      {
        best = d2(i, j);
        best_j = j;
      }
    if (best_j < n)
    {
      raw[i] = comp[best_j];
      r.classes[i] = PointClass::kBorder;
    }
  }
  std::map<int, int> renumber;
  for (std::size_t i = 0; i < n; ++i)
    if (raw[i] >= 0)
    {
      auto it = renumber.find(raw[i]);
      if (it == renumber.end())
        it = renumber.emplace(raw[i], static_cast<int>(renumber.size())).first;
      r.labels[i] = it->second;
    }
  r.clusters = renumber.size();
  return r;
}

/// Same partition up to renaming the clusters (a bijection between labels), same noise.
bool samePartition(const std::vector<int>& a, const std::vector<int>& b)
{
  if (a.size() != b.size())
    return false;
  std::map<int, int> ab, ba;
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    if ((a[i] < 0) != (b[i] < 0))
      return false;
    if (a[i] < 0)
      continue;
    auto x = ab.emplace(a[i], b[i]).first;
    auto y = ba.emplace(b[i], a[i]).first;
    if (x->second != b[i] || y->second != a[i])
      return false;
  }
  return true;
}

void expectSame(const std::vector<Vector3d>& p, double eps, std::size_t m, const std::string& what)
{
  const DbscanResult want = reference(p, eps, m);
  for (const NeighbourSearch s :
       { NeighbourSearch::kGrid, NeighbourSearch::kKdTree, NeighbourSearch::kPclKdTree, NeighbourSearch::kPclOctree })
  {
    const std::string how = what + " [" + toString(s) + "]";
    const DbscanResult got = dbscan(p, eps, m, s);
    ASSERT_EQ(got.clusters, want.clusters) << how;
    EXPECT_TRUE(samePartition(got.labels, want.labels)) << how;
    EXPECT_EQ(got.labels, want.labels) << how << " (canonical numbering)";
    EXPECT_EQ(got.classes, want.classes) << how;
  }
}
}  // namespace

TEST(Dbscan, MatchesBruteForceOnRandomClouds)
{
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> G(0.0, 1.0);
  int multi = 0;
  std::size_t borders = 0;
  for (int trial = 0; trial < 40; ++trial)
  {
    const std::size_t n = 50 + static_cast<std::size_t>(U(rng) * 900);
    std::vector<Vector3d> p;
    // Blobs of varying density plus uniform noise.
    const int blobs = 1 + trial % 7;
    for (std::size_t i = 0; i < n; ++i)
    {
      if (U(rng) < 0.3)
        p.emplace_back(30 * U(rng), 30 * U(rng), 5 * U(rng));
      else
      {
        const int b = static_cast<int>(U(rng) * blobs);
        const double s = 0.2 + 0.3 * b;
        p.emplace_back(4.0 * b + s * G(rng), 3.0 * b + s * G(rng), s * G(rng));
      }
    }
    const double eps = 0.3 + 1.2 * U(rng);
    const std::size_t m = 1 + static_cast<std::size_t>(U(rng) * 8);
    expectSame(p, eps, m, "trial " + std::to_string(trial));
    const DbscanResult r = dbscan(p, eps, m);
    multi += r.clusters > 1;
    borders += static_cast<std::size_t>(std::count(r.classes.begin(), r.classes.end(), PointClass::kBorder));
  }
  // The trials exercised what matters: several clusters, and border points.
  EXPECT_GT(multi, 20);
  EXPECT_GT(borders, 500u);
}

TEST(Dbscan, AdversarialInputs)
{
  // Points exactly eps apart on an integer lattice (distances exact in binary): with
  // eps = 1, a 6-neighbour lattice is one cluster at min_points <= 7 and all noise above.
  std::vector<Vector3d> lattice;
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 5; ++y)
      for (int z = 0; z < 4; ++z)
        lattice.emplace_back(x, y, z);
  for (std::size_t m : { 1u, 2u, 4u, 5u, 7u, 8u })
    expectSame(lattice, 1.0, m, "lattice m=" + std::to_string(m));
  EXPECT_EQ(dbscan(lattice, 1.0, 2).clusters, 1u);
  EXPECT_EQ(dbscan(lattice, 1.0, 8).clusters, 0u);
  EXPECT_EQ(dbscan(lattice, std::nextafter(1.0, 0.0), 2).clusters, 0u);  // just short of eps: isolated

  // Many duplicates: 200 copies of one point, 3 of another 0.5 away, one far away.
  std::vector<Vector3d> dup(200, Vector3d(1, 2, 3));
  for (int k = 0; k < 3; ++k)
    dup.emplace_back(1.5, 2, 3);
  dup.emplace_back(100, 100, 100);
  expectSame(dup, 0.5, 5, "duplicates");
  expectSame(dup, 0.49, 5, "duplicates, eps short");

  // A chain: points 0.9 apart on a line, one cluster by chaining, ends are border points.
  std::vector<Vector3d> chain;
  for (int k = 0; k < 60; ++k)
    chain.emplace_back(0.9 * k, 0.0, 0.0);
  expectSame(chain, 1.0, 3, "chain");
  const DbscanResult cr = dbscan(chain, 1.0, 3);
  EXPECT_EQ(cr.clusters, 1u);
  EXPECT_EQ(cr.classes.front(), PointClass::kBorder);
  EXPECT_EQ(cr.classes[1], PointClass::kCore);

  // Spread over 10^7 eps (a wide grid key), and over 10^21 eps (more cells than the grid's
  // 64-bit keys hold: the kd-tree takes over).
  std::vector<Vector3d> spread{ Vector3d(0, 0, 0), Vector3d(0.5, 0, 0), Vector3d(1e7, 0, 0), Vector3d(1e7, 0.5, 0) };
  expectSame(spread, 1.0, 2, "spread");
  EXPECT_EQ(dbscan(spread, 1.0, 2).clusters, 2u);
  spread.emplace_back(1e21, 0, 0);
  spread.emplace_back(1e21, 0, 0.5);
  expectSame(spread, 1.0, 2, "huge spread");
  EXPECT_EQ(dbscan(spread, 1.0, 2).clusters, 3u);

  // Empty input, one point, everything within eps.
  EXPECT_EQ(dbscan({}, 1.0, 3).clusters, 0u);
  const DbscanResult one = dbscan({ Vector3d(1, 1, 1) }, 1.0, 1);
  EXPECT_EQ(one.clusters, 1u);
  EXPECT_EQ(one.classes[0], PointClass::kCore);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(0.0, 0.1);
  std::vector<Vector3d> dense;
  for (int k = 0; k < 300; ++k)
    dense.emplace_back(U(rng), U(rng), U(rng));
  expectSame(dense, 1.0, 10, "dense");
  EXPECT_EQ(dbscan(dense, 1.0, 10).clusters, 1u);
}

TEST(Dbscan, ContestedBorderPointGoesToItsNearestCoreThenTheLowestIndex)
{
  // Two rows of 11 points 0.1 m apart, A on [-2, -1] and B on [1, 2], and a point P between
  // them. With eps = 1.2 and min_points = 9 every row point is core (it has >= 11 row points
  // within 1 m), the rows are 2 m apart (two clusters), and P sees at most 4 points of each
  // row: it is a border point that both clusters could claim.
  auto cloud = [](double p_x) {
    std::vector<Vector3d> v;
    v.emplace_back(p_x, 0, 0);  // index 0: P
    for (int k = 0; k <= 10; ++k)
      v.emplace_back(-1.0 - 0.1 * k, 0, 0);  // A: 1..11, index 1 at x = -1
    for (int k = 0; k <= 10; ++k)
      v.emplace_back(1.0 + 0.1 * k, 0, 0);  // B: 12..22, index 12 at x = +1
    return v;
  };
  // P at 0.1 is nearer to B's end (0.9 m) than to A's (1.1 m): it joins B, although A is
  // numbered first and a classic DBSCAN visiting in index order would have given it to A.
  {
    const auto v = cloud(0.1);
    const DbscanResult r = dbscan(v, 1.2, 9);
    ASSERT_EQ(r.clusters, 2u);
    EXPECT_EQ(r.classes[0], PointClass::kBorder);
    EXPECT_EQ(r.classes[1], PointClass::kCore);
    EXPECT_EQ(r.classes[12], PointClass::kCore);
    EXPECT_EQ(r.labels[0], r.labels[12]);
    EXPECT_NE(r.labels[0], r.labels[1]);
    expectSame(v, 1.2, 9, "nearer B");
  }
  // At 0: exactly 1 m from both ends; the lower index (A's end, index 1) wins.
  {
    const auto v = cloud(0.0);
    const DbscanResult r = dbscan(v, 1.2, 9);
    ASSERT_EQ(r.clusters, 2u);
    EXPECT_EQ(r.classes[0], PointClass::kBorder);
    EXPECT_EQ(r.labels[0], r.labels[1]);
    expectSame(v, 1.2, 9, "tie");
  }
  // Listed in reverse, P (now last) still joins B (its nearest core, now index 10).
  {
    auto v = cloud(0.1);
    std::reverse(v.begin(), v.end());
    const DbscanResult r = dbscan(v, 1.2, 9);
    ASSERT_EQ(v[10].x(), 1.0);
    EXPECT_EQ(r.labels[22], r.labels[10]);
    expectSame(v, 1.2, 9, "reversed");
  }
}

TEST(Dbscan, BadInputThrowsNamingTheArgument)
{
  const std::vector<Vector3d> p{ Vector3d(0, 0, 0), Vector3d(1, 0, 0) };
  for (double eps : { 0.0, -1.0, std::nan(""), double(INFINITY) })
  {
    try
    {
      dbscan(p, eps, 2);
      FAIL() << eps;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find("eps"), std::string::npos);
    }
  }
  try
  {
    dbscan(p, 1.0, 0);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("min_points"), std::string::npos);
  }
  try
  {
    dbscan({ Vector3d(0, 0, 0), Vector3d(std::nan(""), 0, 0) }, 1.0, 2);
    FAIL();
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("points[1]"), std::string::npos);
  }
}

TEST(Dbscan, PclCloudGivesTheLabelsOfTheSamePointsAsEigenVectors)
{
  // Radar-like blobs in float (as a PCL cloud holds them): the cloud overload widens each
  // coordinate exactly, so its labels are those of the same coordinates given as doubles, and
  // those match the brute-force reference.
  std::mt19937_64 rng(5);
  std::normal_distribution<float> G(0.0f, 0.4f);
  RadarCloud cloud;
  std::vector<Vector3d> same;
  for (int b = 0; b < 6; ++b)
    for (int k = 0; k < 40; ++k)
    {
      RadarPoint p;
      p.x = 10.0f + 3.0f * static_cast<float>(b) + G(rng);
      p.y = 2.0f * static_cast<float>(b % 3) + G(rng);
      p.z = G(rng);
      cloud.push_back(p);
      same.emplace_back(p.x, p.y, p.z);
    }
  const DbscanResult want = reference(same, 0.5, 4);
  ASSERT_GT(want.clusters, 3u);
  for (const NeighbourSearch s : { NeighbourSearch::kGrid, NeighbourSearch::kPclKdTree })
  {
    const DbscanResult got = dbscan(cloud, 0.5, 4, s);
    EXPECT_EQ(got.labels, want.labels) << toString(s);
    EXPECT_EQ(got.classes, want.classes) << toString(s);
  }
  // Any registered type with x, y, z: pcl::PointXYZ too.
  pcl::PointCloud<pcl::PointXYZ> xyz;
  for (const RadarPoint& p : cloud)
    xyz.push_back(pcl::PointXYZ(p.x, p.y, p.z));
  EXPECT_EQ(dbscan(xyz, 0.5, 4).labels, want.labels);
}

TEST(Dbscan, PclCloudWithANanPointIsRefusedNamingThePoint)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.push_back(pcl::PointXYZ(0.0f, 0.0f, 0.0f));
  cloud.push_back(pcl::PointXYZ(0.5f, 0.0f, 0.0f));
  cloud.push_back(pcl::PointXYZ(std::nanf(""), 0.0f, 0.0f));
  try
  {
    dbscan(cloud, 1.0, 2);
    FAIL() << "a NaN point was accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("points[2]"), std::string::npos) << e.what();
  }
  // An empty cloud is a defined result: no clusters.
  EXPECT_EQ(dbscan(pcl::PointCloud<pcl::PointXYZ>(), 1.0, 2).clusters, 0u);
}
