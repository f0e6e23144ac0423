// bench_dem: cost of the DEM soil. For one wheel and for a vehicle's wheels (one bed under each,
// as the moving patch will hold them): particles, DEM steps per second of wall time, and
// simulated seconds per wall hour, with the wheel rolling at 1 m/s and slip 0.2.
//
//   bench_dem [VEHICLE.yaml] [seconds] [radius_scale] [patch_length patch_width patch_depth]
//
// seconds: simulated time measured per bed after the wheel is set down (default 0.05);
// radius_scale multiplies the default particle radii (10, 12.5, 15 mm); the patch defaults to
// 2 x 1 x 0.3 m per wheel (issue 25). The template block is 0.25 m long.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "avsp_dynamics/dem/wheel_rig.hpp"
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
}  // namespace

int main(int argc, char** argv)
{
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
