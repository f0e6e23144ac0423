// Lidar clustering (lidar_clustering.hpp) against the scene's geometry: a VLP-16 sweep over a
// scene of known objects (a deer and a truck as agents, another vehicle's boxes, trees) gives one
// cluster per object, made of exactly the sweep's points inside that object's bounding box and
// above the ground clearance; the default course's trees likewise; no cluster on a bare slope
// (the terrain test, not a flat height cut); unregistered sweeps; NaN points, empty clouds and
// bad configurations.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <avsp_terrain/agents.hpp>
#include <avsp_terrain/default_course.hpp>
#include <avsp_terrain/terrain_objects.hpp>

#include "avsp_sensors/agent_bodies.hpp"
#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/lidar_clustering.hpp"
#include "avsp_sensors/scene.hpp"
#include "avsp_sensors/sensor_suite.hpp"

using namespace avsp::sensors;
namespace terrain = avsp::terrain;
using Eigen::Vector3d;

namespace
{
constexpr double kPi = 3.14159265358979323846;

/// A plane z = slope_x x over [-half, half]^2 on 0.5 m cells.
terrain::ElevationGrid planeGrid(double slope_x = 0.0, double half = 60.0, double cell = 0.5)
{
  const std::size_t n = static_cast<std::size_t>(2 * half / cell) + 1;
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(slope_x * (-half + cell * static_cast<double>(i)));
  return terrain::ElevationGrid(-half, -half, cell, cell, n, n, h);
}

TerrainHeightFn heights(const Scene& scene)
{
  return [&scene](double x, double y, double& z) { return scene.terrain().heightAt(x, y, z); };
}

/// One object of the test scene: its name and its exact axis-aligned bounding box.
struct Known
{
  std::string name;
  Vector3d lo, hi;
};

Known boundsOf(const std::string& name, const std::vector<Primitive>& parts)
{
  Known k{ name, Vector3d::Constant(1e300), Vector3d::Constant(-1e300) };
  for (const Primitive& p : parts)
  {
    Vector3d lo, hi;
    primitiveBounds(p, lo, hi);
    k.lo = k.lo.cwiseMin(lo);
    k.hi = k.hi.cwiseMax(hi);
  }
  return k;
}

terrain::Agent standingAgent(terrain::AgentType type, const std::string& name, double x, double y, double yaw,
                             const terrain::ElevationGrid& ground)
{
  terrain::AgentSpec s;
  s.name = name;
  s.type = type;
  s.path = { Eigen::Vector2d(x, y) };
  s.yaw = yaw;
  return terrain::Agent(s, ground, "agents[0]");
}

/// The sweep's points inside the box grown by `margin` and at least `clearance` above z_ground.
std::vector<int> pointsIn(const LidarCloud& cloud, const Known& k, double margin, double z_ground, double clearance)
{
  std::vector<int> out;
  for (std::size_t i = 0; i < cloud.size(); ++i)
  {
    const Vector3d p(cloud[i].x, cloud[i].y, cloud[i].z);
    if ((p.array() >= k.lo.array() - margin).all() && (p.array() <= k.hi.array() + margin).all() &&
        p.z() - z_ground >= clearance)
      out.push_back(static_cast<int>(i));
  }
  return out;
}

Vector3d meanOf(const LidarCloud& cloud, const std::vector<int>& idx)
{
  Vector3d s = Vector3d::Zero();
  for (int i : idx)
    s += Vector3d(cloud[static_cast<std::size_t>(i)].x, cloud[static_cast<std::size_t>(i)].y,
                  cloud[static_cast<std::size_t>(i)].z);
  return s / static_cast<double>(idx.size());
}

/**
 * The flat test scene: a VLP-16 1.8 m above flat ground at the origin; a deer 8 m ahead, a
 * truck 12 m behind-left, another vehicle's two boxes 10 m to the right and two trees, all
 * more than 3 m apart.
 */
struct FlatScene
{
  terrain::ElevationGrid grid = planeGrid();
  Scene scene{ HeightField::fromGrid(grid) };
  std::vector<Known> known;

