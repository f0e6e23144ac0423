// Loads the reference team's URDF + YAML descriptions and checks them against their
// documented public figures; checks that bad descriptions fail naming the file and key.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "avsp_dynamics/vehicle_model.hpp"

using avsp::dynamics::ConfigError;
using avsp::dynamics::DriveType;
using avsp::dynamics::loadVehicleModel;
using avsp::dynamics::VehicleModel;

namespace
{
const std::string kConfigDir = AVSP_VEHICLE_CONFIG_DIR;

std::string readFile(const std::string& path)
{
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A scratch folder per test with copies of a reference config whose text can be edited.
class ScratchConfig
{
public:
  explicit ScratchConfig(const std::string& model)
  {
    char tmpl[] = "/tmp/avsp_vehicle_test_XXXXXX";
    dir_ = mkdtemp(tmpl);
    yaml_ = readFile(kConfigDir + "/" + model + ".yaml");
    urdf_ = readFile(kConfigDir + "/../../urdf/" + model + ".urdf");
    // Point the copy at the copied URDF.
    replaceIn(yaml_, "../../urdf/" + model + ".urdf", model + ".urdf");
    urdf_name_ = model + ".urdf";
    yaml_path_ = dir_ + "/" + model + ".yaml";
  }
  ~ScratchConfig()
  {
    std::remove(yaml_path_.c_str());
    std::remove((dir_ + "/" + urdf_name_).c_str());
    rmdir(dir_.c_str());
  }
  static void replaceIn(std::string& text, const std::string& from, const std::string& to)
  {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << "fixture text not found: " << from;
    text.replace(at, from.size(), to);
  }
  void editYaml(const std::string& from, const std::string& to) { replaceIn(yaml_, from, to); }
  void editUrdf(const std::string& from, const std::string& to) { replaceIn(urdf_, from, to); }
  void setYaml(const std::string& text) { yaml_ = text; }
  const std::string& yaml() const { return yaml_; }
  void setUrdf(const std::string& text) { urdf_ = text; }
  const std::string& urdf() const { return urdf_; }
  std::string write() const
  {
    std::ofstream(yaml_path_) << yaml_;
    std::ofstream(dir_ + "/" + urdf_name_) << urdf_;
    return yaml_path_;
  }
  std::string urdfPath() const { return dir_ + "/" + urdf_name_; }

private:
  std::string dir_, yaml_, urdf_, urdf_name_, yaml_path_;
};

/// Loads and returns the error text; fails the test if it loads.
std::string loadError(const std::string& path)
{
  try
  {
    loadVehicleModel(path);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  ADD_FAILURE() << path << " loaded but should have failed";
  return "";
}

off_t fileSize(const std::string& path)
{
  struct stat st;
  return stat(path.c_str(), &st) == 0 ? st.st_size : -1;
}

/**
 * loadError in a child process limited to 10 s and 1 GiB, for files the loader must refuse
 * without reading them: a loader that read /dev/zero or opened a FIFO would fill the memory or
 * wait forever; here it fails the test instead of hanging it.
 */
std::string loadErrorBounded(const std::string& path)
{
  int out[2];
  if (pipe(out) != 0)
  {
    ADD_FAILURE() << "pipe failed";
    return "";
  }
  const pid_t pid = fork();
  if (pid == 0)
  {
    close(out[0]);
    const rlimit memory{ 1ull << 30, 1ull << 30 };
    setrlimit(RLIMIT_AS, &memory);
    alarm(10);
    std::string text;
    int code = 0;
    try
    {
      loadVehicleModel(path);
      text = "loaded but should have failed";
      code = 2;
    }
    catch (const ConfigError& e)
    {
      text = e.what();
    }
    catch (const std::exception& e)
    {
      text = std::string("not a ConfigError: ") + e.what();
      code = 3;
    }
    if (write(out[1], text.data(), text.size()) < 0)
      code = 4;
    _exit(code);
  }
  close(out[1]);
  std::string text;
  char buffer[4096];
  ssize_t n;
  while ((n = read(out[0], buffer, sizeof(buffer))) > 0)
    text.append(buffer, static_cast<std::size_t>(n));
  close(out[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFSIGNALED(status))
    ADD_FAILURE() << path << ": the loader did not return within 10 s and 1 GiB (signal " << WTERMSIG(status) << ")";
  else if (WEXITSTATUS(status) != 0)
    ADD_FAILURE() << path << ": " << text;
  return text;
}

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)
}  // namespace

// --- the reference team against its documented figures (README.md of the root package) ---

struct Figures
{
  const char* model;
  DriveType type;
  double total_mass;         // kg
  double wheelbase;          // m (tracked: ground contact length)
  double track_width;        // m (tracked: gauge)
  double wheel_radius;       // m (tracked: road wheel)
  std::size_t running_gear;  // wheels, or road wheels over both tracks
};

class ReferenceVehicle : public ::testing::TestWithParam<Figures>
{
};

TEST_P(ReferenceVehicle, LoadsWithPublishedFigures)
{
  const Figures f = GetParam();
  const VehicleModel m = loadVehicleModel(kConfigDir + "/" + f.model + ".yaml");
  EXPECT_EQ(m.model, f.model);
  EXPECT_EQ(m.drive_type, f.type);
  EXPECT_NEAR(m.total_mass, f.total_mass, 1e-6);
  EXPECT_NEAR(m.wheelbase(), f.wheelbase, 1e-9);
  EXPECT_NEAR(m.trackWidth(), f.track_width, 1e-9);
  if (f.type == DriveType::kTracked)
  {
    ASSERT_EQ(m.tracks.size(), 2u);
    EXPECT_EQ(m.tracks[0].side, "left");
    EXPECT_EQ(m.tracks[0].road_wheels.size() + m.tracks[1].road_wheels.size(), f.running_gear);
    EXPECT_NEAR(m.tracks[0].road_wheels[0].radius, f.wheel_radius, 1e-9);
  }
  else
  {
    ASSERT_EQ(m.wheels.size(), f.running_gear);
    for (const auto& w : m.wheels)
    {
      EXPECT_NEAR(w.radius, f.wheel_radius, 1e-9) << w.name;
      // Wheel centres at axle height: base_link is at axle height by convention.
      EXPECT_NEAR(w.rest_position.z(), 0.0, 1e-9) << w.name;
    }
  }
  for (const auto& b : m.bodies)
  {
    EXPECT_GT(b.mass, 0.0) << b.link;
    EXPECT_GT(b.principal_inertia.minCoeff(), 0.0) << b.link;
  }
  for (const auto& name : avsp::dynamics::requiredSensorLinks())
    ASSERT_TRUE(m.sensor_mounts.count(name)) << name;
  // The lidar is mounted above the chassis reference and above the gps antenna's base.
  EXPECT_GT(m.sensor_mounts.at("lidar").z(), 0.3);
}

INSTANTIATE_TEST_SUITE_P(Team, ReferenceVehicle,
                         ::testing::Values(Figures{ "fed_alpha", DriveType::kAckermann, 5710.0, 3.30, 1.90, 0.546, 4 },
                                           Figures{ "mrzr", DriveType::kAckermann, 888.0, 2.90, 1.27, 0.343, 4 },
                                           Figures{ "tracer_x", DriveType::kSkidSteer, 80.0, 0.55, 0.62, 0.165, 4 },
                                           Figures{ "m113", DriveType::kTracked, 12300.0, 2.67, 2.30, 0.305, 10 }),
                         [](const ::testing::TestParamInfo<Figures>& info) { return std::string(info.param.model); });

TEST(VehicleModel, M113SprocketMatchesTrackPitchByT10)
{
  const VehicleModel m = loadVehicleModel(kConfigDir + "/m113.yaml");
  // v = p N omega / (2 pi): 0.152 m x 10 teeth -> 0.2419 m of track per radian.
  EXPECT_NEAR(m.track.effectiveSprocketRadius(), 0.152 * 10 / (2 * M_PI), 1e-12);
  EXPECT_NEAR(m.track.effectiveSprocketRadius(), m.tracks[0].sprocket_radius, 0.05 * m.tracks[0].sprocket_radius);
}

TEST(VehicleModel, SuspensionPreloadMatchesCornerWeight)
{
  // preload_deflection documents m g / k for a quarter of the vehicle: check it is consistent.
  for (const char* model : { "fed_alpha", "mrzr", "tracer_x" })
  {
    const VehicleModel m = loadVehicleModel(kConfigDir + "/" + model + ".yaml");
    const double expected = m.total_mass / 4.0 * 9.81 / m.suspension.stiffness;
    EXPECT_NEAR(m.suspension.preload_deflection, expected, 0.1 * expected) << model;
  }
}

// The dynamics lumps bodies in base_link: each body's centre of mass and inertia tensor must be
// expressed there, including a rotated and offset <inertial> origin.
TEST(VehicleModel, BodyInertiaIsInBaseLinkAboutItsCentreOfMass)
{
  ScratchConfig c("fed_alpha");
  c.editUrdf(R"(<origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="5240"/>)",
             R"(<origin xyz="0.2 0 0.1" rpy="0 0 1.5707963267948966"/>
      <mass value="5240"/>)");
  const VehicleModel m = loadVehicleModel(c.write());
  for (const auto& b : m.bodies)
  {
    if (b.link != "chassis")
      continue;
    // Chassis joint at z = 0.55; the inertial origin adds (0.2, 0, 0.1).
    EXPECT_NEAR((b.com - Eigen::Vector3d(0.2, 0.0, 0.65)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(b.rest_position.z(), 0.55, 1e-12);
    // Yawed 90 degrees: the URDF's ixx (2742.27) lies along base y, iyy (11113.2) along base x.
    EXPECT_NEAR(b.inertia(0, 0), 11113.2, 1e-6);
    EXPECT_NEAR(b.inertia(1, 1), 2742.27, 1e-6);
    EXPECT_NEAR(b.inertia(2, 2), 12597.8, 1e-6);
    EXPECT_NEAR(b.inertia(0, 1), 0.0, 1e-6);
    return;
  }
  FAIL() << "no chassis body";
}

TEST(VehicleModel, AckermannSteeringWithinJointLimits)
{
  const VehicleModel m = loadVehicleModel(kConfigDir + "/fed_alpha.yaml");
  EXPECT_NEAR(m.steering.max_angle, 0.55, 1e-12);
  int steered = 0;
  for (const auto& w : m.wheels)
    steered += !w.steering_joint.empty();
  EXPECT_EQ(steered, 2);
  EXPECT_EQ(m.drivetrain.differentials.at("center"), avsp::dynamics::Differential::kLocked);
}

// Chassis collision boxes: the URDF <collision> box of each non-running-gear link, placed in
// base_link (fed_alpha: chassis box 4.9 x 2.2 x 1.2 m on a fixed joint 0.55 m above base_link;
// m113: the hull, not the road wheels, sprockets and idlers).
TEST(VehicleModel, CollisionBoxesAreTheChassisLinksBoxesInBaseLink)
{
  const VehicleModel f = loadVehicleModel(kConfigDir + "/fed_alpha.yaml");
  ASSERT_EQ(f.collision_boxes.size(), 1u);
  EXPECT_EQ(f.collision_boxes[0].link, "chassis");
  EXPECT_NEAR((f.collision_boxes[0].size - Eigen::Vector3d(4.9, 2.2, 1.2)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((f.collision_boxes[0].pose.translation() - Eigen::Vector3d(0.0, 0.0, 0.55)).norm(), 0.0, 1e-12);
  EXPECT_TRUE(f.collision_boxes[0].pose.linear().isIdentity(1e-12));
  const VehicleModel m = loadVehicleModel(kConfigDir + "/m113.yaml");
  ASSERT_EQ(m.collision_boxes.size(), 1u);
  EXPECT_EQ(m.collision_boxes[0].link, "chassis");
  EXPECT_NEAR((m.collision_boxes[0].size - Eigen::Vector3d(4.86, 1.9, 1.8)).norm(), 0.0, 1e-12);

  // A rotated, offset <collision> origin: the box's axes and centre follow it into base_link.
  ScratchConfig c("fed_alpha");
  c.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 2.2 1.2"/></geometry>)",
             R"(<collision>
      <origin xyz="0.3 0 0.1" rpy="0 0 1.5707963267948966"/>
      <geometry><box size="4.9 2.2 1.2"/></geometry>)");
  const VehicleModel r = loadVehicleModel(c.write());
  ASSERT_EQ(r.collision_boxes.size(), 1u);
  EXPECT_NEAR((r.collision_boxes[0].pose.translation() - Eigen::Vector3d(0.3, 0.0, 0.65)).norm(), 0.0, 1e-12);
  // The box's own x (its 4.9 m length) now lies along base y.
  EXPECT_NEAR((r.collision_boxes[0].pose.linear().col(0) - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
}

// --- bad descriptions: each names the file and the key ---

TEST(VehicleModelErrors, NegativeMassInUrdfNamesFileAndLink)
{
  ScratchConfig c("fed_alpha");
  c.editUrdf("<mass value=\"5240\"/>", "<mass value=\"-5240\"/>");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, c.urdfPath());
  EXPECT_CONTAINS(err, "link 'chassis'");
  EXPECT_CONTAINS(err, "mass must be > 0");
}

TEST(VehicleModelErrors, NonPhysicalInertiaIsRejected)
{
  ScratchConfig c("mrzr");
  // Break the triangle inequality of the chassis: izz > ixx + iyy.
  c.editUrdf("<inertia ixx=\"160.417\"", "<inertia ixx=\"1.0\"");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, "link 'chassis'");
  EXPECT_CONTAINS(err, "triangle inequality");
}

TEST(VehicleModelErrors, MissingKeyNamesFileAndKey)
{
  ScratchConfig c("fed_alpha");
  c.editYaml("  gear_ratio: 20.0 ", "  # gear_ratio removed ");
  const std::string path = c.write();
  const std::string err = loadError(path);
  EXPECT_CONTAINS(err, path);
  EXPECT_CONTAINS(err, "drivetrain.gear_ratio");
  EXPECT_CONTAINS(err, "missing");
}

TEST(VehicleModelErrors, FirmGroundTyreParametersAreChecked)
{
  // The brush tyre of the rigid-surface contact: missing, negative and implausible values.
  ScratchConfig missing("fed_alpha");
  missing.editYaml("  relaxation_length: 0.55 ", "  # relaxation_length removed ");
  const std::string path = missing.write();
  std::string err = loadError(path);
  EXPECT_CONTAINS(err, path);
  EXPECT_CONTAINS(err, "firm_ground.relaxation_length");
  EXPECT_CONTAINS(err, "missing");

  ScratchConfig negative("fed_alpha");
  negative.editYaml("cornering_stiffness: 9.5", "cornering_stiffness: -9.5");
  EXPECT_CONTAINS(loadError(negative.write()), "firm_ground.cornering_stiffness");

  // 565 N/m for 565000: a spring the vehicle would bottom out on.
  ScratchConfig soft("fed_alpha");
  soft.editYaml("vertical_stiffness: 565000.0", "vertical_stiffness: 565.0");
  err = loadError(soft.write());
  EXPECT_CONTAINS(err, "firm_ground.vertical_stiffness");
  EXPECT_CONTAINS(err, "0.2 m of deflection");

  ScratchConfig grippy("fed_alpha");
  grippy.editYaml("longitudinal_stiffness: 8.0", "longitudinal_stiffness: 800.0");
  EXPECT_CONTAINS(loadError(grippy.write()), "firm_ground.longitudinal_stiffness");
}

TEST(VehicleModelErrors, NegativeValueNamesKey)
{
  ScratchConfig c("mrzr");
  c.editYaml("stiffness: 19500.0", "stiffness: -19500.0");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, "suspension.stiffness");
  EXPECT_CONTAINS(err, "must be > 0");
}

TEST(VehicleModelErrors, WrongTypeNamesKey)
{
  ScratchConfig c("tracer_x");
  c.editYaml("max_torque: 60.0", "max_torque: strong");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, "brakes.max_torque");
  EXPECT_CONTAINS(err, "must be a number");
}

TEST(VehicleModelErrors, UnknownKeyIsNotIgnored)
{
  ScratchConfig c("fed_alpha");
  c.editYaml("  max_rate: 0.8", "  max_rate: 0.8\n  max_rat: 0.9");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, "steering.max_rat'");
  EXPECT_CONTAINS(err, "unknown key");
}

TEST(VehicleModelErrors, UnknownDriveTypeAndDifferential)
{
  ScratchConfig a("fed_alpha");
  a.editYaml("drive_type: ackermann", "drive_type: hovercraft");
  EXPECT_CONTAINS(loadError(a.write()), "drive_type");
  ScratchConfig b("fed_alpha");
  b.editYaml("center: locked", "center: welded");
  EXPECT_CONTAINS(loadError(b.write()), "drivetrain.differentials.center");
}

TEST(VehicleModelErrors, JointNotInUrdfNamesListEntry)
{
  ScratchConfig c("tracer_x");
  c.editYaml("spin_joint: rear_left_wheel_spin", "spin_joint: rear_left_wheel_spun");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, "wheels[2].spin_joint");
  EXPECT_CONTAINS(err, "rear_left_wheel_spun");
}

TEST(VehicleModelErrors, JointOfWrongTypeIsRejected)
{
  ScratchConfig c("fed_alpha");
  // A steering joint named as the spin joint: revolute about z, not continuous about y.
  c.editYaml("spin_joint: front_left_wheel_spin", "spin_joint: front_left_steering");
  EXPECT_CONTAINS(loadError(c.write()), "must be continuous");
}

TEST(VehicleModelErrors, SteeringBeyondJointLimit)
{
  ScratchConfig c("fed_alpha");
  c.editYaml("max_angle: 0.55", "max_angle: 0.9");
  EXPECT_CONTAINS(loadError(c.write()), "steering.max_angle");
}

TEST(VehicleModelErrors, SprocketInconsistentWithPitch)
{
  ScratchConfig c("m113");
  c.editYaml("sprocket_teeth: 10", "sprocket_teeth: 13");
  EXPECT_CONTAINS(loadError(c.write()), "track.sprocket_teeth");
}

TEST(VehicleModelErrors, MissingSensorMount)
{
  ScratchConfig c("mrzr");
  c.editUrdf("<child link=\"radar\"/>", "<child link=\"radar_gone\"/>");
  c.editUrdf("<link name=\"radar\">", "<link name=\"radar_gone\">");
  const std::string err = loadError(c.write());
  EXPECT_CONTAINS(err, "sensor mount link 'radar'");
}

TEST(VehicleModelErrors, BadCollisionGeometryNamesLink)
{
  {
    ScratchConfig c("fed_alpha");
    c.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 2.2 1.2"/></geometry>)",
               R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 0 1.2"/></geometry>)");
    const std::string err = loadError(c.write());
    EXPECT_CONTAINS(err, c.urdfPath());
    EXPECT_CONTAINS(err, "link 'chassis'");
    EXPECT_CONTAINS(err, "box size must be finite and > 0");
  }
  {
    ScratchConfig c("fed_alpha");
    c.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 2.2 1.2"/></geometry>)",
               R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><sphere radius="1.2"/></geometry>)");
    const std::string err = loadError(c.write());
    EXPECT_CONTAINS(err, "link 'chassis'");
    EXPECT_CONTAINS(err, "must be a box");
  }
  {
    ScratchConfig c("fed_alpha");
    c.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 2.2 1.2"/></geometry>
    </collision>)",
               "");
    EXPECT_CONTAINS(loadError(c.write()), "no link other than the running gear has a <collision> box");
  }
}

