// rostest of sensors_node (test/sensors_node.test). This node is the clock and the dynamics:
// it publishes /clock and the odometry of two vehicles at 100 Hz in lockstep (each step waits
// for both vehicles' IMU sample of that step), on the small default course built here with the
// same parameters, so the ground, the buildings and the vehicles' poses are known exactly.
// ego (fed_alpha) stands on the concrete pad facing east; other (mrzr) drives away from it
// at 2 m/s along the same line. Everything is judged on what the node publishes, per sim time.
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include <avsp_msgs/AddSensedVehicle.h>
#include <avsp_msgs/ClassTable.h>
#include <avsp_msgs/DriveCommand.h>
#include <avsp_msgs/Environment.h>
#include <avsp_msgs/ObjectToppled.h>
#include <avsp_msgs/LidarClusterArray.h>
#include <avsp_msgs/RadarTargetArray.h>
#include <avsp_msgs/RemoveSensedVehicle.h>
#include <avsp_msgs/RemoveVehicle.h>
#include <avsp_msgs/SaveMap.h>
#include <avsp_msgs/SpawnVehicle.h>
#include <avsp_msgs/StepPhysics.h>
#include <avsp_msgs/TerrainPatch.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Empty.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <avsp_dynamics/vehicle_model.hpp>
#include <avsp_terrain/default_course.hpp>
#include <avsp_terrain/terrain_objects.hpp>
#include <avsp_terrain/ros/run_command.hpp>
#include <avsp_terrain/ros/spin_until.hpp>

#include "avsp_sensors/geodetic.hpp"
#include "avsp_sensors/lidar.hpp"
#include "avsp_sensors/lidar_clustering.hpp"
#include "avsp_sensors/magnetometer.hpp"
#include "avsp_sensors/ros/vehicle_frames.hpp"

namespace at = avsp::terrain;
namespace as = avsp::sensors;

namespace
{
// The scenario (sensors_node.test and the placement below).
constexpr double kStep = 0.01;                                   // s, odometry period
constexpr int kSteps = 650;                                      // 0 .. 6.5 s of sim time
constexpr double kLagJump = 5.0;                                 // s, /clock ahead of the last odometry at the end
constexpr double kFrom = 1.0, kTo = 6.0;                         // s, the window the rates are counted in
constexpr double kEgoX = 30.0, kEgoY = 131.0;                    // m, on the concrete pad, facing east
constexpr double kOtherX0 = 45.0, kOtherSpeed = 2.0;             // m, m/s: other drives east from here
constexpr double kRutStamp = 2.0, kRutDepth = 0.3;               // s, m
constexpr double kRutX0 = 24.0, kRutY0 = 122.0, kRutSide = 4.0;  // m, the rut square's corner and side
constexpr double kFogStamp = 4.5, kFogVisibility = 20.0;         // s, m
constexpr double kLatitude = 39.7425, kLongitude = -105.1786, kAltitude = 1830.0;
const std::string kWmm2025 = std::string(AVSP_SENSORS_DATA_DIR) + "/magnetic/wmm2025.wmm";

/// Spins until `done` holds or `timeout` (wall s) passes; the deadline only guards a hang.
/// avsp::node::spinUntil, polling every 0.0002 s here.
bool spinUntil(const std::function<bool()>& done, double timeout = 30.0)
{
  return avsp::node::spinUntil(done, timeout, 0.0002);
}

/// Every message of one topic, in arrival order.
template <typename M>
struct Topic
{
  std::string name;
  std::vector<M> messages;
  ros::Subscriber sub;

  void subscribe(ros::NodeHandle& nh, const std::string& topic)
  {
    name = topic;
    sub = nh.subscribe<M>(topic, 5000, [this](const typename M::ConstPtr& m) { messages.push_back(*m); });
  }
  /// Messages stamped in [from, to).
  std::size_t countIn(double from, double to) const
  {
    std::size_t n = 0;
    for (const M& m : messages)
    {
      const double t = m.header.stamp.toSec();
      n += (t >= from - 1e-6 && t < to - 1e-6) ? 1 : 0;
    }
    return n;
  }
};

struct Point
{
  float x, y, z, intensity;
  std::uint16_t ring;
  float time;
};

std::vector<Point> points(const sensor_msgs::PointCloud2& c)
{
  std::vector<Point> out(c.width * c.height);
  for (std::size_t k = 0; k < out.size(); ++k)
  {
    const std::uint8_t* p = &c.data[k * c.point_step];
    std::memcpy(&out[k].x, p, 4);
    std::memcpy(&out[k].y, p + 4, 4);
    std::memcpy(&out[k].z, p + 8, 4);
    std::memcpy(&out[k].intensity, p + 12, 4);
    std::memcpy(&out[k].ring, p + 16, 2);
    std::memcpy(&out[k].time, p + 20, 4);
  }
  return out;
}

/// Height of base_link above the ground for a vehicle standing on its wheels.
double baseHeight(const std::string& config_dir, const std::string& model)
{
  const avsp::dynamics::VehicleModel m = avsp::dynamics::loadVehicleModel(config_dir + "/" + model + ".yaml");
  return m.wheels.front().radius - m.wheels.front().rest_position.z();
}

/// Everything the run recorded; filled once by the first test.
struct Scenario
{
  std::unique_ptr<at::Course> course;
  std::string config_dir, soils_file;
  double ground = 0.0;                // m, the pad's height under ego
  double ego_z = 0.0, other_z = 0.0;  // m, base_link heights
  as::node::VehicleFrames ego_frames, other_frames;
  std::map<std::string, Topic<sensor_msgs::PointCloud2>> clouds;  // by topic
  std::map<std::string, Topic<avsp_msgs::RadarTargetArray>> targets;
  Topic<avsp_msgs::LidarClusterArray> clusters;  // ego's lidar/clusters
  std::map<std::string, Topic<visualization_msgs::MarkerArray>> markers;
  std::map<std::string, Topic<sensor_msgs::NavSatFix>> fixes;
  std::map<std::string, Topic<sensor_msgs::Imu>> imus;
  std::map<std::string, Topic<sensor_msgs::MagneticField>> mags;
  Topic<sensor_msgs::Range> sonar;
  Topic<nav_msgs::OccupancyGrid> grid;
  Topic<tf2_msgs::TFMessage> tf_static;
  std::map<std::string, Topic<sensor_msgs::Image>> images;  // ego's front camera, by topic
  Topic<sensor_msgs::CameraInfo> camera_info;
  Topic<avsp_msgs::ClassTable> classes;
  std::vector<std::string> warnings;
  ros::Subscriber log_sub;
  std::vector<diagnostic_msgs::DiagnosticStatus> diagnostics;  // sensors_node's, in arrival order
  std::size_t diagnostics_in_lockstep = 0;                     // how many came before the clock ran ahead
  ros::Subscriber diagnostics_sub;
  bool completed = false;
  std::string failure;

