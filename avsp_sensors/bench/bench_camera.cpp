// Prints frames per second of a 640 x 480 RGB + depth + semantic camera with sun shadows on the
// default course (soils and objects as sensors_node loads them), 1 and 2 threads, from several
// poses along the course at 2 m above the ground; also the share of rays that hit something and
// the cost without shadows. Target: >= 10 fps on 2 threads. Figures are printed, not asserted.
// CPU time per frame is printed too: on a loaded machine it is the better measure of the work.
//
// Usage: bench_camera [frames per configuration, default 8] [image prefix]
// With a prefix, also writes <prefix>_rgb.ppm and <prefix>_semantic.ppm (classes in false
// colour) of the first pose, and <prefix>_dusk_rgb.ppm, <prefix>_fog_rgb.ppm, <prefix>_night_ir.pgm.
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <vector>

#include "avsp_sensors/camera.hpp"
#include "avsp_terrain/default_course.hpp"

using namespace avsp::sensors;
using Clock = std::chrono::steady_clock;

namespace
{
void writePpm(const std::string& path, const CameraFrame& f, const std::vector<std::uint8_t>& rgb)
{
  std::ofstream out(path, std::ios::binary);
  out << "P6\n" << f.width << " " << f.height << "\n255\n";
  out.write(reinterpret_cast<const char*>(rgb.data()), static_cast<std::streamsize>(rgb.size()));
}

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

  if (argc > 2)
  {
    const std::string prefix = argv[2];
    CameraConfig c;
    c.thermal = true;
    const Camera camera(c);
    const CameraFrame f = camera.render(scene, materials, poses[1], env, 2);
    writePpm(prefix + "_rgb.ppm", f, f.rgb);
    std::vector<std::uint8_t> sem(3 * f.semantic.size());
    for (std::size_t k = 0; k < f.semantic.size(); ++k)
      for (int ch = 0; ch < 3; ++ch)
        sem[3 * k + ch] = static_cast<std::uint8_t>((f.semantic[k] * (37 + 54 * ch) + 40 * ch) % 256);
    writePpm(prefix + "_semantic.ppm", f, sem);
    CameraEnvironment dusk = env, fog = env, night = env;
    dusk.sun_elevation = 2.0 * 3.14159265358979 / 180.0;
    dusk.sun_direction = Eigen::Vector3d(std::cos(dusk.sun_elevation) * std::cos(az),
                                         std::cos(dusk.sun_elevation) * std::sin(az), std::sin(dusk.sun_elevation));
    writePpm(prefix + "_dusk_rgb.ppm", f, camera.render(scene, materials, poses[1], dusk, 2).rgb);
    fog.weather.fog_visibility = 150.0;
    writePpm(prefix + "_fog_rgb.ppm", f, camera.render(scene, materials, poses[1], fog, 2).rgb);
    night.sun_elevation = -0.5;
    night.sun_direction = Eigen::Vector3d(std::cos(0.5), 0.0, -std::sin(0.5));
    const CameraFrame ir = camera.render(scene, materials, poses[1], night, 2);
    std::ofstream out(prefix + "_night_ir.pgm", std::ios::binary);
    out << "P5\n" << ir.width << " " << ir.height << "\n255\n";
    out.write(reinterpret_cast<const char*>(ir.thermal.data()), static_cast<std::streamsize>(ir.thermal.size()));
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
      double best = 1e9, total = 0.0, cpu = 0.0;
      std::size_t hits = 0, pixels = 0;
      for (int f = 0; f < frames; ++f)
      {
        const auto t0 = Clock::now();
        const std::clock_t c0 = std::clock();
        const CameraFrame frame = camera.render(scene, materials, poses[f % poses.size()], env, threads);
        const double s = seconds(t0);
        cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
        best = std::min(best, s);
        total += s;
        for (std::uint8_t cls : frame.semantic)
          hits += cls != kClassNone;
        pixels += frame.semantic.size();
      }
      std::printf(
          "640x480 RGB+depth+semantic, shadows %s, %u thread(s): %.1f fps mean (%.1f ms/frame), best %.1f ms; "
          "%.0f %% of pixels hit something; CPU %.1f ms/frame (all threads)\n",
          shadows ? "on " : "off", threads, frames / total, 1e3 * total / frames, 1e3 * best, 100.0 * hits / pixels,
          1e3 * cpu / frames);
    }
  }
  return 0;
}