TEST(VehicleModelErrors, MissingFilesAndBrokenYaml)
{
  EXPECT_CONTAINS(loadError("/nonexistent/avsp.yaml"), "cannot open");
  ScratchConfig c("fed_alpha");
  c.editYaml("urdf: fed_alpha.urdf", "urdf: no_such.urdf");
  EXPECT_CONTAINS(loadError(c.write()), "key 'urdf'");
  ScratchConfig d("fed_alpha");
  d.setYaml("model: fed_alpha\nwheels: [\n");
  const std::string err = loadError(d.write());
  EXPECT_CONTAINS(err, "not valid YAML");
  EXPECT_CONTAINS(err, "line");
}

TEST(VehicleModelErrors, ModelKeyMustBeTheFileName)
{
  ScratchConfig c("mrzr");
  c.editYaml("model: mrzr", "model: m113");
  const std::string path = c.write();
  const std::string err = loadError(path);
  EXPECT_CONTAINS(err, path + ": key 'model'");
  EXPECT_CONTAINS(err, "'m113' contradicts the file's name 'mrzr'");
}

// --- plausible ranges: every physical value, refused outside what a real vehicle can have ---

TEST(VehicleModelPlausible, LinkMassOutsideRangeNamesFileLinkAndRange)
{
  ScratchConfig huge("mrzr");
  huge.editUrdf("<mass value=\"770\"/>", "<mass value=\"1e308\"/>");
  EXPECT_CONTAINS(
      loadError(huge.write()),
      huge.urdfPath() + ": link 'chassis': mass 1e+308 kg is outside the plausible range [0.001, 200000] kg");
  ScratchConfig tiny("mrzr");
  tiny.editUrdf("<mass value=\"770\"/>", "<mass value=\"1e-6\"/>");
  EXPECT_CONTAINS(loadError(tiny.write()), ": link 'chassis': mass 1e-06 kg is outside the plausible range");
  // Each link plausible, the vehicle not: 200 t + 150 t + the rest.
  ScratchConfig heavy("mrzr");
  heavy.editUrdf("<mass value=\"770\"/>", "<mass value=\"200000\"/>");
  heavy.editUrdf("<mass value=\"15\"/>", "<mass value=\"150000\"/>");
  EXPECT_CONTAINS(loadError(heavy.write()), heavy.urdfPath() + ": the links' total mass 350");
  EXPECT_CONTAINS(loadError(heavy.write()), "kg is outside the plausible range [0.2, 300000] kg");
}