  FlatScene()
  {
    std::vector<Body> bodies;
    // The deer broadside to the sensor (its bearing is atan2(3, 8) = 0.36 rad): seen from behind,
    // its rump and its head stand 1 m apart in plan with its back out of sight between them,
    // and the lidar resolves two objects there (as a real one would).
    const terrain::Agent deer = standingAgent(terrain::AgentType::kDeer, "deer", 8.0, 3.0, 0.36 + 0.5 * kPi, grid);
    const terrain::Agent truck = standingAgent(terrain::AgentType::kTruck, "truck", -12.0, 6.0, 0.3, grid);
    for (const auto& [name, agent, id] :
         { std::tuple<std::string, const terrain::Agent*, std::uint32_t>{ "deer", &deer, 1 }, { "truck", &truck, 2 } })
    {
      const std::vector<Body> b = agentBodies(*agent, 0.0, id);
      std::vector<Primitive> parts;
      for (const Body& x : b)
        parts.push_back(x.primitive);
      known.push_back(boundsOf(name, parts));
      bodies.insert(bodies.end(), b.begin(), b.end());
    }
    // Another vehicle: a chassis and a cab (a collision-box pair like the URDF models'), yawed.
    VehicleState other;
    other.pose.translation() = Vector3d(4.0, -10.0, 0.0);
    other.pose.linear() = Eigen::AngleAxisd(-0.5, Vector3d::UnitZ()).toRotationMatrix();
    BodyBox chassis, cab;
    chassis.pose.translation() = Vector3d(0.0, 0.0, 0.75);
    chassis.size = Vector3d(3.6, 1.8, 0.9);
    cab.pose.translation() = Vector3d(-0.4, 0.0, 1.6);
    cab.size = Vector3d(1.6, 1.6, 0.8);
    const std::vector<Body> vb = vehicleBodies({ chassis, cab }, other, 3, 0.5f);
    std::vector<Primitive> parts;
    for (const Body& x : vb)
      parts.push_back(x.primitive);
    known.push_back(boundsOf("vehicle", parts));
    bodies.insert(bodies.end(), vb.begin(), vb.end());
    scene.setBodies(bodies);
    // Two trees (trunks 0.4 m across, 6 m tall), standing on the ground.
    terrain::ObjectSet objects;
    for (const Vector3d& c : { Vector3d(-6.0, -7.0, 0.0), Vector3d(15.0, -3.0, 0.0) })
    {
      terrain::TerrainObject t;
      t.type = terrain::ObjectType::kTree;
      t.x = c.x();
      t.y = c.y();
      t.length = t.width = 0.4;
      t.height = 6.0;
      objects.add(t);
    }
    scene.setObjects(objects);
    const std::vector<Primitive> trees = objectPrimitives(objects, scene.terrain(), Reflectivities());
    known.push_back(boundsOf("tree 0", { trees[0] }));
    known.push_back(boundsOf("tree 1", { trees[1] }));
  }

  LidarScan sweep(bool registered = true) const
  {
    const Lidar lidar(lidarPreset("VLP-16"), 7);
    LidarScanRequest req;
    req.motion = motion();
    req.registered = registered;
    return lidar.scan(scene, req);
  }

