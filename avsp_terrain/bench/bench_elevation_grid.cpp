// Prints the cost of height queries on a grid of the given size (default 2000 x 2000 at 0.1 m).
// Usage: bench_elevation_grid [points_per_side] [queries]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "avsp_terrain/elevation_grid.hpp"

int main(int argc, char** argv)
{
  const std::size_t n = argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 2000;
  const std::size_t queries = argc > 2 ? std::strtoul(argv[2], nullptr, 10) : 4000000;
  if (n < 2 || queries == 0)
  {
    std::fprintf(stderr, "bench_elevation_grid: points_per_side must be >= 2 and queries > 0\n");
    return 2;
  }
  const double d = 0.1;
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(std::sin(0.01 * i) * std::cos(0.013 * j) * 5.0);
  const avsp::terrain::ElevationGrid grid(0, 0, d, d, n, n, std::move(h));
  // Positions drawn before timing so that the figure is the query alone.
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> pos(0.0, (n - 1) * d);
  std::vector<double> xs(queries), ys(queries);
  for (std::size_t k = 0; k < queries; ++k)
  {
    xs[k] = pos(rng);
    ys[k] = pos(rng);
  }
  double sum = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t k = 0; k < queries; ++k)
    sum += *grid.height(xs[k], ys[k]);
  const auto t1 = std::chrono::steady_clock::now();
  const double s = std::chrono::duration<double>(t1 - t0).count();
  std::printf("grid %zu x %zu points, %zu random bilinear height queries: %.1f ns/query, %.1f M/s per core "
              "(checksum %.3f)\n", n, n, queries, 1e9 * s / queries, queries / s / 1e6, sum);
  std::printf("base height storage: %.1f MB (%zu B per point)\n", n * n * sizeof(float) / 1e6, sizeof(float));
  return 0;
}