TEST(VehicleModelPlausible, InertiaMustMatchTheMass)
{
  // The chassis (5240 kg) with a million times its inertia: 2742 t m^2 > 5240 kg x (50 m)^2.
  ScratchConfig big("fed_alpha");
  big.editUrdf(R"(<inertia ixx="2742.27" ixy="0" ixz="0" iyy="11113.2" iyz="0" izz="12597.8"/>)",
               R"(<inertia ixx="2742.27e6" ixy="0" ixz="0" iyy="11113.2e6" iyz="0" izz="12597.8e6"/>)");
  std::string err = loadError(big.write());
  EXPECT_CONTAINS(err, big.urdfPath() + ": link 'chassis': principal moment of inertia");
  EXPECT_CONTAINS(err, "is outside the plausible range [5.24e-05, 1.31e+07] kg m^2 for its mass 5240 kg");
  // A 70 kg wheel with the inertia of a point: 1e-9 kg m^2 < 70 kg x (0.1 mm)^2.
  ScratchConfig point("fed_alpha");
  point.editUrdf(R"(<inertia ixx="5.99418" ixy="0" ixz="0" iyy="10.4341" iyz="0" izz="5.99418"/>)",
                 R"(<inertia ixx="1e-9" ixy="0" ixz="0" iyy="1e-9" iyz="0" izz="1e-9"/>)");
  err = loadError(point.write());
  EXPECT_CONTAINS(err, "link 'front_left_wheel': principal moment of inertia 1e-09 kg m^2 is outside");
  EXPECT_CONTAINS(err, "for its mass 70 kg");
}

