// Ultrasonic cone: a wall at a known distance within the cone gives that range; a tilted wall the
// nearest of the sampled rays; objects outside the cone or beyond max range give +inf, nearer
// than min range -inf (REP 117); own body ignored; noise; bad configuration.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/scene.hpp"
#include "avsp_sensors/ultrasonic.hpp"

using namespace avsp::sensors;
using Eigen::Vector3d;

namespace
{
constexpr double kDeg = M_PI / 180.0;

Scene flatGround(double half = 50.0, double cell = 1.0)
{
  const auto n = static_cast<std::size_t>(2 * half / cell) + 1;
  return Scene(HeightField(-half, -half, cell, cell, n, n, std::vector<float>(n * n, 0.f)));
}

/// A wall 0.2 m thick, 4 m wide, 2 m tall whose front face is the plane through `face_centre`
/// with outward normal at azimuth `normal_azimuth` (rad; pi = facing back at a sensor on +x).
Primitive wall(const Vector3d& face_centre, double normal_azimuth)
{
  Primitive w;
  w.shape = Shape::kBox;
  w.half_extents = Vector3d(0.1, 2.0, 1.0);
  w.rotation = Eigen::AngleAxisd(normal_azimuth - M_PI, Vector3d::UnitZ()).toRotationMatrix();
  w.centre = face_centre - 0.1 * Vector3d(std::cos(normal_azimuth), std::sin(normal_azimuth), 0.0);
  w.id = 1;
  return w;
}

Primitive pole(const Vector3d& base, double radius)
{
  Primitive p;
  p.shape = Shape::kCylinder;
  p.half_extents = Vector3d(radius, radius, 1.5);
  p.centre = base + Vector3d(0, 0, 1.5);
  p.id = 2;
  return p;
}

UltrasonicConfig noiseFree()
{
  UltrasonicConfig c;
  c.noise = 0.0;
  return c;
}

/// Sensor 1 m above the ground looking along +x: the 7.5 deg half cone reaches the ground only at
/// 7.6 m, beyond the 4 m maximum range.
Eigen::Isometry3d sensorPose()
{
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Vector3d(0.0, 0.0, 1.0);
  return p;
}

std::string thrownMessage(const UltrasonicConfig& c)
{
  try
  {
    Ultrasonic u(c, 1);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

class UltrasonicWall : public ::testing::TestWithParam<double>
{
};

TEST_P(UltrasonicWall, WallAheadGivesItsDistance)
{
  const double d = GetParam();
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(Vector3d(d, 0.0, 1.0), M_PI) });
  Ultrasonic us(noiseFree(), 1);
  const UltrasonicReading r = us.measure(scene, 0.0, sensorPose());
  ASSERT_TRUE(r.detected);
  EXPECT_NEAR(r.range, d, 1e-9);  // the axis ray meets the wall square on
  EXPECT_EQ(r.field_of_view, 15.0 * kDeg);
  EXPECT_EQ(r.min_range, 0.02);
  EXPECT_EQ(r.max_range, 4.0);
}

INSTANTIATE_TEST_SUITE_P(Distances, UltrasonicWall, ::testing::Values(0.05, 0.5, 1.0, 2.5, 3.99));

TEST(Ultrasonic, TiltedWallGivesTheNearestSampledRay)
{
  // A wall at perpendicular distance p whose normal is 5 deg off the axis: a ray with direction u
  // meets it at p / (u . n_in); the reading is the smallest over the cone's rays, between p
  // (the perpendicular, if a ray lay along it) and the axis ray's p / cos 5 deg.
  const double p = 2.0, tilt = 5.0 * kDeg;
  const Vector3d n_in(std::cos(tilt), std::sin(tilt), 0.0);  // from the sensor towards the wall
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(Vector3d(0, 0, 1.0) + p * n_in, M_PI + tilt) });
  Ultrasonic us(noiseFree(), 1);
  double expected = std::numeric_limits<double>::infinity();
  for (const Vector3d& u : us.rayDirections())
    expected = std::min(expected, p / u.dot(n_in));
  const UltrasonicReading r = us.measure(scene, 0.0, sensorPose());
  ASSERT_TRUE(r.detected);
  EXPECT_NEAR(r.range, expected, 1e-9);
  EXPECT_GE(r.range, p);
  EXPECT_LT(r.range, p / std::cos(tilt));
}

