// Cameras (camera.hpp): geometry against closed forms (projection through K, depth along the
// optical axis on planes and boxes, stereo disparity f B / Z, equidistant fisheye), semantics
// against the ray caster, lighting (sun-facing faces, shadow side, night vs noon), fog
// (Koschmieder's exp(-alpha R) of the contrast), thermal (a deer at night), determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "avsp_sensors/camera.hpp"
#include "avsp_terrain/terrain_objects.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;

namespace
{
constexpr double kPi = 3.14159265358979323846;

HeightField plane(double c0, double a, double b, double half = 100.0, double d = 0.5)
{
  const std::size_t n = static_cast<std::size_t>(std::lround(2 * half / d)) + 1;
  std::vector<float> h(n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i)
      h[j * n + i] = static_cast<float>(c0 + a * (-half + i * d) + b * (-half + j * d));
  return HeightField(-half, -half, d, d, n, n, h);
}

/// Optical frame pose for a camera body at `p` with yaw (about z) then pitch (positive: nose down).
Eigen::Isometry3d opticalPose(const Vector3d& p, double yaw, double pitch = 0.0)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = p;
  t.linear() =
      (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY())).toRotationMatrix() *
      opticalFromBody();
  return t;
}

Body sphereBody(const Vector3d& c, double r, std::uint32_t id)
{
  Body b;
  b.primitive.shape = Shape::kEllipsoid;
  b.primitive.half_extents = Vector3d::Constant(r);
  b.primitive.centre = c;
  b.primitive.id = id;
  return b;
}

Primitive box(const Vector3d& c, const Vector3d& half, double yaw, std::uint32_t id)
{
  Primitive p;
  p.shape = Shape::kBox;
  p.half_extents = half;
  p.centre = c;
  p.rotation = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  p.id = id;
  return p;
}

/// Centroid of the pixels of class `cls`; false if none.
bool centroid(const CameraFrame& f, std::uint8_t cls, Eigen::Vector2d& c, int* count = nullptr)
{
  double su = 0, sv = 0;
  int n = 0;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u)
      if (f.semantic[v * f.width + u] == cls)
      {
        su += u;
        sv += v;
        ++n;
      }
  if (count)
    *count = n;
  if (n == 0)
    return false;
  c = Eigen::Vector2d(su / n, sv / n);
  return true;
}

CameraEnvironment noon()
{
  CameraEnvironment e;
  e.sun_elevation = 60.0 * kPi / 180.0;
  e.sun_direction = Vector3d(std::cos(e.sun_elevation), 0.0, std::sin(e.sun_elevation));  // from the east
  return e;
}

CameraEnvironment sunAt(double azimuth_enu, double elevation)
{
  CameraEnvironment e;
  e.sun_elevation = elevation;
  e.sun_direction = Vector3d(std::cos(elevation) * std::cos(azimuth_enu), std::cos(elevation) * std::sin(azimuth_enu),
                             std::sin(elevation));
  return e;
}

float lum(const CameraFrame& f, std::size_t k)
{
  return 0.2126f * f.radiance[3 * k] + 0.7152f * f.radiance[3 * k + 1] + 0.0722f * f.radiance[3 * k + 2];
}

/// Slab intersection of a ray with an oriented box (independent of the ray caster).
bool slab(const Primitive& p, const Vector3d& o, const Vector3d& d, double& t)
{
  const Vector3d lo = p.rotation.transpose() * (o - p.centre), ld = p.rotation.transpose() * d;
  double t0 = 0, t1 = 1e9;
  for (int a = 0; a < 3; ++a)
  {
    if (std::abs(ld[a]) < 1e-15)
    {
      if (std::abs(lo[a]) > p.half_extents[a])
        return false;
      continue;
    }
    double ta = (-p.half_extents[a] - lo[a]) / ld[a], tb = (p.half_extents[a] - lo[a]) / ld[a];
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  t = t0;
  return t0 <= t1 && t0 > 0;
}
}  // namespace