TEST(VehicleModelPlausible, WheelRadiusAndWidthOutsideRange)
{
  ScratchConfig c("tracer_x");
  c.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="1.5708 0 0"/>
      <geometry><cylinder radius="0.165" length="0.12"/></geometry>)",
             R"(<collision>
      <origin xyz="0 0 0" rpy="1.5708 0 0"/>
      <geometry><cylinder radius="1e-9" length="0.12"/></geometry>)");
  EXPECT_CONTAINS(loadError(c.write()), c.urdfPath() +
                                            ": link 'front_left_wheel': collision cylinder radius 1e-09 m is outside "
                                            "the plausible range [0.005, 5] m");
  // A road wheel 100 m wide.
  ScratchConfig m("m113");
  m.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="1.5708 0 0"/>
      <geometry><cylinder radius="0.305" length="0.3"/></geometry>)",
             R"(<collision>
      <origin xyz="0 0 0" rpy="1.5708 0 0"/>
      <geometry><cylinder radius="0.305" length="100"/></geometry>)");
  EXPECT_CONTAINS(loadError(m.write()),
                  "link 'left_road_wheel_1': collision cylinder length (width) 100 m is outside "
                  "the plausible range [0.002, 5] m");
}

TEST(VehicleModelPlausible, LinksFarFromBaseLinkAreRefused)
{
  ScratchConfig chassis("fed_alpha");
  chassis.editUrdf(R"(<origin xyz="0 0 0.55" rpy="0 0 0"/>)", R"(<origin xyz="1e308 0 0.55" rpy="0 0 0"/>)");
  EXPECT_CONTAINS(loadError(chassis.write()), chassis.urdfPath() +
                                                  ": joint 'chassis_mount': link 'chassis' at rest is "
                                                  "inf m from base_link, outside the plausible range "
                                                  "[0, 50] m");
  ScratchConfig lidar("fed_alpha");
  lidar.editUrdf(R"(<origin xyz="1 0 1.4" rpy="0 0 0"/>)", R"(<origin xyz="60 0 1.4" rpy="0 0 0"/>)");
  EXPECT_CONTAINS(loadError(lidar.write()), "joint 'lidar_mount': link 'lidar' at rest is 60.0");
  ScratchConfig com("fed_alpha");
  com.editUrdf(R"(<origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="5240"/>)",
               R"(<origin xyz="0 0 80" rpy="0 0 0"/>
      <mass value="5240"/>)");
  EXPECT_CONTAINS(loadError(com.write()), "link 'chassis': its centre of mass is 80.55 m from base_link");
  ScratchConfig box("fed_alpha");
  box.editUrdf(R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 2.2 1.2"/></geometry>)",
               R"(<collision>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><box size="4.9 2.2 1000"/></geometry>)");
  EXPECT_CONTAINS(loadError(box.write()),
                  "link 'chassis': <collision> box edge 1000 m is outside the plausible range [0.001, 50] m");
}