  double otherX(double t) const { return kOtherX0 + kOtherSpeed * t; }
  double groundAt(double x, double y) const { return course->heights.height(x, y).value_or(std::nan("")); }
};
Scenario* run = nullptr;

nav_msgs::Odometry odometry(const std::string& vehicle, double t, double x, double y, double z, double speed)
{
  nav_msgs::Odometry o;
  o.header.stamp = ros::Time(t);
  o.header.frame_id = "odom";
  o.child_frame_id = vehicle + "/base_link";
  o.pose.pose.position.x = x;
  o.pose.pose.position.y = y;
  o.pose.pose.position.z = z;
  o.pose.pose.orientation.w = 1.0;  // facing east
  o.twist.twist.linear.x = speed;   // in base_link
  return o;
}

/// The rut: the course's points in the square, lowered by kRutDepth.
avsp_msgs::TerrainPatch rutPatch(const at::Course& course, double stamp)
{
  const at::ElevationGrid& g = course.heights;
  avsp_msgs::TerrainPatch p;
  p.header.stamp = ros::Time(stamp);
  p.header.frame_id = "map";
  p.origin.x = kRutX0;
  p.origin.y = kRutY0;
  p.resolution = g.dx();
  p.width = static_cast<std::uint32_t>(std::lround(kRutSide / g.dx())) + 1;
  p.height = p.width;
  const std::size_t i0 = static_cast<std::size_t>(std::lround((kRutX0 - g.originX()) / g.dx()));
  const std::size_t j0 = static_cast<std::size_t>(std::lround((kRutY0 - g.originY()) / g.dy()));
  for (std::uint32_t r = 0; r < p.height; ++r)
    for (std::uint32_t c = 0; c < p.width; ++c)
      p.heights.push_back(static_cast<float>(g.pointHeight(i0 + c, j0 + r) - kRutDepth));
  return p;
}

/// Runs the whole lockstep scenario once and records what the node published.
void runScenario(Scenario& r)
{
  ros::NodeHandle nh, pnh("~");
  r.log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&r](const rosgraph_msgs::Log::ConstPtr& m) {
    if (m->level >= rosgraph_msgs::Log::WARN)
      r.warnings.push_back(m->msg);
  });
  for (const char* v : { "/ego", "/other" })
  {
    const std::string p(v);
    r.clouds[p + "/avt_341/points"].subscribe(nh, p + "/avt_341/points");
    r.clouds[p + "/radar/points"].subscribe(nh, p + "/radar/points");
    r.targets[p + "/radar/targets"].subscribe(nh, p + "/radar/targets");
    r.markers[p + "/radar/markers"].subscribe(nh, p + "/radar/markers");
    r.fixes[p + "/gps/fix"].subscribe(nh, p + "/gps/fix");
    r.imus[p + "/imu/data"].subscribe(nh, p + "/imu/data");
    r.mags[p + "/mag"].subscribe(nh, p + "/mag");
  }
  r.diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&r](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        for (const auto& s : m->status)
          if (s.name.rfind("sensors: ", 0) == 0)
            r.diagnostics.push_back(s);
      });
  r.markers["/ego/octomap/occupied_cells"].subscribe(nh, "/ego/octomap/occupied_cells");
  r.markers["/ego/lidar/cluster_markers"].subscribe(nh, "/ego/lidar/cluster_markers");
  r.clusters.subscribe(nh, "/ego/lidar/clusters");
  r.sonar.subscribe(nh, "/ego/ultrasonic/sonar_down");
  r.grid.subscribe(nh, "/ego/occupancy/grid");
  r.tf_static.subscribe(nh, "/tf_static");
  for (const char* t : { "/ego/front/image_raw", "/ego/front/depth/image_raw", "/ego/front/semantic/image_raw" })
    r.images[t].subscribe(nh, t);
  r.camera_info.subscribe(nh, "/ego/front/camera_info");
  r.classes.sub = nh.subscribe<avsp_msgs::ClassTable>(
      "/ego/semantic_classes", 1, [&r](const avsp_msgs::ClassTable::ConstPtr& m) { r.classes.messages.push_back(*m); });

  ros::Publisher clock_pub = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  ros::Publisher ego_pub = nh.advertise<nav_msgs::Odometry>("/ego/avt_341/odometry", 100);
  ros::Publisher other_pub = nh.advertise<nav_msgs::Odometry>("/other/avt_341/odometry", 100);
  ros::Publisher ruts_pub = nh.advertise<avsp_msgs::TerrainPatch>("/terrain/ruts", 10);
  ros::Publisher toppled_pub = nh.advertise<avsp_msgs::ObjectToppled>("/terrain/toppled", 10);
  ros::Publisher env_pub = nh.advertise<avsp_msgs::Environment>("/environment", 10);

  // The node is up once it listens to everything and every output is connected.
  const bool connected = spinUntil(
      [&] {
        for (ros::Publisher* p : { &clock_pub, &ego_pub, &other_pub, &ruts_pub, &toppled_pub, &env_pub })
          if (p->getNumSubscribers() == 0)
            return false;
        auto all = [](auto& topics) {
          for (auto& [name, t] : topics)
            if (t.sub.getNumPublishers() == 0)
              return false;
          return true;
        };
        return all(r.clouds) && all(r.targets) && all(r.markers) && all(r.fixes) && all(r.imus) && all(r.mags) &&
               all(r.images) && r.camera_info.sub.getNumPublishers() > 0 && r.sonar.sub.getNumPublishers() > 0 &&
               r.grid.sub.getNumPublishers() > 0 && r.clusters.sub.getNumPublishers() > 0;
      },
      60.0);
  if (!connected)
  {
    r.failure = "sensors_node did not connect to every topic within 60 s";
    return;
  }

  auto imuAt = [&r](const std::string& topic, double t) {
    const auto& m = r.imus[topic].messages;
    return !m.empty() && std::abs(m.back().header.stamp.toSec() - t) < 1e-6;
  };
  const ros::WallTime wall_start = ros::WallTime::now();
  for (int k = 0; k <= kSteps; ++k)
  {
    const double t = k * kStep;
    rosgraph_msgs::Clock c;
    c.clock = ros::Time(t);
    clock_pub.publish(c);
    if (k == 100)
    {
      // Published 1 s ahead of its stamp: the rut, then messages the node must refuse.
      ruts_pub.publish(rutPatch(*r.course, kRutStamp));
      avsp_msgs::TerrainPatch bad = rutPatch(*r.course, kRutStamp);
      bad.resolution = 0.3;
      ruts_pub.publish(bad);
      avsp_msgs::ObjectToppled unknown;
      unknown.header.frame_id = "map";
      unknown.id = 999999;
      toppled_pub.publish(unknown);
    }
    if (k == 300)
    {
      nav_msgs::Odometry nan_odom = odometry("ego", t, kEgoX, kEgoY, r.ego_z, 0.0);
      nan_odom.pose.pose.position.x = std::nan("");
      ego_pub.publish(nan_odom);
      avsp_msgs::Environment bad_env;
      bad_env.header.stamp = ros::Time(t);
      bad_env.fog_visibility = -1.0;
      env_pub.publish(bad_env);
    }
    if (k == 350)
    {
      avsp_msgs::Environment fog;
      fog.header.stamp = ros::Time(kFogStamp);
      fog.fog_visibility = kFogVisibility;
      fog.air_temperature = 283.0;
      env_pub.publish(fog);
    }
    ego_pub.publish(odometry("ego", t, kEgoX, kEgoY, r.ego_z, 0.0));
    other_pub.publish(odometry("other", t, r.otherX(t), kEgoY, r.other_z, kOtherSpeed));
    if (!spinUntil([&] { return imuAt("/ego/imu/data", t) && imuAt("/other/imu/data", t); }))
    {
      r.failure = "no IMU sample of both vehicles for t = " + std::to_string(t) + " s within 30 s";
      return;
    }
  }
  // The last outputs of the last step (published after the IMU's) and the rosout backlog.
  spinUntil([] { return false; }, 1.0);
  // The clock runs kLagJump past the last odometry: sensors_node's next /diagnostics report
  // must say how far behind it the sensing is.
  r.diagnostics_in_lockstep = r.diagnostics.size();
  rosgraph_msgs::Clock ahead;
  ahead.clock = ros::Time(kSteps * kStep + kLagJump);
  clock_pub.publish(ahead);
  if (!spinUntil(
          [&] {
            std::size_t seen = 0;
            for (std::size_t k = r.diagnostics_in_lockstep; k < r.diagnostics.size(); ++k)
              seen += r.diagnostics[k].name == "sensors: ego" || r.diagnostics[k].name == "sensors: other";
            return seen >= 2;
          },
          30.0))
  {
    r.failure = "no /diagnostics report of both vehicles after the clock ran ahead";
    return;
  }
  r.completed = true;
  std::printf("[sensors_node test] %d lockstep steps (%.1f s of sim time) in %.1f s of wall time\n", kSteps,
              kSteps * kStep, (ros::WallTime::now() - wall_start).toSec());
}

class SensorsNode : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    if (run != nullptr)
      return;
    run = new Scenario();
    ros::NodeHandle pnh("~");
    pnh.getParam("config_dir", run->config_dir);
    pnh.getParam("soils_file", run->soils_file);
    at::CourseOptions o;
    o.seed = 7;
    o.cell_size = 0.5;
    o.length_x = 300.0;
    o.length_y = 200.0;
    run->course = std::make_unique<at::Course>(at::makeDefaultCourse(o));
    run->ground = run->groundAt(kEgoX, kEgoY);
    run->ego_z = run->ground + baseHeight(run->config_dir, "fed_alpha");
    run->other_z = run->groundAt(kOtherX0, kEgoY) + baseHeight(run->config_dir, "mrzr");
    run->ego_frames = as::node::loadVehicleFrames(run->config_dir + "/fed_alpha.yaml");
    run->other_frames = as::node::loadVehicleFrames(run->config_dir + "/mrzr.yaml");
    runScenario(*run);
  }

  void SetUp() override { ASSERT_TRUE(run->completed) << run->failure; }
};

/// A map point inside a box of the vehicle at (x, y, z) facing east, widened by `margin`.
bool insideBoxes(const as::node::VehicleFrames& f, double x, double y, double z, const Point& p, double margin)
{
  for (const as::BodyBox& b : f.boxes)
  {
    const Eigen::Vector3d local = b.pose.inverse() * (Eigen::Vector3d(p.x, p.y, p.z) - Eigen::Vector3d(x, y, z));
    if ((local.cwiseAbs() - 0.5 * b.size).maxCoeff() < margin)
      return true;
  }
  return false;
}

/// A point within `margin` of a standing object's footprint (grass does not count).
bool nearObject(const at::Course& course, double x, double y, double margin)
{
  for (std::uint32_t id : course.objects.query(x - 30.0, y - 30.0, x + 30.0, y + 30.0))
  {
    const at::TerrainObject& o = course.objects.get(id);
    if (o.type == at::ObjectType::kGrass)
      continue;
    double hx, hy;
    at::footprintHalfExtents(o, hx, hy);
    if (std::abs(x - o.x) < hx + margin && std::abs(y - o.y) < hy + margin)
      return true;
  }
  return false;
}

TEST_F(SensorsNode, EveryOutputArrivesAtItsConfiguredRateInSimTime)
{
  // Rates of sensors_node.test: lidar 10 Hz (VLP-16), radar 10 Hz (targets, points, markers),
  // GPS 10 Hz (other: 5 Hz), IMU 100 Hz, magnetometer 15 Hz, sonar 20 Hz, occupancy 2 Hz.
  const double span = kTo - kFrom;
  auto expectRate = [span](const std::string& topic, std::size_t count, double rate) {
    EXPECT_EQ(count, static_cast<std::size_t>(std::lround(rate * span))) << topic;
    std::printf("[sensors_node test] %-30s %3zu messages in %.1f s of sim time (%.1f Hz configured)\n", topic.c_str(),
                count, span, rate);
  };
  for (const char* v : { "/ego", "/other" })
  {
    const std::string p(v);
    expectRate(p + "/avt_341/points", run->clouds[p + "/avt_341/points"].countIn(kFrom, kTo), 10.0);
    expectRate(p + "/radar/targets", run->targets[p + "/radar/targets"].countIn(kFrom, kTo), 10.0);
    expectRate(p + "/radar/points", run->clouds[p + "/radar/points"].countIn(kFrom, kTo), 10.0);
    std::size_t marker_sets = 0;
    for (const auto& m : run->markers[p + "/radar/markers"].messages)
    {
      const double t = m.markers.front().header.stamp.toSec();
      marker_sets += (t >= kFrom - 1e-6 && t < kTo - 1e-6) ? 1 : 0;
    }
    expectRate(p + "/radar/markers", marker_sets, 10.0);
    expectRate(p + "/gps/fix", run->fixes[p + "/gps/fix"].countIn(kFrom, kTo), p == "/ego" ? 10.0 : 5.0);
    expectRate(p + "/imu/data", run->imus[p + "/imu/data"].countIn(kFrom, kTo), 100.0);
    expectRate(p + "/mag", run->mags[p + "/mag"].countIn(kFrom, kTo), 15.0);
  }
  expectRate("/ego/ultrasonic/sonar_down", run->sonar.countIn(kFrom, kTo), 20.0);
  expectRate("/ego/occupancy/grid", run->grid.countIn(kFrom, kTo), 2.0);
  std::size_t cell_sets = 0;
  for (const auto& m : run->markers["/ego/octomap/occupied_cells"].messages)
  {
    const double t = m.markers.front().header.stamp.toSec();
    cell_sets += (t >= kFrom - 1e-6 && t < kTo - 1e-6) ? 1 : 0;
  }
  expectRate("/ego/octomap/occupied_cells", cell_sets, 2.0);

  // Not only counts: the samples sit on their grids (lidar sweeps start on whole 0.1 s, the
  // IMU on every 10 ms step, each sensor's stamps strictly increasing).
  for (const auto& c : run->clouds["/ego/avt_341/points"].messages)
    EXPECT_NEAR(std::remainder(c.header.stamp.toSec(), 0.1), 0.0, 1e-6);
  const auto& imu = run->imus["/ego/imu/data"].messages;
  for (std::size_t k = 1; k < imu.size(); ++k)
    ASSERT_NEAR((imu[k].header.stamp - imu[k - 1].header.stamp).toSec(), kStep, 1e-6) << k;
}

