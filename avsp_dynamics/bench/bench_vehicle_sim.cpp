// Prints the vehicle simulation's figures (not a test): real-time factor at a 1 ms physics step
// of one vehicle (or a team in one world) driving on deformable soil, and microseconds per
// step split into ODE step, soil contact, collision and the rest; the terrain
// update is the contact's extra cost with deformation on over the same run with it off. Then
// the cost of obstacle collision: the first vehicle on the default course (avsp_terrain) with
// none of its objects as obstacles, with all of them, and driving into its woods.
// Usage: bench_vehicle_sim SOILS.yaml VEHICLE.yaml[,VEHICLE.yaml...] [seconds, default 60] [soil ...]
// (wheeled or tracked; several comma-separated vehicles drive side by side, 10 m apart).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <avsp_terrain/default_course.hpp>
#include <avsp_terrain/deformable_terrain.hpp>
#include <avsp_terrain/soil.hpp>

#include "avsp_dynamics/vehicle_sim.hpp"

using namespace avsp;
using Clock = std::chrono::steady_clock;

namespace
{
struct Run
{
  double wall = 0.0;      ///< s
  double sim = 0.0;       ///< s
  double distance = 0.0;  ///< m
  double max_rut = 0.0;   ///< m, deepest sinkage seen
  dynamics::StepTimes times;
};

/// The vehicles on a flat 200 m x 200 m terrain at 0.1 m cells (the founding report's site
/// resolution), each holding 5 m/s (or 80 % of its top speed if lower) with a slowly swinging
/// steering so they keep to fresh soil.
Run drive(const terrain::SoilParameters& soil, const std::vector<dynamics::VehicleModel>& models, double seconds,
          const dynamics::WorldOptions& options)
{
  const double size = 200.0, res = 0.1;
  const std::size_t n = static_cast<std::size_t>(size / res) + 1;
  terrain::DeformableTerrain ground(
      terrain::ElevationGrid(-0.5 * size, -0.5 * size, res, res, n, n, std::vector<float>(n * n, 0.f)), soil,
      terrain::DeformableTerrain::Options{ true });
  dynamics::World world(ground, options);
  const std::size_t count = models.size();
  std::vector<double> integral(count, 0.0), target(count);
  std::vector<Eigen::Vector3d> last(count);
  for (std::size_t v = 0; v < count; ++v)
  {
    const double y = 10.0 * (static_cast<double>(v) - 0.5 * static_cast<double>(count - 1));
    world.addVehicle(models[v], world.restingPose(models[v], -60.0, y, 0.0, 0.01));
    last[v] = world.state(v).pose.translation();
    target[v] = std::min(5.0, 0.8 * models[v].drivetrain.max_speed);
  }
  Run run;
  const auto t0 = Clock::now();
  const auto steps = static_cast<long>(std::lround(seconds / options.step));
  for (long k = 0; k < steps; ++k)
  {
    for (std::size_t v = 0; v < count; ++v)
    {
      const dynamics::VehicleState& s = world.state(v);
      const double error = target[v] - s.body_velocity.x();
      integral[v] = std::clamp(integral[v] + 0.3 * error * options.step, 0.0, 1.0);
      dynamics::DriveCommand c;
      c.throttle = std::clamp(0.5 * error + integral[v], 0.0, 1.0);
      c.steering = 0.15 * std::sin(2.0 * M_PI * world.time() / 40.0);
      world.setCommand(v, c);
    }
    world.step();
    for (std::size_t v = 0; v < count; ++v)
    {
      const dynamics::VehicleState& after = world.state(v);
      run.distance += (after.pose.translation() - last[v]).head<2>().norm() / static_cast<double>(count);
      last[v] = after.pose.translation();
      for (const dynamics::WheelState& w : after.wheels)
        run.max_rut = std::max(run.max_rut, w.sinkage);
      for (const dynamics::TrackState& t : after.tracks)
        for (const dynamics::TrackSegmentState& seg : t.segments)
          run.max_rut = std::max(run.max_rut, seg.sinkage);
    }
  }
  run.wall = std::chrono::duration<double>(Clock::now() - t0).count();
  run.sim = world.time();
  run.times = world.times();
  return run;
}

/// fed_alpha holding 5 m/s straight ahead from (x, y) heading yaw on the default course, its
/// objects as obstacles when `objects` is given.
struct CourseRun
{
  Run run;
  std::size_t geoms = 0;
  long contact_steps = 0;
  std::size_t toppled = 0;
};

CourseRun driveCourse(terrain::DeformableTerrain& ground, terrain::ObjectSet* objects,
                      const dynamics::VehicleModel& model, double x, double y, double yaw, double seconds)
{
  dynamics::WorldOptions options;
  options.profile = true;
  dynamics::World world(ground, options);
  CourseRun out;
  std::size_t toppled_before = 0;
  if (objects)
  {
    world.setObstacles(*objects);
    for (const terrain::TerrainObject& o : objects->all())
      toppled_before += o.toppled;
  }
  out.geoms = world.obstacleGeomCount();
  const std::size_t id = world.addVehicle(model, world.restingPose(model, x, y, yaw, 0.01));
  double integral = 0.0;
  Eigen::Vector3d last = world.state(id).pose.translation();
  const auto t0 = Clock::now();
  const auto steps = static_cast<long>(std::lround(seconds / options.step));
  for (long k = 0; k < steps; ++k)
  {
    const dynamics::VehicleState& s = world.state(id);
    const double error = 5.0 - s.body_velocity.x();
    integral = std::clamp(integral + 0.3 * error * options.step, 0.0, 1.0);
    dynamics::DriveCommand c;
    c.throttle = std::clamp(0.5 * error + integral, 0.0, 1.0);
    world.setCommand(id, c);
    world.step();
    const dynamics::VehicleState& after = world.state(id);
    out.run.distance += (after.pose.translation() - last).head<2>().norm();
    last = after.pose.translation();
    out.contact_steps += after.obstacle_contacts > 0;
  }
  out.run.wall = std::chrono::duration<double>(Clock::now() - t0).count();
  out.run.sim = world.time();
  out.run.times = world.times();
  if (objects)
    for (const terrain::TerrainObject& o : objects->all())
      out.toppled += o.toppled;
  out.toppled -= std::min(out.toppled, toppled_before);
  return out;
}

void printCourse(const char* label, const CourseRun& c)
{
  const double per = 1e6 / static_cast<double>(c.run.times.steps);
  const dynamics::StepTimes& t = c.run.times;
  std::printf(
      "  %-30s %5zu geoms: collision %.2f us per step (total step %.1f us: ODE %.1f, soil contact %.1f; "
      "real-time factor %.1fx); %.0f m, %ld steps in contact, %zu objects toppled\n",
      label, c.geoms, t.collision * per, (t.ode + t.contact + t.other + t.collision) * per, t.ode * per,
      t.contact * per, c.run.sim / c.run.wall, c.run.distance, c.contact_steps, c.toppled);
}

void print(const char* label, const Run& r)
{
  const double per = 1e6 / static_cast<double>(r.times.steps);
  std::printf("  %-34s real-time factor %6.1fx  (%.1f s simulated in %.2f s, %.0f m, sinkage up to %.1f mm)\n", label,
              r.sim / r.wall, r.sim, r.wall, r.distance, 1e3 * r.max_rut);
  std::printf("  %-34s us per step: ODE %.1f, soil contact %.1f, collision %.2f, rest %.1f (total %.1f)\n", "",
              r.times.ode * per, r.times.contact * per, r.times.collision * per, r.times.other * per,
              (r.times.ode + r.times.contact + r.times.collision + r.times.other) * per);
}
}  // namespace

