// bench_dem: cost of the DEM soil. For one wheel and for a vehicle's wheels (one bed under each,
// as the moving patch will hold them): particles, DEM steps per second of wall time, and
// simulated seconds per wall hour, with the wheel rolling at 1 m/s and slip 0.2.
//
//   bench_dem [VEHICLE.yaml] [seconds] [radius_scale] [patch_length patch_width patch_depth]
//   bench_dem --crossing VEHICLE.yaml SOILS.yaml
//
// --crossing: the vehicle on DemVehicleSoil (the contact mode dynamics_node runs) over a 1.8 m
// segment of flat dry sand at half throttle, the test beds' coarse particles (18-22 mm, 0.2 ms
// step, a 1.2 m patch per side 0.3 m wide): wall time per sim second over the crossing.
//
// seconds: simulated time measured per bed after the wheel is set down (default 0.05);
// radius_scale multiplies the default particle radii (10, 12.5, 15 mm); the patch defaults to
// 2 x 1 x 0.3 m per wheel (issue 25). The template block is 0.25 m long.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/dem/dem_vehicle_soil.hpp"
#include "avsp_dynamics/dem/wheel_rig.hpp"
#include "avsp_dynamics/vehicle_sim.hpp"
#include "avsp_dynamics/vehicle_model.hpp"

namespace dem = avsp::dynamics::dem;

namespace
{
struct Cost
{
  std::size_t particles = 0;
  double wall_per_sim_second = 0.0;  // s of wall time per s of DEM time
  double steps_per_second = 0.0;
};

double now()
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

Cost oneWheel(const dem::BedTemplate& bed, double length, double radius, double width, double load, double seconds)
{
  const int blocks = static_cast<int>(std::lround(length / bed.length()));
  dem::DemDomain d{ 0.0, blocks * bed.length(), 0.0, bed.width(), 0.0, bed.depth() + 2.5 * radius + 0.1 };
  dem::DemWorld world(bed.parameters(), d, bed);
  world.addBed(
      0.0, blocks * bed.length(), [&](double, double) { return bed.depth(); }, true, true);
  world.setBedEnds(0.0, blocks * bed.length());
  world.settle(0.1);
  dem::WheelRigSpec spec;
  spec.radius = radius;
  spec.width = width;
  spec.load = load;
  dem::SingleWheelRig rig(world, spec, radius + 0.05);
  rig.setSpinRate(1.0 / radius);
  rig.setCarriageSpeed(0.8);
  const int intervals = std::max(1, static_cast<int>(std::lround(seconds / bed.parameters().coupling_interval)));
  const double t0 = now();
  for (int k = 0; k < intervals; ++k)
    rig.step();
  const double wall = now() - t0;
  Cost c;
  c.particles = world.particleCount();
  const double sim = intervals * bed.parameters().coupling_interval;
  c.wall_per_sim_second = wall / sim;
  c.steps_per_second = sim / bed.parameters().timestep / wall;
  return c;
}

void print(const char* what, std::size_t particles, double wall_per_sim_second, double timestep)
{
  std::printf("%-28s %9zu particles  %8.1f DEM steps/s  %8.2f sim s per wall hour  (%.0f x slower than real time)\n",
              what, particles, 1.0 / (wall_per_sim_second * timestep), 3600.0 / wall_per_sim_second,
              wall_per_sim_second);
}
/// The crossing of --crossing; returns 0 or 1.
int crossing(const std::string& vehicle, const std::string& soils)
{
  dem::DemParameters p;
  p.particles = { { 0.018, 0.5 }, { 0.022, 0.5 } };
  p.youngs_modulus = 2.0e7;
  p.timestep = 2.0e-4;
  double t0 = now();
  const auto bed = dem::BedTemplate::settle(p, 0.12, 0.3, 0.1);
  std::printf("template 0.12 x 0.30 x 0.10 m: %zu particles, settled in %.1f s wall\n", bed.particles().size(),
              now() - t0);
  const auto model = avsp::dynamics::loadVehicleModel(vehicle);
  const std::size_t nx = 241, ny = 81;
  avsp::terrain::DeformableTerrain ground(
      avsp::terrain::ElevationGrid(-1.0, -1.0, 0.025, 0.025, nx, ny, std::vector<float>(nx * ny, 0.0f)),
      avsp::terrain::SoilLibrary::load(soils).get("dry_sand"), avsp::terrain::DeformableTerrain::Options{ true });
  avsp::dynamics::World world(ground);
  // Front wheels 0.3 m before the segment's start.
  double front = 0.0;
  for (const auto& w : model.wheels)
    front = std::max(front, w.rest_position.x() + w.radius);
  const double x_min = 1.0;
  const std::size_t v = world.addVehicle(model, world.restingPose(model, x_min - 0.3 - front, 0.0, 0.0, 0.01), "v");
  dem::DemSegmentSpec seg;
  seg.x_min = x_min;
  seg.x_max = x_min + 15 * 0.12;
  seg.patch_length = 1.2;
  seg.front_margin = 0.3;
  auto soil = std::make_shared<dem::DemVehicleSoil>(bed, ground, seg);
  world.setExternalWheelSoil(v, soil);
  avsp::dynamics::DriveCommand c;
  c.throttle = 0.5;
  double wall_on = 0.0, sim_on = 0.0;
  while (!soil->report().crossed && world.time() < 20.0)
  {
    const auto& pose = world.state(v).pose;
    c.steering = std::clamp(
        -(4.0 * pose.translation().y() + 2.0 * std::atan2(pose.rotation()(1, 0), pose.rotation()(0, 0))), -1.0, 1.0);
    world.setCommand(v, c);
    const bool on = soil->activePatches() > 0;
    t0 = now();
    world.advance(world.options().step);
    if (on)
    {
      wall_on += now() - t0;
      sim_on += world.options().step;
    }
  }
  const auto& r = soil->report();
  std::printf(
      "%s crossing 1.8 m of DEM: %s at %.2f s, %d patch moves, peak %zu particles, %.2f s of sim time on "
      "the DEM in %.1f s wall\n",
      model.model.c_str(), r.crossed ? "crossed" : "NOT crossed", world.time(), r.relocations, r.peak_particles, sim_on,
      wall_on);
  if (sim_on > 0.0)
    print((model.model + " on the DEM").c_str(), r.peak_particles, wall_on / sim_on, p.timestep);
  return r.crossed ? 0 : 1;
}
}  // namespace

