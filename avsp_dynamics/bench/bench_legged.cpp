// Prints a legged vehicle's figures (not a test): real-time factor of one robot standing on a
// flat soil at a 1 ms physics step on one core, and microseconds per step split into ODE step,
// soil contact and the rest (issue 24's target: >= 5x real time alone; it stands, no gait yet).
// Usage: bench_legged SOILS.yaml VEHICLE.yaml [seconds, default 60] [soil ..., default gravel
// dry_sand asphalt]. The terrain: 10 m x 10 m at 0.02 m cells (a 6 cm foot pad covers 3 x 3).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv)
{
  if (argc < 3)
  {
    std::fprintf(stderr, "usage: %s SOILS.yaml VEHICLE.yaml [seconds] [soil ...]\n", argv[0]);
    return 2;
  }
  try
  {
    const terrain::SoilLibrary soils = terrain::SoilLibrary::load(argv[1]);
    const dynamics::VehicleModel model = dynamics::loadVehicleModel(argv[2]);
    const double seconds = argc > 3 ? std::atof(argv[3]) : 60.0;
    if (!(seconds > 0.0))
    {
      std::fprintf(stderr, "bench_legged: seconds must be > 0, got '%s'\n", argv[3]);
      return 2;
    }
    std::vector<std::string> names;
    for (int k = 4; k < argc; ++k)
      names.push_back(argv[k]);
    if (names.empty())
      names = { "gravel", "dry_sand", "asphalt" };
    std::printf("%s (%zu legs, %.1f kg) standing, 1 ms step, %.0f s sim each\n", model.model.c_str(), model.legs.size(),
                model.total_mass, seconds);
    std::printf("%-10s %8s %8s %8s %8s %8s\n", "soil", "rtf", "us/step", "ode", "contact", "other");
    for (const std::string& name : names)
    {
      const double res = 0.02, size = 10.0;
      const std::size_t n = static_cast<std::size_t>(std::lround(size / res)) + 1;
      terrain::DeformableTerrain ground(
          terrain::ElevationGrid(-0.5 * size, -0.5 * size, res, res, n, n, std::vector<float>(n * n, 0.f)),
          soils.get(name), terrain::DeformableTerrain::Options{ true });
      dynamics::WorldOptions options;
      options.profile = true;
      dynamics::World world(ground, options);
      const std::size_t id = world.addVehicle(model, world.restingPose(model, 0.0, 0.0, 0.0));
      const auto start = Clock::now();
      world.advance(seconds);
      const double wall = std::chrono::duration<double>(Clock::now() - start).count();
      const dynamics::StepTimes& t = world.times();
      const double per = 1e6 / static_cast<double>(t.steps);
      std::printf("%-10s %7.1fx %8.1f %8.1f %8.1f %8.1f%s\n", name.c_str(), seconds / wall, 1e6 * wall / t.steps,
                  per * t.ode, per * t.contact, per * t.other, world.state(id).fallen ? "  (fallen)" : "");
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_legged: %s\n", e.what());
    return 1;
  }
  return 0;
}