TEST_F(SensorsNode, OutputsAreInTheContractFrames)
{
  auto expectFrame = [](const std::string& topic, const std::string& got, const std::string& expected) {
    EXPECT_EQ(got, expected) << topic;
  };
  expectFrame("ego points", run->clouds["/ego/avt_341/points"].messages.at(0).header.frame_id, "odom");
  expectFrame("other points", run->clouds["/other/avt_341/points"].messages.at(0).header.frame_id, "other/lidar");
  for (const char* v : { "ego", "other" })
  {
    const std::string n(v), p = "/" + n;
    expectFrame(p + " targets", run->targets[p + "/radar/targets"].messages.at(0).header.frame_id, n + "/radar");
    expectFrame(p + " radar points", run->clouds[p + "/radar/points"].messages.at(0).header.frame_id, n + "/radar");
    expectFrame(p + " gps", run->fixes[p + "/gps/fix"].messages.at(0).header.frame_id, n + "/gps");
    expectFrame(p + " imu", run->imus[p + "/imu/data"].messages.at(0).header.frame_id, n + "/imu");
    expectFrame(p + " mag", run->mags[p + "/mag"].messages.at(0).header.frame_id, n + "/imu");
  }
  expectFrame("sonar", run->sonar.messages.at(0).header.frame_id, "ego/sonar_down");
  expectFrame("grid", run->grid.messages.at(0).header.frame_id, "odom");
  const auto& cells = run->markers["/ego/octomap/occupied_cells"].messages.back();
  ASSERT_GE(cells.markers.size(), 2u);
  expectFrame("occupied cells", cells.markers[1].header.frame_id, "odom");
  // The PointCloud2 fields of docs/ARCHITECTURE.md: x, y, z, intensity, ring (+ time).
  const auto& cloud = run->clouds["/ego/avt_341/points"].messages.at(0);
  std::vector<std::string> names;
  for (const auto& f : cloud.fields)
    names.push_back(f.name);
  EXPECT_EQ(names, (std::vector<std::string>{ "x", "y", "z", "intensity", "ring", "time" }));

  // The sonar is not a URDF link: the node publishes its frame on /tf_static.
  bool found = false;
  for (const auto& m : run->tf_static.messages)
    for (const auto& t : m.transforms)
      if (t.child_frame_id == "ego/sonar_down")
      {
        found = true;
        EXPECT_EQ(t.header.frame_id, "ego/base_link");
        EXPECT_NEAR(t.transform.translation.x, 2.0, 1e-9);
        EXPECT_NEAR(t.transform.translation.z, 0.5, 1e-9);
        EXPECT_NEAR(t.transform.rotation.y, std::sin(M_PI / 4), 1e-9);  // pitch 90 deg: looking down
      }
  EXPECT_TRUE(found) << "no static transform ego/base_link -> ego/sonar_down";
}

TEST_F(SensorsNode, LidarPointsLieOnTheGroundAndShowTheBuildingsAndTheOtherVehicle)
{
  const auto& sweeps = run->clouds["/ego/avt_341/points"].messages;
  std::size_t ground = 0, on_ground = 0, below = 0, building = 0, own = 0, other = 0, used = 0;
  double worst_below = 0.0;
  for (const auto& c : sweeps)
  {
    const double t0 = c.header.stamp.toSec();
    if (t0 > kRutStamp - 0.2 + 1e-6)
      break;  // before the rut arrives
    ++used;
    // The scene of a sweep is the world at its end: other stands where it was then.
    const double ox = run->otherX(t0 + 0.1);
    for (const Point& p : points(c))
    {
      own += insideBoxes(run->ego_frames, kEgoX, kEgoY, run->ego_z, p, -0.05) ? 1 : 0;
      if (insideBoxes(run->other_frames, ox, kEgoY, run->other_z, p, 0.05))
      {
        ++other;
        continue;
      }
      // Building 0 of the course: (48, 123), 14 m x 9 m.
      if (p.x > 40.9 && p.x < 55.1 && p.y > 118.4 && p.y < 127.6 && p.z > run->ground + 0.3)
        ++building;
      if (nearObject(*run->course, p.x, p.y, 1.0) || insideBoxes(run->other_frames, ox, kEgoY, run->other_z, p, 0.5))
        continue;
      const double h = run->groundAt(p.x, p.y);
      if (!std::isfinite(h))
        continue;
      ++ground;
      on_ground += std::abs(p.z - h) < 0.1 ? 1 : 0;
      below += p.z < h - 0.3 ? 1 : 0;
      worst_below = std::min(worst_below, p.z - h);
    }
  }
  ASSERT_GE(used, 15u);
  std::printf(
      "[sensors_node test] %zu sweeps: %zu ground points, %.3f %% within 0.1 m of the course; %zu on "
      "building 0, %zu on other, %zu on ego\n",
      used, ground, 100.0 * on_ground / std::max<std::size_t>(1, ground), building, other, own);
  EXPECT_GT(ground, 100000u);
  EXPECT_GE(static_cast<double>(on_ground), 0.995 * ground);
  EXPECT_EQ(below, 0u) << "a point 0.3 m under the ground (worst " << worst_below << " m)";
  EXPECT_GT(building, 50u * used) << "building 0 is not in the cloud";
  EXPECT_GT(other, 10u * used) << "the other vehicle is not in the cloud";
  EXPECT_EQ(own, 0u) << "ego sees its own body";

  // other's own cloud is in its lidar frame: every point within the VLP-16's 100 m, and some.
  for (const auto& c : run->clouds["/other/avt_341/points"].messages)
  {
    const std::vector<Point> pts = points(c);
    ASSERT_GT(pts.size(), 1000u);
    for (const Point& p : pts)
      ASSERT_LT(std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z), 100.5f);
  }
}

