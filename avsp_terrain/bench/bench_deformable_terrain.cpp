// Prints the soil-contact figures of the terrain issue:
//  - one wheel patch update (about 0.3 m x 0.4 m at 0.05 m cells; simple and Bekker soil), a
//    4-wheel vehicle step, a track segment step and a whole track patch step: thread CPU time
//    per step, best and median of 5 runs on fresh terrain (the machines are shared);
//  - bytes per deformed point and state growth over a simulated traverse at 0.1 m cells;
//  - bilinear height queries per second on the deformable terrain.
// Usage: bench_deformable_terrain SOILS.yaml [traverse_km, default 1]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <time.h>

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

/// CPU time of this thread, s: on a shared, busy machine wall time also counts other
/// processes' turns; this does not.
double cpuSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

constexpr int kRepeats = 5;

struct Timing
{
  double best, median;  ///< us per step over kRepeats runs
};

/// Runs step(terrain, k) for k = 0 .. steps - 1 on a fresh terrain from make(), kRepeats times.
template <class Make, class Step>
Timing timeSteps(Make make, Step step, int steps)
{
  std::vector<double> us;
  for (int r = 0; r < kRepeats; ++r)
  {
    DeformableTerrain t = make();
    const double t0 = cpuSeconds();
    for (int k = 0; k < steps; ++k)
      step(t, k);
    us.push_back(1e6 * (cpuSeconds() - t0) / steps);
  }
  std::sort(us.begin(), us.end());
  return { us.front(), us[us.size() / 2] };
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

/// Patch update cost at 0.05 m cells, each figure on fresh terrain, best and median of 5.
void benchPatchUpdates(const SoilLibrary& soils)
{
  const std::size_t n = 400;
  const auto fresh = [&](const char* soil) {
    return DeformableTerrain(ElevationGrid(0, 0, 0.05, 0.05, n, n, std::vector<float>(n * n, 0.f)), soils.get(soil),
                             DeformableTerrain::Options{ true });
  };
  const int steps = 20000;
  for (const char* soil : { "sandy_loam", "dry_sand" })
  {
    int points = 0;
    const Timing t = timeSteps([&] { return fresh(soil); },
                               [&](DeformableTerrain& t, int k) {
                                 points +=
                                     t.wheelContact(wheel(2.0 + 1e-4 * k, 10.0, 0.02, 1.0), 0.001, true).contact_points;
                               },
                               steps);
    std::printf(
        "wheel patch update, %s (%s; 0.70 m x 0.30 m footprint, 0.05 m cells, %.1f loaded points): "
        "%.2f us, median %.2f us  (target <= 5 us)\n",
        soil, soils.get(soil).model == SinkageModel::kBekker ? "Bekker" : "simple", double(points) / (kRepeats * steps),
        t.best, t.median);
  }
  {
    // A 4-wheel vehicle (track 1.9 m, wheelbase 3.3 m) creeping along x: four contacts per step.
    const Timing t = timeSteps([&] { return fresh("sandy_loam"); },
                               [&](DeformableTerrain& t, int k) {
                                 for (const double dxw : { 1.65, -1.65 })
                                   for (const double dyw : { 0.95, -0.95 })
                                     t.wheelContact(wheel(4.0 + 1e-4 * k + dxw, 10.0 + dyw, 0.02, 1.0), 0.001, true);
                               },
                               steps);
    std::printf("4-wheel vehicle step: %.2f us, median %.2f us  (target <= 20 us)\n", t.best, t.median);
  }
  for (const bool segment : { true, false })
  {
    // An M113-class track (2.67 m x 0.38 m ground contact, 10-tooth sprocket, 0.152 m
    // pitch) at 10 % slip: one of its six road-wheel segments, or the whole contact as one patch.
    TrackPatch track;
    track.width = 0.38;
    track.track_length = 2.67;
    track.length = segment ? 2.67 / 6 : 2.67;
    track.segment_offset = segment ? 0.5 * (2.67 - track.length) : 0.0;
    track.sprocket_pitch = 0.152;
    track.sprocket_teeth = 10;
    track.velocity = Eigen::Vector3d(1.0, 0, 0);
    track.sprocket_spin_rate = 1.0 / 0.9 * 2.0 * M_PI / (0.152 * 10);
    int points = 0;
    const Timing t = timeSteps([&] { return fresh("sandy_loam"); },
                               [&](DeformableTerrain& t, int k) {
                                 track.centre = Eigen::Vector3d(4.0 + 1e-4 * k + track.segment_offset, 10.0, -0.02);
                                 points += t.trackContact(track, 0.001, true).contact_points;
                               },
                               steps);
    std::printf("%s (%.2f m x 0.38 m, 0.05 m cells, %.1f loaded points): %.2f us, median %.2f us\n",
                segment ? "track segment step, one road-wheel station" : "whole track patch step", track.length,
                double(points) / (kRepeats * steps), t.best, t.median);
  }
}

/// Traverse at 0.1 m cells: a 4-wheel vehicle (track 1.9 m, wheelbase 3.3 m) driving along x.
void benchTraverse(const SoilLibrary& soils, double km)
{
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
  std::printf(
      "traverse %.1f km at 0.1 m cells (%.1f s): %zu deformed points, %.2f MB of state, %.1f B per deformed "
      "point (peer: 165 B; target <= 33 B), RSS growth %.1f MB; fixed tile directory %.2f MB, soil map "
      "%.2f MB (1 B per grid point with several soils, 0 with one)\n",
      km, s, t.deformedPoints(), t.deformationBytes() / 1e6,
      double(t.deformationBytes()) / std::max<std::size_t>(t.deformedPoints(), 1), rssMegabytes() - rss0,
      t.directoryBytes() / 1e6, t.soilMapBytes() / 1e6);
}

/// Height queries on deformed terrain.
void benchHeightQueries(const SoilLibrary& soils)
{
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

  benchPatchUpdates(soils);
  benchTraverse(soils, km);
  benchHeightQueries(soils);
  return 0;
}