  static SensorMotion motion()
  {
    SensorMotion m;
    m.pose.translation() = Vector3d(0.0, 0.0, 1.8);
    m.linear_velocity = Vector3d(2.0, 0.0, 0.0);  // a vehicle creeping forward during the sweep
    return m;
  }
};

/// The gap in plan that surely separates two clusters: the tolerance, less twice a cell's
/// diagonal when points are merged per cell (lidar_clustering.hpp, cell_size).
double separation(const LidarClusterConfig& c)
{
  return c.cluster_tolerance - 2.0 * std::sqrt(2.0) * c.cell_size;
}

/**
 * The object's cluster, given the object's points (those inside its box grown by a margin,
 * above the clearance): the cluster holding most of them holds nothing else; every object point
 * left out of it lies farther than `tolerance` (in plan) from every point in it, i.e. in a
 * fragment that geometry separates (a truck's axle seen under its overhanging body, 0.7 m
 * behind the body's face), and such points are at most 2 % of the object's.
 */
const LidarCluster* objectCluster(const LidarCloud& cloud, const LidarClustering& result, const std::vector<int>& want,
                                  double tolerance, const std::string& name)
{
  const LidarCluster* best = nullptr;
  std::size_t best_common = 0;
  for (const LidarCluster& c : result.clusters)
  {
    std::size_t common = 0;
    for (int i : want)
      common += std::binary_search(c.indices.begin(), c.indices.end(), i);
    if (common > best_common)
    {
      best = &c;
      best_common = common;
    }
  }
  if (best == nullptr)
  {
    ADD_FAILURE() << name << " is in no cluster";
    return nullptr;
  }
  EXPECT_TRUE(std::includes(want.begin(), want.end(), best->indices.begin(), best->indices.end()))
      << name << ": its cluster holds points that are not the object's";
  std::size_t left_out = 0;
  for (int i : want)
  {
    if (std::binary_search(best->indices.begin(), best->indices.end(), i))
      continue;
    ++left_out;
    const LidarPoint& p = cloud[static_cast<std::size_t>(i)];
    for (int j : best->indices)
    {
      const LidarPoint& q = cloud[static_cast<std::size_t>(j)];
      if (!(std::hypot(p.x - q.x, p.y - q.y) > tolerance))
      {
        ADD_FAILURE() << name << ": point " << i << " is within the tolerance of its cluster but not in it";
        return best;
      }
    }
  }
  EXPECT_LE(left_out, want.size() / 50) << name;
  return best;
}

/**
 * Each known object is one cluster (objectCluster()), a different one for each object and none
 * besides; its centroid is the mean of its points (well within 0.3 m of the object's points'
 * mean), its box lies inside the object's grown box and spans at least half the object's height
 * above the clearance.
 */
void expectOneClusterPerObject(const LidarCloud& cloud, const LidarClustering& result, const std::vector<Known>& known,
                               const LidarClusterConfig& config, double margin)
{
  const double clearance = config.ground_clearance;
  EXPECT_EQ(result.clusters.size(), known.size());
  std::set<const LidarCluster*> used;
  for (const Known& k : known)
  {
    const std::vector<int> want = pointsIn(cloud, k, margin, 0.0, clearance);
    ASSERT_GE(want.size(), 10u) << k.name << ": the sweep should see it";
    const LidarCluster* it = objectCluster(cloud, result, want, separation(config), k.name);
    ASSERT_NE(it, nullptr);
    EXPECT_TRUE(used.insert(it).second) << k.name << " shares a cluster with another object";
    EXPECT_LT((it->centroid - meanOf(cloud, it->indices)).norm(), 1e-9) << k.name;
    EXPECT_LT((it->centroid - meanOf(cloud, want)).norm(), 0.3) << k.name;
    EXPECT_TRUE((it->min.array() >= k.lo.array() - margin).all()) << k.name;
    EXPECT_TRUE((it->max.array() <= k.hi.array() + margin).all()) << k.name;
    EXPECT_GE(it->extent().z(), 0.5 * (k.hi.z() - clearance)) << k.name;
    // Horizontally the centroid lies within the object's footprint (grown by 0.3 m).
    EXPECT_TRUE(it->centroid.x() >= k.lo.x() - 0.3 && it->centroid.x() <= k.hi.x() + 0.3 &&
                it->centroid.y() >= k.lo.y() - 0.3 && it->centroid.y() <= k.hi.y() + 0.3)
        << k.name << " centroid " << it->centroid.transpose();
  }
}
}  // namespace

TEST(LidarClustering, EachObjectOfAKnownSceneIsOneClusterOfItsPoints)
{
  // With the default 0.1 m cells and exactly (every point queried): the same objects.
  const FlatScene s;
  const LidarScan scan = s.sweep();
  LidarClusterConfig exact;
  exact.cell_size = 0.0;
  for (const LidarClusterConfig& config : { LidarClusterConfig(), exact })
  {
    SCOPED_TRACE("cell_size " + std::to_string(config.cell_size));
    const LidarClusterer clusterer(config);
    const LidarClustering r = clusterer.cluster(scan.points, FlatScene::motion().pose.translation(), heights(s.scene));
    // Ground points are the bulk of a sweep on flat ground; everything else is an object's.
    EXPECT_GT(r.ground_points, scan.points.size() / 2);
    EXPECT_EQ(r.ground_points + r.object_points, scan.points.size());
    EXPECT_EQ(r.invalid_points, 0u);
    expectOneClusterPerObject(scan.points, r, s.known, config, 0.15);
    // Largest first.
    for (std::size_t k = 1; k < r.clusters.size(); ++k)
      EXPECT_GE(r.clusters[k - 1].size(), r.clusters[k].size());
    // Range: horizontal distance from the sensor to the centroid.
    for (const LidarCluster& c : r.clusters)
      EXPECT_NEAR(c.range, std::hypot(c.centroid.x(), c.centroid.y()), 1e-9);
  }
}