TEST(Camera, IntrinsicsFollowCameraInfoConventions)
{
  CameraConfig c;
  c.width = 640;
  c.height = 480;
  c.hfov = kPi / 2;
  c.stereo_tx = -0.3;
  const CameraIntrinsics in = cameraIntrinsics(c);
  EXPECT_NEAR(in.fx, 320.0, 1e-9);  // (w / 2) / tan(45 deg)
  EXPECT_NEAR(in.fy, 320.0, 1e-9);
  EXPECT_DOUBLE_EQ(in.cx, 319.5);
  EXPECT_DOUBLE_EQ(in.cy, 239.5);
  EXPECT_EQ(in.distortion_model, "plumb_bob");
  EXPECT_EQ(in.D.size(), 5u);
  EXPECT_DOUBLE_EQ(in.K[0], in.fx);
  EXPECT_DOUBLE_EQ(in.K[2], in.cx);
  EXPECT_DOUBLE_EQ(in.K[4], in.fy);
  EXPECT_DOUBLE_EQ(in.K[5], in.cy);
  EXPECT_DOUBLE_EQ(in.K[8], 1.0);
  EXPECT_DOUBLE_EQ(in.P[3], -0.3 * 320.0);  // Tx = -fx B
  EXPECT_DOUBLE_EQ(in.P[10], 1.0);
  // Optical frame: z forward = body x, x right = -body y, y down = -body z.
  const Eigen::Matrix3d r = opticalFromBody();
  EXPECT_TRUE((r * Vector3d::UnitZ()).isApprox(Vector3d::UnitX()));
  EXPECT_TRUE((r * Vector3d::UnitX()).isApprox(-Vector3d::UnitY()));
  EXPECT_TRUE((r * Vector3d::UnitY()).isApprox(-Vector3d::UnitZ()));
  c.projection = CameraProjection::kFisheye;
  c.hfov = kPi;
  const CameraIntrinsics fe = cameraIntrinsics(c);
  EXPECT_EQ(fe.distortion_model, "equidistant");
  EXPECT_NEAR(fe.fx, 320.0 / (kPi / 2), 1e-9);
}

TEST(Camera, BadConfigNamesTheField)
{
  CameraConfig c;
  c.name = "front";
  c.width = 0;
  try
  {
    Camera cam(c);
    FAIL() << "width 0 accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("'front': width"), std::string::npos) << e.what();
  }
  c.width = 64;
  c.hfov = kPi;
  EXPECT_THROW(Camera{ c }, std::invalid_argument);
  c.hfov = 1.0;
  c.rgb = c.depth = c.semantic = c.thermal = false;
  EXPECT_THROW(Camera{ c }, std::invalid_argument);
}

TEST(Camera, SphereProjectsToThePixelKPredicts)
{
  Scene scene(plane(-50.0, 0, 0));
  CameraMaterials mat;
  mat.setBody(7, kClassAnimal);
  CameraConfig c;
  c.width = 320;
  c.height = 240;
  c.hfov = 70.0 * kPi / 180.0;
  c.rgb = false;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(1.0, -2.0, 1.5), 0.4, 0.1);
  int checked = 0;
  for (const Vector3d& centre :
       { Vector3d(12.0, 3.0, 1.0), Vector3d(8.0, 0.0, 2.0), Vector3d(20.0, 10.0, 0.0), Vector3d(6.0, 2.5, 0.5) })
  {
    scene.setBodies({ sphereBody(centre, 0.35, 7) });
    const CameraFrame f = cam.render(scene, mat, pose, noon(), 2);
    Eigen::Vector2d uv, got;
    ASSERT_TRUE(cam.project(pose.inverse() * centre, uv));
    const Vector3d p = pose.inverse() * centre;
    // K by hand: u = fx X / Z + cx.
    EXPECT_NEAR(uv.x(), cam.intrinsics().fx * p.x() / p.z() + cam.intrinsics().cx, 1e-9);
    EXPECT_NEAR(uv.y(), cam.intrinsics().fy * p.y() / p.z() + cam.intrinsics().cy, 1e-9);
    int n = 0;
    ASSERT_TRUE(centroid(f, kClassAnimal, got, &n)) << centre.transpose();
    EXPECT_GT(n, 20);
    EXPECT_NEAR(got.x(), uv.x(), 0.5) << centre.transpose();
    EXPECT_NEAR(got.y(), uv.y(), 0.5) << centre.transpose();
    ++checked;
  }
  EXPECT_EQ(checked, 4);
}

TEST(Camera, DepthIsTheDistanceAlongTheOpticalAxisOnPlanesAndBoxes)
{
  // A tilted plane z = c0 + a x + b y and an oriented box on it.
  const double c0 = -0.3, a = 0.05, b = -0.08;
  Scene scene(plane(c0, a, b));
  const Primitive bx = box(Vector3d(9.0, 1.0, 0.8), Vector3d(0.6, 1.5, 1.0), 0.35, 3);
  scene.setStaticPrimitives({ bx });
  CameraMaterials mat;
  CameraConfig c;
  c.width = 200;
  c.height = 150;
  c.rgb = false;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0.5, 0.2, 1.8), 0.1, 0.25);
  const CameraFrame f = cam.render(scene, mat, pose, noon(), 2);
  int ground = 0, boxes = 0;
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u)
    {
      const std::size_t k = v * c.width + u;
      const Vector3d ro = cam.pixelRay(u, v).cast<double>();
      const Vector3d d = (pose.linear() * ro).normalized();
      const Vector3d o = pose.translation();
      double t_box = 0;
      const bool on_box = slab(bx, o, d, t_box);
      const double t_plane = (c0 + a * o.x() + b * o.y() - o.z()) / (d.z() - a * d.x() - b * d.y());
      double t = 0;
      if (on_box && (t_plane <= 0 || t_box < t_plane))
      {
        t = t_box;
        ++boxes;
      }
      else if (t_plane > 0)
      {
        const Vector3d p = o + t_plane * d;
        if (std::abs(p.x()) > 99 || std::abs(p.y()) > 99)
          continue;
        t = t_plane;
        ++ground;
      }
      else
        continue;
      // Depth = t times the cosine to the optical axis (the ray's z in the optical frame).
      ASSERT_NEAR(f.depth[k], t * ro.normalized().z(), 1e-3) << "pixel " << u << ", " << v;
    }
  EXPECT_GT(ground, 5000);
  EXPECT_GT(boxes, 500);
}