TEST_F(SensorsNode, LidarClustersShowTheOtherVehicleAndTheBuildingAsOneClusterEach)
{
  // ego's lidar/clusters, one message per sweep with the sweep's stamp, in odom. Before the rut
  // arrives, in every sweep: the other vehicle (its collision boxes at the sweep's end, the
  // world of a sweep) is exactly one cluster, whose centroid lies within 0.3 m of the mean of
  // the sweep's points inside its boxes and above the clearance (the geometric oracle), whose
  // point count is theirs plus at most 10 % (beams straddling its edges put points beside it),
  // and whose box lies within its boxes' grown by the 0.5 m tolerance; building 0 of the course
  // (48, 123), 14 m x 9 m, is one cluster too. The oracle's boxes are grown by 3 sigma of the
  // VLP-16's range noise (0.03 m): the rear face's returns scatter that much along the beam, and
  // at 0.05 m (1.7 sigma) ~5 % of them fell outside, more than the 10 % allows on 26-30 points.
  // In the first sweep one ring hits the rear face just under its top edge and the next lands
  // on the roof 0.64-0.8 m behind it: the ring links make them one cluster
  // (lidar_clustering.hpp).
  const auto& sweeps = run->clouds["/ego/avt_341/points"].messages;
  const auto& arrays = run->clusters.messages;
  ASSERT_EQ(arrays.size(), sweeps.size());
  const double clearance = as::LidarClusterConfig().ground_clearance;
  const double margin = 3.0 * as::lidarPreset("VLP-16").range_noise;
  // other's boxes' bounds in base_link (facing east: no rotation in the map).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const as::BodyBox& b : run->other_frames.boxes)
    for (int corner = 0; corner < 8; ++corner)
    {
      const Eigen::Vector3d c(corner & 1 ? 0.5 : -0.5, corner & 2 ? 0.5 : -0.5, corner & 4 ? 0.5 : -0.5);
      const Eigen::Vector3d q = b.pose * c.cwiseProduct(b.size);
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  std::size_t used = 0;
  for (std::size_t k = 0; k < sweeps.size(); ++k)
  {
    const avsp_msgs::LidarClusterArray& a = arrays[k];
    EXPECT_EQ(a.header.frame_id, "odom");
    EXPECT_EQ(a.header.stamp, sweeps[k].header.stamp);
    const double t0 = sweeps[k].header.stamp.toSec();
    if (t0 > kRutStamp - 0.2 + 1e-6)
      break;
    ++used;
    const Eigen::Vector3d at(run->otherX(t0 + 0.1), kEgoY, run->other_z);
    std::size_t count = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Point& p : points(sweeps[k]))
      if (insideBoxes(run->other_frames, at.x(), at.y(), at.z(), p, margin) &&
          p.z - run->groundAt(p.x, p.y) >= clearance)
      {
        ++count;
        sum += Eigen::Vector3d(p.x, p.y, p.z);
      }
    ASSERT_GT(count, 10u) << "t0 " << t0;
    const Eigen::Vector3d mean = sum / static_cast<double>(count);
    std::vector<const avsp_msgs::LidarCluster*> on_other, on_building;
    for (const avsp_msgs::LidarCluster& c : a.clusters)
    {
      if (std::abs(c.centroid.x - at.x()) < 0.5 * (hi.x() - lo.x()) + 0.5 &&
          std::abs(c.centroid.y - at.y()) < 0.5 * (hi.y() - lo.y()) + 0.5)
        on_other.push_back(&c);
      if (c.centroid.x > 40.9 && c.centroid.x < 55.1 && c.centroid.y > 118.4 && c.centroid.y < 127.6)
        on_building.push_back(&c);
    }
    ASSERT_EQ(on_other.size(), 1u) << "t0 " << t0;
    const avsp_msgs::LidarCluster& c = *on_other[0];
    EXPECT_LT(std::hypot(c.centroid.x - mean.x(), c.centroid.y - mean.y(), c.centroid.z - mean.z()), 0.3) << t0;
    EXPECT_GE(c.point_count, count) << t0;
    EXPECT_LE(c.point_count, count + count / 10) << t0;
    EXPECT_GE(c.min.x, at.x() + lo.x() - 0.5) << t0;
    EXPECT_LE(c.max.x, at.x() + hi.x() + 0.5) << t0;
    EXPECT_GE(c.min.y, at.y() + lo.y() - 0.5) << t0;
    EXPECT_LE(c.max.y, at.y() + hi.y() + 0.5) << t0;
    EXPECT_LE(c.max.z, at.z() + hi.z() + 0.5) << t0;
    EXPECT_NEAR(c.extent.x, c.max.x - c.min.x, 1e-9);
    EXPECT_NEAR(c.range, std::hypot(c.centroid.x - (kEgoX + 1.0), c.centroid.y - kEgoY), 0.5) << t0;
    EXPECT_EQ(on_building.size(), 1u) << "t0 " << t0;
  }
  EXPECT_GE(used, 15u);
  // Markers while subscribed: DELETEALL, then a box and a label per cluster.
  const auto& markers = run->markers["/ego/lidar/cluster_markers"].messages;
  ASSERT_FALSE(markers.empty());
  EXPECT_EQ(markers[0].markers.at(0).action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(markers[0].markers.size(), 1 + 2 * arrays.at(0).clusters.size());
}

TEST_F(SensorsNode, RutsFromTheTerrainReachTheLidarAtTheirStamp)
{
  const double x0 = kRutX0 + 0.5, x1 = kRutX0 + kRutSide - 0.5, y0 = kRutY0 + 0.5, y1 = kRutY0 + kRutSide - 0.5;
  std::size_t before = 0, before_flat = 0, after = 0, after_deep = 0;
  for (const auto& c : run->clouds["/ego/avt_341/points"].messages)
  {
    const double t0 = c.header.stamp.toSec();
    if (t0 > kFogStamp - 0.2)
      break;
    for (const Point& p : points(c))
    {
      if (p.x < x0 || p.x > x1 || p.y < y0 || p.y > y1)
        continue;
      const double dz = p.z - run->groundAt(p.x, p.y);
      // A sweep is cast when it ends, with the world then: the sweep from 1.9 s sees the rut.
      if (t0 < kRutStamp - 0.15)
      {
        ++before;
        before_flat += std::abs(dz) < 0.1 ? 1 : 0;
      }
      else
      {
        ++after;
        after_deep += std::abs(dz + kRutDepth) < 0.1 ? 1 : 0;
      }
    }
  }
  std::printf("[sensors_node test] rut square: %zu points before (%zu on the course), %zu after (%zu 0.3 m deeper)\n",
              before, before_flat, after, after_deep);
  EXPECT_GT(before, 20u);
  EXPECT_EQ(before_flat, before);
  EXPECT_GT(after, 20u);
  EXPECT_EQ(after_deep, after);
}

TEST_F(SensorsNode, FogFromTheEnvironmentShortensTheLidarsReachAtItsStamp)
{
  // Ego's lidar: fed_alpha's lidar link, 1 m ahead of and 1.4 m above base_link.
  const Eigen::Vector3d sensor(kEgoX + 1.0, kEgoY, run->ego_z + 1.4);
  std::size_t clear = 0, foggy = 0;
  for (const auto& c : run->clouds["/ego/avt_341/points"].messages)
  {
    const double t0 = c.header.stamp.toSec();
    double farthest = 0.0;
    for (const Point& p : points(c))
      farthest = std::max(farthest, (Eigen::Vector3d(p.x, p.y, p.z) - sensor).norm());
    if (t0 < kFogStamp - 0.15)
    {
      EXPECT_GT(farthest, 30.0) << "sweep at " << t0 << " s, before the fog";
      ++clear;
    }
    else
    {
      // V = 20 m: alpha = 3.912 / 20 per m; a 0.5-reflectivity surface at normal incidence
      // falls below the VLP-16's threshold (0.8 at 100 m) beyond about 10.5 m.
      EXPECT_LT(farthest, 11.0) << "sweep at " << t0 << " s, in the fog";
      ++foggy;
    }
  }
  EXPECT_GT(clear, 30u);
  EXPECT_GT(foggy, 15u);
}

TEST_F(SensorsNode, GpsFixesAreThePositionThroughTheReferenceOrigin)
{
  const as::EnuFrame origin({ kLatitude, kLongitude, kAltitude });
  // ego: noise-free; its antenna (fed_alpha's gps link) at (-0.5, 0, 1.25) in base_link.
  const Eigen::Vector3d antenna(kEgoX - 0.5, kEgoY, run->ego_z + 1.25);
  const as::Geodetic expected = origin.toGeodetic(antenna);
  // Independent of the ellipsoid math to ~1e-6 deg: a metre north is 1/111,000 of a degree.
  EXPECT_NEAR(expected.latitude_deg, kLatitude + antenna.y() / 111030.0, 2e-5);
  EXPECT_NEAR(expected.longitude_deg, kLongitude + antenna.x() / (111320.0 * std::cos(kLatitude * M_PI / 180.0)), 2e-5);
  const auto& fixes = run->fixes["/ego/gps/fix"].messages;
  ASSERT_FALSE(fixes.empty());
  for (const auto& f : fixes)
  {
    ASSERT_NEAR(f.latitude, expected.latitude_deg, 1e-9);
    ASSERT_NEAR(f.longitude, expected.longitude_deg, 1e-9);
    ASSERT_NEAR(f.altitude, expected.altitude, 1e-4);
    EXPECT_EQ(f.status.status, sensor_msgs::NavSatStatus::STATUS_FIX);
  }
  // other: the default receiver (2.1 m per horizontal axis): within 15 m of its antenna.
  for (const auto& f : run->fixes["/other/gps/fix"].messages)
  {
    const double t = f.header.stamp.toSec();
    const Eigen::Vector3d enu = origin.toEnu({ f.latitude, f.longitude, f.altitude });
    const Eigen::Vector3d antenna_other =
        run->other_frames.link("gps").translation() + Eigen::Vector3d(run->otherX(t), kEgoY, run->other_z);
    EXPECT_LT((enu - antenna_other).head<2>().norm(), 15.0) << t;
    EXPECT_GT(f.position_covariance[0], 4.0);
  }
}

TEST_F(SensorsNode, ImuAtRestAndAtConstantSpeedReadsPlusGAndNoRotation)
{
  for (const char* topic : { "/ego/imu/data", "/other/imu/data" })
  {
    const auto& samples = run->imus[topic].messages;
    ASSERT_GT(samples.size(), 600u) << topic;
    Eigen::Vector3d f = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
    for (const auto& s : samples)
    {
      f += Eigen::Vector3d(s.linear_acceleration.x, s.linear_acceleration.y, s.linear_acceleration.z);
      w += Eigen::Vector3d(s.angular_velocity.x, s.angular_velocity.y, s.angular_velocity.z);
    }
    f /= static_cast<double>(samples.size());
    w /= static_cast<double>(samples.size());
    // ADIS16448 noise: 0.018 m/s^2 and 0.0019 rad/s per sample at 100 Hz; means of 651.
    EXPECT_NEAR(f.z(), 9.81, 0.01) << topic;
    EXPECT_NEAR(f.x(), 0.0, 0.01) << topic;
    EXPECT_NEAR(f.y(), 0.0, 0.01) << topic;
    EXPECT_LT(w.norm(), 0.001) << topic;
    EXPECT_NEAR(samples.back().orientation.w, 1.0, 1e-3) << topic;  // facing east, level
  }
  // ego's noise-free magnetometer reads the World Magnetic Model 2025 at its position on the
  // node's ~date (2025-10-15), in its frame (the imu link): test_geomagnetic_model checks the
  // model against NOAA's test values; here the node's wiring (file, date, origin, frames).
  const as::MapMagneticField wmm(as::GeomagneticModel(kWmm2025), as::EnuFrame({ kLatitude, kLongitude, kAltitude }),
                                 as::decimalYear("2025-10-15"));
  const Eigen::Isometry3d mount = run->ego_frames.link("imu");  // base_link at (kEgoX, kEgoY, ego_z), facing east
  const Eigen::Vector3d position = Eigen::Vector3d(kEgoX, kEgoY, run->ego_z) + mount.translation();
  const Eigen::Vector3d expected = mount.linear().transpose() * wmm.at(position);
  const auto& mags = run->mags["/ego/mag"].messages;
  ASSERT_FALSE(mags.empty());
  for (const auto& m : mags)
    ASSERT_LT((Eigen::Vector3d(m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z) - expected).norm(), 1e-13);
  // Facing east, the field's horizontal part points 7.67 deg east of north (to 0.01 deg: the
  // site's declination, what the former dipole model set to 0).
  const as::EarthField site = as::earthFieldFromEnu(mount.linear() * expected);
  EXPECT_NEAR(site.declination_deg, 7.668, 0.01);
}

TEST_F(SensorsNode, RadarSeesTheOtherVehicleRecedingAndTheSonarTheGround)
{
  std::size_t scans = 0, seen = 0;
  for (const auto& scan : run->targets["/ego/radar/targets"].messages)
  {
    const double t = scan.header.stamp.toSec();
    if (t > 4.0)
      break;  // other goes out of the pad's lane towards the staging area's edge
    ++scans;
    // ego's radar (fed_alpha) is 2.45 m ahead of base_link; other's box (mrzr) ends 1.8 m behind its base_link.
    const double rear = run->otherX(t) - 1.8 - (kEgoX + 2.45);
    for (const auto& target : scan.targets)
      if (target.range_rate > 1.0)
      {
        ++seen;
        EXPECT_NEAR(target.range_rate, kOtherSpeed, 0.1) << t;
        EXPECT_NEAR(target.azimuth, 0.0, 0.05) << t;
        EXPECT_NEAR(target.centroid.x, rear, 0.5) << t;
        break;
      }
  }
  EXPECT_GT(scans, 30u);
  EXPECT_EQ(seen, scans) << "the receding vehicle is missing from some radar scans";

  // The sonar 2 m ahead of base_link, 0.5 m up, looking down: the ground (noise 0.01 m).
  const double expected = run->ego_z + 0.5 - run->groundAt(kEgoX + 2.0, kEgoY);
  ASSERT_FALSE(run->sonar.messages.empty());
  for (const auto& r : run->sonar.messages)
  {
    ASSERT_NEAR(r.range, expected, 0.05);
    EXPECT_EQ(r.radiation_type, sensor_msgs::Range::ULTRASOUND);
  }
}

TEST_F(SensorsNode, OccupancyGridMarksTheBuildingAndTheGroundAheadAndTheMapCanBeSaved)
{
  ASSERT_FALSE(run->grid.messages.empty());
  const nav_msgs::OccupancyGrid& g = run->grid.messages.back();
  auto at = [&g](double x, double y) {
    const int i = static_cast<int>(std::floor((x - g.info.origin.position.x) / g.info.resolution));
    const int j = static_cast<int>(std::floor((y - g.info.origin.position.y) / g.info.resolution));
    if (i < 0 || j < 0 || i >= static_cast<int>(g.info.width) || j >= static_cast<int>(g.info.height))
      return -2;
    return static_cast<int>(g.data[static_cast<std::size_t>(j) * g.info.width + i]);
  };
  EXPECT_NEAR(g.info.width * g.info.resolution, 60.0, 0.5);
  // Building 0's north wall (y = 127.5, x 41..55) faces ego across the lane: its voxels'
  // centres lie on y = 127.5.
  int wall = 0;
  for (double x = 41.1; x < 55.0; x += 0.2)
    wall += at(x, 127.5) == 100 ? 1 : 0;
  EXPECT_GT(wall, 30) << "cells of building 0's north wall marked occupied";
  EXPECT_EQ(at(38.0, 131.0), 0) << "the ground 7 m ahead of ego";

  ros::NodeHandle nh;
  std::string output_dir;
  ASSERT_TRUE(ros::param::get("~output_dir", output_dir));
  const std::string path = output_dir + "/ego.bt";
  avsp_msgs::SaveMap srv;
  srv.request.path = path;
  ASSERT_TRUE(ros::service::call("/sensors/ego/save_map", srv));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  EXPECT_EQ(srv.response.message, path);
  struct stat st;
  ASSERT_EQ(stat(path.c_str(), &st), 0);
  EXPECT_GT(st.st_size, 1000);
  std::remove(path.c_str());
  // Relative paths are written in ~output_dir.
  srv.request.path = "relative.bt";
  ASSERT_TRUE(ros::service::call("/sensors/ego/save_map", srv));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  EXPECT_EQ(srv.response.message, output_dir + "/relative.bt");
  EXPECT_EQ(stat((output_dir + "/relative.bt").c_str(), &st), 0);
  std::remove((output_dir + "/relative.bt").c_str());
  // Issue 21, finding 7: a .bt linked to /dev/full answered success; NUL and paths outside the
  // folder were written too. Each is refused now, naming why.
  ASSERT_EQ(symlink("/dev/full", (output_dir + "/full.bt").c_str()), 0);
  const std::vector<std::pair<std::string, std::string>> refused = {
    { output_dir + "/full.bt", "symbolic link" },
    { output_dir + std::string("/a\0b.bt", 7), "control character" },
    { "/tmp/avsp_sensors_outside_" + std::to_string(getpid()) + ".bt", "outside the output folder" },
    { output_dir + "/map.txt", "must end in .bt" },
  };
  for (const auto& [request, reason] : refused)
  {
    srv.request.path = request;
    ASSERT_TRUE(ros::service::call("/sensors/ego/save_map", srv));
    EXPECT_FALSE(srv.response.success) << request;
    EXPECT_NE(srv.response.message.find(reason), std::string::npos) << srv.response.message;
  }
  EXPECT_NE(stat((output_dir + "/a").c_str(), &st), 0) << "the NUL request wrote its prefix";
  std::remove((output_dir + "/full.bt").c_str());
}

TEST_F(SensorsNode, BadMessagesAreIgnoredWithAWarningNamingTheTopic)
{
  auto warned = [](std::initializer_list<const char*> parts) {
    for (const std::string& w : run->warnings)
    {
      bool all = true;
      for (const char* p : parts)
        all = all && w.find(p) != std::string::npos;
      if (all)
        return true;
    }
    return false;
  };
  EXPECT_TRUE(warned({ "/ego/avt_341/odometry ignored", "not finite" }));
  EXPECT_TRUE(warned({ "/terrain/ruts from", "rejected", "resolution" }));
  EXPECT_TRUE(warned({ "/terrain/toppled ignored", "999999" }));
  EXPECT_TRUE(warned({ "/environment ignored", "fog_visibility" }));
  // The node kept going: every IMU step was answered (the lockstep completed).
}

/// The value of `key` in a diagnostic status as a number (NaN when absent).
double numberOf(const diagnostic_msgs::DiagnosticStatus& s, const std::string& key)
{
  for (const auto& kv : s.values)
    if (kv.key == key)
      return std::stod(kv.value);
  return std::nan("");
}

TEST_F(SensorsNode, DiagnosticsSayHowFarBehindTheClockTheSensingIsAndWhatWasIgnored)
{
  // In the lockstep the sensing keeps up with the clock to one step (a state may even be
  // sensed just before its clock tick arrives); one report per vehicle every 1 s of sim time.
  std::map<std::string, int> lockstep_reports;
  bool ego_warned = false, inputs_warned = false;
  for (std::size_t k = 0; k < run->diagnostics_in_lockstep; ++k)
  {
    const diagnostic_msgs::DiagnosticStatus& s = run->diagnostics[k];
    ++lockstep_reports[s.name];
    if (s.name == "sensors: inputs")
    {
      inputs_warned = inputs_warned || s.level == diagnostic_msgs::DiagnosticStatus::WARN;
      continue;
    }
    EXPECT_LE(std::abs(numberOf(s, "behind /clock (s)")), kStep + 1e-6) << s.name << ": " << s.message;
    if (s.name == "sensors: ego" && s.level == diagnostic_msgs::DiagnosticStatus::WARN)
      ego_warned = ego_warned || s.message.find("odometry message(s) ignored") != std::string::npos;
  }
  for (const char* name : { "sensors: ego", "sensors: other", "sensors: inputs" })
  {
    EXPECT_GE(lockstep_reports[name], static_cast<int>(kSteps * kStep) - 1) << name;
    EXPECT_LE(lockstep_reports[name], static_cast<int>(kSteps * kStep) + 1) << name;
  }
  EXPECT_TRUE(ego_warned) << "the report after the NaN odometry must warn";
  EXPECT_TRUE(inputs_warned) << "the report after the bad rut, topple and environment must warn";

  // After the clock ran ahead: kLagJump behind, a warning (> ~max_lag, 1 s); every state sensed
  // once; ego's NaN odometry the only one ignored.
  std::map<std::string, diagnostic_msgs::DiagnosticStatus> last;
  for (std::size_t k = run->diagnostics_in_lockstep; k < run->diagnostics.size(); ++k)
    last[run->diagnostics[k].name] = run->diagnostics[k];
  for (const char* name : { "sensors: ego", "sensors: other" })
  {
    ASSERT_EQ(last.count(name), 1u) << name;
    const diagnostic_msgs::DiagnosticStatus& s = last[name];
    EXPECT_NEAR(numberOf(s, "behind /clock (s)"), kLagJump, 1e-6) << name;
    EXPECT_NEAR(numberOf(s, "sensed up to (s)"), kSteps * kStep, 1e-9) << name;
    EXPECT_EQ(numberOf(s, "states sensed"), kSteps + 1) << name;
    EXPECT_EQ(numberOf(s, "times waited out"), 0.0) << name;
    EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN) << name;
    EXPECT_NE(s.message.find("5.00 s behind /clock"), std::string::npos) << s.message;
    EXPECT_EQ(s.hardware_id, "/sensors");
  }
  EXPECT_EQ(numberOf(last["sensors: ego"], "odometry ignored"), 1.0);
  EXPECT_EQ(numberOf(last["sensors: other"], "odometry ignored"), 0.0);
  ASSERT_GT(run->diagnostics_in_lockstep, 0u);
  diagnostic_msgs::DiagnosticStatus inputs;
  for (const auto& s : run->diagnostics)
    if (s.name == "sensors: inputs")
      inputs = s;
  EXPECT_EQ(numberOf(inputs, "/terrain/ruts ignored"), 1.0);     // the patch at 0.3 m
  EXPECT_EQ(numberOf(inputs, "/terrain/toppled ignored"), 1.0);  // object 999999
  EXPECT_EQ(numberOf(inputs, "/environment ignored"), 1.0);      // fog_visibility -1
}

