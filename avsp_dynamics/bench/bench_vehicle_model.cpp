// Prints how long loading and validating a vehicle description takes (start-up cost per vehicle).
// Usage: bench_vehicle_model <config/vehicles/x.yaml>...
#include <chrono>
#include <cstdio>

#include "avsp_dynamics/vehicle_model.hpp"

int main(int argc, char** argv)
{
  if (argc < 2)
  {
    std::fprintf(stderr, "usage: bench_vehicle_model CONFIG.yaml [CONFIG.yaml ...]\n");
    return 2;
  }
  for (int k = 1; k < argc; ++k)
  {
    try
    {
      const int reps = 50;
      const auto t0 = std::chrono::steady_clock::now();
      avsp::dynamics::VehicleModel m;
      for (int r = 0; r < reps; ++r)
        m = avsp::dynamics::loadVehicleModel(argv[k]);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%-10s %-10s %8.1f kg %3zu bodies: %.2f ms per load+validate\n", m.model.c_str(),
                  avsp::dynamics::toString(m.drive_type), m.total_mass, m.bodies.size(), 1e3 * s / reps);
    }
    catch (const avsp::dynamics::ConfigError& e)
    {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
  }
  return 0;
}