TEST(VehicleModelPlausible, MoreLinksThanAVehicleHasAreRefused)
{
  // 2001 massless links on fixed joints: no vehicle has that many (each costs a rest-pose walk).
  std::string extra;
  for (int k = 0; k < 2001; ++k)
  {
    const std::string n = std::to_string(k);
    extra += "<link name=\"extra_" + n + "\"/><joint name=\"extra_" + n +
             "_mount\" type=\"fixed\"><parent link=\"base_link\"/><child link=\"extra_" + n + "\"/></joint>\n";
  }
  ScratchConfig c("tracer_x");
  c.editUrdf("</robot>", extra + "</robot>");
  EXPECT_CONTAINS(loadError(c.write()), c.urdfPath() + ": has 2015 links, more than the 2000 a vehicle plausibly has");
}

TEST(VehicleModelPlausible, JointLimitsOutsideRange)
{
  ScratchConfig susp("fed_alpha");
  susp.editUrdf(R"(<limit lower="-0.15" upper="0.15")", R"(<limit lower="-1e308" upper="0.15")");
  EXPECT_CONTAINS(loadError(susp.write()),
                  susp.urdfPath() +
                      ": joint 'front_left_suspension': limits [-1e+308, 0.15] m are outside the "
                      "plausible range [-2, 2] m (suspension travel)");
  ScratchConfig steer("fed_alpha");
  steer.editUrdf(R"(<limit lower="-0.6" upper="0.6")", R"(<limit lower="-0.6" upper="100")");
  EXPECT_CONTAINS(loadError(steer.write()),
                  "joint 'front_left_steering': limits [-0.6, 100] rad are outside the "
                  "plausible range [-3.14159, 3.14159] rad");
  ScratchConfig arm("m113");
  arm.editUrdf(R"(<limit lower="-0.45" upper="0.45")", R"(<limit lower="-0.45" upper="3")");
  EXPECT_CONTAINS(loadError(arm.write()),
                  "joint 'left_road_arm_1_swing': limits [-0.45, 3] rad are outside the "
                  "plausible range [-1.5708, 1.5708] rad");
}

