// The DEM contact mode for a whole vehicle (issue 25, items 1-3 and 5): the tracer_x drives
// across a DEM segment of a flat sand terrain; each side runs on a moving patch whose wheels
// ODE moves, the DEM's forces carry the vehicle, and the crossing leaves its rut in the terrain.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <string>

#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/dem/dem_vehicle_soil.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"

namespace dem = avsp::dynamics::dem;
namespace terrain = avsp::terrain;
using avsp::dynamics::DriveCommand;
using avsp::dynamics::VehicleModel;
using avsp::dynamics::World;

namespace
{
constexpr double kG = 9.81;

/// Coarse particles for a vehicle-sized bed in a test: 18 and 22 mm radius (about 1 300
/// particles in two 1.2 m patches), E = 2e7 Pa, a 0.2 ms step (85 % of its stability limit).
dem::DemParameters vehicleParameters()
{
  dem::DemParameters p;
  p.particles = { { 0.018, 0.5 }, { 0.022, 0.5 } };
  p.youngs_modulus = 2.0e7;
  p.timestep = 2.0e-4;
  return p;
}

/// 0.12 m long, 0.3 m wide (a tracer_x wheel is 0.12 m wide), 0.1 m deep; settled once.
const dem::BedTemplate& vehicleTemplate()
{
  static const auto bed = dem::BedTemplate::settle(vehicleParameters(), 0.12, 0.3, 0.10);
  return bed;
}

const terrain::SoilLibrary& soils()
{
  static const terrain::SoilLibrary lib = terrain::SoilLibrary::load(AVSP_SOILS_YAML);
  return lib;
}

/// Flat dry sand at height 0, x in [-1, 5], y in [-1, 1], 2.5 cm grid.
std::unique_ptr<terrain::DeformableTerrain> flatSand()
{
  const double res = 0.025;
  const std::size_t nx = 241, ny = 81;
  return std::make_unique<terrain::DeformableTerrain>(
      terrain::ElevationGrid(-1.0, -1.0, res, res, nx, ny, std::vector<float>(nx * ny, 0.0f)), soils().get("dry_sand"),
      terrain::DeformableTerrain::Options{ true });
}

/// Segment x in [1, 2.8] (15 template lengths), patches of 1.2 m per side.
dem::DemSegmentSpec segment()
{
  dem::DemSegmentSpec s;
  s.x_min = 1.0;
  s.x_max = 1.0 + 15 * 0.12;
  s.patch_length = 1.2;
  s.front_margin = 0.3;
  return s;
}

struct Crossing
{
  dem::DemSoilReport report;
  double mean_normal = 0.0;  ///< N, sum of the wheels' normal forces, mean while all four are on the bed
  int samples = 0;
  double time = 0.0;  ///< s when the vehicle had crossed
  Eigen::Matrix4d pose;
  std::size_t active = 0, particles = 0;
  std::vector<double> heights;  ///< terrain heights along both tracks and the centre line
};

Crossing cross(double throttle)
{
  const VehicleModel tracer = avsp::dynamics::loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/tracer_x.yaml");
  auto ground = flatSand();
  World world(*ground);
  const std::size_t v = world.addVehicle(tracer, world.restingPose(tracer, 0.0, 0.0, 0.0, 0.01), "t");
  auto soil = std::make_shared<dem::DemVehicleSoil>(vehicleTemplate(), *ground, segment());
  world.setExternalWheelSoil(v, soil);
  DriveCommand c;
  c.throttle = throttle;
  world.setCommand(v, c);
  Crossing out;
  double sum = 0.0;
  while (!soil->report().crossed && world.time() < 8.0)
  {
    // Holding the line y = 0 as a driver would (the two sides' beds are not alike, so a
    // skid-steer vehicle yaws on them): + steering turns left.
    const auto& now = world.state(v).pose;
    const double yaw = std::atan2(now.rotation()(1, 0), now.rotation()(0, 0));
    c.steering = std::clamp(-(4.0 * now.translation().y() + 2.0 * yaw), -1.0, 1.0);
    world.setCommand(v, c);
    world.advance(world.options().step);
    const double x = world.state(v).pose.translation().x();
    // All four wheels wholly on the bed: rear wheel past x_min + r, front short of x_max - r.
    if (x - 0.275 > 1.0 + 0.165 + 0.05 && x + 0.275 < 2.8 - 0.165 - 0.05)
    {
      double f = 0.0;
      for (const auto& w : world.state(v).wheels)
        f += w.normal_force;
      sum += f;
      ++out.samples;
    }
  }
  out.report = soil->report();
  out.mean_normal = out.samples ? sum / out.samples : 0.0;
  out.time = world.time();
  out.pose = world.state(v).pose.matrix();
  out.active = soil->activePatches();
  out.particles = soil->particleCount();
  for (double y : { -0.31, 0.0, 0.31 })
    for (int k = 0; k <= 12; ++k)
      out.heights.push_back(*ground->height(1.3 + 0.1 * k, y));
  return out;
}

double mean(const std::vector<double>& h, std::size_t first, std::size_t n)
{
  double s = 0.0;
  for (std::size_t k = first; k < first + n; ++k)
    s += h[k];
  return s / n;
}
}  // namespace

