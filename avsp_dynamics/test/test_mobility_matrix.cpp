// The mobility matrix (config/mobility_matrix.yaml): every case run through the World and held
// to its reference, a closed form computed from the vehicle's and the soil's parameters, a
// public figure, or an acceptance limit (issue 18). bench_mobility prints the same cases as
// the table of docs/mobility_matrix.md. Then the matrix file's own checking: bad files are
// refused naming the file and the key.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

#include <avsp_terrain/default_course.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/mobility.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp::dynamics;

namespace
{
const char* const kMatrix = AVSP_MOBILITY_MATRIX;

// Loaded once for the parametrised cases; a file that does not load gives no cases, and
// MatrixFile.ShippedMatrixLoads fails with the loader's message.
std::vector<mobility::Case> shippedCases()
{
  try
  {
    return mobility::loadMatrix(kMatrix);
  }
  catch (const std::exception&)
  {
    return {};
  }
}

const mobility::Setup& setup()
{
  static const mobility::Setup s{ AVSP_VEHICLE_CONFIG_DIR, AVSP_SOILS_YAML };
  return s;
}

class MobilityMatrix : public ::testing::TestWithParam<mobility::Case>
{
};

TEST_P(MobilityMatrix, MeetsItsReference)
{
  const mobility::Case& c = GetParam();
  const mobility::Result r = mobility::run(c, setup());
  ASSERT_TRUE(std::isfinite(r.value)) << c.id << ": " << r.detail;
  ASSERT_TRUE(std::isfinite(r.reference)) << c.id;
  // The verdict is recomputed here from the figures, not taken from Result::pass.
  switch (c.check)
  {
    case mobility::Check::kAtMost:
      EXPECT_LE(r.value, c.value) << c.id << " (" << c.unit << "): " << c.source << "; " << r.detail;
      break;
    case mobility::Check::kAtLeast:
      EXPECT_GE(r.value, c.value) << c.id << " (" << c.unit << "): " << c.source << "; " << r.detail;
      break;
    case mobility::Check::kPublic:
      EXPECT_NEAR(r.value, c.value, c.tolerance * std::fabs(c.value))
          << c.id << " (" << c.unit << "): " << c.source << "; " << r.detail;
      break;
    case mobility::Check::kClosedForm:
    {
      // Between two bounds there is no error; outside, the nearer bound is the reference.
      const double hi = r.reference;
      const double lo = std::isnan(r.reference_low) ? hi : r.reference_low;
      const double nearest = r.value < lo ? lo : (r.value > hi ? hi : r.value);
      const double allowed = std::isfinite(c.tolerance_abs) ? c.tolerance_abs : c.tolerance * std::fabs(nearest);
      EXPECT_NEAR(r.value, nearest, allowed)
          << c.id << " (" << c.unit << ") against [" << lo << ", " << hi << "]: " << c.source << "; " << r.detail;
      break;
    }
  }
  EXPECT_EQ(r.pass, !::testing::Test::HasFailure()) << c.id << ": the runner's verdict disagrees with the figures";
}

std::string caseName(const ::testing::TestParamInfo<mobility::Case>& info)
{
  std::string n = info.param.id;
  for (char& ch : n)
    if (!std::isalnum(static_cast<unsigned char>(ch)))
      ch = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Shipped, MobilityMatrix, ::testing::ValuesIn(shippedCases()), caseName);

TEST(MatrixFile, ShippedMatrixLoads)
{
  std::vector<mobility::Case> cases;
  ASSERT_NO_THROW(cases = mobility::loadMatrix(kMatrix));
  // The situations: every manoeuvre the runner knows appears at least once.
  for (const auto& m : mobility::manoeuvres())
  {
    bool used = false;
    for (const mobility::Case& c : cases)
      used = used || c.manoeuvre == m.first;
    EXPECT_TRUE(used) << "no case runs manoeuvre " << m.first;
  }
}

TEST(MatrixFile, SameCaseSameFigureBitForBit)
{
  const std::vector<mobility::Case> cases = mobility::loadMatrix(kMatrix);
  const mobility::Case* parked = nullptr;
  for (const mobility::Case& c : cases)
    if (c.manoeuvre == "parked_sinkage" && !parked)
      parked = &c;
  ASSERT_NE(parked, nullptr);
  const mobility::Result a = mobility::run(*parked, setup());
  const mobility::Result b = mobility::run(*parked, setup());
  EXPECT_EQ(a.value, b.value);
  EXPECT_EQ(a.detail, b.detail);
}

// The course's own 17.5 deg plane (default course, seed 1, 0.1 m: sandy loam mottled with grass
// over loam), not a synthetic one: the four reference vehicles braked across it, facing up it
// and facing down it, all twelve in one world, set down 5 mm above it. Each may settle by what
// its soil's shear needs to mobilise: the downhill load comes on suddenly, so the shear
// displacement overshoots its static value (about K = 25-30 mm on these soils) up to twice,
// and the soil does not give it back (a slid contact unloads elastically); with the sinkage
// along the slope and the tyres' and suspension's give, at most 15 cm (measured 2-10 cm). Then
// it holds within 1 cm over 10 s (issue 18: a braked m113 slid 14 m off it in 6 s; the
// reference traverse's vehicles may park there).
TEST(CoursePlane, BrakedVehiclesStayOnTheSideSlope)
{
  const avsp::terrain::SoilLibrary soils = avsp::terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  avsp::terrain::Course course = avsp::terrain::makeDefaultCourse(avsp::terrain::CourseOptions{});
  const avsp::terrain::CourseFeature plane = course.feature("side_slope");
  avsp::terrain::DeformableTerrain ground(
      std::move(course.heights), avsp::terrain::paletteFromNames(course.soil_names, soils), std::move(course.soil_map),
      avsp::terrain::DeformableTerrain::Options{ true });
  const double theta = 17.5 * M_PI / 180.0;
  World world(ground);
  struct Parked
  {
    std::string what;
    std::size_t id;
  };
  std::vector<Parked> parked;
  const char* const models[] = { "m113", "mrzr", "tracer_x", "fed_alpha" };
  for (int v = 0; v < 4; ++v)
  {
    const VehicleModel m = loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/" + models[v] + ".yaml");
    const double x = plane.min_x + 5.0 + 10.0 * v;
    // The plane rises northwards (+y): facing east the left side is up (roll +theta); facing
    // north the nose is up (pitch -theta); facing south it is down.
    const struct
    {
      const char* name;
      double y, yaw, roll, pitch;
    } ways[] = { { "across", plane.min_y + 6.0, 0.0, theta, 0.0 },
                 { "uphill", 0.5 * (plane.min_y + plane.max_y), 0.5 * M_PI, 0.0, -theta },
                 { "downhill", plane.max_y - 6.0, -0.5 * M_PI, 0.0, theta } };
    for (const auto& w : ways)
    {
      const std::string what = std::string(models[v]) + " " + w.name;
      const std::size_t id =
          world.addVehicle(m, mobility::placeOnGround(ground, m, x, w.y, w.yaw, w.roll, w.pitch, 0.005), what);
      world.setCommand(id, DriveCommand{ 0.0, 1.0, 0.0 });
      parked.push_back({ what, id });
    }
  }
  std::vector<Eigen::Vector3d> set_down, start;
  for (const Parked& p : parked)
    set_down.push_back(world.state(p.id).pose.translation());
  world.advance(4.0);
  for (const Parked& p : parked)
    start.push_back(world.state(p.id).pose.translation());
  world.advance(10.0);
  for (std::size_t k = 0; k < parked.size(); ++k)
  {
    const VehicleState& s = world.state(parked[k].id);
    const Eigen::Vector3d settled = start[k] - set_down[k];
    const double settle = std::hypot(settled.x(), settled.y());
    const double drift = (s.pose.translation() - start[k]).norm();
    std::printf("[course plane] %-20s settled %.1f mm, then drift %.2f mm in 10 s\n", parked[k].what.c_str(),
                1e3 * settle, 1e3 * drift);
    EXPECT_LT(settle, 0.15) << parked[k].what;
    EXPECT_LT(drift, 0.01) << parked[k].what;
    // Still on its wheels or tracks: its up axis within 5 deg of the plane's normal's tilt.
    EXPECT_GT(s.pose.linear()(2, 2), std::cos(theta + 5.0 * M_PI / 180.0)) << parked[k].what;
  }
}

// Writes a matrix with one case, `fields` being its YAML map's body.
std::string writeMatrix(const std::string& body)
{
  const std::string path = ::testing::TempDir() + "mobility_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << body;
  return path;
}

const char* const kGood =
    "{id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: closed_form, unit: m/s, source: s}";

// The loader's message for `yaml`, which must contain every one of `words`.
void expectRefused(const std::string& yaml, const std::vector<std::string>& words)
{
  const std::string path = writeMatrix(yaml);
  try
  {
    mobility::loadMatrix(path);
    ADD_FAILURE() << "accepted:\n" << yaml;
  }
  catch (const std::runtime_error& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    for (const std::string& w : words)
      EXPECT_NE(what.find(w), std::string::npos) << "'" << w << "' not in: " << what;
  }
}

TEST(MatrixFile, GoodOneCaseFileLoads)
{
  const std::vector<mobility::Case> cases = mobility::loadMatrix(writeMatrix(std::string("cases:\n  - ") + kGood));
  ASSERT_EQ(cases.size(), 1u);
  EXPECT_EQ(cases[0].id, "a");
  EXPECT_EQ(cases[0].step, 0.001);
  EXPECT_TRUE(std::isnan(cases[0].tolerance_abs));
}

TEST(MatrixFile, BadFilesAreRefusedNamingTheKey)
{
  expectRefused(std::string("cases:\n  - ") + kGood + "\n  - " + kGood, { "id", "twice" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: moonwalk, check: closed_form, "
      "unit: m/s, source: s}",
      { "manoeuvre", "moonwalk" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: roughly, "
      "unit: m/s, source: s}",
      { "check", "roughly" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: closed_form, "
      "unit: m/s, source: s, colour: red}",
      { "colour" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: closed_form, "
      "unit: m/s, source: s, step: 0}",
      { "step" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: closed_form, "
      "unit: m/s, source: s, slope_deg: -3}",
      { "slope_deg" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: at_most, "
      "unit: m/s, source: s}",
      { "value" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: at_most, "
      "value: 1, tolerance_abs: 0.1, unit: m/s, source: s}",
      { "tolerance_abs" });
  expectRefused(
      "cases:\n  - {id: a, vehicle: fed_alpha, soil: asphalt, manoeuvre: top_speed, check: closed_form, "
      "unit: m/s, source: s, tolerance: fast}",
      { "tolerance" });
}

TEST(MatrixFile, UnknownVehicleOrSoilIsRefusedWhenRun)
{
  mobility::Case c = mobility::loadMatrix(writeMatrix(std::string("cases:\n  - ") + kGood)).front();
  c.soil = "cheese";
  EXPECT_THROW(mobility::run(c, setup()), std::exception);
  c.soil = "asphalt";
  c.vehicle = "no_such_vehicle";
  EXPECT_THROW(mobility::run(c, setup()), std::exception);
}
}  // namespace