// Every physical YAML key outside its range: the refusal names the file, the key and the range.
TEST(VehicleModelPlausible, YamlValuesOutsideRangeNameFileKeyAndRange)
{
  struct Case
  {
    const char* model;
    const char* from;
    const char* to;
    const char* key;
    const char* text;
  };
  const Case cases[] = {
    { "fed_alpha", "stiffness: 95000.0", "stiffness: 1e12", "suspension.stiffness",
      "1e+12 N/m is outside the plausible range [10, 1e+09] N/m (per wheel)" },
    { "fed_alpha", "damping: 8150.0", "damping: 1e10", "suspension.damping",
      "1e+10 N s/m is outside the plausible range [0, 1e+08] N s/m" },
    { "fed_alpha", "max_angle: 0.55", "max_angle: 0.01", "steering.max_angle",
      "0.01 rad is outside the plausible range [0.05, 1.4] rad" },
    { "fed_alpha", "max_rate: 0.8", "max_rate: 1000", "steering.max_rate",
      "1000 rad/s is outside the plausible range [0.01, 20] rad/s" },
    { "fed_alpha", "engine_max_torque: 700.0", "engine_max_torque: 1e9", "drivetrain.engine_max_torque",
      "1e+09 N m is outside the plausible range [0.0001, 1e+06] N m" },
    { "fed_alpha", "engine_max_power: 150000.0", "engine_max_power: 1e12", "drivetrain.engine_max_power",
      "1e+12 W is outside the plausible range [0.1, 1e+08] W" },
    { "fed_alpha", "gear_ratio: 20.0", "gear_ratio: 1e6", "drivetrain.gear_ratio",
      "1e+06 is outside the plausible range [0.1, 5000]" },
    { "fed_alpha", "efficiency: 0.85", "efficiency: 1e-9", "drivetrain.efficiency",
      "1e-09 is outside the plausible range [0.05, 1]" },
    { "fed_alpha", "max_speed: 30.0", "max_speed: 1e5", "drivetrain.max_speed",
      "100000 m/s is outside the plausible range [0.01, 150] m/s" },
    { "fed_alpha", "reverse_max_speed: 5.0", "reverse_max_speed: 0.001", "drivetrain.reverse_max_speed",
      "0.001 m/s is outside the plausible range [0.01, 150] m/s" },
    { "fed_alpha", "max_torque: 8000.0", "max_torque: 1e12", "brakes.max_torque",
      "1e+12 N m is outside the plausible range [0.001, 1e+07] N m" },
    { "fed_alpha", "longitudinal_stiffness: 8.0", "longitudinal_stiffness: 0.001", "firm_ground.longitudinal_stiffness",
      "0.001 is outside the plausible range [0.1, 100] (C_x / F_z per unit slip)" },
    { "fed_alpha", "cornering_stiffness: 9.5", "cornering_stiffness: 1000", "firm_ground.cornering_stiffness",
      "1000 is outside the plausible range [0.1, 100]" },
    { "fed_alpha", "relaxation_length: 0.55", "relaxation_length: 1e-6", "firm_ground.relaxation_length",
      "1e-06 m is outside the plausible range [0.001, 10] m" },
    { "fed_alpha", "vertical_stiffness: 565000.0", "vertical_stiffness: 1e12", "firm_ground.vertical_stiffness",
      "1e+12 N/m must be between" },
    { "m113", "torsion_stiffness: 10800.0", "torsion_stiffness: 1e12", "suspension.torsion_stiffness",
      "1e+12 N m/rad is outside the plausible range [0.01, 1e+08] N m/rad" },
    { "m113", "torsion_damping: 650.0", "torsion_damping: 1e9", "suspension.torsion_damping",
      "1e+09 N m s/rad is outside the plausible range [0, 1e+07] N m s/rad" },
    { "m113", "preload_angle: 0.276", "preload_angle: 3", "suspension.preload_angle",
      "3 rad is outside the plausible range [0, 1.5708] rad" },
    { "m113", "pitch: 0.152", "pitch: 1e-6", "track.pitch", "1e-06 m is outside the plausible range [0.002, 1] m" },
    { "m113", "sprocket_teeth: 10", "sprocket_teeth: 1000", "track.sprocket_teeth",
      "1000 is outside the plausible range [3, 100]" },
    { "m113", "shoe_width: 0.38", "shoe_width: 1e-6", "track.shoe_width",
      "1e-06 m is outside the plausible range [0.005, 5] m" },
    { "m113", "coefficient: 0.022", "coefficient: 0.5", "track.internal_resistance.coefficient",
      "0.5 is outside the plausible range [0, 0.3] (a fraction of the weight)" },
    { "m113", "per_speed: 0.0011", "per_speed: 0.1", "track.internal_resistance.per_speed",
      "0.1 per m/s is outside the plausible range [0, 0.05] per m/s" },
  };
  for (const Case& c : cases)
  {
    ScratchConfig v(c.model);
    v.editYaml(c.from, c.to);
    const std::string path = v.write();
    const std::string err = loadError(path);
    EXPECT_CONTAINS(err, path + ": key '" + c.key + "'");
    EXPECT_CONTAINS(err, c.text);
  }
}