TEST(Ultrasonic, OutsideTheConeOrBeyondMaxRangeIsPlusInfinity)
{
  Ultrasonic us(noiseFree(), 1);
  {
    Scene scene = flatGround();  // nothing at all within 4 m
    const UltrasonicReading r = us.measure(scene, 0.0, sensorPose());
    EXPECT_FALSE(r.detected);
    EXPECT_EQ(r.range, std::numeric_limits<double>::infinity());
  }
  {
    Scene scene = flatGround();  // a wall at 4.5 m, beyond the 4 m maximum
    scene.setStaticPrimitives({ wall(Vector3d(4.5, 0.0, 1.0), M_PI) });
    EXPECT_EQ(us.measure(scene, 0.1, sensorPose()).range, std::numeric_limits<double>::infinity());
  }
  // A 10 cm pole 2 m away: seen 5 deg off the axis, not 12 deg off (half-angle 7.5 deg).
  for (const double az_deg : { 5.0, 12.0 })
  {
    Scene scene = flatGround();
    const double az = az_deg * kDeg;
    scene.setStaticPrimitives({ pole(Vector3d(2.0 * std::cos(az), 2.0 * std::sin(az), 0.0), 0.05) });
    const UltrasonicReading r = us.measure(scene, 0.2 + az_deg, sensorPose());
    if (az_deg < 7.5)
    {
      ASSERT_TRUE(r.detected);
      EXPECT_GT(r.range, 1.95 - 1e-9);  // the pole's front is 1.95 m from the sensor's axis line
      EXPECT_LT(r.range, 2.0);
    }
    else
      EXPECT_EQ(r.range, std::numeric_limits<double>::infinity()) << az_deg;
  }
}

TEST(Ultrasonic, NearerThanMinRangeIsMinusInfinity)
{
  UltrasonicConfig c = noiseFree();
  c.min_range = 0.2;
  Ultrasonic us(c, 1);
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(Vector3d(0.1, 0.0, 1.0), M_PI) });
  const UltrasonicReading r = us.measure(scene, 0.0, sensorPose());
  EXPECT_FALSE(r.detected);
  EXPECT_EQ(r.range, -std::numeric_limits<double>::infinity());
}

TEST(Ultrasonic, OwnBodyIsIgnoredAndPoseTurnsTheCone)
{
  Scene scene = flatGround();
  Body self;
  self.primitive.shape = Shape::kBox;
  self.primitive.half_extents = Vector3d(0.5, 0.5, 0.5);
  self.primitive.centre = Vector3d(-0.3, 0.0, 1.0);  // the sensor sits inside the front of its body
  self.primitive.id = 7;
  Body other = self;
  other.primitive.centre = Vector3d(0.0, 3.0, 1.0);  // 2.5 m to the left (its face at y = 2.5)
  other.primitive.id = 8;
  scene.setBodies({ self, other });
  Ultrasonic us(noiseFree(), 1);
  Eigen::Isometry3d left = sensorPose();
  left.linear() = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()).toRotationMatrix();  // looking along +y
  EXPECT_NEAR(us.measure(scene, 0.0, left, 7).range, 2.5, 1e-9);
  EXPECT_EQ(us.measure(scene, 0.1, sensorPose(), 7).range, std::numeric_limits<double>::infinity());
}

TEST(Ultrasonic, NoiseSpreadAndRate)
{
  UltrasonicConfig c;
  c.noise = 0.01;
  c.rate = 20.0;
  Ultrasonic us(c, 3);
  Scene scene = flatGround();
  scene.setStaticPrimitives({ wall(Vector3d(2.0, 0.0, 1.0), M_PI) });
  const int n = 4000;
  double sum = 0.0, sum2 = 0.0;
  int samples = 0;
  for (int k = 0; k < 100 * n && samples < n; ++k)
  {
    const double t = 0.001 * k;
    if (!us.due(t))
      continue;
    const double e = us.measure(scene, t, sensorPose()).range - 2.0;
    sum += e;
    sum2 += e * e;
    ++samples;
  }
  ASSERT_EQ(samples, n);  // 4000 readings took 200 s at 20 Hz
  EXPECT_NEAR(sum / n, 0.0, 4.0 * 0.01 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(sum2 / n) / 0.01, 1.0, 0.05);
}

TEST(Ultrasonic, BadConfigNamesTheField)
{
  UltrasonicConfig c;
  c.field_of_view = 0.0;
  EXPECT_NE(thrownMessage(c).find("field_of_view"), std::string::npos);
  c = UltrasonicConfig();
  c.max_range = 0.01;  // below min_range
  EXPECT_NE(thrownMessage(c).find("max_range"), std::string::npos);
  c = UltrasonicConfig();
  c.min_range = -1.0;
  EXPECT_NE(thrownMessage(c).find("min_range"), std::string::npos);
  c = UltrasonicConfig();
  c.rays_per_ring = 2;
  EXPECT_NE(thrownMessage(c).find("rays_per_ring"), std::string::npos);
  c = UltrasonicConfig();
  c.rings = 0;
  EXPECT_NE(thrownMessage(c).find("rings"), std::string::npos);
  c = UltrasonicConfig();
  c.noise = std::nan("");
  EXPECT_NE(thrownMessage(c).find("noise"), std::string::npos);
}