TEST(Camera, StereoDisparityIsFocalTimesBaselineOverDepth)
{
  Scene scene(plane(-50.0, 0, 0));
  CameraMaterials mat;
  mat.setBody(1, kClassPerson);
  CameraConfig c;
  c.width = 400;
  c.height = 300;
  c.hfov = 60.0 * kPi / 180.0;
  c.rgb = false;
  const double baseline = 0.3;
  CameraConfig cr = c;
  cr.stereo_tx = -baseline;
  const Camera left(c), right(cr);
  EXPECT_DOUBLE_EQ(right.intrinsics().P[3], -left.intrinsics().fx * baseline);
  // Left camera at the origin looking along +x; the right one baseline to its right (-y).
  const Eigen::Isometry3d pl = opticalPose(Vector3d(0, 0, 1.5), 0.0);
  const Eigen::Isometry3d pr = opticalPose(Vector3d(0, -baseline, 1.5), 0.0);
  for (double z : { 4.0, 7.0, 12.0 })
  {
    scene.setBodies({ sphereBody(Vector3d(z, 0.4, 1.3), 0.12, 1) });
    Eigen::Vector2d ul, ur;
    ASSERT_TRUE(centroid(left.render(scene, mat, pl, noon(), 1), kClassPerson, ul));
    ASSERT_TRUE(centroid(right.render(scene, mat, pr, noon(), 1), kClassPerson, ur));
    EXPECT_NEAR(ul.x() - ur.x(), left.intrinsics().fx * baseline / z, 0.5) << "Z = " << z;
    EXPECT_NEAR(ul.y(), ur.y(), 0.2);
  }
}

TEST(Camera, EquidistantFisheyeMapsAngleToRadius)
{
  Scene scene(plane(-50.0, 0, 0));
  CameraMaterials mat;
  mat.setBody(2, kClassVehicle);
  CameraConfig c;
  c.projection = CameraProjection::kFisheye;
  c.width = c.height = 300;
  c.hfov = kPi;  // 180 deg across the width
  c.rgb = false;
  const Camera cam(c);
  const double f = cam.intrinsics().fx;
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.5), 0.0);
  for (double theta_deg : { 0.0, 30.0, 60.0, 80.0 })
  {
    const double th = theta_deg * kPi / 180.0;
    // A point at angle theta from the axis, to the left (image left: u < cx).
    const Vector3d centre(10.0 * std::cos(th), 10.0 * std::sin(th), 1.5);
    scene.setBodies({ sphereBody(centre, 0.3, 2) });
    Eigen::Vector2d uv, got;
    ASSERT_TRUE(cam.project(pose.inverse() * centre, uv));
    EXPECT_NEAR(cam.intrinsics().cx - uv.x(), f * th, 1e-6);  // r = f theta
    ASSERT_TRUE(centroid(cam.render(scene, mat, pose, noon(), 2), kClassVehicle, got));
    EXPECT_NEAR(got.x(), uv.x(), 0.5) << theta_deg;
    EXPECT_NEAR(got.y(), uv.y(), 0.5) << theta_deg;
  }
}