/**
 * The vehicle's URDF and YAML scaled by `s` with Froude similarity: lengths s, masses s^3,
 * inertias s^5, times and speeds s^0.5 (so forces s^3, torques s^4, power s^3.5). The result is
 * the same machine as a toy or a giant, as consistent as the original (ride frequencies, Froude
 * number, T10, preloads and steering angles all carry over).
 */
void scaleVehicle(ScratchConfig& c, double s)
{
  auto number = [](double v) {
    std::ostringstream out;
    out.precision(12);
    out << v;
    return out.str();
  };
  // Scales every number of the named attributes on one line.
  auto scaleAttributes = [&](const std::string& line, const std::map<std::string, double>& factors) {
    static const std::regex attribute(R"re(([a-z]+)="([^"]*)")re");
    std::string out;
    auto last = line.cbegin();
    for (std::sregex_iterator it(line.begin(), line.end(), attribute), end; it != end; ++it)
    {
      const auto& match = *it;
      out.append(last, match[0].first);
      const auto factor = factors.find(match[1].str());
      if (factor == factors.end())
      {
        out += match[0].str();
      }
      else
      {
        std::istringstream in(match[2].str());
        std::string scaled;
        double v;
        while (in >> v)
          scaled += (scaled.empty() ? "" : " ") + number(v * factor->second);
        out += match[1].str() + "=\"" + scaled + "\"";
      }
      last = match[0].second;
    }
    out.append(last, line.cend());
    return out;
  };
  std::istringstream urdf(c.urdf());
  std::string line, scaled, joint_type;
  static const std::regex joint(R"re(<joint name="[^"]*" type="([a-z]+)")re");
  while (std::getline(urdf, line))
  {
    std::smatch m;
    if (std::regex_search(line, m, joint))
      joint_type = m[1];
    if (line.find("<origin") != std::string::npos)
      line = scaleAttributes(line, { { "xyz", s } });
    else if (line.find("<box") != std::string::npos)
      line = scaleAttributes(line, { { "size", s } });
    else if (line.find("<cylinder") != std::string::npos)
      line = scaleAttributes(line, { { "radius", s }, { "length", s } });
    else if (line.find("<mass") != std::string::npos)
      line = scaleAttributes(line, { { "value", s * s * s } });
    else if (line.find("<inertia") != std::string::npos)
    {
      const double i = std::pow(s, 5);
      line =
          scaleAttributes(line, { { "ixx", i }, { "ixy", i }, { "ixz", i }, { "iyy", i }, { "iyz", i }, { "izz", i } });
    }
    else if (line.find("<limit") != std::string::npos && joint_type == "prismatic")
      line = scaleAttributes(line, { { "lower", s }, { "upper", s } });
    scaled += line + "\n";
  }
  c.setUrdf(scaled);

  // The power of s of each YAML number's unit.
  static const std::map<std::string, double> exponent{
    { "stiffness", 2.0 },
    { "damping", 2.5 },
    { "preload_deflection", 1.0 },
    { "torsion_stiffness", 4.0 },
    { "torsion_damping", 4.5 },
    { "preload_angle", 0.0 },
    { "max_angle", 0.0 },
    { "max_rate", -0.5 },
    { "pitch", 1.0 },
    { "sprocket_teeth", 0.0 },
    { "shoe_width", 1.0 },
    { "coefficient", 0.0 },
    { "per_speed", -0.5 },
    { "engine_max_torque", 4.0 },
    { "engine_max_power", 3.5 },
    { "gear_ratio", 0.0 },
    { "efficiency", 0.0 },
    { "max_speed", 0.5 },
    { "reverse_max_speed", 0.5 },
    { "max_torque", 4.0 },
    { "vertical_stiffness", 2.0 },
    { "longitudinal_stiffness", 0.0 },
    { "cornering_stiffness", 0.0 },
    { "relaxation_length", 1.0 },
  };
  static const std::regex key_number(R"re(^(\s*)([a-z_]+): ([-+0-9.eE]+)(\s.*)?$)re");
  std::istringstream yaml(c.yaml());
  scaled.clear();
  while (std::getline(yaml, line))
  {
    std::smatch m;
    if (std::regex_match(line, m, key_number))
    {
      const auto e = exponent.find(m[2]);
      if (e == exponent.end())
        ADD_FAILURE() << "scaleVehicle: no unit for key '" << m[2] << "'";
      else if (e->second != 0.0)
        line = m[1].str() + m[2].str() + ": " + number(std::stod(m[3]) * std::pow(s, e->second)) + m[4].str();
    }
    scaled += line + "\n";
  }
  c.setYaml(scaled);
}

// The ranges admit any real ground vehicle from a 1 kg toy robot to a 200 t machine: each
// reference vehicle, scaled to either mass, still loads.
TEST(VehicleModelPlausible, ReferenceVehiclesScaledTo1KgAnd200TLoad)
{
  for (const char* model : { "fed_alpha", "mrzr", "tracer_x", "m113" })
  {
    const double mass = loadVehicleModel(kConfigDir + "/" + model + ".yaml").total_mass;
    for (const double target : { 1.0, 200000.0 })
    {
      ScratchConfig c(model);
      const double s = std::cbrt(target / mass);
      scaleVehicle(c, s);
      try
      {
        const VehicleModel m = loadVehicleModel(c.write());
        EXPECT_NEAR(m.total_mass, target, 1e-6 * target) << model;
        EXPECT_NEAR(m.wheelbase(), s * loadVehicleModel(kConfigDir + "/" + model + ".yaml").wheelbase(), 1e-6) << model;
      }
      catch (const ConfigError& e)
      {
        ADD_FAILURE() << model << " scaled to " << target << " kg (lengths x " << s << "): " << e.what();
      }
    }
  }
}

// --- vehicle files: regular files of at most 16 MiB, refused before reading otherwise ---

TEST(VehicleFiles, UrdfThatIsNotARegularFileIsRefusedUnread)
{
  ScratchConfig c("fed_alpha");
  const std::string fifo = c.urdfPath() + ".fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string folder = c.urdfPath() + ".d";
  ASSERT_EQ(mkdir(folder.c_str(), 0700), 0);
  const std::pair<std::string, std::string> cases[] = {
    { "/dev/zero", "is a character device, not a regular file" },
    { fifo, "is a FIFO (named pipe), not a regular file" },
    { folder, "is a directory, not a regular file" },
  };
  for (const auto& [path, why] : cases)
  {
    ScratchConfig v("fed_alpha");
    v.editYaml("urdf: fed_alpha.urdf", "urdf: " + path);
    const std::string yaml = v.write();
    const std::string err = loadErrorBounded(yaml);
    EXPECT_CONTAINS(err, yaml);
    EXPECT_CONTAINS(err, "key 'urdf'");
    EXPECT_CONTAINS(err, "'" + path + "' " + why);
  }
  std::remove(fifo.c_str());
  rmdir(folder.c_str());
}

TEST(VehicleFiles, YamlThatIsNotARegularFileIsRefusedUnread)
{
  EXPECT_CONTAINS(loadErrorBounded("/dev/zero"), "/dev/zero: is a character device, not a regular file");
  char tmpl[] = "/tmp/avsp_vehicle_test_XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  const std::string fifo = dir + "/fed_alpha.yaml";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_CONTAINS(loadErrorBounded(fifo), fifo + ": is a FIFO (named pipe), not a regular file");
  std::remove(fifo.c_str());
  const std::string folder = dir + "/fed_alpha.yaml";
  ASSERT_EQ(mkdir(folder.c_str(), 0700), 0);
  EXPECT_CONTAINS(loadErrorBounded(folder), folder + ": is a directory, not a regular file");
  rmdir(folder.c_str());
  rmdir(dir.c_str());
}

TEST(VehicleFiles, FilesOver16MiBAreRefused)
{
  // 17 MiB of comment in an otherwise valid file.
  const std::string padding(17u << 20, 'x');
  ScratchConfig urdf("fed_alpha");
  urdf.editUrdf("</robot>", "</robot>\n<!-- " + padding + " -->");
  std::string err = loadErrorBounded(urdf.write());
  EXPECT_CONTAINS(err, urdf.urdfPath() + "' is " + std::to_string(fileSize(urdf.urdfPath())) + " bytes");
  EXPECT_CONTAINS(err, "bytes, more than the 16777216 (16 MiB)");

  ScratchConfig yaml("fed_alpha");
  yaml.setYaml(yaml.yaml() + "\n# " + padding + "\n");
  const std::string path = yaml.write();
  err = loadErrorBounded(path);
  EXPECT_CONTAINS(err, path + ": is " + std::to_string(fileSize(path)) + " bytes");
  EXPECT_CONTAINS(err, "(16 MiB)");

  // The limit is not near real files: 15 MiB of comment still loads.
  ScratchConfig big("fed_alpha");
  big.editUrdf("</robot>", "</robot>\n<!-- " + std::string(15u << 20, 'x') + " -->");
  EXPECT_EQ(loadVehicleModel(big.write()).model, "fed_alpha");
}

// --- fuzz: random edits of a valid file either load or throw ConfigError, never crash ---

TEST(VehicleModelFuzz, RandomByteEditsNeverCrash)
{
  ScratchConfig c("m113");
  const std::string original = c.yaml();
  std::mt19937 rng(20261123);  // fixed seed: the same edits every run
  const std::string alphabet = "-:{}[],#\n 0123456789.abcxyz_'\"&*!|>";
  int rejected = 0, loaded = 0;
  for (int iteration = 0; iteration < 300; ++iteration)
  {
    std::string text = original;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e)
    {
      const std::size_t at = rng() % text.size();
      switch (rng() % 3)
      {
        case 0:
          text[at] = alphabet[rng() % alphabet.size()];
          break;
        case 1:
          text.erase(at, 1 + rng() % 8);
          break;
        default:
          text.insert(at, 1, alphabet[rng() % alphabet.size()]);
      }
    }
    c.setYaml(text);
    try
    {
      loadVehicleModel(c.write());
      ++loaded;
    }
    catch (const ConfigError& e)
    {
      ++rejected;
      // The YAML, or the URDF when an edit makes a URDF link mean something else (a road wheel
      // no longer listed is then a chassis link whose cylinder is refused).
      const std::string what = e.what();
      EXPECT_TRUE(what.find(".yaml") != std::string::npos || what.find(".urdf") != std::string::npos)
          << "error must name a file: " << what;
    }
  }
  // Most random edits break something; a validator that accepted them all would be wrong.
  EXPECT_GT(rejected, 100);
  EXPECT_EQ(rejected + loaded, 300);
}