namespace
{
/// A box body on flat ground (its footprint centred at (x, 0), bottom to top), and its bounds.
Known addBox(std::vector<Body>& bodies, const std::string& name, double x, double length, double width, double bottom,
             double top, std::uint32_t id)
{
  VehicleState state;
  state.pose.translation() = Vector3d(x, 0.0, 0.0);
  BodyBox box;
  box.pose.translation() = Vector3d(0.0, 0.0, 0.5 * (bottom + top));
  box.size = Vector3d(length, width, top - bottom);
  const std::vector<Body> b = vehicleBodies({ box }, state, id, 0.5f);
  std::vector<Primitive> parts;
  for (const Body& x : b)
    parts.push_back(x.primitive);
  bodies.insert(bodies.end(), b.begin(), b.end());
  return boundsOf(name, parts);
}

/// A still VLP-16 1.8 m above flat ground at the origin, looking at the scene's bodies.
LidarScan stillSweep(const Scene& scene)
{
  const Lidar lidar(lidarPreset("VLP-16"), 5);
  LidarScanRequest req;
  req.motion.pose.translation() = Vector3d(0.0, 0.0, 1.8);
  return lidar.scan(scene, req);
}
}  // namespace

TEST(LidarClustering, AVehicleSeenPastItsTopEdgeIsOneCluster)
{
  // A vehicle-sized box facing away 10 m ahead (rear face at x = 10, 0.4-0.73 m up), its top
  // 6.5 cm under the VLP-16's -5 deg ring there: the -7 deg ring hits the rear face, the -5 deg
  // ring clears the edge and lands on the roof 0.065 / tan(5 deg) = 0.74 m behind the face, the
  // -9 deg ring passes under the box to the ground. On the ground plane the face's and the
  // roof's returns lie farther apart than the tolerance (the split sensors_node's rostest met at
  // 12.4 m); the ring links (beta ~26 deg, 0.74 m <= ring_link_gap) make them one cluster,
  // without them they are two.
  const double deg = kPi / 180.0;
  const double top = 1.8 - 10.0 * std::tan(5.0 * deg) - 0.065;
  Scene scene(HeightField::fromGrid(planeGrid()));
  std::vector<Body> bodies;
  const Known vehicle = addBox(bodies, "vehicle", 11.8, 3.6, 1.5, 0.4, top, 1);
  scene.setBodies(bodies);
  const LidarScan scan = stillSweep(scene);
  LidarClusterConfig exact;  // every point queried: the plan gap is judged exactly
  exact.cell_size = 0.0;
  // The premise: face and roof returns, farther apart on the ground plane than the tolerance and
  // within the ring links' reach.
  std::vector<int> face, roof;
  for (int i : pointsIn(scan.points, vehicle, 0.15, 0.0, exact.ground_clearance))
  {
    const LidarPoint& p = scan.points[static_cast<std::size_t>(i)];
    (p.x < 10.2f ? face : roof).push_back(i);
  }
  ASSERT_GE(face.size(), exact.min_points);
  ASSERT_GE(roof.size(), exact.min_points);
  double gap = 1e300;
  for (int i : face)
    for (int j : roof)
    {
      const LidarPoint& p = scan.points[static_cast<std::size_t>(i)];
      const LidarPoint& q = scan.points[static_cast<std::size_t>(j)];
      EXPECT_NEAR(q.z, top, 0.05);  // on the roof
      gap = std::min(gap, static_cast<double>(std::hypot(p.x - q.x, p.y - q.y)));
    }
  EXPECT_GT(gap, exact.cluster_tolerance);
  EXPECT_LT(gap, exact.ring_link_gap - 0.15);

  for (const LidarClusterConfig& config : { LidarClusterConfig(), exact })
  {
    SCOPED_TRACE("cell_size " + std::to_string(config.cell_size));
    const LidarClustering r = LidarClusterer(config).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
    expectOneClusterPerObject(scan.points, r, { vehicle }, config, 0.15);
    ASSERT_EQ(r.clusters.size(), 1u);
    EXPECT_EQ(r.clusters[0].size(), face.size() + roof.size());
  }
  const LidarClustering linked = LidarClusterer(exact).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
  EXPECT_GE(linked.ring_links, 1u);

  LidarClusterConfig unlinked = exact;
  unlinked.ring_link_angle = 0.5 * kPi;
  const LidarClustering apart = LidarClusterer(unlinked).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
  EXPECT_EQ(apart.ring_links, 0u);
  ASSERT_EQ(apart.clusters.size(), 2u);
  EXPECT_EQ(apart.clusters[0].size() + apart.clusters[1].size(), face.size() + roof.size());
}