// The tracer_x (77 kg) at half throttle (1 m/s) over a 1.8 m DEM segment: each side's 1.2 m
// patch moves 5 times, the DEM carries the vehicle's weight while all four wheels are on it,
// the crossing ends with no particle left, the rut is in the terrain along both tracks (and
// nowhere else), and a second run gives the same bits.
TEST(DemVehicle, CrossesASegmentOnTheDemWhichCarriesItAndLeavesItsRut)
{
  const VehicleModel tracer = avsp::dynamics::loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/tracer_x.yaml");
  const Crossing a = cross(0.5);
  const double weight = tracer.total_mass * kG;
  const double rut = -mean(a.heights, 0, 13) / 2.0 - mean(a.heights, 26, 13) / 2.0;
  std::cout << "crossed at " << a.time << " s; relocations " << a.report.relocations << ", peak particles "
            << a.report.peak_particles << ", mean normal " << a.mean_normal << " N over " << a.samples
            << " steps (weight " << weight << " N), sinkage mean " << a.report.mean_sinkage << " max "
            << a.report.max_sinkage << " m, rut " << rut << " m, slip " << a.report.mean_slip << ", energy "
            << a.report.energy << " J, points written " << a.report.points_written << "\n";
  ASSERT_TRUE(a.report.crossed);
  EXPECT_EQ(a.active, 0u);
  EXPECT_EQ(a.particles, 0u);
  // Two sides, each patch's front from 2.2 m to the segment's end at 2.8 m in 0.12 m moves.
  EXPECT_EQ(a.report.relocations, 10);
  // Vertical momentum over the window: the DEM's mean normal force is the weight (the chassis'
  // vertical speed changes by less than 0.1 m/s over it: < 1.2 % of the weight).
  ASSERT_GT(a.samples, 500);
  EXPECT_NEAR(a.mean_normal, weight, 0.03 * weight);
  // The crossing's rut is in the terrain along both tracks, deeper than the bed's surface
  // roughness (an undisturbed bed's surface reads the ground to within a few mm over 13 points,
  // test_dem_patch); between the tracks (outside both strips) the terrain is as it was. The
  // wheels rode on the particles' tops (sinkage within half a radius of the ground).
  EXPECT_GT(rut, 0.005);
  EXPECT_LT(rut, 0.165);
  EXPECT_LT(std::abs(a.report.mean_sinkage), 0.5 * 0.022);
  EXPECT_LT(a.report.max_sinkage, 0.5 * 0.165);
  for (std::size_t k = 13; k < 26; ++k)
    EXPECT_EQ(a.heights[k], 0.0);
  EXPECT_GT(a.report.points_written, 0u);
  // The wheels did work on the soil (compaction, bulldozing, slip).
  EXPECT_GT(a.report.energy, 0.0);
  EXPECT_GT(a.report.entered, 0.0);
  EXPECT_GT(a.report.left, a.report.entered);
  // Deterministic: the same crossing again, bit for bit.
  const Crossing b = cross(0.5);
  EXPECT_EQ(a.pose, b.pose);
  EXPECT_EQ(a.heights, b.heights);
  EXPECT_EQ(a.report.energy, b.report.energy);
  EXPECT_EQ(a.mean_normal, b.mean_normal);
}