TEST_F(SensorsNode, CameraImagesAndInfoAtTheirRateInTheOpticalFrame)
{
  // sensors_node.test: ego's front camera, 160 x 120, 90 deg, 5 Hz, at (1.0, 0, 1.8) in base_link.
  const double span = kTo - kFrom;
  for (auto& [topic, t] : run->images)
  {
    EXPECT_EQ(t.countIn(kFrom, kTo), static_cast<std::size_t>(std::lround(5.0 * span))) << topic;
    ASSERT_FALSE(t.messages.empty()) << topic;
    for (const auto& m : t.messages)
    {
      EXPECT_EQ(m.header.frame_id, "ego/front_optical") << topic;
      EXPECT_NEAR(std::remainder(m.header.stamp.toSec(), 0.2), 0.0, 1e-6) << topic;  // on the 5 Hz grid
      EXPECT_EQ(m.width, 160u);
      EXPECT_EQ(m.height, 120u);
    }
  }
  EXPECT_EQ(run->camera_info.countIn(kFrom, kTo), static_cast<std::size_t>(std::lround(5.0 * span)));
  EXPECT_EQ(run->images["/ego/front/image_raw"].messages[0].encoding, "rgb8");
  EXPECT_EQ(run->images["/ego/front/depth/image_raw"].messages[0].encoding, "32FC1");
  EXPECT_EQ(run->images["/ego/front/semantic/image_raw"].messages[0].encoding, "mono8");
  const sensor_msgs::CameraInfo& ci = run->camera_info.messages.at(0);
  EXPECT_EQ(ci.header.frame_id, "ego/front_optical");
  EXPECT_EQ(ci.distortion_model, "plumb_bob");
  EXPECT_NEAR(ci.K[0], 80.0, 1e-9);  // (160 / 2) / tan(45 deg)
  EXPECT_NEAR(ci.K[2], 79.5, 1e-9);
  EXPECT_NEAR(ci.K[5], 59.5, 1e-9);
  // The optical frame on /tf_static: from base_link at the mount, z forward (base x), y down.
  bool found = false;
  for (const auto& m : run->tf_static.messages)
    for (const auto& t : m.transforms)
      if (t.child_frame_id == "ego/front_optical")
      {
        found = true;
        EXPECT_EQ(t.header.frame_id, "ego/base_link");
        EXPECT_NEAR(t.transform.translation.x, 1.0, 1e-9);
        EXPECT_NEAR(t.transform.translation.z, 1.8, 1e-9);
        const Eigen::Quaterniond q(t.transform.rotation.w, t.transform.rotation.x, t.transform.rotation.y,
                                   t.transform.rotation.z);
        EXPECT_TRUE((q * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX(), 1e-9));
        EXPECT_TRUE((q * Eigen::Vector3d::UnitY()).isApprox(-Eigen::Vector3d::UnitZ(), 1e-9));
      }
  EXPECT_TRUE(found) << "no static transform ego/base_link -> ego/front_optical";
  // The class table, latched; every class id in the semantic images is in it.
  ASSERT_FALSE(run->classes.messages.empty());
  const avsp_msgs::ClassTable& table = run->classes.messages.front();
  ASSERT_EQ(table.ids.size(), table.names.size());
  std::uint8_t vehicle = 0;
  for (std::size_t k = 0; k < table.ids.size(); ++k)
    if (table.names[k] == "vehicle")
      vehicle = table.ids[k];
  ASSERT_NE(vehicle, 0);
  // The other vehicle drives away straight ahead: in the depth image its rear face lies at the
  // distance from the camera to the rear of its boxes (the nearest vehicle pixel).
  const auto& sem = run->images["/ego/front/semantic/image_raw"].messages;
  const auto& depth = run->images["/ego/front/depth/image_raw"].messages;
  ASSERT_EQ(sem.size(), depth.size());
  double rear = 1e9;
  for (const as::BodyBox& b : run->other_frames.boxes)
    rear = std::min(rear, b.pose.translation().x() - 0.5 * b.size.x());
  std::size_t checked = 0;
  for (std::size_t f = 0; f < sem.size(); ++f)
  {
    ASSERT_EQ(sem[f].header.stamp, depth[f].header.stamp);
    const double t = sem[f].header.stamp.toSec();
    double nearest = 1e9;
    for (std::size_t k = 0; k < sem[f].data.size(); ++k)
    {
      EXPECT_NE(std::find(table.ids.begin(), table.ids.end(), sem[f].data[k]), table.ids.end());
      if (sem[f].data[k] == vehicle)
      {
        float d;
        std::memcpy(&d, &depth[f].data[4 * k], 4);
        nearest = std::min(nearest, static_cast<double>(d));
      }
    }
    ASSERT_LT(nearest, 1e9) << "no vehicle pixel at t = " << t;
    // The camera is 1.0 m ahead of ego's base_link; the frame is rendered at its stamp.
    EXPECT_NEAR(nearest, run->otherX(t) + rear - (kEgoX + 1.0), 0.02) << "t = " << t;
    ++checked;
  }
  EXPECT_GT(checked, 25u);
}