namespace
{
/// Two clusters, one per object: each holds only points inside its own object's box (grown by
/// 0.15 m).
void expectApart(const LidarCloud& cloud, const LidarClustering& r, const Known& a, const Known& b)
{
  ASSERT_EQ(r.clusters.size(), 2u);
  std::set<std::string> seen;
  for (const LidarCluster& c : r.clusters)
  {
    const Known* owner = nullptr;
    for (const Known* k : { &a, &b })
    {
      const std::vector<int> in = pointsIn(cloud, *k, 0.15, 0.0, -1e9);
      if (std::includes(in.begin(), in.end(), c.indices.begin(), c.indices.end()))
        owner = k;
    }
    ASSERT_NE(owner, nullptr) << "a cluster holds points of both objects";
    seen.insert(owner->name);
  }
  EXPECT_EQ(seen.size(), 2u);
}
}  // namespace

TEST(LidarClustering, RingLinksKeepApartWhatTheRangeImageResolves)
{
  // Adjacent rings of one column, one return on a box's face and one, past the box's top, on a
  // wall behind it: a second object, which the links leave apart in two ways. Every point
  // queried (no cells), so that the plan tolerance keeps the two apart and the links decide.
  LidarClusterConfig config;
  config.cell_size = 0.0;
  {
    // Near: a box 3 m ahead (0.3 m long, 1.48 m tall: the -5 deg ring passes over it), a wall
    // 0.9 m behind its face, narrower than the box (beams straddling the box's sides would
    // otherwise merge the two echoes, 0.9 m apart, into points between them). The gap is within
    // ring_link_gap, but at 3 m the rings are 0.1 m apart and the segment runs along the beam
    // (beta ~7 deg < 10 deg): a depth jump.
    SCOPED_TRACE("near");
    Scene scene(HeightField::fromGrid(planeGrid()));
    std::vector<Body> bodies;
    const Known box = addBox(bodies, "box", 3.15, 0.3, 1.5, 0.0, 1.48, 1);
    const Known wall = addBox(bodies, "wall", 4.15, 0.5, 1.2, 0.0, 3.0, 2);
    scene.setBodies(bodies);
    const LidarScan scan = stillSweep(scene);
    const LidarClustering r = LidarClusterer(config).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
    expectApart(scan.points, r, box, wall);
    EXPECT_EQ(r.ring_links, 0u);
    LidarClusterConfig eager = config;  // a link angle under that beta joins them
    eager.ring_link_angle = 5.0 * kPi / 180.0;
    const LidarClustering joined = LidarClusterer(eager).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
    EXPECT_GE(joined.ring_links, 1u);
    EXPECT_EQ(joined.clusters.size(), 1u);
  }
  {
    // Far: a box 20 m ahead (0.6 m long, 1.3 m tall: the -3 deg ring hits its face, the -1 deg
    // ring passes over it), a wall 2 m behind its face that the -1 deg ring hits. At 20 m the
    // rings are 0.7 m apart and beta ~19 deg, but the gap is beyond ring_link_gap (1 m).
    SCOPED_TRACE("far");
    Scene scene(HeightField::fromGrid(planeGrid()));
    std::vector<Body> bodies;
    const Known box = addBox(bodies, "box", 20.3, 0.6, 1.5, 0.0, 1.3, 1);
    const Known wall = addBox(bodies, "wall", 22.25, 0.5, 2.0, 0.0, 3.0, 2);
    scene.setBodies(bodies);
    const LidarScan scan = stillSweep(scene);
    const LidarClustering r = LidarClusterer(config).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
    expectApart(scan.points, r, box, wall);
    EXPECT_EQ(r.ring_links, 0u);
    LidarClusterConfig reach = config;  // a longer reach joins them
    reach.ring_link_gap = 2.5;
    const LidarClustering joined = LidarClusterer(reach).cluster(scan.points, Vector3d(0.0, 0.0, 1.8), heights(scene));
    EXPECT_GE(joined.ring_links, 1u);
    EXPECT_EQ(joined.clusters.size(), 1u);
  }
}

