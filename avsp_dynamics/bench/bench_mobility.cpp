// Prints the mobility matrix (not a test; test_mobility_matrix asserts the same cases): each
// case of config/mobility_matrix.yaml run through the World, AVSP's figure beside its reference
// (closed form or public figure), the error and PASS/FAIL, as the markdown table docs/
// mobility_matrix.md keeps; then the wall time of the whole matrix.
// Usage: bench_mobility MATRIX.yaml VEHICLE_DIR SOILS.yaml [id-substring ...]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "avsp_dynamics/mobility.hpp"

using namespace avsp::dynamics;

int main(int argc, char** argv)
{
  if (argc < 4)
  {
    std::fprintf(stderr, "usage: %s MATRIX.yaml VEHICLE_DIR SOILS.yaml [id-substring ...]\n", argv[0]);
    return 2;
  }
  try
  {
    const std::vector<mobility::Case> cases = mobility::loadMatrix(argv[1]);
    const mobility::Setup setup{ argv[2], argv[3] };
    std::vector<std::string> filters(argv + 4, argv + argc);
    std::printf("| case | vehicle | surface | manoeuvre | AVSP | reference | error | criterion | result | source |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
    int passed = 0, failed = 0;
    double wall = 0.0;
    for (const mobility::Case& c : cases)
    {
      bool chosen = filters.empty();
      for (const std::string& f : filters)
        chosen = chosen || c.id.find(f) != std::string::npos;
      if (!chosen)
        continue;
      const mobility::Result r = mobility::run(c, setup);
      wall += r.wall;
      const bool relative = (c.check == mobility::Check::kClosedForm && std::isnan(c.tolerance_abs)) ||
                            c.check == mobility::Check::kPublic;
      char error[32];
      if (relative)
        std::snprintf(error, sizeof error, "%+.1f %%", 100.0 * r.error);
      else
        std::snprintf(error, sizeof error, "%+.3g", r.error);
      char reference[64];
      if (std::isnan(r.reference_low))
        std::snprintf(reference, sizeof reference, "%.4g", r.reference);
      else
        std::snprintf(reference, sizeof reference, "%.4g-%.4g", r.reference_low, r.reference);
      std::printf("| %s | %s | %s | %s | %.4g %s | %s | %s | %s | %s | %s%s%s |\n", c.id.c_str(), c.vehicle.c_str(),
                  c.soil.c_str(), c.manoeuvre.c_str(), r.value, c.unit.c_str(), reference, error,
                  mobility::criterion(c).c_str(), r.pass ? "PASS" : "FAIL", c.source.c_str(),
                  r.detail.empty() ? "" : "; ", r.detail.c_str());
      std::fflush(stdout);
      (r.pass ? passed : failed)++;
    }
    std::printf("\n%d cases: %d PASS, %d FAIL; %.1f s wall\n", passed + failed, passed, failed, wall);
    return failed == 0 ? 0 : 1;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_mobility: %s\n", e.what());
    return 2;
  }
}
