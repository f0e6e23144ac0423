// IMU model: closed-form specific force and rates (at rest, tilted, turning, accelerating, lever
// arm), noise spread, bias random walk growing as sqrt(t), rate, determinism, bad configuration.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "avsp_sensors/imu.hpp"

using namespace avsp::sensors;

namespace
{
constexpr double kG = 9.81;

ImuConfig noiseFree()
{
  ImuConfig c;
  c.gyro_noise_density = c.gyro_random_walk = 0.0;
  c.accel_noise_density = c.accel_random_walk = 0.0;
  c.orientation_noise = 0.0;
  return c;
}

ImuInput at(double t, const Eigen::Matrix3d& r)
{
  ImuInput in;
  in.time = t;
  in.pose.linear() = r;
  return in;
}

Eigen::Matrix3d rotZ(double a)
{
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

std::string thrownMessage(const ImuConfig& c)
{
  try
  {
    Imu imu(c, 1);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Imu, LevelAtRestReadsPlusGOnZAndZeroRate)
{
  Imu imu(noiseFree(), 1);
  for (int k = 0; k < 3; ++k)
  {
    const ImuSample s = imu.measure(at(0.01 * k, Eigen::Matrix3d::Identity()));
    EXPECT_NEAR((s.linear_acceleration - Eigen::Vector3d(0, 0, kG)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(s.angular_velocity.norm(), 0.0, 1e-15);
    EXPECT_NEAR(s.orientation.angularDistance(Eigen::Quaterniond::Identity()), 0.0, 1e-12);
  }
}

class ImuTilt : public ::testing::TestWithParam<double>
{
};

TEST_P(ImuTilt, GravitySplitsBySinAndCosOfRollAndPitch)
{
  const double a = GetParam() * M_PI / 180.0;
  {
    Imu imu(noiseFree(), 1);  // roll a about x: gravity's reaction leans onto +y
    const ImuSample s = imu.measure(at(0.0, Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix()));
    EXPECT_NEAR(s.linear_acceleration.x(), 0.0, 1e-12);
    EXPECT_NEAR(s.linear_acceleration.y(), kG * std::sin(a), 1e-12);
    EXPECT_NEAR(s.linear_acceleration.z(), kG * std::cos(a), 1e-12);
  }
  {
    Imu imu(noiseFree(), 1);  // pitch a about y (nose down for a > 0): onto -x
    const ImuSample s = imu.measure(at(0.0, Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix()));
    EXPECT_NEAR(s.linear_acceleration.x(), -kG * std::sin(a), 1e-12);
    EXPECT_NEAR(s.linear_acceleration.y(), 0.0, 1e-12);
    EXPECT_NEAR(s.linear_acceleration.z(), kG * std::cos(a), 1e-12);
  }
}

INSTANTIATE_TEST_SUITE_P(Angles, ImuTilt, ::testing::Values(-90.0, -30.0, 5.0, 20.0, 45.0, 90.0, 180.0));

TEST(Imu, TurningBodyReadsItsYawRateAndCentripetalAcceleration)
{
  // A body driving a circle: speed v, yaw rate w (left turn), heading psi = w t; accelerations
  // left to the backward differences of the velocities at 100 Hz.
  const double v = 5.0, w = 0.5;
  Imu imu(noiseFree(), 1);
  for (int k = 0; k <= 200; ++k)
  {
    const double t = 0.01 * k, psi = w * t;
    ImuInput in = at(t, rotZ(psi));
    in.linear_velocity = v * Eigen::Vector3d(std::cos(psi), std::sin(psi), 0.0);
    in.angular_velocity = Eigen::Vector3d(0.0, 0.0, w);
    const ImuSample s = imu.measure(in);
    EXPECT_NEAR(s.angular_velocity.z(), w, 1e-12);
    EXPECT_NEAR(s.angular_velocity.head<2>().norm(), 0.0, 1e-12);
    EXPECT_NEAR(s.orientation.angularDistance(Eigen::Quaterniond(rotZ(psi))), 0.0, 1e-9);
    if (k > 0)
    {
      // Centripetal v w towards the centre (+y, left). Exactly, the backward difference of the
      // velocities over dt is (2 v / dt) sin(w dt / 2) along the left normal of the heading half
      // a step earlier: body x = (2 v / dt) sin^2(w dt / 2), y = (v / dt) sin(w dt).
      const double dt = 0.01;
      EXPECT_NEAR(s.linear_acceleration.y(), v / dt * std::sin(w * dt), 1e-9);
      EXPECT_NEAR(s.linear_acceleration.x(), 2.0 * v / dt * std::pow(std::sin(0.5 * w * dt), 2), 1e-9);
      EXPECT_NEAR(s.linear_acceleration.y(), v * w, 1e-4 * v * w);  // = v w to O((w dt)^2)
      EXPECT_NEAR(s.linear_acceleration.z(), kG, 1e-12);
    }
  }
}

TEST(Imu, YawRateOfAPitchedBodyIsResolvedIntoItsAxes)
{
  const double w = 0.8, pitch = 0.3;
  Imu imu(noiseFree(), 1);
  ImuInput in = at(0.0, Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()).toRotationMatrix());
  in.angular_velocity = Eigen::Vector3d(0.0, 0.0, w);  // turning about the map's vertical
  const ImuSample s = imu.measure(in);
  EXPECT_NEAR(s.angular_velocity.x(), -w * std::sin(pitch), 1e-12);
  EXPECT_NEAR(s.angular_velocity.y(), 0.0, 1e-12);
  EXPECT_NEAR(s.angular_velocity.z(), w * std::cos(pitch), 1e-12);
}

TEST(Imu, KnownLinearAccelerationIsRead)
{
  // Heading north (yaw 90 deg), accelerating east at 2 m/s^2: body y points west.
  const Eigen::Vector3d a(2.0, 0.0, 0.0);
  {
    Imu imu(noiseFree(), 1);
    ImuInput in = at(0.0, rotZ(M_PI / 2));
    in.linear_acceleration = a;
    EXPECT_NEAR((imu.measure(in).linear_acceleration - Eigen::Vector3d(0.0, -2.0, kG)).norm(), 0.0, 1e-12);
  }
  {
    // The same from successive velocities v = a t (exact for a constant acceleration).
    Imu imu(noiseFree(), 1);
    for (int k = 0; k <= 10; ++k)
    {
      ImuInput in = at(0.01 * k, rotZ(M_PI / 2));
      in.linear_velocity = a * (0.01 * k);
      const ImuSample s = imu.measure(in);
      if (k > 0)
      {
        EXPECT_NEAR((s.linear_acceleration - Eigen::Vector3d(0.0, -2.0, kG)).norm(), 0.0, 1e-9);
      }
    }
  }
  {
    // Free fall reads zero specific force.
    Imu imu(noiseFree(), 1);
    ImuInput in = at(0.0, Eigen::Matrix3d::Identity());
    in.linear_acceleration = Eigen::Vector3d(0.0, 0.0, -kG);
    EXPECT_NEAR(imu.measure(in).linear_acceleration.norm(), 0.0, 1e-12);
  }
}

TEST(Imu, LeverArmAddsCentripetalAndTangentialAcceleration)
{
  ImuConfig c = noiseFree();
  c.mount.translation() = Eigen::Vector3d(1.5, 0.0, 0.0);  // 1.5 m ahead of the body origin
  Imu imu(c, 1);
  const double w = 2.0, alpha = 0.5;
  ImuInput in = at(0.0, Eigen::Matrix3d::Identity());
  in.angular_velocity = Eigen::Vector3d(0.0, 0.0, w);
  in.linear_acceleration = Eigen::Vector3d::Zero();
  in.angular_acceleration = Eigen::Vector3d(0.0, 0.0, alpha);
  const ImuSample s = imu.measure(in);
  EXPECT_NEAR(s.linear_acceleration.x(), -w * w * 1.5, 1e-12);  // towards the axis
  EXPECT_NEAR(s.linear_acceleration.y(), alpha * 1.5, 1e-12);   // tangential
  EXPECT_NEAR(s.linear_acceleration.z(), kG, 1e-12);
}

TEST(Imu, MountRotationTurnsTheReadings)
{
  ImuConfig c = noiseFree();
  c.mount.linear() = rotZ(M_PI / 2);  // IMU x along the body's y
  Imu imu(c, 1);
  ImuInput in = at(0.0, Eigen::Matrix3d::Identity());
  in.linear_acceleration = Eigen::Vector3d(3.0, 0.0, 0.0);  // forward
  in.angular_velocity = Eigen::Vector3d(0.4, 0.0, 0.0);     // rolling about the body's x
  const ImuSample s = imu.measure(in);
  EXPECT_NEAR((s.linear_acceleration - Eigen::Vector3d(0.0, -3.0, kG)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((s.angular_velocity - Eigen::Vector3d(0.0, -0.4, 0.0)).norm(), 0.0, 1e-12);
}

TEST(Imu, WhiteNoiseSpreadIsDensityTimesSqrtRate)
{
  ImuConfig c = noiseFree();
  c.gyro_noise_density = 1.92e-4;
  c.accel_noise_density = 1.83e-3;
  c.orientation_noise = 0.01;
  c.rate = 200.0;
  Imu imu(c, 5);
  const int n = 20000;
  Eigen::Vector3d sg = Eigen::Vector3d::Zero(), sg2 = sg, sa = sg, sa2 = sg;
  double so2 = 0.0;
  ImuSample s;
  for (int k = 0; k < n; ++k)
  {
    s = imu.measure(at(k / 200.0, Eigen::Matrix3d::Identity()));
    sg += s.angular_velocity;
    sg2 += s.angular_velocity.cwiseAbs2();
    const Eigen::Vector3d ea = s.linear_acceleration - Eigen::Vector3d(0, 0, kG);
    sa += ea;
    sa2 += ea.cwiseAbs2();
    const double angle = s.orientation.angularDistance(Eigen::Quaterniond::Identity());
    so2 += angle * angle;
  }
  const double sigma_g = 1.92e-4 * std::sqrt(200.0), sigma_a = 1.83e-3 * std::sqrt(200.0);
  for (int k = 0; k < 3; ++k)
  {
    EXPECT_NEAR(sg[k] / n, 0.0, 4.0 * sigma_g / std::sqrt(n));
    EXPECT_NEAR(sa[k] / n, 0.0, 4.0 * sigma_a / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(sg2[k] / n) / sigma_g, 1.0, 0.03);
    EXPECT_NEAR(std::sqrt(sa2[k] / n) / sigma_a, 1.0, 0.03);
  }
  // Orientation: a rotation by sigma_o n, n a 3-vector of unit normals: E[angle^2] = 3 sigma_o^2.
  EXPECT_NEAR(std::sqrt(so2 / n / 3.0) / 0.01, 1.0, 0.03);
  EXPECT_NEAR(s.angular_velocity_covariance(0, 0), sigma_g * sigma_g, 1e-18);
  EXPECT_NEAR(s.linear_acceleration_covariance(2, 2), sigma_a * sigma_a, 1e-15);
  EXPECT_NEAR(s.orientation_covariance(1, 1), 1e-4, 1e-15);
}

TEST(Imu, BiasRandomWalkGrowsAsSqrtT)
{
  // 300 IMUs at rest for 40 s at 100 Hz: across them, each bias axis has sigma = K sqrt(t).
  ImuConfig c = noiseFree();
  c.gyro_random_walk = 2.22e-6;
  c.accel_random_walk = 7.75e-5;
  const int runs = 300;
  std::vector<double> g10, g40, a10, a40;
  for (int r = 0; r < runs; ++r)
  {
    Imu imu(c, 1000 + r);
    for (int k = 0; k <= 4000; ++k)
    {
      imu.measure(at(0.01 * k, Eigen::Matrix3d::Identity()));
      if (k == 1000 || k == 4000)
        for (int a = 0; a < 3; ++a)
        {
          (k == 1000 ? g10 : g40).push_back(imu.gyroBias()[a]);
          (k == 1000 ? a10 : a40).push_back(imu.accelBias()[a]);
        }
    }
  }
  const auto rms = [](const std::vector<double>& x) {
    double s = 0.0;
    for (double v : x)
      s += v * v;
    return std::sqrt(s / x.size());
  };
  // 900 values per estimate: the rms has a standard error of ~2.4 %; 8 % is > 3 se.
  EXPECT_NEAR(rms(g10) / (2.22e-6 * std::sqrt(10.0)), 1.0, 0.08);
  EXPECT_NEAR(rms(g40) / (2.22e-6 * std::sqrt(40.0)), 1.0, 0.08);
  EXPECT_NEAR(rms(a10) / (7.75e-5 * std::sqrt(10.0)), 1.0, 0.08);
  EXPECT_NEAR(rms(a40) / (7.75e-5 * std::sqrt(40.0)), 1.0, 0.08);
  // Four times the time, twice the spread.
  EXPECT_NEAR(rms(g40) / rms(g10), 2.0, 0.2);
  EXPECT_NEAR(rms(a40) / rms(a10), 2.0, 0.2);
}

TEST(Imu, SamplesComeAtTheConfiguredRate)
{
  Imu imu(ImuConfig(), 1);  // 100 Hz
  int samples = 0;
  for (int k = 0; k < 10000; ++k)  // polled at 10 kHz for 1 s
  {
    const double t = 1e-4 * k;
    if (imu.due(t))
    {
      imu.measure(at(t, Eigen::Matrix3d::Identity()));
      ++samples;
    }
  }
  EXPECT_EQ(samples, 100);
  EXPECT_GE(ImuConfig().rate, 100.0);
}

TEST(Imu, SameSeedSameSamples)
{
  Imu a(ImuConfig(), 8), b(ImuConfig(), 8), c(ImuConfig(), 9);
  bool differs = false;
  for (int k = 0; k < 100; ++k)
  {
    const ImuSample sa = a.measure(at(0.01 * k, rotZ(0.1 * k))), sb = b.measure(at(0.01 * k, rotZ(0.1 * k))),
                    sc = c.measure(at(0.01 * k, rotZ(0.1 * k)));
    EXPECT_EQ(sa.linear_acceleration, sb.linear_acceleration);
    EXPECT_EQ(sa.angular_velocity, sb.angular_velocity);
    EXPECT_EQ(sa.orientation.coeffs(), sb.orientation.coeffs());
    differs = differs || sa.linear_acceleration != sc.linear_acceleration;
  }
  EXPECT_TRUE(differs);
}

TEST(Imu, BadConfigNamesTheField)
{
  ImuConfig c;
  c.rate = -100.0;
  EXPECT_NE(thrownMessage(c).find("rate"), std::string::npos);
  c = ImuConfig();
  c.gyro_noise_density = std::nan("");
  EXPECT_NE(thrownMessage(c).find("gyro_noise_density"), std::string::npos);
  c = ImuConfig();
  c.accel_random_walk = -1e-3;
  EXPECT_NE(thrownMessage(c).find("accel_random_walk"), std::string::npos);
  c = ImuConfig();
  c.mount.linear() = Eigen::Matrix3d::Identity() * 2.0;
  EXPECT_NE(thrownMessage(c).find("mount"), std::string::npos);
}

TEST(Imu, BadInputIsRejected)
{
  Imu imu(ImuConfig(), 1);
  imu.measure(at(1.0, Eigen::Matrix3d::Identity()));
  EXPECT_THROW(imu.measure(at(0.5, Eigen::Matrix3d::Identity())), std::invalid_argument);
  ImuInput in = at(2.0, Eigen::Matrix3d::Identity());
  in.angular_velocity.x() = std::nan("");
  EXPECT_THROW(imu.measure(in), std::invalid_argument);
  EXPECT_THROW(imu.measure(at(2.0, Eigen::Matrix3d::Identity() * 1.1)), std::invalid_argument);
}