/// Runs sensors_node under a fresh name with private parameters set on the master first: it
/// must exit 1 and say what is wrong.
std::pair<int, std::string> runBadNode(const XmlRpc::XmlRpcValue& sensors, const XmlRpc::XmlRpcValue* own,
                                       bool origin = true, const std::string& date = "2025-10-15",
                                       double longitude = kLongitude)
{
  static int count = 0;
  const std::string name = "bad_sensors_" + std::to_string(getpid()) + "_" + std::to_string(count++);
  ros::NodeHandle nh;
  XmlRpc::XmlRpcValue vehicles, v;
  v["name"] = std::string("ego");
  v["model"] = std::string("fed_alpha");
  vehicles[0] = v;
  const std::string ns = "/" + name + "/";
  nh.setParam(ns + "vehicles", vehicles);
  nh.setParam(ns + "config_dir", run->config_dir);
  nh.setParam(ns + "soils_file", run->soils_file);
  nh.setParam(ns + "flat_soil", std::string("gravel"));
  nh.setParam(ns + "flat_size", 20.0);
  if (origin)
  {
    nh.setParam(ns + "latitude", kLatitude);
    nh.setParam(ns + "longitude", longitude);
    nh.setParam(ns + "date", date);
  }
  nh.setParam(ns + "sensors", sensors);
  if (own != nullptr)
  {
    XmlRpc::XmlRpcValue per;
    per["ego"] = *own;
    nh.setParam(ns + "vehicle_sensors", per);
  }
  return avsp::node::runCommand(std::string(SENSORS_NODE_PATH) + " __name:=" + name);
}

XmlRpc::XmlRpcValue section(const std::string& sensor, const std::string& key, const XmlRpc::XmlRpcValue& value)
{
  XmlRpc::XmlRpcValue s, inner;
  inner[key] = value;
  s[sensor] = inner;
  return s;
}

/// {cameras: [entry]}.
XmlRpc::XmlRpcValue cameras(const XmlRpc::XmlRpcValue& entry)
{
  XmlRpc::XmlRpcValue s, list;
  list[0] = entry;
  s["cameras"] = list;
  return s;
}

/// A camera entry named `name` (none if empty) with one more key.
XmlRpc::XmlRpcValue cameraEntry(const std::string& name, const std::string& key, const XmlRpc::XmlRpcValue& value)
{
  XmlRpc::XmlRpcValue e;
  if (!name.empty())
    e["name"] = name;
  e[key] = value;
  return e;
}

XmlRpc::XmlRpcValue outputsList(const std::string& extra)
{
  XmlRpc::XmlRpcValue l;
  l[0] = std::string("rgb");
  l[1] = extra;
  return l;
}

TEST_F(SensorsNode, MalformedSensorConfigurationExitsOneNamingTheKey)
{
  struct Case
  {
    XmlRpc::XmlRpcValue sensors;
    bool own;
    bool origin;
    std::vector<std::string> said;
    std::string date = "2025-10-15";
    double longitude = kLongitude;
  };
  const std::vector<Case> cases{
    { section("radar", "max_range", -5.0), false, true, { "~sensors/radar", "max_range" } },
    { section("lidar", "preset", std::string("VLP-17")), false, true, { "~sensors/lidar/preset", "VLP-17" } },
    { section("lidar", "rang", 3.0), false, true, { "~sensors/lidar/rang", "not a known key" } },
    { section("imu", "rate", 0.0), true, true, { "~vehicle_sensors/ego/imu", "rate" } },
    { section("lidar", "frame", std::string("periscope")), false, true, { "~sensors/lidar/frame", "periscope" } },
    { section("gps", "rate", 10.0), false, false, { "~latitude" } },
    { section("magnetometer", "model", std::string("wmm1990")),
      false,
      true,
      { "~sensors/magnetometer/model = 'wmm1990'", "wmm1990.wmm" } },
    { section("magnetometer", "declination_deg", 7.7),
      false,
      true,
      { "~sensors/magnetometer/declination_deg", "only read with model 'fixed'" } },
    { section("magnetometer", "rate", 15.0),
      false,
      true,
      { "~date '2031-01-01'", "valid for decimal years 2025.0 to 2030.0" },
      "2031-01-01" },
    { cameras(cameraEntry("front", "hfov_deg", 200.0)), false, true, { "~sensors/cameras[0]", "hfov" } },
    { cameras(cameraEntry("front", "outputs", outputsList("infrared"))),
      false,
      true,
      { "~sensors/cameras[0]/outputs" } },
    { cameras(cameraEntry("", "width", 64)), true, true, { "~vehicle_sensors/ego/cameras[0]/name", "required" } },
    { cameras(cameraEntry("front", "lens", 1.0)), false, true, { "~sensors/cameras[0]/lens", "not a known key" } },
    // The scenario's range for the site (avsp_terrain/geodetic_reference.hpp), not one of its own
    // (it refused 180-360 deg east, which the scenario check and environment_node accept).
    { section("gps", "rate", 10.0), false, true, { "~longitude = 361", "-180", "360" }, "2025-10-15", 361.0 },
  };
  for (const Case& c : cases)
  {
    XmlRpc::XmlRpcValue empty;
    empty.begin();
    const auto [code, out] = c.own ? runBadNode(empty, &c.sensors, c.origin, c.date, c.longitude)
                                   : runBadNode(c.sensors, nullptr, c.origin, c.date, c.longitude);
    EXPECT_EQ(code, 1) << out;
    for (const std::string& s : c.said)
      EXPECT_NE(out.find(s), std::string::npos) << "'" << s << "' not in: " << out;
  }
}

// ---- sensors_dynamics.test: behind the real dynamics_node ---------------------------------