int main(int argc, char** argv)
{
  if (argc < 3)
  {
    std::fprintf(stderr, "usage: bench_vehicle_sim SOILS.yaml VEHICLE.yaml[,VEHICLE.yaml...] [seconds] [soil ...]\n");
    return 2;
  }
  try
  {
    const terrain::SoilLibrary soils = terrain::SoilLibrary::load(argv[1]);
    std::vector<dynamics::VehicleModel> models;
    std::string names_list;
    for (std::size_t from = 0, to = 0; from <= std::strlen(argv[2]); from = to + 1)
    {
      to = std::string(argv[2]).find(',', from);
      if (to == std::string::npos)
        to = std::strlen(argv[2]);
      models.push_back(dynamics::loadVehicleModel(std::string(argv[2]).substr(from, to - from)));
      names_list += (names_list.empty() ? "" : " + ") + models.back().model;
    }
    const double seconds = argc > 3 ? std::atof(argv[3]) : 60.0;
    std::vector<std::string> names;
    for (int k = 4; k < argc; ++k)
      names.push_back(argv[k]);
    if (names.empty())
      names = { "gravel", "sandy_loam" };
    std::printf("%s at 5 m/s on a 200 m x 200 m terrain at 0.1 m cells, 1 ms physics step, %.0f s per run\n",
                names_list.c_str(), seconds);
    for (const std::string& name : names)
    {
      std::printf("%s:\n", name.c_str());
      dynamics::WorldOptions options;
      options.profile = true;
      const Run deforming = drive(soils.get(name), models, seconds, options);
      print("deformable (ruts), exact solver", deforming);
      options.deform_terrain = false;
      const Run rigid = drive(soils.get(name), models, seconds, options);
      print("same without deformation", rigid);
      const double per_d = 1e6 / static_cast<double>(deforming.times.steps);
      const double per_r = 1e6 / static_cast<double>(rigid.times.steps);
      std::printf("  %-34s terrain update (contact with ruts - without) %.1f us per step\n", "",
                  deforming.times.contact * per_d - rigid.times.contact * per_r);
      options.deform_terrain = true;
      options.solver = dynamics::Solver::kIterative;
      print("deformable, iterative solver (20 it.)", drive(soils.get(name), models, seconds, options));
    }

    // Obstacles: the default course's objects (seed 1, 600 m x 400 m; 0.5 m cells, as the
    // objects do not depend on the cell size and the grid only has to carry the vehicle).
    const dynamics::VehicleModel& model = models.front();
    terrain::CourseOptions course_options;
    course_options.cell_size = 0.5;
    terrain::Course course = terrain::makeDefaultCourse(course_options);
    std::size_t grass = 0, rigid = 0;
    for (const terrain::TerrainObject& o : course.objects.all())
    {
      grass += o.type == terrain::ObjectType::kGrass;
      rigid += o.type != terrain::ObjectType::kGrass && !std::isfinite(o.strength);
    }
    std::printf(
        "default course (600 m x 400 m, seed 1): %zu objects (%zu grass, %zu rigid, %zu toppleable); "
        "%s at 5 m/s:\n",
        course.objects.size(), grass, rigid, course.objects.size() - grass - rigid, model.model.c_str());
    terrain::DeformableTerrain ground(std::move(course.heights), terrain::paletteFromNames(course.soil_names, soils),
                                      std::move(course.soil_map), terrain::DeformableTerrain::Options{ true });
    // Up the gravel dirt trail (open ground, objects kept a few metres off it): broad phase only.
    const terrain::CourseFeature& trail = course.feature("dirt_trail");
    const double trail_x = 0.5 * (trail.min_x + trail.max_x), trail_y = trail.min_y + 8.0;
    printCourse("up the trail, no obstacles",
                driveCourse(ground, nullptr, model, trail_x, trail_y, 0.5 * M_PI, seconds));
    terrain::ObjectSet all = course.objects;
    printCourse("up the trail, all objects", driveCourse(ground, &all, model, trail_x, trail_y, 0.5 * M_PI, seconds));
    const terrain::CourseFeature& woods = course.feature("woods");
    terrain::ObjectSet forest = course.objects;
    printCourse("into the woods, all objects",
                driveCourse(ground, &forest, model, woods.min_x - 10.0, 0.5 * (woods.min_y + woods.max_y), 0.0,
                            std::min(seconds, 20.0)));
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_vehicle_sim: %s\n", e.what());
    return 1;
  }
  return 0;
}