TEST(LidarClustering, UnregisteredSweepGivesTheSameClustersInTheMap)
{
  // The same sweep in the sensor frame (each point at its firing pose): the clusterer carries
  // the points into the map, so the clusters are the registered sweep's to float rounding.
  const FlatScene s;
  const LidarClusterer clusterer{ LidarClusterConfig() };
  const LidarClustering a = clusterer.cluster(s.sweep(true), FlatScene::motion(), heights(s.scene));
  const LidarClustering b = clusterer.cluster(s.sweep(false), FlatScene::motion(), heights(s.scene));
  ASSERT_EQ(a.clusters.size(), b.clusters.size());
  for (std::size_t k = 0; k < a.clusters.size(); ++k)
  {
    EXPECT_EQ(a.clusters[k].indices, b.clusters[k].indices);
    EXPECT_LT((a.clusters[k].centroid - b.clusters[k].centroid).norm(), 1e-4);
  }
}

TEST(LidarClustering, NoClusterOnABareSlopeWhereAFlatHeightCutWouldFindMany)
{
  // A 10 deg plane and nothing on it: every return is ground by the terrain test. A cut at
  // 0.3 m above the sensor's ground (z > 0.3) would keep the whole uphill side.
  const terrain::ElevationGrid grid = planeGrid(std::tan(10.0 * kPi / 180.0));
  const Scene scene(HeightField::fromGrid(grid));
  const Lidar lidar(lidarPreset("VLP-16"), 3);
  LidarScanRequest req;
  req.motion.pose.translation() = Vector3d(0.0, 0.0, 1.8);
  const LidarScan scan = lidar.scan(scene, req);
  std::size_t above_flat_cut = 0;
  for (const LidarPoint& p : scan.points)
    above_flat_cut += p.z > 0.3f;
  ASSERT_GT(above_flat_cut, 1000u);
  const LidarClusterer clusterer{ LidarClusterConfig() };
  const LidarClustering r = clusterer.cluster(scan.points, req.motion.pose.translation(), heights(scene));
  EXPECT_EQ(r.object_points, 0u);
  EXPECT_EQ(r.ground_points, scan.points.size());
  EXPECT_TRUE(r.clusters.empty());
}

TEST(LidarClustering, TheCoursesTreesAreOneClusterEach)
{
  // The default course (seed 1) on its own hills: for its first trees standing clear of every
  // other object (no trunk, shrub, rock or structure within 2 m), a VLP-16 1.8 m above the
  // ground 10 m south of the tree; the tree is one cluster of the sweep's points in its box and
  // above the clearance over the course's terrain (the oracle's ground is the terrain under
  // each point), its centroid on the trunk.
  const terrain::Course course = terrain::makeDefaultCourse(terrain::CourseOptions());
  Scene scene(HeightField::fromGrid(course.heights));
  scene.setObjects(course.objects);
  const std::vector<Primitive> prims = objectPrimitives(course.objects, scene.terrain(), Reflectivities());
  const LidarClusterConfig config;
  const LidarClusterer clusterer(config);
  const Lidar lidar(lidarPreset("VLP-16"), 11);
  auto solid = [&](std::uint32_t id) { return course.objects.get(id).type != terrain::ObjectType::kGrass; };
  std::size_t checked = 0, large = 0;
  for (std::uint32_t id = 0; id < course.objects.size() && checked < 8; ++id)
  {
    const terrain::TerrainObject& o = course.objects.get(id);
    if (o.type != terrain::ObjectType::kTree || o.toppled)
      continue;
    bool clear = true;
    for (std::uint32_t other : course.objects.query(o.x - 2.0, o.y - 2.0, o.x + 2.0, o.y + 2.0))
      clear = clear && (other == id || !solid(other));
    const double sx = o.x, sy = o.y - 10.0;
    for (std::uint32_t other : course.objects.at(sx, sy))
      clear = clear && !solid(other);  // the sensor must not stand inside something
    double z = 0.0;
    if (!clear || !scene.terrain().heightAt(sx, sy, z))
      continue;
    LidarScanRequest req;
    req.motion.pose.translation() = Vector3d(sx, sy, z + 1.8);
    const LidarScan scan = lidar.scan(scene, req);
    const Known k = boundsOf("tree " + std::to_string(id), { prims[id] });
    std::vector<int> want;
    for (std::size_t i = 0; i < scan.points.size(); ++i)
    {
      const LidarPoint& p = scan.points[i];
      double g = 0.0;
      if (p.x >= k.lo.x() - 0.15 && p.x <= k.hi.x() + 0.15 && p.y >= k.lo.y() - 0.15 && p.y <= k.hi.y() + 0.15 &&
          scene.terrain().heightAt(p.x, p.y, g) && p.z - g >= config.ground_clearance)
        want.push_back(static_cast<int>(i));
    }
    if (want.size() < 2 * config.min_points)
      continue;  // hidden by a hill or another object on the way
    const LidarClustering r = clusterer.cluster(scan.points, req.motion.pose.translation(), heights(scene));
    const LidarCluster* c = objectCluster(scan.points, r, want, separation(config), k.name);
    ASSERT_NE(c, nullptr);
    EXPECT_LT(std::hypot(c->centroid.x() - o.x, c->centroid.y() - o.y), 0.3) << k.name << " d " << o.length;
    EXPECT_NEAR(c->range, std::hypot(c->centroid.x() - sx, c->centroid.y() - sy), 1e-9);
    ++checked;
    large += o.length >= 0.3;
  }
  EXPECT_EQ(checked, 8u) << "too few clear trees on the course";
  std::printf("[lidar clustering] %zu course trees checked (%zu large)\n", checked, large);
}