TEST(Camera, EveryPixelsClassIsTheClassOfWhatItsCentreRayHits)
{
  // Two soils (a road strip of asphalt across sandy loam), objects of every kind, three bodies.
  Scene scene(plane(0.0, 0.02, 0.0));
  const std::size_t n = scene.terrain().columns();
  std::vector<std::uint8_t> soil_map(n * scene.terrain().rows(), 1);
  for (std::size_t j = 0; j < scene.terrain().rows(); ++j)
    for (std::size_t i = 0; i < n; ++i)
      if (std::abs(scene.terrain().originY() + j * scene.terrain().dy()) < 2.0)
        soil_map[j * n + i] = 0;
  CameraMaterials mat;
  mat.setSoils({ { "asphalt", soilAlbedo("asphalt"), 0.f }, { "sandy_loam", soilAlbedo("sandy_loam"), 0.2f } },
               soil_map);
  avsp::terrain::ObjectSet objects;
  const avsp::terrain::ObjectType types[] = { avsp::terrain::ObjectType::kTree,    avsp::terrain::ObjectType::kShrub,
                                              avsp::terrain::ObjectType::kRock,    avsp::terrain::ObjectType::kPole,
                                              avsp::terrain::ObjectType::kFence,   avsp::terrain::ObjectType::kBarrier,
                                              avsp::terrain::ObjectType::kBuilding };
  for (int k = 0; k < 7; ++k)
  {
    avsp::terrain::TerrainObject o;
    o.type = types[k];
    o.x = 12.0 + 3.0 * k;
    o.y = -9.0 + 3.0 * k;
    o.length = 1.2;
    o.width = 0.8;
    o.height = 1.5;
    objects.add(o);
  }
  scene.setObjects(objects);
  mat.setObjects(objects);
  scene.setBodies({ sphereBody(Vector3d(8, 3, 1), 0.6, 100), sphereBody(Vector3d(9, -3, 1), 0.5, 101),
                    sphereBody(Vector3d(15, 1, 1), 0.8, 102) });
  mat.setBody(100, kClassPerson);
  mat.setBody(101, kClassAnimal);  // 102: a vehicle by default
  CameraConfig c;
  c.width = 240;
  c.height = 160;
  c.rgb = false;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 2.0), 0.0, 0.1);
  const CameraFrame f = cam.render(scene, mat, pose, noon(), 3);
  std::vector<int> seen(256, 0);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u)
    {
      Ray r;
      r.origin = pose.translation();
      r.direction = (pose.linear() * cam.pixelRay(u, v).cast<double>()).normalized();
      r.max_range = c.max_range;
      const RayHit hit = scene.cast(r);
      const std::uint8_t expected = mat.classOf(hit, scene.terrain());
      ASSERT_EQ(f.semantic[v * c.width + u], expected) << u << ", " << v;
      ++seen[expected];
    }
  // Every class of the scene is in the image (the check above is not vacuous), with the
  // object-kind mapping checked by name.
  for (int cls :
       std::vector<int>{ kClassNone, kClassRoad, kClassSoilBase + 1, kClassVegetation, kClassRock, kClassPole,
                         kClassFence, kClassBarrier, kClassBuilding, kClassPerson, kClassAnimal, kClassVehicle })
    EXPECT_GT(seen[cls], 0) << "class " << cls;
  const std::vector<ClassEntry> table = mat.classTable();
  bool has_loam = false, has_road = false;
  for (const ClassEntry& e : table)
  {
    has_loam = has_loam || (e.id == kClassSoilBase + 1 && e.name == "terrain/sandy_loam");
    has_road = has_road || (e.id == kClassRoad && e.name == "road");
  }
  EXPECT_TRUE(has_loam && has_road);
  // The centre pixel of the road strip, straight down the road: road.
  Eigen::Vector2d uv;
  ASSERT_TRUE(cam.project(pose.inverse() * Vector3d(5.0, 0.0, 0.1), uv));
  EXPECT_EQ(f.semantic[std::lround(uv.y()) * c.width + std::lround(uv.x())], kClassRoad);
}

TEST(Camera, SurfaceFacingTheSunIsBrighterThanOneFacingAway)
{
  Scene scene(plane(0.0, 0, 0));
  scene.setStaticPrimitives({ box(Vector3d(10, 0, 1.0), Vector3d(0.5, 2.0, 1.0), 0.0, 0) });
  avsp::terrain::ObjectSet objects;
  CameraMaterials mat;
  CameraConfig c;
  c.width = 160;
  c.height = 120;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.0), 0.0);
  // The camera sees the box's -x face. Sun behind the camera (from -x, the face lit) or in
  // front (from +x, the face away from it), same elevation.
  const CameraFrame lit = cam.render(scene, mat, pose, sunAt(kPi, 0.5), 1);
  const CameraFrame away = cam.render(scene, mat, pose, sunAt(0.0, 0.5), 1);
  EXPECT_DOUBLE_EQ(lit.exposure_lux, away.exposure_lux);
  const std::size_t centre = (c.height / 2) * c.width + c.width / 2;
  ASSERT_EQ(lit.semantic[centre], kClassUnknown);  // the box (no ObjectSet entry)
  EXPECT_GT(lum(lit, centre), 3.0f * lum(away, centre));
  EXPECT_GT(lit.rgb[3 * centre + 1], away.rgb[3 * centre + 1]);
}

