#include "avsp_sensors/magnetometer.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <GeographicLib/MagneticModel.hpp>

namespace avsp
{
namespace sensors
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;
}

Eigen::Vector3d earthFieldEnu(const EarthField& f)
{
  const double inc = f.inclination_deg * kDegToRad, dec = f.declination_deg * kDegToRad;
  const double h = f.intensity * std::cos(inc);
  return { h * std::sin(dec), h * std::cos(dec), -f.intensity * std::sin(inc) };
}

EarthField earthFieldFromEnu(const Eigen::Vector3d& b)
{
  double horizontal = 0.0;
  EarthField f;
  GeographicLib::MagneticModel::FieldComponents(b.x(), b.y(), b.z(), horizontal, f.intensity, f.declination_deg,
                                                f.inclination_deg);
  return f;
}

void validateMagnetometerConfig(const MagnetometerConfig& c)
{
  const std::string ctx = "MagnetometerConfig";
  check::positive(ctx, "rate", c.rate);
  check::nonNegative(ctx, "field.intensity", c.field.intensity);
  check::within(ctx, "field.inclination_deg", c.field.inclination_deg, -90.0, 90.0);
  check::within(ctx, "field.declination_deg", c.field.declination_deg, -180.0, 180.0);
  check::nonNegative(ctx, "noise", c.noise);
  if (!c.offset.allFinite())
    throw std::invalid_argument(ctx + ": offset must be finite");
  const Eigen::Matrix3d r = c.mount.linear();
  if (!c.mount.matrix().allFinite())
    throw std::invalid_argument(ctx + ": mount must be finite");
  if (!(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || r.determinant() < 0.0)
    throw std::invalid_argument(ctx + ": mount rotation must be a rotation matrix");
}

namespace
{
const MagnetometerConfig& validated(const MagnetometerConfig& c)
{
  validateMagnetometerConfig(c);
  return c;
}
}  // namespace

Magnetometer::Magnetometer(MagnetometerConfig config, std::uint64_t seed)
  : config_(validated(config)), fixed_field_enu_(earthFieldEnu(config_.field)), normal_(seed), clock_(config_.rate)
{
}

MagSample Magnetometer::measure(double t, const Eigen::Isometry3d& body_pose)
{
  const std::string ctx = "Magnetometer::measure";
  if (!std::isfinite(t))
    throw std::invalid_argument(ctx + ": time is not finite");
  const Eigen::Matrix3d body_rot = body_pose.linear();
  if (!body_pose.matrix().allFinite() ||
      !(body_rot.transpose() * body_rot).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || body_rot.determinant() < 0.0)
    throw std::invalid_argument(ctx + ": body_pose is not finite or its rotation is not a rotation matrix");
  if (started_ && t < last_time_)
    throw std::invalid_argument(ctx + ": time " + std::to_string(t) + " s is earlier than the last sample (" +
                                std::to_string(last_time_) + " s)");
  const Eigen::Isometry3d sensor = body_pose * config_.mount;
  const Eigen::Vector3d field_enu = config_.model ? config_.model->at(sensor.translation()) : fixed_field_enu_;
  MagSample s;
  s.time = t;
  s.field = sensor.linear().transpose() * field_enu + config_.offset + config_.noise * normal_.vector3();
  s.covariance = Eigen::Matrix3d::Identity() * (config_.noise * config_.noise);
  started_ = true;
  last_time_ = t;
  clock_.taken(t);
  return s;
}

}  // namespace sensors
}  // namespace avsp