TEST(LidarClustering, NanPointsAreSkippedAndCounted)
{
  // The flat scene's sweep with NaN and infinite points spliced in: the same clusters, their
  // indices shifted past the inserted points, and the bad points counted.
  const FlatScene s;
  const LidarScan scan = s.sweep();
  const LidarClusterer clusterer{ LidarClusterConfig() };
  const Vector3d origin = FlatScene::motion().pose.translation();
  const LidarClustering clean = clusterer.cluster(scan.points, origin, heights(s.scene));
  LidarCloud dirty;
  LidarPoint bad;
  bad.x = std::numeric_limits<float>::quiet_NaN();
  dirty.push_back(bad);
  for (const LidarPoint& p : scan.points)
    dirty.push_back(p);
  bad = LidarPoint();
  bad.z = std::numeric_limits<float>::infinity();
  dirty.push_back(bad);
  const LidarClustering r = clusterer.cluster(dirty, origin, heights(s.scene));
  EXPECT_EQ(r.invalid_points, 2u);
  ASSERT_EQ(r.clusters.size(), clean.clusters.size());
  for (std::size_t k = 0; k < r.clusters.size(); ++k)
  {
    std::vector<int> shifted = clean.clusters[k].indices;
    for (int& i : shifted)
      ++i;
    EXPECT_EQ(r.clusters[k].indices, shifted);
    EXPECT_EQ(r.clusters[k].centroid, clean.clusters[k].centroid);
  }
}

TEST(LidarClustering, EmptyCloudAndAllGroundGiveNoClusters)
{
  const LidarClusterer clusterer{ LidarClusterConfig() };
  const TerrainHeightFn flat = [](double, double, double& z) {
    z = 0.0;
    return true;
  };
  const LidarClustering empty = clusterer.cluster(LidarCloud(), Vector3d::Zero(), flat);
  EXPECT_TRUE(empty.clusters.empty());
  EXPECT_EQ(empty.object_points + empty.ground_points + empty.invalid_points, 0u);
  LidarCloud ground;
  for (int k = 0; k < 100; ++k)
  {
    LidarPoint p;
    p.x = 0.1f * static_cast<float>(k);
    p.z = 0.29f;  // just under the 0.3 m clearance
    ground.push_back(p);
  }
  EXPECT_TRUE(clusterer.cluster(ground, Vector3d::Zero(), flat).clusters.empty());
  // Off the terrain (the height function answers false) points count as above the ground.
  const TerrainHeightFn none = [](double, double, double&) { return false; };
  const LidarClustering off = clusterer.cluster(ground, Vector3d::Zero(), none);
  ASSERT_EQ(off.clusters.size(), 1u);
  EXPECT_EQ(off.clusters[0].size(), 100u);
  EXPECT_NEAR(off.clusters[0].extent().x(), 9.9, 1e-5);
}