TEST(Camera, BoxShadowFallsOppositeTheSunAzimuth)
{
  Scene scene(plane(0.0, 0, 0));
  scene.setStaticPrimitives({ box(Vector3d(0, 0, 1.0), Vector3d(1.0, 1.0, 1.0), 0.0, 0) });
  CameraMaterials mat;
  CameraConfig c;
  c.width = c.height = 200;
  c.hfov = 60.0 * kPi / 180.0;
  const Camera cam(c);
  // Looking straight down from 30 m.
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 30.0), 0.0, kPi / 2);
  for (double az : { 0.0, kPi / 2, 2.3 })  // sun toward east, north, north-west (ENU angle)
  {
    const CameraFrame f = cam.render(scene, mat, pose, sunAt(az, kPi / 4), 2);
    const Vector3d toward(std::cos(az), std::sin(az), 0.0), across(-std::sin(az), std::cos(az), 0.0);
    // The shadow of a 2 m box at 45 deg reaches 2 m beyond its edge (1.0 + 2.0 from its centre,
    // more along the diagonal): 2 m from the centre away from the sun is in shadow; toward the
    // sun and across it is lit.
    auto at = [&](const Vector3d& p) {
      Eigen::Vector2d uv;
      EXPECT_TRUE(cam.project(pose.inverse() * p, uv));
      return lum(f, std::lround(uv.y()) * c.width + std::lround(uv.x()));
    };
    const float shadow = at(-2.0 * toward), sunny = at(2.0 * toward), side = at(2.5 * across),
                other = at(-2.5 * across);
    EXPECT_LT(shadow, 0.5f * sunny) << "azimuth " << az;
    EXPECT_LT(shadow, 0.5f * side) << "azimuth " << az;
    EXPECT_LT(shadow, 0.5f * other) << "azimuth " << az;
    EXPECT_NEAR(sunny, side, 1e-4f * sunny);  // the open ground: all equal
    // Beyond the shadow's tip (3 m + margin), lit again.
    EXPECT_NEAR(at(-4.5 * toward), sunny, 1e-4f * sunny);
  }
}

TEST(Camera, NightIsFarDarkerThanNoonAndDuskInBetween)
{
  Scene scene(plane(0.0, 0.01, 0.0));
  scene.setStaticPrimitives({ box(Vector3d(10, 0, 1.0), Vector3d(0.5, 2.0, 1.0), 0.3, 0) });
  CameraMaterials mat;
  CameraConfig c;
  c.width = 160;
  c.height = 120;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.5), 0.0, 0.1);
  auto mean = [&](const CameraEnvironment& e) {
    const CameraFrame f = cam.render(scene, mat, pose, e, 2);
    double s = 0;
    for (std::uint8_t x : f.rgb)
      s += x;
    return s / f.rgb.size();
  };
  CameraEnvironment night = sunAt(1.0, -30.0 * kPi / 180.0);
  night.moon_elevation = 0.8;
  night.moon_direction = Vector3d(0, std::cos(0.8), std::sin(0.8));
  night.moon_illumination = 1.0;  // full moon
  const double m_noon = mean(noon()), m_dusk = mean(sunAt(1.0, -3.0 * kPi / 180.0)), m_night = mean(night);
  // Stated fraction: night (full moon) mean 8-bit value below 5 % of noon's.
  EXPECT_LT(m_night, 0.05 * m_noon);
  EXPECT_GT(m_dusk, m_night);
  EXPECT_GT(m_noon, 60.0);
  // The light itself: noon > dawn/dusk > moonlit night > moonless night.
  CameraEnvironment moonless = night;
  moonless.moon_illumination = 0.0;
  const double e_noon = skyLight(noon()).horizontal_total,
               e_dusk = skyLight(sunAt(1.0, -3.0 * kPi / 180.0)).horizontal_total;
  EXPECT_GT(e_noon, 50000.0);
  EXPECT_GT(e_dusk, 1.0);
  EXPECT_LT(e_dusk, 800.0);
  EXPECT_GT(skyLight(night).horizontal_total, 0.1);
  EXPECT_LT(skyLight(moonless).horizontal_total, 0.01);
}

TEST(Camera, FogContrastFallsAsExpOfMinusThreeRangeOverVisibility)
{
  // A camera 100 m above the ground (which stays out of view) looks level at a wall facing it.
  Scene scene(plane(-100.0, 0, 0));
  CameraMaterials mat;
  CameraConfig c;
  c.width = 41;
  c.height = 31;
  c.hfov = 0.2;
  c.shadows = false;
  c.fog_contrast_threshold = 0.05;  // visibility by the 5 % contrast threshold: alpha = ln 20 / V = 3.0 / V
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 0), 0.0);
  CameraEnvironment env = sunAt(kPi, 0.6);
  env.weather.fog_visibility = 300.0;
  const std::size_t centre = (c.height / 2) * c.width + c.width / 2;
  // The sky behind (no wall).
  const float sky = lum(cam.render(scene, mat, pose, env, 1), centre);
  std::vector<double> contrast;
  const std::vector<double> ranges{ 10.0, 30.0, 60.0, 100.0, 150.0, 250.0 };
  for (double r : ranges)
  {
    scene.setStaticPrimitives({ box(Vector3d(r + 0.5, 0, 0), Vector3d(0.5, 30.0, 30.0), 0.0, 0) });
    const CameraFrame f = cam.render(scene, mat, pose, env, 1);
    ASSERT_NEAR(f.depth[centre], r, 1e-4);
    contrast.push_back((lum(f, centre) - sky) / sky);
  }
  for (std::size_t k = 0; k < ranges.size(); ++k)
  {
    if (k > 0)
    {
      EXPECT_LT(std::abs(contrast[k]), std::abs(contrast[k - 1]));
    }
    // Relative to the nearest: exp(-3 (R - R0) / V) within 5 %.
    const double expected = std::exp(-3.0 * (ranges[k] - ranges[0]) / env.weather.fog_visibility);
    EXPECT_NEAR(contrast[k] / contrast[0], expected, 0.05 * expected) << "R = " << ranges[k];
  }
  // The default threshold (2 %) is the lidar's Koschmieder 3.912 / V.
  // (-ln 0.02 = 3.91202; the lidar's law uses 3.912.)
  EXPECT_NEAR(-std::log(CameraConfig().fog_contrast_threshold) / 300.0, fogExtinction(300.0, 550e-9),
              1e-5 * fogExtinction(300.0, 550e-9));
}

