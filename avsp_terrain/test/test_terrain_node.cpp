// rostest of terrain_node (test/terrain_node.test): what it publishes is checked against the
// same default course built here with the core library, and against geometry.
#include <dirent.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <tuple>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <avsp_msgs/Environment.h>
#include <avsp_msgs/ObjectToppled.h>
#include <avsp_msgs/SaveMap.h>
#include <avsp_msgs/TerrainPatch.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <visualization_msgs/MarkerArray.h>
#include <avsp_terrain/ros/run_command.hpp>
#include <avsp_terrain/ros/spin_until.hpp>

#include "avsp_terrain/default_course.hpp"
#include "avsp_terrain/dem_io.hpp"
#include "avsp_terrain/terrain_file.hpp"

namespace at = avsp::terrain;

namespace
{
constexpr double kRutDepth = 0.1;  // m, depth of the test's patch below the course
constexpr float kRutLift = 0.02f;  // m, terrain_node's default ~rut_marker_lift

/// Spins until `done` holds or `timeout` (wall s) passes; the deadline only guards a hang.
/// avsp::node::spinUntil, polling every 0.005 s here.
bool spinUntil(const std::function<bool()>& done, double timeout = 60.0)
{
  return avsp::node::spinUntil(done, timeout, 0.005);
}

struct Fixture : ::testing::Test
{
  static void SetUpTestSuite()
  {
    ros::NodeHandle pnh("~");
    at::CourseOptions options;
    int seed = 0;
    ASSERT_TRUE(pnh.getParam("course_seed", seed));
    options.seed = static_cast<std::uint64_t>(seed);
    ASSERT_TRUE(pnh.getParam("course_cell_size", options.cell_size));
    ASSERT_TRUE(pnh.getParam("course_length_x", options.length_x));
    ASSERT_TRUE(pnh.getParam("course_length_y", options.length_y));
    ASSERT_TRUE(pnh.getParam("soils_file", soils_file));
    ASSERT_TRUE(pnh.getParam("output_dir", output_dir));
    course = std::make_unique<at::Course>(at::makeDefaultCourse(options));
  }

  static std::unique_ptr<at::Course> course;
  static std::string soils_file;
  static std::string output_dir;  // terrain_node's ~output_dir

  /// Grid index of a map coordinate that must sit on a grid point.
  static bool gridIndex(double x, double y, std::size_t& i, std::size_t& j)
  {
    const at::ElevationGrid& g = course->heights;
    const double fi = (x - g.originX()) / g.dx(), fj = (y - g.originY()) / g.dy();
    if (std::abs(fi - std::round(fi)) > 1e-3 || std::abs(fj - std::round(fj)) > 1e-3 || fi < -0.5 || fj < -0.5)
      return false;
    i = static_cast<std::size_t>(std::lround(fi));
    j = static_cast<std::size_t>(std::lround(fj));
    return i < g.columns() && j < g.rows();
  }