TEST(LidarClustering, MinMaxPointsAndToleranceDecideWhatIsACluster)
{
  // Three rows of points 0.2 m apart along x, 1 m apart in y: with a 0.5 m tolerance three
  // clusters, with 1.1 m one; a 4-point row is dropped below min_points 5; a row above
  // max_points is dropped whole (PCL's rule).
  const TerrainHeightFn flat = [](double, double, double& z) {
    z = 0.0;
    return true;
  };
  LidarCloud cloud;
  auto row = [&](double y, int n) {
    for (int k = 0; k < n; ++k)
    {
      LidarPoint p;
      p.x = 0.2f * static_cast<float>(k);
      p.y = static_cast<float>(y);
      p.z = 1.0f + 0.01f * static_cast<float>(k);
      cloud.push_back(p);
    }
  };
  row(0.0, 10);
  row(1.0, 4);
  row(2.0, 30);
  LidarClusterConfig c;
  c.cluster_tolerance = 0.5;
  c.min_points = 5;
  c.max_points = 20;
  const LidarClustering r = LidarClusterer(c).cluster(cloud, Vector3d::Zero(), flat);
  ASSERT_EQ(r.clusters.size(), 1u);  // the 4-row below min, the 30-row above max
  EXPECT_EQ(r.clusters[0].size(), 10u);
  EXPECT_EQ(r.clusters[0].indices.front(), 0);
  c.max_points = 100;
  const LidarClustering all = LidarClusterer(c).cluster(cloud, Vector3d::Zero(), flat);
  ASSERT_EQ(all.clusters.size(), 2u);
  EXPECT_EQ(all.clusters[0].size(), 30u);  // largest first
  c.cluster_tolerance = 1.1;
  const LidarClustering joined = LidarClusterer(c).cluster(cloud, Vector3d::Zero(), flat);
  ASSERT_EQ(joined.clusters.size(), 1u);
  EXPECT_EQ(joined.clusters[0].size(), 44u);
  EXPECT_NEAR(joined.clusters[0].extent().y(), 2.0, 1e-6);
}

TEST(LidarClustering, BadConfigurationIsRefusedNamingTheField)
{
  auto refused = [](LidarClusterConfig c, const std::string& field) {
    try
    {
      LidarClusterer clusterer(c);
      ADD_FAILURE() << field << " accepted";
    }
    catch (const std::invalid_argument& e)
    {
      const std::string what = e.what();
      EXPECT_NE(what.find("LidarClusterConfig"), std::string::npos) << what;
      EXPECT_NE(what.find(field), std::string::npos) << what;
    }
  };
  for (double tol : { 0.0, -0.5, std::nan(""), std::numeric_limits<double>::infinity() })
  {
    LidarClusterConfig c;
    c.cluster_tolerance = tol;
    refused(c, "cluster_tolerance");
  }
  LidarClusterConfig c;
  c.min_points = 0;
  refused(c, "min_points");
  c = LidarClusterConfig();
  c.max_points = c.min_points - 1;
  refused(c, "max_points");
  c = LidarClusterConfig();
  c.cell_size = -0.1;
  refused(c, "cell_size");
  c.cell_size = c.cluster_tolerance;  // a cell as wide as the tolerance would join what it should not
  refused(c, "cell_size");
  c = LidarClusterConfig();
  for (double angle : { 0.0, -0.1, 0.5 * kPi + 1e-9, std::nan("") })
  {
    c.ring_link_angle = angle;
    refused(c, "ring_link_angle");
  }
  c = LidarClusterConfig();
  for (double gap : { -0.1, std::nan(""), std::numeric_limits<double>::infinity() })
  {
    c.ring_link_gap = gap;
    refused(c, "ring_link_gap");
  }
  c = LidarClusterConfig();
  c.ground_clearance = -0.1;
  refused(c, "ground_clearance");
  c.ground_clearance = std::nan("");
  refused(c, "ground_clearance");
  // The suite validates it with the rest of the lidar.
  SuiteConfig suite;
  suite.lidar.emplace();
  suite.lidar->config = lidarPreset("VLP-16");
  suite.lidar->clustering = LidarClusterConfig();
  suite.lidar->clustering->cluster_tolerance = 0.0;
  EXPECT_THROW(validateSuiteConfig(suite), std::invalid_argument);
}