TEST(Camera, DeerAtNightVisibleInThermalNotInRgb)
{
  Scene scene(plane(0.0, 0, 0));
  CameraMaterials mat;
  const std::uint32_t deer = 42;
  Body b;
  b.primitive.shape = Shape::kEllipsoid;
  b.primitive.half_extents = Vector3d(0.3, 0.8, 0.45);  // seen from its side
  b.primitive.centre = Vector3d(10.0, 0.0, 0.95);
  b.primitive.id = deer;
  scene.setBodies({ b });
  mat.setBody(deer, kClassAnimal);
  CameraConfig c;
  c.width = 320;
  c.height = 240;
  c.thermal = true;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.5), 0.0, 0.05);
  CameraEnvironment night = sunAt(1.0, -25.0 * kPi / 180.0);  // moonless
  night.air_temperature = 283.15;
  const CameraFrame f = cam.render(scene, mat, pose, night, 2);
  double t_deer = 0, t_ground = 0;
  int n_deer = 0, n_ground = 0, rgb_max_diff = 0;
  int g_rgb = -1;
  for (std::size_t k = 0; k < f.semantic.size(); ++k)
  {
    const int g = f.rgb[3 * k + 1];
    if (f.semantic[k] == kClassAnimal)
    {
      t_deer += f.temperature[k];
      ++n_deer;
    }
    else if (f.semantic[k] == kClassSoilBase)
    {
      t_ground += f.temperature[k];
      ++n_ground;
    }
    if (f.semantic[k] != kClassNone)
    {
      if (g_rgb < 0)
        g_rgb = g;
      rgb_max_diff = std::max(rgb_max_diff, std::abs(g - g_rgb));
    }
  }
  ASSERT_GT(n_deer, 100);
  ASSERT_GT(n_ground, 1000);
  // Stated margin: the deer at least 10 K above the ground in IR, and in its mono8 image.
  EXPECT_GT(t_deer / n_deer - t_ground / n_ground, 10.0);
  // RGB: deer and ground are the same (black) to within one 8-bit level.
  EXPECT_LE(rgb_max_diff, 1);
  // By day the same deer is plainly visible in RGB (the scene is lit).
  const CameraFrame day = cam.render(scene, mat, pose, noon(), 2);
  EXPECT_GT(*std::max_element(day.rgb.begin(), day.rgb.end()), 100);
}

TEST(Camera, MoistureDarkensSnowCoversSeasonsChangeVegetation)
{
  Scene scene(plane(0.0, 0, 0));
  avsp::terrain::ObjectSet objects;
  avsp::terrain::TerrainObject tree;
  tree.type = avsp::terrain::ObjectType::kTree;
  tree.x = 8.0;
  tree.length = tree.width = 2.0;
  tree.height = 4.0;
  objects.add(tree);
  scene.setObjects(objects);
  CameraMaterials mat;
  mat.setObjects(objects);
  CameraConfig c;
  c.width = 80;
  c.height = 60;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.5), 0.0, 0.0);
  const std::size_t ground = (c.height - 2) * c.width + c.width / 2, trunk = (c.height / 2) * c.width + c.width / 2;
  CameraEnvironment dry = noon(), wet = noon(), snowy = noon(), fall = noon();
  wet.surface_wetness = 1.0;
  snowy.snow_cover = 1.0;
  fall.season = Season::kFall;
  const CameraFrame f_dry = cam.render(scene, mat, pose, dry, 1), f_wet = cam.render(scene, mat, pose, wet, 1);
  const CameraFrame f_snow = cam.render(scene, mat, pose, snowy, 1), f_fall = cam.render(scene, mat, pose, fall, 1);
  ASSERT_EQ(f_dry.semantic[trunk], kClassVegetation);
  EXPECT_NEAR(lum(f_wet, ground), 0.5f * lum(f_dry, ground), 1e-4f);  // saturated: half as bright
  EXPECT_GT(lum(f_snow, ground), 2.0f * lum(f_dry, ground));
  // Summer green (g > r), fall yellow/red (r > g).
  EXPECT_GT(f_dry.radiance[3 * trunk + 1], f_dry.radiance[3 * trunk]);
  EXPECT_GT(f_fall.radiance[3 * trunk], f_fall.radiance[3 * trunk + 1]);
  EXPECT_EQ(seasonOf(10, 40.0), Season::kFall);
  EXPECT_EQ(seasonOf(10, -40.0), Season::kSpring);
  EXPECT_EQ(seasonOf(1, 40.0), Season::kWinter);
}