TEST(WithDynamics, SensorsFollowTheDynamicsClockAndSeeTheSettledVehicles)
{
  ros::NodeHandle nh, pnh("~");
  std::string config_dir;
  ASSERT_TRUE(pnh.getParam("config_dir", config_dir));
  const as::node::VehicleFrames ego_frames = as::node::loadVehicleFrames(config_dir + "/fed_alpha.yaml");
  Topic<sensor_msgs::Imu> imu, mule_imu;
  Topic<sensor_msgs::PointCloud2> cloud;
  Topic<avsp_msgs::RadarTargetArray> targets;
  Topic<sensor_msgs::NavSatFix> fixes;
  Topic<nav_msgs::Odometry> ego_odom, mule_odom;
  imu.subscribe(nh, "/ego/imu/data");
  mule_imu.subscribe(nh, "/mule/imu/data");
  cloud.subscribe(nh, "/ego/avt_341/points");
  targets.subscribe(nh, "/ego/radar/targets");
  fixes.subscribe(nh, "/ego/gps/fix");
  ego_odom.subscribe(nh, "/ego/avt_341/odometry");
  mule_odom.subscribe(nh, "/mule/avt_341/odometry");
  // Until 4 s of sim time have been sensed (the dynamics may run ahead: the sensors follow).
  const double until = 4.0;
  ASSERT_TRUE(spinUntil(
      [&] {
        return !imu.messages.empty() && imu.messages.back().header.stamp.toSec() >= until &&
               !mule_imu.messages.empty() && mule_imu.messages.back().header.stamp.toSec() >= until;
      },
      90.0))
      << "IMU samples: ego " << imu.messages.size() << ", mule " << mule_imu.messages.size();
  // Every sensor has sensed up to `until` (they publish in their own order within an instant).
  const auto reached = [&](const auto& topic) {
    return !topic.messages.empty() && topic.messages.back().header.stamp.toSec() >= until - 1e-6;
  };
  ASSERT_TRUE(spinUntil([&] { return reached(cloud) && reached(targets) && reached(fixes); }, 30.0))
      << "sweeps " << cloud.messages.size() << ", radar scans " << targets.messages.size() << ", fixes "
      << fixes.messages.size();

  // Rates per sim time over [1, 4): IMU 100 Hz, lidar, radar and GPS 10 Hz, each sensor on its
  // own grid of the sim clock: the exact counts, none skipped, none twice.
  const double from = 1.0, span = until - from;
  EXPECT_EQ(imu.countIn(from, until), static_cast<std::size_t>(std::lround(100.0 * span)));
  EXPECT_EQ(mule_imu.countIn(from, until), static_cast<std::size_t>(std::lround(100.0 * span)));
  EXPECT_EQ(cloud.countIn(from, until), static_cast<std::size_t>(std::lround(10.0 * span)));
  EXPECT_EQ(targets.countIn(from, until), static_cast<std::size_t>(std::lround(10.0 * span)));
  EXPECT_EQ(fixes.countIn(from, until), static_cast<std::size_t>(std::lround(10.0 * span)));
  std::printf(
      "[sensors_node test] behind dynamics_node over %.0f s of sim time: %zu + %zu IMU samples, %zu sweeps, "
      "%zu radar scans, %zu fixes\n",
      span, imu.countIn(from, until), mule_imu.countIn(from, until), cloud.countIn(from, until),
      targets.countIn(from, until), fixes.countIn(from, until));

  // Braked and settled after the first second: +g and no rotation.
  for (const Topic<sensor_msgs::Imu>* t : { &imu, &mule_imu })
  {
    Eigen::Vector3d f = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
    std::size_t n = 0;
    for (const auto& s : t->messages)
      if (s.header.stamp.toSec() >= 2.0)
      {
        f += Eigen::Vector3d(s.linear_acceleration.x, s.linear_acceleration.y, s.linear_acceleration.z);
        w += Eigen::Vector3d(s.angular_velocity.x, s.angular_velocity.y, s.angular_velocity.z);
        ++n;
      }
    ASSERT_GT(n, 100u);
    f /= static_cast<double>(n);
    w /= static_cast<double>(n);
    EXPECT_NEAR(f.norm(), 9.81, 0.05) << t->name;
    EXPECT_LT(w.norm(), 0.005) << t->name;
  }

  // ego's radar (2.45 m ahead of its base_link) sees mule's rear (1.8 m behind mule's base_link,
  // 12 m ahead), standing still.
  ASSERT_FALSE(mule_odom.messages.empty());
  ASSERT_FALSE(ego_odom.messages.empty());
  EXPECT_EQ(mule_odom.messages.back().header.frame_id, "mule/odom");
  EXPECT_EQ(ego_odom.messages.back().header.frame_id, "ego/odom");
  const auto& mp = mule_odom.messages.back().pose.pose.position;
  const auto& ep = ego_odom.messages.back().pose.pose.position;
  std::size_t scans = 0, seen = 0;
  for (const auto& scan : targets.messages)
  {
    if (scan.header.stamp.toSec() < 2.0)
      continue;
    ++scans;
    for (const auto& t : scan.targets)
      if (std::abs(t.azimuth) < 0.1 && std::abs(t.centroid.x - (mp.x - 1.8 - (ep.x + 2.45))) < 0.5)
      {
        ++seen;
        EXPECT_LT(std::abs(t.range_rate), 0.1);
        break;
      }
  }
  EXPECT_GT(scans, 15u);
  EXPECT_EQ(seen, scans);

  // The lidar: the flat ground (z = 0, ruts under the wheels aside), mule's body, not ego's.
  std::size_t ground = 0, flat = 0, on_mule = 0, own = 0;
  for (const auto& c : cloud.messages)
  {
    if (c.header.stamp.toSec() < 2.0)
      continue;
    EXPECT_EQ(c.header.frame_id, "ego/odom");  // ~per_vehicle_odom_frames on both nodes
    for (const Point& p : points(c))
    {
      own += insideBoxes(ego_frames, ep.x, ep.y, ep.z, p, -0.05) ? 1 : 0;
      if (std::abs(p.x - mp.x) < 3.0 && std::abs(p.y - mp.y) < 2.0)
      {
        on_mule += p.z > 0.3 ? 1 : 0;
        continue;
      }
      if (std::abs(p.x - ep.x) < 3.5 && std::abs(p.y - ep.y) < 2.5)
        continue;
      ++ground;
      flat += std::abs(p.z) < 0.1 ? 1 : 0;
    }
  }
  EXPECT_GT(ground, 10000u);
  EXPECT_EQ(flat, ground);
  EXPECT_GT(on_mule, 100u);
  EXPECT_EQ(own, 0u);
}
}  // namespace

/// The ego's IMU stamps in arrival order and how far /clock got ahead of the last one.
struct ImuBehindClock
{
  std::vector<double> imu;  ///< stamps, s
  double lead = 0.0;        ///< s, the most /clock was ahead of the last IMU state received
  double last_clock = 0.0;
  ros::Subscriber imu_sub, clock_sub;

