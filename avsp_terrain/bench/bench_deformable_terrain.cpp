// Prints the soil-contact figures of the terrain issue:
//  - one wheel patch update (about 0.3 m x 0.4 m at 0.05 m cells), and a 4-wheel vehicle step;
//  - bytes per deformed point and state growth over a simulated traverse at 0.1 m cells;
//  - bilinear height queries per second on the deformable terrain.
// Usage: bench_deformable_terrain SOILS.yaml [traverse_km, default 1]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "avsp_terrain/deformable_terrain.hpp"

using namespace avsp::terrain;
using Clock = std::chrono::steady_clock;

namespace
{
double rssMegabytes()
{
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return pages_resident * 4096.0 / 1e6;
}

WheelPatch wheel(double x, double y, double sink, double speed)
{
  WheelPatch w;
  w.radius = 0.35;
  w.width = 0.3;
  w.centre = Eigen::Vector3d(x, y, w.radius - sink);
  w.velocity = Eigen::Vector3d(speed, 0, 0);
  w.spin_rate = 1.1 * speed / w.radius;
  return w;
}
}  // namespace

int main(int argc, char** argv)
{
  if (argc < 2)
  {
    std::fprintf(stderr, "usage: bench_deformable_terrain SOILS.yaml [traverse_km]\n");
    return 2;
  }
  const double km = argc > 2 ? std::atof(argv[2]) : 1.0;
  const SoilLibrary soils = SoilLibrary::load(argv[1]);

  {  // Patch update cost at 0.05 m cells.
    const std::size_t n = 400;
    const auto fresh = [&] {
      return DeformableTerrain(ElevationGrid(0, 0, 0.05, 0.05, n, n, std::vector<float>(n * n, 0.f)),
                               soils.get("sandy_loam"), DeformableTerrain::Options{ true });
    };
    const int steps = 20000;
    {
      DeformableTerrain t = fresh();
      int points = 0;
      const auto t0 = Clock::now();
      for (int k = 0; k < steps; ++k)
        points += t.wheelContact(wheel(2.0 + 1e-4 * k, 10.0, 0.02, 1.0), 0.001, true).contact_points;
      const double us = 1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / steps;
      std::printf("wheel patch update (0.30 m wide, 0.05 m cells, %.1f loaded points): %.2f us  (target <= 5 us)\n",
                  double(points) / steps, us);
    }
    {
      // A 4-wheel vehicle (track 1.9 m, wheelbase 3.3 m) creeping along x: four contacts per step.
      DeformableTerrain t = fresh();
      const auto t0 = Clock::now();
      for (int k = 0; k < steps; ++k)
        for (const double dxw : { 1.65, -1.65 })
          for (const double dyw : { 0.95, -0.95 })
            t.wheelContact(wheel(4.0 + 1e-4 * k + dxw, 10.0 + dyw, 0.02, 1.0), 0.001, true);
      const double us = 1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / steps;
      std::printf("4-wheel vehicle step: %.2f us  (target <= 20 us)\n", us);
    }
  }

  {  // Traverse at 0.1 m cells: a 4-wheel vehicle (track 1.9 m, wheelbase 3.3 m) driving along x.
    const double length_m = 1000.0 * km;
    // Lanes 5 m apart: a traverse longer than 2 km continues on a fresh parallel lane.
    const std::size_t lanes = static_cast<std::size_t>(std::ceil(length_m / 2000.0));
    const std::size_t cols = static_cast<std::size_t>(std::min(length_m, 2000.0) / 0.1) + 50, rows = 50 * lanes + 60;
    DeformableTerrain t(ElevationGrid(0, 0, 0.1, 0.1, cols, rows, std::vector<float>(cols * rows, 0.f)),
                        soils.get("sandy_loam"), DeformableTerrain::Options{ true });
    const double rss0 = rssMegabytes();
    const double span = (cols - 40) * 0.1;  // wrap onto parallel lanes when longer than the grid
    double driven = 0.0;
    int lane = 0;
    const auto t0 = Clock::now();
    while (driven < length_m)
    {
      const double x = 2.0 + std::fmod(driven, span);
      lane = static_cast<int>(driven / span);
      const double y = 2.5 + 5.0 * lane;
      for (const double dxw : { 1.65, -1.65 })
        for (const double dyw : { 0.95, -0.95 })
          t.wheelContact(wheel(x + dxw, y + 2.0 + dyw, 0.03, 2.0), 0.05, true);
      driven += 0.1;
    }
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    std::printf("traverse %.1f km at 0.1 m cells (%.1f s): %zu deformed points, %.2f MB of state, %.1f B per deformed "
                "point (peer: 165 B; target <= 33 B), RSS growth %.1f MB; fixed tile directory %.2f MB\n",
                km, s, t.deformedPoints(), t.deformationBytes() / 1e6,
                double(t.deformationBytes()) / std::max<std::size_t>(t.deformedPoints(), 1), rssMegabytes() - rss0,
                t.directoryBytes() / 1e6);
  }

  {  // Height queries on deformed terrain.
    const std::size_t n = 2000;
    DeformableTerrain t(ElevationGrid(0, 0, 0.1, 0.1, n, n, std::vector<float>(n * n, 0.f)), soils.get("clay"),
                        DeformableTerrain::Options{ true });
    for (int k = 0; k < 2000; ++k)
      t.wheelContact(wheel(10.0 + 0.05 * k, 100.0, 0.03, 1.0), 0.05, true);
    // Positions drawn before timing, so the figure is the query alone: random over the
    // whole 200 m x 200 m grid (cache-missing), and local to a 10 m x 10 m window around the
    // rut (how wheels and sensor rays query).
    std::mt19937 rng(1);
    const int q = 4000000;
    for (const double window : { 199.0, 10.0 })
    {
      std::uniform_real_distribution<double> pos_x(window < 100 ? 95.0 : 0.0, window < 100 ? 95.0 + window : window);
      std::uniform_real_distribution<double> pos_y(window < 100 ? 95.0 : 0.0, window < 100 ? 95.0 + window : window);
      std::vector<double> xs(q), ys(q);
      for (int k = 0; k < q; ++k)
      {
        xs[k] = pos_x(rng);
        ys[k] = pos_y(rng);
      }
      double sum = 0.0;
      const auto t0 = Clock::now();
      for (int k = 0; k < q; ++k)
        sum += *t.height(xs[k], ys[k]);
      const double s = std::chrono::duration<double>(Clock::now() - t0).count();
      std::printf("deformable terrain height queries, %s: %.1f M/s per core (target >= 20 M/s; checksum %.3f)\n",
                  window < 100 ? "local 10 m window over the rut" : "random over 200 m x 200 m", q / s / 1e6, sum);
    }
  }
  return 0;
}