TEST(Camera, OutputDoesNotDependOnTheThreadCount)
{
  Scene scene(plane(0.0, 0.03, -0.02));
  scene.setStaticPrimitives({ box(Vector3d(7, 1, 1.0), Vector3d(0.5, 1.0, 1.0), 0.4, 0) });
  scene.setBodies({ sphereBody(Vector3d(5, -1, 1), 0.5, 3) });
  CameraMaterials mat;
  CameraConfig c;
  c.width = 97;
  c.height = 61;
  c.thermal = true;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.5), 0.2, 0.1);
  CameraEnvironment e = noon();
  e.weather.fog_visibility = 400.0;
  const CameraFrame a = cam.render(scene, mat, pose, e, 1), b = cam.render(scene, mat, pose, e, 2),
                    d = cam.render(scene, mat, pose, e, 3);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(a.rgb, d.rgb);
  EXPECT_EQ(a.semantic, d.semantic);
  EXPECT_EQ(std::memcmp(a.depth.data(), d.depth.data(), a.depth.size() * sizeof(float)), 0);
  EXPECT_EQ(a.thermal, d.thermal);
}

TEST(Camera, PlumbBobDistortionRoundTrips)
{
  CameraConfig c;
  c.width = 200;
  c.height = 100;
  c.distortion = { -0.2, 0.05, 0.001, -0.002, 0.0 };
  const Camera cam(c);
  // Each pixel's ray, projected through the distortion, lands back on the pixel.
  for (int v = 0; v < c.height; v += 9)
    for (int u = 0; u < c.width; u += 13)
    {
      Eigen::Vector2d uv;
      ASSERT_TRUE(cam.project(cam.pixelRay(u, v).cast<double>(), uv));
      EXPECT_NEAR(uv.x(), u, 1e-3);
      EXPECT_NEAR(uv.y(), v, 1e-3);
    }
}

#include "avsp_sensors/camera_rig.hpp"

TEST(CameraRig, FramesOnTheirSimTimeGridsFromTheMountAtThatState)
{
  Scene scene(plane(0.0, 0, 0));
  CameraMaterials mat;
  CameraConfig front, side;
  front.name = "front";
  front.width = side.width = 32;
  front.height = side.height = 24;
  front.rate = 10.0;
  front.mount.translation() = Vector3d(1.0, 0.0, 1.5);
  side.name = "left";
  side.rate = 3.0;
  side.mount.translation() = Vector3d(0.0, 0.5, 1.5);
  side.mount.linear() = Eigen::AngleAxisd(kPi / 2, Vector3d::UnitZ()).toRotationMatrix();
  const std::uint32_t own = 5;
  CameraRig rig({ front, side }, own);
  // The optical frame of the left camera: its z (forward) along base_link +y.
  EXPECT_TRUE((rig.opticalMount(1).linear() * Vector3d::UnitZ()).isApprox(Vector3d::UnitY()));
  EXPECT_THROW(CameraRig({ front, front }, own), std::invalid_argument);
  // The vehicle's own box right in front of the front camera (hidden) and another body ahead.
  Body own_box;
  own_box.primitive.half_extents = Vector3d(0.3, 0.3, 0.3);
  own_box.primitive.centre = Vector3d(1.6, 0, 1.5);
  own_box.primitive.id = own;
  Body other;  // a wall-like body, its face square to the axis at x = 5.5
  other.primitive.half_extents = Vector3d(0.5, 2.0, 2.0);
  other.primitive.centre = Vector3d(6.0, 0.0, 1.5);
  other.primitive.id = 9;
  scene.setBodies({ own_box, other });
  std::vector<int> count(2, 0);
  for (int k = 0; k <= 200; ++k)  // 100 Hz states over 2 s
  {
    VehicleState s;
    s.time = 0.01 * k;
    for (const CameraOutput& o : rig.update(s, scene, mat, CameraEnvironment(), 1))
    {
      const double rate = o.index == 0 ? 10.0 : 3.0;
      // On the grid k / rate (the first state at or after it: here exactly on it, or 0.01 s later).
      const double late = (o.time * rate - std::floor(o.time * rate + 1e-6)) / rate;  // s after its grid time
      EXPECT_GT(late, -1e-9) << o.time;
      EXPECT_LT(late, 0.01 - 1e-6) << o.time;
      ++count[o.index];
      if (o.index == 0)
      {
        const std::size_t centre = 12 * 32 + 16;
        EXPECT_EQ(o.frame.semantic[centre], kClassVehicle);   // the other body, not the own box
        EXPECT_NEAR(o.frame.depth[centre], 5.5 - 1.0, 1e-5);  // from the camera at x = 1
      }
    }
  }
  EXPECT_EQ(count[0], 21);  // 0, 0.1, ..., 2.0
  EXPECT_EQ(count[1], 7);   // 0, 1/3, ..., 2.0
}

