// Prints frames per second of a 640 x 480 RGB + depth + semantic camera with sun shadows on the
// default course (soils and objects as sensors_node loads them), 1 and 2 threads, from several
// poses along the course at 2 m above the ground; also the share of rays that hit something and
// the cost without shadows. Target: >= 10 fps on 2 threads. Figures are printed, not asserted.
//
// Usage: bench_camera [frames per configuration, default 8]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "avsp_sensors/camera.hpp"
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
  const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 8;
  const avsp::terrain::Course course = avsp::terrain::makeDefaultCourse(avsp::terrain::CourseOptions());
  Scene scene(HeightField::fromGrid(course.heights));
  scene.setObjects(course.objects);
  CameraMaterials materials;
  std::vector<SoilLook> soils;
  for (const std::string& name : course.soil_names)
    soils.push_back({ name, soilAlbedo(name), 0.2f });
  materials.setSoils(soils, course.soil_map);
  materials.setObjects(course.objects);
  std::printf("default course: %zu x %zu points, %zu objects, %zu soils\n", course.heights.columns(),
              course.heights.rows(), course.objects.size(), soils.size());

  CameraEnvironment env;
  env.sun_elevation = 40.0 * 3.14159265358979 / 180.0;
  const double az = 2.0;  // ENU angle of the sun's azimuth: north-west-ish, long shadows
  env.sun_direction = Eigen::Vector3d(std::cos(env.sun_elevation) * std::cos(az),
                                      std::cos(env.sun_elevation) * std::sin(az), std::sin(env.sun_elevation));

  // Poses: across the course, heading alternately east and north-east, level, 2 m up.
  std::vector<Eigen::Isometry3d> poses;
  for (int k = 0; k < 8; ++k)
  {
    const double x = 60.0 + 60.0 * k, y = 80.0 + 30.0 * (k % 4);
    double h = 0.0;
    scene.terrain().heightAt(x, y, h);
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.translation() = Eigen::Vector3d(x, y, h + 2.0);
    p.linear() = Eigen::AngleAxisd(0.4 * (k % 3), Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                 Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix() * opticalFromBody();
    poses.push_back(p);
  }

  for (bool shadows : { true, false })
  {
    CameraConfig c;
    c.width = 640;
    c.height = 480;
    c.hfov = 90.0 * 3.14159265358979 / 180.0;
    c.shadows = shadows;
    const Camera camera(c);
    for (unsigned threads : { 1u, 2u })
    {
      double best = 1e9, total = 0.0;
      std::size_t hits = 0, pixels = 0;
      for (int f = 0; f < frames; ++f)
      {
        const auto t0 = Clock::now();
        const CameraFrame frame = camera.render(scene, materials, poses[f % poses.size()], env, threads);
        const double s = seconds(t0);
        best = std::min(best, s);
        total += s;
        for (std::uint8_t cls : frame.semantic)
          hits += cls != kClassNone;
        pixels += frame.semantic.size();
      }
      std::printf("640x480 RGB+depth+semantic, shadows %s, %u thread(s): %.1f fps mean (%.1f ms/frame), best %.1f ms; "
                  "%.0f %% of pixels hit something\n",
                  shadows ? "on " : "off", threads, frames / total, 1e3 * total / frames, 1e3 * best,
                  100.0 * hits / pixels);
    }
  }
  return 0;
}
