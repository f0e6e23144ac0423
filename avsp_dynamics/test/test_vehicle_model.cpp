// Loads the reference team's URDF + YAML descriptions and checks them against their
// documented public figures; checks that bad descriptions fail naming the file and key.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
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
  double total_mass;   // kg
  double wheelbase;    // m (tracked: ground contact length)
  double track_width;  // m (tracked: gauge)
  double wheel_radius; // m (tracked: road wheel)
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

INSTANTIATE_TEST_SUITE_P(
    Team, ReferenceVehicle,
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