  explicit ImuBehindClock(ros::NodeHandle& nh)
  {
    imu_sub = nh.subscribe<sensor_msgs::Imu>(
        "/ego/imu/data", 1000, [this](const sensor_msgs::Imu::ConstPtr& m) { imu.push_back(m->header.stamp.toSec()); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
        "/clock", 1000,
        [this](const rosgraph_msgs::Clock::ConstPtr& c) {
          last_clock = c->clock.toSec();
          if (!imu.empty())
            lead = std::max(lead, last_clock - imu.back());
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }

  /// Every state from the first received to `until` once, in order, 10 ms apart (100 Hz).
  void expectEveryState(double until) const
  {
    ASSERT_FALSE(imu.empty());
    std::size_t n = 0;
    for (double t : imu)
      if (t <= until + 1e-9)
        ++n;
    EXPECT_EQ(n, static_cast<std::size_t>(std::llround((until - imu.front()) * 100.0)) + 1);
    for (std::size_t k = 1; k < imu.size(); ++k)
      ASSERT_NEAR(imu[k] - imu[k - 1], 0.01, 1e-6) << k;
  }
};

TEST(Lockstep, TheClockWaitsForTheSensors)
{
  ros::NodeHandle nh, pnh("~");
  double until = 3.0;
  pnh.param("until", until, 3.0);
  ImuBehindClock w(nh);
  const ros::WallTime start = ros::WallTime::now();
  ASSERT_TRUE(spinUntil([&] { return !w.imu.empty() && w.imu.back() >= until; }, 100.0))
      << "the IMU did not reach " << until << " s (clock at " << w.last_clock << " s)";
  // Every state sensed once, in order (100 Hz from 0), and the clock never far ahead of the
  // sensed states: the clock moves on after the sensors' report of T, which they send after
  // the IMU of T; the IMU travels on its own connection, so on a loaded machine it can arrive
  // a few ticks after the clock (0.04 s seen). Without the sensors in the lockstep the clock
  // runs ahead at the physics' pace, seconds ahead of these sensors.
  // (From the first state this node got: the sensors may publish t = 0 before this node's
  // subscription is connected.)
  ASSERT_FALSE(w.imu.empty());
  EXPECT_LE(w.imu.front(), 0.05);
  w.expectEveryState(until);
  EXPECT_LE(w.lead, 0.1 + 1e-6);
  std::printf("[ lockstep ] %.1f s of sim time in %.1f s wall; /clock at most %.3f s ahead of the sensed IMU\n", until,
              (ros::WallTime::now() - start).toSec(), w.lead);
}

// sensors_node following dynamics_node's clock (~clock_followers, the single-process run of
// every scenario; test/sensors_follow_clock.test) with this process burning `hog_threads`
// cores (niced threads): the clock stays within ~follower_lag of the sensors, no state is lost, and a fog
// that comes in at `fog_start` (environment_node, /environment every 0.1 s) reaches exactly
// the first sweep that ends after it, whatever the load.
TEST(LockstepFollow, ClockSensorsAndWeatherUnderLoad)
{
  ros::NodeHandle nh, pnh("~");
  double until = 1.6, fog_start = 1.05, sweep_period = 0.1;
  int hog_threads = 2;
  pnh.param("until", until, until);
  pnh.param("fog_start", fog_start, fog_start);
  pnh.param("sweep_period", sweep_period, sweep_period);
  pnh.param("hog_threads", hog_threads, hog_threads);
  std::atomic<bool> burn{ true };
  std::vector<std::thread> hogs;
  for (int k = 0; k < hog_threads; ++k)
    hogs.emplace_back([&burn] {
      // Niced (this thread only): the hog takes what the nodes leave, and this process's own
      // receiving threads are not starved, which would delay the IMU behind the clock here
      // and measure this test's lateness instead of the sensors'.
      setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
      volatile double x = 1.0;
      while (burn.load(std::memory_order_relaxed))
        x = x * 1.0000001 + 1e-9;
    });
  struct StopHogs
  {
    std::atomic<bool>& burn;
    std::vector<std::thread>& hogs;
    ~StopHogs()
    {
      burn = false;
      for (auto& t : hogs)
        t.join();
    }
  } stop_hogs{ burn, hogs };

  std::vector<std::pair<double, std::size_t>> sweeps;  // stamp (sweep start), points
  double sweep_lead = 0.0;
  ImuBehindClock w(nh);
  ros::Subscriber points_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/ego/avt_341/points", 100,
      [&](const sensor_msgs::PointCloud2::ConstPtr& m) {
        sweeps.emplace_back(m->header.stamp.toSec(), static_cast<std::size_t>(m->width) * m->height);
        sweep_lead = std::max(sweep_lead, w.last_clock - m->header.stamp.toSec());
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  // The physics starts on this test's signal (dynamics_node ~start_topic), once it listens.
  ASSERT_TRUE(spinUntil(
      [&] {
        return w.imu_sub.getNumPublishers() > 0 && points_sub.getNumPublishers() > 0 &&
               w.clock_sub.getNumPublishers() > 0;
      },
      60.0));
  ros::Publisher start_pub = nh.advertise<std_msgs::Empty>("/test/start", 1, true);
  start_pub.publish(std_msgs::Empty());
  const ros::WallTime start = ros::WallTime::now();
  ASSERT_TRUE(spinUntil([&] { return !w.imu.empty() && w.imu.back() >= until; }, 100.0))
      << "the IMU did not reach " << until << " s (clock at " << w.last_clock << " s)";
  ASSERT_FALSE(w.imu.empty());
  EXPECT_LE(w.imu.front(), 1e-9);  // from the very first state
  w.expectEveryState(until);
  // ~follower_lag 0.05 s, plus up to 0.1 s for this process's receiving: the IMU and the clock
  // come on separate connections, and after each sweep the paced clock catches up with its
  // pace (up to 0.1 s wall behind, ad::Pacer) at the physics' speed, where a few ms of
  // delivery are hundredths of a second of sim time (0.054-0.102 s measured in 5 runs under
  // the hog). The sensors run at ~0.45x real time here: without the lockstep the clock would
  // be over 1.5 s ahead of them at 3 s.
  EXPECT_LE(w.lead, 0.05 + 0.1 + 1e-6);
  // A sweep goes out once it has ended (one period after its stamp), then the same.
  EXPECT_LE(sweep_lead, sweep_period + 0.05 + 0.1 + 1e-6);

  // The fog: every sweep that ended before fog_start is clear, every one that ended after it foggy.
  const double boundary =
      std::ceil(fog_start / sweep_period - 1e-9) * sweep_period - sweep_period;  // first foggy stamp
  std::size_t clear_min = std::numeric_limits<std::size_t>::max(), foggy_max = 0, clear_n = 0, foggy_n = 0;
  for (const auto& [stamp, points] : sweeps)
  {
    if (stamp + sweep_period > until + 1e-9)
      continue;
    if (stamp < boundary - 1e-6)
      clear_min = std::min(clear_min, points), ++clear_n;
    else
      foggy_max = std::max(foggy_max, points), ++foggy_n;
  }
  ASSERT_GE(clear_n, 2u);
  ASSERT_GE(foggy_n, 2u);
  EXPECT_LT(2 * foggy_max, clear_min) << "the sweep stamped " << boundary << " s (ending after the fog came at "
                                      << fog_start << " s) is the first foggy one";
  std::printf(
      "[ follow ] %.1f s of sim time in %.1f s wall with %d busy thread(s); /clock at most %.3f s ahead of the "
      "IMU, %.3f s of a sweep's stamp; sweeps: clear >= %zu points, foggy (from %.2f s) <= %zu\n",
      until, (ros::WallTime::now() - start).toSec(), hog_threads, w.lead, sweep_lead, clear_min, boundary, foggy_max);
}

// A vehicle spawned into a run with sensors (spawn_sensed.test): dynamics_node ~spawn_vehicle
// gives it to sensors_node (~sensor_nodes), which senses it with the run's defaults (~sensors:
// a registered VLP-16) and puts its body in the ego's scene; ~remove_vehicle takes both away.
// The ego stands braked at the origin; the mrzr "visitor" is spawned 10 m ahead at t = 0.5 s
// and removed at t = 2 s; paused, stepped, so every sweep is sensed (the lockstep).
TEST(SpawnSensed, TheSpawnedVehicleSensesAndIsSeenUntilRemoved)
{
  ros::NodeHandle nh;
  Topic<sensor_msgs::PointCloud2> ego_cloud, visitor_cloud;
  ego_cloud.subscribe(nh, "/ego/avt_341/points");
  visitor_cloud.subscribe(nh, "/visitor/avt_341/points");
  double clock = -1.0;
  ros::Subscriber clock_sub = nh.subscribe<rosgraph_msgs::Clock>(
      "/clock", 1000, [&](const rosgraph_msgs::Clock::ConstPtr& c) { clock = c->clock.toSec(); });
  ros::ServiceClient pause = nh.serviceClient<std_srvs::Trigger>("/dynamics/pause");
  ros::ServiceClient step = nh.serviceClient<avsp_msgs::StepPhysics>("/dynamics/step");
  ros::ServiceClient spawn = nh.serviceClient<avsp_msgs::SpawnVehicle>("/dynamics/spawn_vehicle");
  ros::ServiceClient remove = nh.serviceClient<avsp_msgs::RemoveVehicle>("/dynamics/remove_vehicle");
  ros::ServiceClient sensed_add = nh.serviceClient<avsp_msgs::AddSensedVehicle>("/sensors/add_vehicle");
  ros::ServiceClient sensed_remove = nh.serviceClient<avsp_msgs::RemoveSensedVehicle>("/sensors/remove_vehicle");
  for (ros::ServiceClient* c : { &pause, &step, &spawn, &remove, &sensed_add, &sensed_remove })
    ASSERT_TRUE(c->waitForExistence(ros::Duration(60.0))) << c->getService();
  std_srvs::Trigger trig;
  ASSERT_TRUE(pause.call(trig));
  ros::Publisher cmd = nh.advertise<avsp_msgs::DriveCommand>("/ego/cmd_drive", 1, true);
  avsp_msgs::DriveCommand braked;
  braked.brake = 1.0;
  cmd.publish(braked);
  // Steps `n` and waits until the ego's sweeps up to the clock are in (10 Hz).
  const auto stepBy = [&](std::uint32_t n) {
    avsp_msgs::StepPhysics sp;
    sp.request.steps = n;
    if (!step.call(sp) || !sp.response.success)
      return false;
    const double until = sp.response.until;
    return spinUntil(
        [&] {
          return clock >= until - 1e-9 && !ego_cloud.messages.empty() &&
                 ego_cloud.messages.back().header.stamp.toSec() >= until - 0.1 - 1e-6;
        },
        120.0);
  };
  ASSERT_TRUE(stepBy(500)) << "clock at " << clock;

  // sensors_node refuses what it cannot take, naming it.
  avsp_msgs::AddSensedVehicle twice;
  twice.request.name = "ego";
  twice.request.model = "fed_alpha";
  twice.request.first_time = 10.0;
  ASSERT_TRUE(sensed_add.call(twice));
  EXPECT_FALSE(twice.response.success);
  EXPECT_NE(twice.response.message.find("already a vehicle 'ego'"), std::string::npos) << twice.response.message;
  avsp_msgs::AddSensedVehicle unknown_model = twice;
  unknown_model.request.name = "other";
  unknown_model.request.model = "rover7";
  ASSERT_TRUE(sensed_add.call(unknown_model));
  EXPECT_FALSE(unknown_model.response.success);
  EXPECT_NE(unknown_model.response.message.find("rover7"), std::string::npos) << unknown_model.response.message;
  avsp_msgs::RemoveSensedVehicle nobody;
  nobody.request.name = "nobody";
  nobody.request.last_time = 1.0;
  ASSERT_TRUE(sensed_remove.call(nobody));
  EXPECT_FALSE(nobody.response.success);

  avsp_msgs::SpawnVehicle visitor;
  visitor.request.name = "visitor";
  visitor.request.model = "mrzr";
  visitor.request.x = 10.0;
  ASSERT_TRUE(spawn.call(visitor));
  ASSERT_TRUE(visitor.response.success) << visitor.response.message;
  ASSERT_TRUE(stepBy(1500)) << "clock at " << clock;  // to 2 s
  avsp_msgs::RemoveVehicle leave;
  leave.request.name = "visitor";
  ASSERT_TRUE(remove.call(leave));
  ASSERT_TRUE(leave.response.success) << leave.response.message;
  ASSERT_TRUE(stepBy(1000)) << "clock at " << clock;  // to 3 s
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const ros::master::TopicInfo& t : topics)
    EXPECT_NE(t.name, "/visitor/avt_341/points") << "the removed vehicle's lidar is still advertised";

  // The ego's sweeps (registered: map = odom, z up): points on the visitor's body (its box round
  // (10, 0), 0.3 m above the ground) from the first sweep after 0.5 s to the last before 2 s,
  // none before or after.
  const auto on_visitor = [](const sensor_msgs::PointCloud2& c) {
    std::size_t n = 0;
    for (const Point& p : points(c))
      n += std::abs(p.x - 10.0) < 2.0 && std::abs(p.y) < 1.2 && p.z > 0.3 ? 1 : 0;
    return n;
  };
  std::size_t before = 0, during = 0, after = 0, sweeps_during = 0, sweeps_seeing = 0;
  for (const auto& c : ego_cloud.messages)
  {
    const double t = c.header.stamp.toSec();  // the sweep's start
    const std::size_t n = on_visitor(c);
    if (t < 0.5 - 1e-6)
      before += n;
    else if (t >= 0.6 - 1e-6 && t < 1.9 - 1e-6)
    {
      ++sweeps_during;
      during += n;
      sweeps_seeing += n > 0 ? 1 : 0;
    }
    else if (t >= 2.1 - 1e-6)
      after += n;
  }
  // The visitor's own lidar: sweeps from after its spawn to its removal, none outside.
  std::size_t visitor_sweeps = 0, visitor_outside = 0;
  for (const auto& c : visitor_cloud.messages)
  {
    const double t = c.header.stamp.toSec();
    visitor_outside += (t < 0.5 || t > 2.0) ? 1 : 0;
    visitor_sweeps += 1;
  }
  std::printf(
      "[spawn sensed] ego sweeps: %zu points on the visitor before its spawn, %zu in %zu sweeps while it "
      "stood (%zu sweeps saw it), %zu after its removal; visitor's own sweeps: %zu\n",
      before, during, sweeps_during, sweeps_seeing, after, visitor_sweeps);
  EXPECT_EQ(before, 0u);
  EXPECT_EQ(sweeps_during, 13u);
  EXPECT_EQ(sweeps_seeing, sweeps_during) << "a sweep while the visitor stood did not see it";
  EXPECT_GT(during, 100u * sweeps_during);
  EXPECT_EQ(after, 0u) << "the removed visitor is still in the ego's scene";
  EXPECT_GE(visitor_sweeps, 13u);
  EXPECT_EQ(visitor_outside, 0u);
  ASSERT_FALSE(visitor_cloud.messages.empty());
  // Its own lidar sees the ego (10 m behind it: points round the origin above the ground).
  std::size_t on_ego = 0;
  for (const Point& p : points(visitor_cloud.messages.back()))
    on_ego += std::abs(p.x) < 3.0 && std::abs(p.y) < 1.5 && p.z > 0.3 ? 1 : 0;
  EXPECT_GT(on_ego, 50u);
}

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sensors_node");
  ros::NodeHandle nh;
  const int result = RUN_ALL_TESTS();
  delete run;
  return result;
}