int main(int argc, char** argv)
{
  if (argc > 1 && std::string(argv[1]) == "--crossing")
  {
    if (argc < 4)
    {
      std::fprintf(stderr, "usage: bench_dem --crossing VEHICLE.yaml SOILS.yaml\n");
      return 2;
    }
    try
    {
      return crossing(argv[2], argv[3]);
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "bench_dem: %s\n", e.what());
      return 1;
    }
  }
  const std::string vehicle = argc > 1 ? argv[1] : "";
  const double seconds = argc > 2 ? std::atof(argv[2]) : 0.05;
  const double scale = argc > 3 ? std::atof(argv[3]) : 1.0;
  const double length = argc > 4 ? std::atof(argv[4]) : 2.0;
  const double width = argc > 5 ? std::atof(argv[5]) : 1.0;
  const double depth = argc > 6 ? std::atof(argv[6]) : 0.3;
  try
  {
    dem::DemParameters p;
    for (auto& c : p.particles)
      c.radius *= scale;
    p.timestep *= scale;  // the stability limit scales with the radius
    dem::validate(p);
    const double t0 = now();
    const auto bed = dem::BedTemplate::settle(p, 0.25, width, depth);
    std::printf("template 0.25 x %.2f x %.2f m: %zu particles, packing %.3f, settled in %.2f s DEM, %.1f s wall\n",
                width, depth, bed.particles().size(), bed.packing(), bed.settleTime(), now() - t0);
    const Cost one = oneWheel(bed, length, 0.4, 0.3, 2500.0, seconds);
    print("one wheel (r 0.4, b 0.3 m)", one.particles, one.wall_per_sim_second, p.timestep);
    if (!vehicle.empty())
    {
      const auto model = avsp::dynamics::loadVehicleModel(vehicle);
      std::size_t particles = 0;
      double wall = 0.0;
      for (const auto& w : model.wheels)
      {
        const Cost c = oneWheel(bed, length, w.radius, std::min(w.width, 0.8 * width),
                                model.total_mass * 9.81 / model.wheels.size(), seconds);
        particles += c.particles;
        wall += c.wall_per_sim_second;  // the beds run one after the other on one core
      }
      print((model.model + " (" + std::to_string(model.wheels.size()) + " wheels)").c_str(), particles, wall,
            p.timestep);
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_dem: %s\n", e.what());
    return 1;
  }
  return 0;
}