  static std::string savePath(const std::string& tag) { return output_dir + "/" + tag + ".avspterrain"; }
};
std::unique_ptr<at::Course> Fixture::course;
std::string Fixture::soils_file;
std::string Fixture::output_dir;

/// The names and sizes of the files in `dir`: what a refused save must leave as it was.
std::set<std::string> listing(const std::string& dir)
{
  std::set<std::string> out;
  DIR* d = opendir(dir.c_str());
  if (d == nullptr)
    return out;
  while (dirent* e = readdir(d))
  {
    struct stat st;
    if (lstat((dir + "/" + e->d_name).c_str(), &st) == 0)
      out.insert(std::string(e->d_name) + " " + std::to_string(st.st_size));
  }
  closedir(d);
  return out;
}

/// Mean of a marker's vertex colours (r + g + b) / 3.
double meanBrightness(const visualization_msgs::Marker& m)
{
  double sum = 0;
  for (const auto& c : m.colors)
    sum += (c.r + c.g + c.b) / 3.0;
  return m.colors.empty() ? 0.0 : sum / m.colors.size();
}

TEST_F(Fixture, PublishesTheCourseAndAppliesPatchesFromOtherNodes)
{
  ros::NodeHandle nh;
  std::vector<visualization_msgs::MarkerArray> meshes, ruts, objects;
  auto keep = [](std::vector<visualization_msgs::MarkerArray>& into) {
    return boost::function<void(const visualization_msgs::MarkerArray::ConstPtr&)>(
        [&into](const visualization_msgs::MarkerArray::ConstPtr& m) { into.push_back(*m); });
  };
  ros::Subscriber mesh_sub = nh.subscribe<visualization_msgs::MarkerArray>("/terrain/mesh", 10, keep(meshes));
  ros::Subscriber ruts_sub = nh.subscribe<visualization_msgs::MarkerArray>("/terrain/rut_markers", 10, keep(ruts));
  ros::Subscriber obj_sub = nh.subscribe<visualization_msgs::MarkerArray>("/terrain/objects", 10, keep(objects));
  ASSERT_TRUE(spinUntil([&] { return !meshes.empty() && !objects.empty(); })) << "no /terrain/mesh or /terrain/objects";

  // --- Mesh: 300 m x 200 m at 0.5 m, 2 m stride, 50 m chunks -> 6 x 4 chunks covering the
  // course exactly once, counter-clockwise triangles, vertices on the course's heights.
  const at::ElevationGrid& g = course->heights;
  const visualization_msgs::MarkerArray mesh = meshes.front();  // a copy: the vector grows
  ASSERT_EQ(mesh.markers.size(), 24u);
  double area = 0.0;
  std::set<int> ids;
  for (const auto& m : mesh.markers)
  {
    ids.insert(m.id);
    EXPECT_EQ(m.header.frame_id, "map");
    EXPECT_EQ(m.type, visualization_msgs::Marker::TRIANGLE_LIST);
    ASSERT_EQ(m.points.size() % 3, 0u);
    ASSERT_EQ(m.colors.size(), m.points.size());
    for (std::size_t k = 0; k < m.points.size(); k += 3)
    {
      const auto &a = m.points[k], &b = m.points[k + 1], &c = m.points[k + 2];
      const double cross = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
      ASSERT_GT(cross, 0.0) << "triangle " << k / 3 << " of chunk " << m.id << " faces down";
      area += 0.5 * cross;
    }
    for (const auto& p : m.points)
    {
      std::size_t i, j;
      ASSERT_TRUE(gridIndex(p.x, p.y, i, j)) << "vertex (" << p.x << ", " << p.y << ") is not a grid point";
      ASSERT_NEAR(p.z, g.pointHeight(i, j), 1e-4);
    }
  }
  EXPECT_EQ(ids.size(), 24u);
  EXPECT_NEAR(area, 300.0 * 200.0, 1e-6 * 300.0 * 200.0);

  // --- Objects: one marker per course object, standing where the course put it.
  const visualization_msgs::MarkerArray objs = objects.front();
  ASSERT_EQ(objs.markers.size(), course->objects.size());
  for (const auto& m : objs.markers)
  {
    const at::TerrainObject& o = course->objects.get(static_cast<std::uint32_t>(m.id));
    EXPECT_EQ(m.ns, at::toString(o.type));
    EXPECT_NEAR(m.pose.position.x, o.x, 1e-9);
    EXPECT_NEAR(m.pose.position.y, o.y, 1e-9);
    EXPECT_NEAR(m.scale.z, std::max(o.height, 0.02), 1e-9);
  }

  // --- A rut from another node: points i 100..119, j 60..71 lowered by 0.1 m.
  ros::Publisher patch_pub = nh.advertise<avsp_msgs::TerrainPatch>("/terrain/ruts", 10);
  ASSERT_TRUE(spinUntil([&] { return patch_pub.getNumSubscribers() > 0; })) << "terrain_node never subscribed";
  const std::size_t pi0 = 100, pj0 = 60, pw = 20, ph = 12;
  avsp_msgs::TerrainPatch patch;
  patch.header.frame_id = "map";
  patch.origin.x = g.originX() + pi0 * g.dx();
  patch.origin.y = g.originY() + pj0 * g.dy();
  patch.resolution = g.dx();
  patch.width = pw;
  patch.height = ph;
  for (std::size_t j = pj0; j < pj0 + ph; ++j)
    for (std::size_t i = pi0; i < pi0 + pw; ++i)
      patch.heights.push_back(static_cast<float>(g.pointHeight(i, j) - kRutDepth));
  auto expected = [&](std::size_t i, std::size_t j) {
    const bool inside = i >= pi0 && i < pi0 + pw && j >= pj0 && j < pj0 + ph;
    return inside ? static_cast<double>(patch.heights[(j - pj0) * pw + (i - pi0)]) : g.pointHeight(i, j);
  };
  const std::size_t meshes_before = meshes.size();
  patch_pub.publish(patch);
  // The update is the first mesh message after the patch that shows it at (pi0, pj0); a full
  // snapshot for a new connection could arrive in between and must not be taken for it.
  auto showsPatch = [&](const visualization_msgs::MarkerArray& a) {
    for (const auto& m : a.markers)
      for (const auto& p : m.points)
      {
        std::size_t i, j;
        if (gridIndex(p.x, p.y, i, j) && i == pi0 && j == pj0 && std::abs(p.z - expected(i, j)) < 1e-4)
          return true;
      }
    return false;
  };
  std::size_t update_index = 0;
  ASSERT_TRUE(spinUntil([&] {
    for (std::size_t k = meshes_before; k < meshes.size() && update_index == 0; ++k)
      if (showsPatch(meshes[k]))
        update_index = k;
    return update_index != 0 && !ruts.empty();
  })) << "patch not applied";

  // Rut markers: full resolution over the deformed tiles, the patch's cells at its heights.
  std::size_t rut_vertices_in_patch = 0;
  for (const auto& m : ruts.back().markers)
  {
    EXPECT_EQ(m.ns, "terrain_ruts");
    for (const auto& p : m.points)
    {
      std::size_t i, j;
      ASSERT_TRUE(gridIndex(p.x, p.y, i, j));
      ASSERT_NEAR(p.z, expected(i, j) + kRutLift, 1e-4) << "rut vertex at grid point " << i << ", " << j;
      if (i >= pi0 && i < pi0 + pw && j >= pj0 && j < pj0 + ph)
        ++rut_vertices_in_patch;
    }
  }
  // Each of the patch's 19 x 11 inner cells gives 6 vertices, all inside the patch.
  EXPECT_GE(rut_vertices_in_patch, 6u * (pw - 1) * (ph - 1));

  // Mesh update: only the chunks holding the patch (x 50..59.5 m sits on the border of
  // chunks 0 and 1 at x = 50 m; y 30..35.5 m in chunk row 0), vertices at the new heights.
  const visualization_msgs::MarkerArray update = meshes[update_index];
  std::set<int> updated;
  for (const auto& m : update.markers)
  {
    updated.insert(m.id);
    for (const auto& p : m.points)
    {
      std::size_t i, j;
      ASSERT_TRUE(gridIndex(p.x, p.y, i, j));
      ASSERT_NEAR(p.z, expected(i, j), 1e-4);
    }
  }
  EXPECT_EQ(updated, (std::set<int>{ 0, 1 }));

  // --- ~save_map writes the applied rut; the core library reads it back.
  ros::ServiceClient save = nh.serviceClient<avsp_msgs::SaveMap>("/terrain/save_map");
  ASSERT_TRUE(save.waitForExistence(ros::Duration(30.0)));
  avsp_msgs::SaveMap srv;
  srv.request.path = savePath("rut");
  ASSERT_TRUE(save.call(srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  {
    const at::LoadedTerrain saved = at::loadTerrain(srv.request.path, at::SoilLibrary::load(soils_file));
    EXPECT_EQ(saved.objects.size(), course->objects.size());
    for (std::size_t j = pj0 - 10; j < pj0 + ph + 10; ++j)
      for (std::size_t i = pi0 - 10; i < pi0 + pw + 10; ++i)
      {
        if (i >= pi0 && i < pi0 + pw && j >= pj0 && j < pj0 + ph)
          ASSERT_NEAR(saved.terrain.pointHeight(i, j), expected(i, j), 1e-6) << i << ", " << j;
        else
          ASSERT_EQ(saved.terrain.pointHeight(i, j), g.pointHeight(i, j)) << i << ", " << j;
      }
  }
  std::remove(srv.request.path.c_str());

  // --- Bad input keeps the last good state: a patch at the wrong resolution, one with the
  // wrong number of heights, one in another frame; then the terrain is saved again.
  avsp_msgs::TerrainPatch bad = patch;
  bad.origin.x += 20.0;  // on untouched ground, so a wrongly applied patch would show
  for (float& h : bad.heights)
    h -= 5.0f;
  avsp_msgs::TerrainPatch wrong_resolution = bad, wrong_size = bad, wrong_frame = bad;
  wrong_resolution.resolution = 0.25;
  wrong_size.heights.pop_back();
  wrong_frame.header.frame_id = "odom";
  patch_pub.publish(wrong_resolution);
  patch_pub.publish(wrong_size);
  patch_pub.publish(wrong_frame);
  // The node handles messages in order: a good patch after the bad ones marks when they are done.
  avsp_msgs::TerrainPatch marker_patch = patch;
  marker_patch.origin.x = g.originX() + 400 * g.dx();
  marker_patch.origin.y = g.originY() + 300 * g.dy();
  marker_patch.width = 1;
  marker_patch.height = 1;
  marker_patch.heights = { static_cast<float>(g.pointHeight(400, 300) - kRutDepth) };
  const std::size_t ruts_before = ruts.size();
  patch_pub.publish(marker_patch);
  ASSERT_TRUE(spinUntil([&] { return ruts.size() > ruts_before; }));
  srv.request.path = savePath("after_bad");
  ASSERT_TRUE(save.call(srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  {
    const at::LoadedTerrain saved = at::loadTerrain(srv.request.path, at::SoilLibrary::load(soils_file));
    for (std::size_t j = pj0; j < pj0 + ph; ++j)
      for (std::size_t i = pi0 + 40; i < pi0 + 40 + pw; ++i)
        ASSERT_EQ(saved.terrain.pointHeight(i, j), g.pointHeight(i, j)) << "bad patch applied at " << i << ", " << j;
    EXPECT_NEAR(saved.terrain.pointHeight(400, 300), g.pointHeight(400, 300) - kRutDepth, 1e-6);
    EXPECT_NEAR(saved.terrain.pointHeight(pi0, pj0), expected(pi0, pj0), 1e-6);
  }
  std::remove(srv.request.path.c_str());

  // --- ~save_map writes under ~output_dir only and tells the truth (issue 21, finding 7).
  srv.request.path = "relative.asc";
  ASSERT_TRUE(save.call(srv));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  EXPECT_EQ(srv.response.message, output_dir + "/relative.asc");
  {
    const at::HeightRaster back = at::readAsciiGrid(output_dir + "/relative.asc");
    EXPECT_EQ(back.columns, g.columns());
    EXPECT_NEAR(back.heights[pj0 * back.columns + pi0], expected(pi0, pj0), 1e-4);
  }
  std::remove((output_dir + "/relative.asc").c_str());
  const auto expectRefused = [&](const std::string& path, const std::string& reason) {
    const std::set<std::string> before = listing(output_dir);
    avsp_msgs::SaveMap s;
    s.request.path = path;
    ASSERT_TRUE(save.call(s));
    EXPECT_FALSE(s.response.success) << path;
    EXPECT_NE(s.response.message.find(reason), std::string::npos) << s.response.message;
    EXPECT_EQ(listing(output_dir), before) << "a refused save changed " << output_dir;
  };
  expectRefused(output_dir + "/terrain.xyz", "unknown extension");
  expectRefused("/tmp/avsp_outside_" + std::to_string(getpid()) + ".avspterrain", "outside the output folder");
  // A NUL inside the path: the node once wrote "a" and answered success for the whole name.
  expectRefused(output_dir + std::string("/a\0b.avspterrain", 16), "control character");
  ASSERT_EQ(symlink("/dev/full", (output_dir + "/full.avspterrain").c_str()), 0);
  expectRefused(output_dir + "/full.avspterrain", "symbolic link");
  std::remove((output_dir + "/full.avspterrain").c_str());
  expectRefused("../escape.avspterrain", "'..'");

  // 1000 seeded requests: none may crash the node; a refusal changes nothing in the folder,
  // an acceptance writes exactly the file the answer names, inside the folder.
  {
    const std::vector<std::string> pieces = {
      "a",   "/",    "..",        ".",        "sub", std::string(1, '\0'),  "\n",           "\x7f", "\xc3\xa9",
      " ",   "/tmp", "/dev/full", output_dir, "*",   std::string(260, 'n'), ".avspterrain", ".asc", ".xyz",
      ".tif"
    };
    std::mt19937 rng(2112);
    std::uniform_int_distribution<std::size_t> pick(0, pieces.size() - 1);
    std::uniform_int_distribution<int> count(1, 5);
    int accepted = 0, refused = 0;
    for (int k = 0; k < 1000; ++k)
    {
      avsp_msgs::SaveMap s;
      for (int n = count(rng); n > 0; --n)
        s.request.path += pieces[pick(rng)];
      const std::set<std::string> before = listing(output_dir);
      ASSERT_TRUE(save.call(s)) << "case " << k << ": the node did not answer";
      if (!s.response.success)
      {
        ++refused;
        ASSERT_EQ(listing(output_dir), before) << "case " << k << ": " << s.response.message;
        continue;
      }
      ++accepted;
      ASSERT_EQ(s.response.message.rfind(output_dir + "/", 0), 0u) << s.response.message;
      struct stat st;
      ASSERT_EQ(lstat(s.response.message.c_str(), &st), 0) << s.response.message;
      ASSERT_TRUE(S_ISREG(st.st_mode));
      ASSERT_GT(st.st_size, 1000);
      std::remove(s.response.message.c_str());
    }
    EXPECT_GT(accepted, 10);
    EXPECT_GT(refused, 500);
  }

  // --- /environment: an hour of 20 mm/h rain wets the soil, and the mesh darkens.
  ros::Publisher env_pub = nh.advertise<avsp_msgs::Environment>("/environment", 10);
  ASSERT_TRUE(spinUntil([&] { return env_pub.getNumSubscribers() > 0; }));
  std::map<int, double> dry_brightness;
  for (const auto& m : mesh.markers)
    dry_brightness[m.id] = meanBrightness(m);
  avsp_msgs::Environment env;
  env.header.frame_id = "map";
  env.fog_visibility = std::numeric_limits<double>::infinity();
  env.rain_rate_mm_h = 20.0;
  env.header.stamp = ros::Time(100.0);
  const std::size_t meshes_before_rain = meshes.size();
  env_pub.publish(env);
  avsp_msgs::Environment nan_env = env;  // refused: keeps the soil as it was
  nan_env.rain_rate_mm_h = std::nan("");
  nan_env.header.stamp = ros::Time(1000.0);
  env_pub.publish(nan_env);
  env.header.stamp = ros::Time(100.0 + 3600.0);
  env_pub.publish(env);
  ASSERT_TRUE(spinUntil([&] { return meshes.size() > meshes_before_rain; })) << "rain did not change the mesh";
  const visualization_msgs::MarkerArray wet = meshes[meshes_before_rain];
  ASSERT_EQ(wet.markers.size(), 24u);
  for (const auto& m : wet.markers)
    EXPECT_LT(meanBrightness(m), dry_brightness[m.id] - 0.01) << "chunk " << m.id << " did not darken";

  // --- /terrain/toppled (from the dynamics): a shrub lies down along its fall direction; a
  // rigid object, an unknown id and a NaN direction change nothing.
  std::uint32_t shrub = 0, rigid = 0;
  bool have_shrub = false, have_rigid = false;
  for (const at::TerrainObject& o : course->objects.all())
  {
    if (!have_shrub && o.type == at::ObjectType::kShrub && std::isfinite(o.strength))
      shrub = o.id, have_shrub = true;
    if (!have_rigid && !std::isfinite(o.strength))
      rigid = o.id, have_rigid = true;
  }
  ASSERT_TRUE(have_shrub && have_rigid) << "the course should have a shrub and a rigid object";
  ros::Publisher toppled_pub = nh.advertise<avsp_msgs::ObjectToppled>("/terrain/toppled", 10);
  ASSERT_TRUE(spinUntil([&] { return toppled_pub.getNumSubscribers() > 0; })) << "no /terrain/toppled subscriber";
  avsp_msgs::ObjectToppled bad_topple;
  bad_topple.header.frame_id = "map";
  bad_topple.id = rigid;
  toppled_pub.publish(bad_topple);
  bad_topple.id = static_cast<std::uint32_t>(course->objects.size());
  toppled_pub.publish(bad_topple);
  bad_topple.id = shrub;
  bad_topple.fall_direction = std::nan("");
  toppled_pub.publish(bad_topple);
  const std::size_t objects_before = objects.size();
  avsp_msgs::ObjectToppled fell;
  fell.header.frame_id = "map";
  fell.id = shrub;
  fell.fall_direction = 0.5;
  fell.vehicle = "test";
  toppled_pub.publish(fell);
  ASSERT_TRUE(spinUntil([&] { return objects.size() > objects_before; })) << "no /terrain/objects after a topple";
  const visualization_msgs::MarkerArray after = objects.back();
  ASSERT_EQ(after.markers.size(), course->objects.size());
  for (const auto& m : after.markers)
  {
    const at::TerrainObject& o = course->objects.get(static_cast<std::uint32_t>(m.id));
    if (m.id == static_cast<int>(shrub))
    {
      // Lying: its centre half its height out along the fall direction, tipped by 90 deg.
      EXPECT_NEAR(m.pose.position.x, o.x + 0.5 * o.height * std::cos(0.5), 1e-9);
      EXPECT_NEAR(m.pose.position.y, o.y + 0.5 * o.height * std::sin(0.5), 1e-9);
      EXPECT_NEAR(std::abs(m.pose.orientation.x) + std::abs(m.pose.orientation.y),
                  std::sqrt(0.5) * (std::cos(0.25) + std::sin(0.25)), 1e-9);
    }
    else
    {
      EXPECT_NEAR(m.pose.position.x, o.x, 1e-9) << "object " << m.id << " moved";
      EXPECT_NEAR(m.pose.orientation.x, 0.0, 1e-12) << "object " << m.id << " tipped";
      EXPECT_NEAR(m.pose.orientation.y, 0.0, 1e-12) << "object " << m.id << " tipped";
    }
  }
}

/// The value of `key` in a diagnostic status ("" when absent).
std::string valueOf(const diagnostic_msgs::DiagnosticStatus& s, const std::string& key)
{
  for (const auto& kv : s.values)
    if (kv.key == key)
      return kv.value;
  return "";
}

// terrain_node's /diagnostics ("terrain: inputs", every ~diagnostic_period = 1 s of sim time):
// the messages it ignored per input topic. The test is the clock here (nothing else publishes
// /clock in this launch); it sends 3 bad patches, 2 bad topples and 1 bad /environment and
// waits for the counts to grow by exactly that.
TEST_F(Fixture, DiagnosticsCountTheMessagesIgnoredPerTopic)
{
  ros::NodeHandle nh;
  std::vector<diagnostic_msgs::DiagnosticStatus> reports;
  ros::Subscriber sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        for (const auto& s : m->status)
          if (s.name == "terrain: inputs")
            reports.push_back(s);
      });
  ros::Publisher clock_pub = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  ros::Publisher patch_pub = nh.advertise<avsp_msgs::TerrainPatch>("/terrain/ruts", 10);
  ros::Publisher toppled_pub = nh.advertise<avsp_msgs::ObjectToppled>("/terrain/toppled", 10);
  ros::Publisher env_pub = nh.advertise<avsp_msgs::Environment>("/environment", 10);
  ASSERT_TRUE(spinUntil([&] {
    return clock_pub.getNumSubscribers() > 0 && patch_pub.getNumSubscribers() > 0 &&
           toppled_pub.getNumSubscribers() > 0 && env_pub.getNumSubscribers() > 0 && sub.getNumPublishers() > 0;
  })) << "terrain_node did not connect to /clock, its inputs and /diagnostics";
  double t = 100.0;
  // Moves the clock on by 2 s (more than the period) and waits for the report it gives.
  auto nextReport = [&]() -> bool {
    const std::size_t n = reports.size();
    t += 2.0;
    rosgraph_msgs::Clock c;
    c.clock = ros::Time(t);
    clock_pub.publish(c);
    return spinUntil([&] { return reports.size() > n; }, 30.0);
  };
  ASSERT_TRUE(nextReport()) << "no terrain: inputs status on /diagnostics";
  const diagnostic_msgs::DiagnosticStatus before = reports.back();
  for (const char* key : { "/terrain/ruts ignored", "/terrain/toppled ignored", "/environment ignored",
                           "/terrain/ruts applied", "mesh chunks waiting" })
    EXPECT_FALSE(valueOf(before, key).empty()) << key;
  auto grown = [&](const diagnostic_msgs::DiagnosticStatus& s, const std::string& key) {
    return std::stoull(valueOf(s, key)) - std::stoull(valueOf(before, key));
  };

  const at::ElevationGrid& g = course->heights;
  avsp_msgs::TerrainPatch bad;
  bad.header.frame_id = "map";
  bad.origin.x = g.originX() + 100 * g.dx();
  bad.origin.y = g.originY() + 100 * g.dy();
  bad.resolution = 0.25;  // the course's cells are 0.5 m
  bad.width = 2;
  bad.height = 2;
  bad.heights.assign(4, 0.0f);
  patch_pub.publish(bad);
  bad.resolution = g.dx();
  bad.heights.pop_back();  // 3 heights for 2 x 2
  patch_pub.publish(bad);
  bad.heights.assign(4, 0.0f);
  bad.header.frame_id = "odom";
  patch_pub.publish(bad);
  avsp_msgs::ObjectToppled topple;
  topple.header.frame_id = "map";
  topple.id = static_cast<std::uint32_t>(course->objects.size());  // no such object
  toppled_pub.publish(topple);
  topple.id = 0;
  topple.header.frame_id = "odom";
  toppled_pub.publish(topple);
  avsp_msgs::Environment env;
  env.header.stamp = ros::Time(t);
  env.rain_rate_mm_h = std::nan("");
  env_pub.publish(env);

  // Reports until all six are counted (they may arrive over more than one report).
  bool counted = false;
  bool warned = false;
  for (int k = 0; k < 15 && !counted; ++k)
  {
    ASSERT_TRUE(nextReport());
    const diagnostic_msgs::DiagnosticStatus& r = reports.back();
    warned = warned || (r.level == diagnostic_msgs::DiagnosticStatus::WARN &&
                        r.message.find("ignored since the last report") != std::string::npos);
    counted = grown(r, "/terrain/ruts ignored") == 3 && grown(r, "/terrain/toppled ignored") == 2 &&
              grown(r, "/environment ignored") == 1;
  }
  ASSERT_TRUE(counted) << "last report: ruts " << valueOf(reports.back(), "/terrain/ruts ignored") << ", toppled "
                       << valueOf(reports.back(), "/terrain/toppled ignored") << ", environment "
                       << valueOf(reports.back(), "/environment ignored")
                       << " (before: " << valueOf(before, "/terrain/ruts ignored") << ", "
                       << valueOf(before, "/terrain/toppled ignored") << ", " << valueOf(before, "/environment ignored")
                       << ")";
  EXPECT_TRUE(warned) << "a report that counts new ignored messages is a warning";
  EXPECT_EQ(grown(reports.back(), "/terrain/ruts applied"), 0u);
  // Nothing new: the next report is OK again.
  ASSERT_TRUE(nextReport());
  EXPECT_EQ(reports.back().level, diagnostic_msgs::DiagnosticStatus::OK) << reports.back().message;
  EXPECT_EQ(reports.back().hardware_id, "/terrain");
}

/// Runs terrain_node with bad parameters: it must exit 1 and say which parameter or file.
std::pair<int, std::string> runBadNode(const std::string& args)
{
  // A fresh node name per run: private parameters stay on the master after a node exits.
  static int run = 0;
  return avsp::node::runCommand(std::string(TERRAIN_NODE_PATH) + " __name:=bad_terrain_" + std::to_string(getpid()) +
                                "_" + std::to_string(run++) + " " + args);
}

TEST(TerrainNodeStartup, RefusesBadParametersByName)
{
  auto [code, out] = runBadNode("_soil:=marmalade");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~soil"), std::string::npos) << out;
  EXPECT_NE(out.find("marmalade"), std::string::npos) << out;

  std::tie(code, out) = runBadNode("_dem_file:=/tmp/no_such_dem_avsp.asc");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("/tmp/no_such_dem_avsp.asc"), std::string::npos) << out;

  std::tie(code, out) = runBadNode("_dem_file:=/tmp/heights.jpg");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("unknown extension"), std::string::npos) << out;

  std::tie(code, out) = runBadNode("_course_cell_size:=-1.0");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~course_cell_size"), std::string::npos) << out;

  std::tie(code, out) = runBadNode("_output_dir:=relative/maps");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("~output_dir"), std::string::npos) << out;
  EXPECT_NE(out.find("absolute"), std::string::npos) << out;

  std::tie(code, out) = runBadNode("_terrain_file:=/tmp/no_such_terrain_avsp.avspterrain");
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("/tmp/no_such_terrain_avsp.avspterrain"), std::string::npos) << out;
}
}  // namespace

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_terrain_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