TEST(Camera, SrgbEncodingMatchesTheTransferFunction)
{
  for (int k = 0; k <= 1000; ++k)
  {
    const double x = k / 1000.0;
    const double s = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    const double code = 255.0 * s;
    if (std::abs(code - std::floor(code) - 0.5) < 1e-3)
      continue;  // a rounding tie: either code is right
    EXPECT_EQ(encodeSrgb(static_cast<float>(x)), std::lround(code)) << x;
  }
  EXPECT_EQ(encodeSrgb(-1.f), 0);
  EXPECT_EQ(encodeSrgb(7.f), 255);
}

TEST(Camera, SrgbEncodingStepsExactlyAtTheThresholds)
{
  // Each code k >= 1 begins at the linear value of (k - 0.5) / 255 through the inverse transfer
  // function, rounded to float: just below it the code is k - 1, at it k. Checked at every
  // threshold and on a dense sweep against a binary search over the thresholds.
  std::vector<float> t;
  for (int k = 1; k <= 255; ++k)
  {
    const double s = (k - 0.5) / 255.0;
    t.push_back(static_cast<float>(s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4)));
  }
  auto reference = [&](float x) { return static_cast<int>(std::upper_bound(t.begin(), t.end(), x) - t.begin()); };
  for (int k = 1; k <= 255; ++k)
  {
    const float at = t[k - 1];
    EXPECT_EQ(encodeSrgb(at), k) << k;
    EXPECT_EQ(encodeSrgb(std::nextafter(at, 0.f)), k - 1) << k;
  }
  for (int n = 0; n <= 2000000; ++n)
  {
    const float x = static_cast<float>(1.001 * n / 2000000.0);
    ASSERT_EQ(encodeSrgb(x), reference(x)) << x;
  }
  EXPECT_EQ(encodeSrgb(0.f), 0);
  EXPECT_EQ(encodeSrgb(std::numeric_limits<float>::quiet_NaN()), 255);
}

TEST(Camera, RainStreaksAndSnowflakesAreSeededAndOnlyInRgb)
{
  Scene scene(plane(0.0, 0, 0));
  CameraMaterials mat;
  CameraConfig c;
  c.width = 200;
  c.height = 150;
  const Camera cam(c);
  const Eigen::Isometry3d pose = opticalPose(Vector3d(0, 0, 1.5), 0.0, 0.1);
  const CameraEnvironment dry = noon();
  CameraEnvironment rain = dry, heavy = dry, snow = dry;
  rain.weather.rain_rate = 5.0;
  heavy.weather.rain_rate = 50.0;
  snow.weather.snow_rate = 5.0;
  auto changed = [&](const CameraFrame& a, const CameraFrame& b) {
    int n = 0;
    for (std::size_t k = 0; k < a.rgb.size(); ++k)
      n += a.rgb[k] != b.rgb[k];
    return n;
  };
  const CameraFrame f_dry = cam.render(scene, mat, pose, dry, 2, PrimitiveBvh::kNoId, 7);
  // Rain extinction alone (no streaks) would change the image too: compare streaked and unstreaked.
  CameraConfig plain = c;
  plain.precipitation = false;
  const Camera cam_plain(plain);
  const CameraFrame r_plain = cam_plain.render(scene, mat, pose, rain, 2, PrimitiveBvh::kNoId, 7);
  const CameraFrame r1 = cam.render(scene, mat, pose, rain, 2, PrimitiveBvh::kNoId, 7);
  const CameraFrame r1_again = cam.render(scene, mat, pose, rain, 1, PrimitiveBvh::kNoId, 7);
  const CameraFrame r2 = cam.render(scene, mat, pose, rain, 2, PrimitiveBvh::kNoId, 8);
  const CameraFrame h1 = cam.render(scene, mat, pose, heavy, 2, PrimitiveBvh::kNoId, 7);
  const CameraFrame h_plain = cam_plain.render(scene, mat, pose, heavy, 2, PrimitiveBvh::kNoId, 7);
  const CameraFrame s1 = cam.render(scene, mat, pose, snow, 2, PrimitiveBvh::kNoId, 7);
  EXPECT_EQ(changed(f_dry, cam.render(scene, mat, pose, dry, 2, PrimitiveBvh::kNoId, 99)),
            0);  // no weather: no key effect
  EXPECT_GT(changed(r_plain, r1), 100);
  EXPECT_EQ(r1.rgb, r1_again.rgb);                            // same key, same streaks (any thread count)
  EXPECT_GT(changed(r1, r2), 100);                            // another frame, other streaks
  EXPECT_GT(changed(h_plain, h1), 3 * changed(r_plain, r1));  // heavier rain, more streaks
  EXPECT_GT(changed(f_dry, s1), 100);
  EXPECT_EQ(r1.semantic, f_dry.semantic);  // streaks are in the RGB image only
  EXPECT_EQ(std::memcmp(r1.depth.data(), f_dry.depth.data(), r1.depth.size() * sizeof(float)), 0);
}
