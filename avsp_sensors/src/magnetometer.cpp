#include "avsp_sensors/magnetometer.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

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

Eigen::Vector3d dipoleFieldEcef(const Eigen::Vector3d& ecef)
{
  const double r = ecef.norm();
  if (!ecef.allFinite() || !(r > 0.0))
    throw std::invalid_argument("dipoleFieldEcef: position must be finite and away from the Earth's centre");
  using namespace igrf13_dipole;
  const Eigen::Vector3d g = Eigen::Vector3d(kG11, kH11, kG10) * 1e-9;  // T
  const Eigen::Vector3d u = ecef / r;
  const double s = kReferenceRadius / r;
  return s * s * s * (3.0 * g.dot(u) * u - g);
}

EarthField dipoleEarthField(const Geodetic& p)
{
  const Eigen::Vector3d b = dipoleFieldEcef(geodeticToEcef(p));
  const double lat = p.latitude_deg * kDegToRad, lon = p.longitude_deg * kDegToRad;
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  const double east = -so * b.x() + co * b.y();
  const double north = -sl * co * b.x() - sl * so * b.y() + cl * b.z();
  const double up = cl * co * b.x() + cl * so * b.y() + sl * b.z();
  EarthField f;
  f.intensity = b.norm();
  f.inclination_deg = std::atan2(-up, std::hypot(east, north)) / kDegToRad;
  f.declination_deg = std::atan2(east, north) / kDegToRad;
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
  : config_(validated(config)), field_enu_(earthFieldEnu(config_.field)), normal_(seed), clock_(config_.rate)
{
}

MagSample Magnetometer::measure(double t, const Eigen::Quaterniond& body_orientation)
{
  const std::string ctx = "Magnetometer::measure";
  if (!std::isfinite(t))
    throw std::invalid_argument(ctx + ": time is not finite");
  if (!body_orientation.coeffs().allFinite() || std::abs(body_orientation.norm() - 1.0) > 1e-6)
    throw std::invalid_argument(ctx + ": body_orientation is not a unit quaternion");
  if (started_ && t < last_time_)
    throw std::invalid_argument(ctx + ": time " + std::to_string(t) + " s is earlier than the last sample (" +
                                std::to_string(last_time_) + " s)");
  const Eigen::Matrix3d rot = body_orientation.toRotationMatrix() * config_.mount.linear();
  MagSample s;
  s.time = t;
  s.field = rot.transpose() * field_enu_ + config_.offset + config_.noise * normal_.vector3();
  s.covariance = Eigen::Matrix3d::Identity() * (config_.noise * config_.noise);
  started_ = true;
  last_time_ = t;
  clock_.taken(t);
  return s;
}

}  // namespace sensors
}  // namespace avsp
