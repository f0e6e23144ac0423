// Prints ray-casting throughput on the default course (600 m x 400 m at 0.1 m, ~1090
// objects) with 1 and 2 threads: lidar-like fans (64 channels from +2 to -24.8 deg, full
// circle) from sensor positions 2 m above the ground all over the course, max range 120 m.
// Also: height-field build time and memory, and the cost of refreshing the mips under a rut.
// The target is >= 5 M rays/s per core. Figures are printed, not asserted. The process CPU time
// per cast is printed too: on a loaded machine it is the better measure of the work per core.
//
// Usage: bench_raycast [positions, default 24] [azimuth steps per position, default 1024]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <vector>

#include "avsp_sensors/scene.hpp"
#include "avsp_terrain/default_course.hpp"

using namespace avsp::sensors;
using Clock = std::chrono::steady_clock;

namespace
{
double seconds(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
}  // namespace

int main(int argc, char** argv)
{
  const int positions = argc > 1 ? std::atoi(argv[1]) : 24;
  const int azimuths = argc > 2 ? std::atoi(argv[2]) : 1024;
  auto t0 = Clock::now();
  const avsp::terrain::Course course = avsp::terrain::makeDefaultCourse(avsp::terrain::CourseOptions());
  std::printf("default course built in %.1f s: %zu x %zu points, %zu objects\n", seconds(t0), course.heights.columns(),
              course.heights.rows(), course.objects.size());
  t0 = Clock::now();
  Scene scene(HeightField::fromGrid(course.heights));
  const double build_s = seconds(t0);
  t0 = Clock::now();
  scene.setObjects(course.objects);
  std::printf("height field + max mips: %.2f s, %.0f MB (%zu mip levels); object BVH: %.2f ms, %zu primitives\n",
              build_s, scene.terrain().bytes() / 1e6, scene.terrain().mipLevels(), 1e3 * seconds(t0),
              scene.staticPrimitives().size());

  // A rut arriving: 3 m x 0.5 m of points lowered by 5 cm, mips refreshed above it only.
  {
    const std::size_t i0 = 3000, j0 = 2000, w = 31, h = 6;
    std::vector<float> patch(w * h);
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c)
        patch[r * w + c] = static_cast<float>(scene.terrain().pointHeight(i0 + c, j0 + r) - 0.05);
    const int reps = 2000;
    t0 = Clock::now();
    for (int k = 0; k < reps; ++k)
      scene.terrain().setHeights(i0, j0, w, h, patch);
    std::printf("rut patch 31 x 6 points: %.1f us per refresh (heights + all mip levels above it)\n",
                1e6 * seconds(t0) / reps);
  }

  // Sensor positions: a seeded spread over the course, 2 m above the ground there.
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> ux(20.0, 580.0), uy(20.0, 380.0);
  std::vector<Ray> rays;
  rays.reserve(static_cast<std::size_t>(positions) * azimuths * 64);
  for (int p = 0; p < positions; ++p)
  {
    const double x = ux(rng), y = uy(rng);
    double z = 0.0;
    scene.terrain().heightAt(x, y, z);
    const Eigen::Vector3d o(x, y, z + 2.0);
    for (int a = 0; a < azimuths; ++a)
    {
      const double az = 2.0 * M_PI * a / azimuths;
      for (int c = 0; c < 64; ++c)
      {
        const double el = (2.0 - 26.8 * c / 63.0) * M_PI / 180.0;
        Ray r;
        r.origin = o;
        r.direction = Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        r.max_range = 120.0;
        rays.push_back(r);
      }
    }
  }
  std::vector<RayHit> hits;
  for (unsigned threads : { 1u, 2u })
  {
    double best = 1e300, best_cpu = 1e300;
    for (int rep = 0; rep < 3; ++rep)  // best of 3: the machine is shared
    {
      t0 = Clock::now();
      const std::clock_t c0 = std::clock();
      scene.cast(rays, hits, threads);
      best = std::min(best, seconds(t0));
      best_cpu = std::min(best_cpu, static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
    }
    std::size_t terrain = 0, objects = 0, none = 0;
    double range_sum = 0.0;
    for (const RayHit& h : hits)
    {
      terrain += h.kind == HitKind::kTerrain;
      objects += h.kind == HitKind::kObject;
      none += h.kind == HitKind::kNone;
      if (h.hit())
        range_sum += h.range;
    }
    std::printf(
        "%u thread%s: %zu rays in %.3f s = %.2f M rays/s (%.2f M/s per thread); hits: %.1f%% terrain, "
        "%.1f%% objects, %.1f%% none; mean hit range %.1f m; CPU %.3f s (all threads) = %.2f M rays per "
        "CPU-second\n",
        threads, threads > 1 ? "s" : "", rays.size(), best, rays.size() / best / 1e6,
        rays.size() / best / 1e6 / threads, 100.0 * terrain / hits.size(), 100.0 * objects / hits.size(),
        100.0 * none / hits.size(), range_sum / std::max<std::size_t>(1, terrain + objects), best_cpu,
        rays.size() / best_cpu / 1e6);
  }
  return 0;
}
