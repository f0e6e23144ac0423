// Prints what proxies (World::addProxy: the vehicles of other dynamics partitions) cost a
// partition per physics step (not a test): N vehicles (m113, mrzr, tracer_x, fed_alpha in turn)
// driving in lanes 6 m apart on flat sandy loam, with 0 proxies and with N proxies in lanes of
// their own beside them (placed every 10 ms, as the exchange does, never touching), and the
// cost of the soil exchange: takeChanges() and applyChanges() of the interval's changes.
// Usage: bench_proxies SOILS.yaml VEHICLES_DIR [seconds, default 3] [N ...] (default 16 32)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp;
using Clock = std::chrono::steady_clock;

namespace
{
struct Result
{
  double us_per_step = 0.0, collision_us = 0.0, take_us = 0.0, apply_us = 0.0, points = 0.0;
};

Result run(const terrain::SoilParameters& soil, const std::vector<dynamics::VehicleModel>& models, std::size_t n,
           bool proxies, double seconds)
{
  const double size = 400.0, res = 0.1;
  const std::size_t cells = static_cast<std::size_t>(size / res) + 1;
  const terrain::ElevationGrid grid(-0.5 * size, -0.5 * size, res, res, cells, cells,
                                    std::vector<float>(cells * cells, 0.f));
  terrain::DeformableTerrain ground(grid, soil, terrain::DeformableTerrain::Options{ true });
  // Where the "other partition" applies this one's changes.
  terrain::DeformableTerrain peer_ground(grid, soil, terrain::DeformableTerrain::Options{ true });
  dynamics::WorldOptions options;
  options.profile = true;
  dynamics::World world(ground, options);
  std::vector<Eigen::Isometry3d> proxy_poses;
  for (std::size_t k = 0; k < n; ++k)
  {
    const dynamics::VehicleModel& m = models[k % models.size()];
    const double y = -0.5 * size + 10.0 + 12.0 * static_cast<double>(k);
    world.addVehicle(m, world.restingPose(m, -150.0, y, 0.0, 0.01));
    world.setCommand(k, { 0.5, 0.0, 0.0 });
    if (proxies)
    {
      world.addProxy(m, "proxy" + std::to_string(k));
      proxy_poses.push_back(world.restingPose(m, -150.0, y + 6.0, 0.0));
    }
  }
  if (proxies)
    ground.setChangeTracking(true);
  const std::size_t steps = static_cast<std::size_t>(seconds / options.step);
  double take = 0.0, apply = 0.0, points = 0.0;
  std::size_t intervals = 0;
  const auto t0 = Clock::now();
  for (std::size_t s = 1; s <= steps; ++s)
  {
    world.step();
    if (proxies && s % 10 == 0)
    {
      for (std::size_t k = 0; k < n; ++k)
      {
        proxy_poses[k].translation().x() += 0.03;  // 3 m/s
        world.setProxyState(k, proxy_poses[k], Eigen::Vector3d(3.0, 0.0, 0.0), Eigen::Vector3d::Zero());
      }
      const auto a = Clock::now();
      const std::vector<terrain::PointChange> changes = ground.takeChanges();
      const auto b = Clock::now();
      peer_ground.applyChanges(changes);
      const auto c = Clock::now();
      take += std::chrono::duration<double>(b - a).count();
      apply += std::chrono::duration<double>(c - b).count();
      points += static_cast<double>(changes.size());
      ++intervals;
    }
  }
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  Result r;
  r.us_per_step = 1e6 * (wall - take - apply) / static_cast<double>(steps);
  r.collision_us = 1e6 * world.times().collision / static_cast<double>(world.times().steps);
  if (intervals > 0)
  {
    r.take_us = 1e6 * take / static_cast<double>(intervals);
    r.apply_us = 1e6 * apply / static_cast<double>(intervals);
    r.points = points / static_cast<double>(intervals);
  }
  return r;
}
}  // namespace

int main(int argc, char** argv)
{
  if (argc < 3)
  {
    std::fprintf(stderr, "usage: %s SOILS.yaml VEHICLES_DIR [seconds] [N ...]\n", argv[0]);
    return 2;
  }
  const double seconds = argc > 3 ? std::atof(argv[3]) : 3.0;
  std::vector<std::size_t> counts;
  for (int k = 4; k < argc; ++k)
    counts.push_back(static_cast<std::size_t>(std::atoi(argv[k])));
  if (counts.empty())
    counts = { 16, 32 };
  try
  {
    const terrain::SoilLibrary soils = terrain::SoilLibrary::load(argv[1]);
    std::vector<dynamics::VehicleModel> models;
    for (const char* name : { "m113", "mrzr", "tracer_x", "fed_alpha" })
      models.push_back(dynamics::loadVehicleModel(std::string(argv[2]) + "/" + name + ".yaml"));
    std::printf("Proxies and soil exchange, flat sandy loam, %g s at 1 ms steps, 10 ms intervals\n", seconds);
    std::printf(
        "| vehicles | proxies | us/step | of which collision | changed points/interval | takeChanges us | "
        "applyChanges us |\n|---:|---:|---:|---:|---:|---:|---:|\n");
    for (std::size_t n : counts)
      for (bool proxies : { false, true })
      {
        const Result r = run(soils.get("sandy_loam"), models, n, proxies, seconds);
        std::printf("| %zu | %zu | %.0f | %.0f | %.0f | %.1f | %.1f |\n", n, proxies ? n : 0, r.us_per_step,
                    r.collision_us, r.points, r.take_us, r.apply_us);
        std::fflush(stdout);
      }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_proxies: %s\n", e.what());
    return 1;
  }
  return 0;
}