// Bad input: named errors before (or instead of) a step with them.
TEST(DemVehicle, RefusesWhatItCannotRun)
{
  const auto& bed = vehicleTemplate();
  auto ground = flatSand();
  auto refused = [&](const dem::DemSegmentSpec& spec, const std::string& key) {
    try
    {
      dem::DemVehicleSoil soil(bed, *ground, spec);
      ADD_FAILURE() << "accepted; expected an error naming " << key;
    }
    catch (const dem::DemParameterError& e)
    {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  auto s = segment();
  s.x_max = s.x_min + 1.25;  // not whole template lengths
  refused(s, "dem.segment.x_max");
  s = segment();
  s.patch_length = 1.25;
  refused(s, "dem.patch.length");
  s.patch_length = 2.4;  // longer than the 1.8 m segment
  refused(s, "dem.patch.length");
  s = segment();
  s.front_margin = 0.0;
  refused(s, "dem.patch.front_margin");
  s = segment();
  s.facets = 8;
  refused(s, "dem.patch.facets");

  // At the first step, against the vehicle: a patch too short for the tracer_x's 0.55 m
  // wheelbase; a vehicle started on the segment; a step that is not whole coupling intervals.
  const VehicleModel tracer = avsp::dynamics::loadVehicleModel(std::string(AVSP_VEHICLE_CONFIG_DIR) + "/tracer_x.yaml");
  auto first_step = [&](const dem::DemSegmentSpec& spec, double x, double step, const std::string& key) {
    auto g = flatSand();
    avsp::dynamics::WorldOptions o;
    o.step = step;
    World world(*g, o);
    const std::size_t v = world.addVehicle(tracer, world.restingPose(tracer, x, 0.0, 0.0, 0.01), "t");
    world.setExternalWheelSoil(v, std::make_shared<dem::DemVehicleSoil>(bed, *g, spec));
    try
    {
      world.advance(step);
      ADD_FAILURE() << "stepped; expected an error naming " << key;
    }
    catch (const std::exception& e)
    {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  s = segment();
  s.patch_length = 0.6;
  first_step(s, 0.0, 0.001, "dem.patch.length");
  first_step(segment(), 1.0, 0.001, "dem.segment.x_min");
  first_step(segment(), 0.55, 0.0015, "dem.coupling_interval");
}

// The `dem:` section (a scenario's, dynamics_node's ~dem): every key read, every bad value
// refused naming where and the key, before anything is settled.
TEST(DemVehicle, TheDemSectionIsReadAndCheckedKeyByKey)
{
  const dem::DemSoilSpec s = dem::parseDemSoilSpec(
      "segment: {x_min: 1.0, x_max: 2.8}\n"
      "patch: {length: 1.2, front_margin: 0.3, settle_time: 0.1, facets: 24, max_yaw_deg: 8}\n"
      "template: {length: 0.12, width: 0.3, depth: 0.1}\n"
      "particles: [{radius: 0.018, mass_fraction: 0.5}, {radius: 0.022, mass_fraction: 0.5}]\n"
      "youngs_modulus: 2.0e7\ntimestep: 2.0e-4\ncoupling_interval: 1.0e-3\nfriction: 0.45\nseed: 7\n",
      "s.yaml: dem");
  EXPECT_EQ(s.segment.x_min, 1.0);
  EXPECT_EQ(s.segment.x_max, 2.8);
  EXPECT_EQ(s.segment.patch_length, 1.2);
  EXPECT_EQ(s.segment.front_margin, 0.3);
  EXPECT_EQ(s.segment.settle_time, 0.1);
  EXPECT_EQ(s.segment.facets, 24);
  EXPECT_EQ(s.segment.max_yaw_deg, 8.0);
  EXPECT_EQ(s.template_width, 0.3);
  ASSERT_EQ(s.parameters.particles.size(), 2u);
  EXPECT_EQ(s.parameters.particles[1].radius, 0.022);
  EXPECT_EQ(s.parameters.youngs_modulus, 2.0e7);
  EXPECT_EQ(s.parameters.timestep, 2.0e-4);
  EXPECT_EQ(s.parameters.friction, 0.45);
  EXPECT_EQ(s.parameters.seed, 7u);
  // Everything else at its default.
  EXPECT_EQ(s.parameters.wall_friction, dem::DemParameters().wall_friction);

  const std::string base =
      "segment: {x_min: 1.0, x_max: 2.8}\npatch: {length: 1.2, front_margin: 0.3}\n"
      "particles: [{radius: 0.018, mass_fraction: 0.5}, {radius: 0.022, mass_fraction: 0.5}]\n"
      "youngs_modulus: 2.0e7\ncoupling_interval: 1.0e-3\n";
  auto refused = [](const std::string& text, const std::string& key) {
    try
    {
      dem::parseDemSoilSpec(text, "~dem");
      ADD_FAILURE() << "accepted; expected an error naming " << key << " in:\n" << text;
    }
    catch (const dem::DemParameterError& e)
    {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind("~dem", 0), 0u) << what;
      EXPECT_NE(what.find(key), std::string::npos) << what;
    }
  };
  refused(base + "timestep: 2.0e-4\nfrction: 0.4\n", "frction: unknown key");
  refused(base + "timestep: fast\n", "timestep: must be a finite number");
  refused("patch: {length: 1.2}\n", "segment: required");
  refused(base + "timestep: 2.0e-4\ntemplate: {width: 0.3, depth: 0.1, lenght: 0.12}\n", "template.lenght");
  // The DEM step above the Hertz contact's stability limit (0.23 ms for 18 mm particles).
  refused(base + "timestep: 5.0e-4\n", "dem.timestep");
  // A particle size <= 0.
  refused(
      "segment: {x_min: 1.0, x_max: 2.8}\npatch: {length: 1.2, front_margin: 0.3}\n"
      "particles: [{radius: 0.0, mass_fraction: 1.0}]\n",
      "dem.particles[0]");
  // A bed larger than the memory budget: two 1.2 m patches of 18-22 mm particles in 1 MB.
  refused(base + "timestep: 2.0e-4\nmemory_budget: 1.0e6\n", "dem.memory_budget");
  refused(base + "timestep: 2.0e-4\ntemplate: {length: 0.05}\n", "dem.template.length");
  // Faces round a rim outside [12, 100000]: refused, not clamped.
  refused(
      "segment: {x_min: 1.0, x_max: 2.8}\npatch: {length: 1.2, front_margin: 0.3, facets: 2000000}\n"
      "particles: [{radius: 0.018, mass_fraction: 1.0}]\ntimestep: 2.0e-4\n",
      "patch.facets: must be in [12, 100000]");
  refused("segment: {x_min: 1.0, x_max: 2.85}\n" + base.substr(base.find('\n') + 1) + "timestep: 2.0e-4\n",
          "dem.segment.x_max");
  refused("segment: [1, 2]\n", "segment: must be a mapping");
  refused("segment: {x_min: 1.0\n", "YAML");
}
