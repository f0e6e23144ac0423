#include "avsp_terrain/terramechanics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace terrain
{
double shearStrength(const SoilParameters& soil, double sigma)
{
  return soil.cohesion + std::max(sigma, 0.0) * std::tan(soil.friction_angle);
}

double shearStress(const SoilParameters& soil, double sigma, double j)
{
  return shearStrength(soil, sigma) * (1.0 - std::exp(-std::abs(j) / soil.shear_modulus));
}

double meanShearStress(const SoilParameters& soil, double sigma, double slip, double x0, double x1)
{
  const double s = std::abs(slip);
  const double length = x1 - x0;
  if (!(length > 0.0))
    return 0.0;
  const double k = soil.shear_modulus;
  // (1/L) * integral of (1 - exp(-s x / K)) dx from x0 to x1; for s -> 0 the bracket
  // vanishes like s, so use the limit form when s x / K is tiny to avoid cancellation.
  double mean;
  if (s * x1 / k < 1e-8)
    mean = s * (x0 + x1) / (2.0 * k);
  else
    mean = 1.0 - k / (s * length) * (std::exp(-s * x0 / k) - std::exp(-s * x1 / k));
  const double tau = shearStrength(soil, sigma) * mean;
  return slip < 0.0 ? -tau : tau;
}

double tractionForce(const SoilParameters& soil, const std::vector<ContactStrip>& strips, double slip)
{
  double force = 0.0;
  for (const ContactStrip& strip : strips)
    force += meanShearStress(soil, strip.sigma, slip, strip.x_front, strip.x_back) * strip.area;
  return force;
}

double janosiTractiveEffort(const SoilParameters& soil, double area, double length, double load, double slip)
{
  const double s = std::abs(slip);
  const double k = soil.shear_modulus;
  const double envelope = area * soil.cohesion + load * std::tan(soil.friction_angle);
  const double factor =
      (s * length / k < 1e-8) ? s * length / (2.0 * k) : 1.0 - k / (s * length) * (1.0 - std::exp(-s * length / k));
  return (slip < 0.0 ? -1.0 : 1.0) * envelope * factor;
}

double longitudinalSlip(double v_theoretical, double v_actual)
{
  const double vt = std::abs(v_theoretical);
  const double v = std::abs(v_actual);
  if (vt == 0.0 && v == 0.0)
    return 0.0;
  // Driving when the running gear is faster than the ground speed, braking (skid) otherwise;
  // the sign of motion is that of the faster of the two.
  const bool driving = vt >= v;
  const double direction = (driving ? v_theoretical : v_actual) < 0.0 ? -1.0 : 1.0;
  const double s = direction * (v_theoretical - v_actual) / (driving ? vt : v);
  return std::clamp(s, -1.0, 1.0);
}

double regularisedSlip(double v_theoretical, double v_actual, double v0)
{
  const double scale = std::max({ std::abs(v_actual), std::abs(v_theoretical), v0 });
  return std::clamp((v_theoretical - v_actual) / scale, -1.0, 1.0);
}

double wheelTheoreticalSpeed(double radius, double omega)
{
  return radius * omega;
}

double trackTheoreticalSpeed(double pitch, int teeth, double omega)
{
  return pitch * teeth * omega / (2.0 * M_PI);
}

double plasticSinkage(const SoilParameters& soil, double sigma_max)
{
  // Mass in the column is conserved: h0 rho0 = (h0 - z_p) rho(sigma).
  return soil.h0 * (1.0 - soil.rho0 / soil.compression.density(sigma_max));
}

double elasticSinkage(const SoilParameters& soil, double sigma, double z)
{
  return std::max(soil.h0 - z, 0.0) * soil.elastic_e * std::max(sigma, 0.0);
}

double resistanceForce(const SoilParameters& soil, double sigma, double width, double z_rel, double area)
{
  return shearStrength(soil, sigma) * width * std::max(z_rel, 0.0) +
         soil.rolling_resistance * area * std::max(sigma, 0.0);
}

double bekkerPressure(const SoilParameters& soil, double b, double z)
{
  if (!(z > 0.0))
    return 0.0;
  return (soil.k_c / b + soil.k_phi) * std::pow(z, soil.n);
}

RigidWheelLoad rigidWheelOnBekkerSoil(const SoilParameters& soil, double radius, double width, double sinkage,
                                      int samples)
{
  RigidWheelLoad out{ 0.0, 0.0, 0.0 };
  if (!(sinkage > 0.0))
    return out;
  const double z0 = std::min(sinkage, radius);
  // Front arc from the bottom (theta = 0) to the entry angle theta1, cos(theta1) = 1 - z0/r.
  const double theta1 = std::acos(1.0 - z0 / radius);
  const double dtheta = theta1 / samples;
  for (int k = 0; k < samples; ++k)
  {
    const double theta = (k + 0.5) * dtheta;
    const double z = radius * std::cos(theta) - (radius - z0);  // local sinkage
    const double p = bekkerPressure(soil, width, z);
    // Radial pressure on the rim element r dtheta: vertical and horizontal components.
    out.normal_force += p * std::cos(theta) * width * radius * dtheta;
    out.compaction_resistance += p * std::sin(theta) * width * radius * dtheta;
  }
  out.contact_length = radius * std::sin(theta1);
  return out;
}

namespace
{
/// The sinkage in [0, radius] at which `normal(z)` (increasing) carries `load`, by bisection.
template <typename Normal>
double sinkageCarrying(const char* fn, const SoilParameters& soil, double radius, double load, Normal normal)
{
  if (!(load > 0.0))
    return 0.0;
  if (normal(radius) < load)
    throw std::domain_error(std::string(fn) + ": soil '" + soil.name +
                            "' cannot carry the load before the wheel sinks to its axle");
  double lo = 0.0, hi = radius;
  for (int k = 0; k < 100 && hi - lo > 1e-12; ++k)
  {
    const double mid = 0.5 * (lo + hi);
    (normal(mid) < load ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}
}  // namespace

double rigidWheelStaticSinkage(const SoilParameters& soil, double radius, double width, double load)
{
  return sinkageCarrying("rigidWheelStaticSinkage", soil, radius, load,
                         [&](double z) { return rigidWheelOnBekkerSoil(soil, radius, width, z).normal_force; });
}

RigidWheelLoad rollingWheelOnBekkerSoil(const SoilParameters& soil, double radius, double width, double sinkage,
                                        int samples)
{
  RigidWheelLoad out = rigidWheelOnBekkerSoil(soil, radius, width, sinkage, samples);
  if (!(sinkage > 0.0) || !(soil.k_unload > 0.0))
    return out;
  // Behind the bottom the soil, pressed to z0 at p_max, springs back by p_max / k_unload and
  // presses on the rim with p_max - k_unload (z0 - z) until the rim has risen that far.
  const double z0 = std::min(sinkage, radius);
  const double p_max = bekkerPressure(soil, width, z0);
  const double rise = std::min(p_max / soil.k_unload, z0);
  const double theta2 = std::acos(1.0 - rise / radius);
  const double dtheta = theta2 / samples;
  for (int k = 0; k < samples; ++k)
  {
    const double theta = (k + 0.5) * dtheta;
    const double p = std::max(p_max - soil.k_unload * radius * (1.0 - std::cos(theta)), 0.0);
    out.normal_force += p * std::cos(theta) * width * radius * dtheta;
    out.compaction_resistance -= p * std::sin(theta) * width * radius * dtheta;  // pushes forward
  }
  return out;
}

double rollingWheelTraction(const SoilParameters& soil, double radius, double width, double sinkage, double slip,
                            int samples)
{
  if (!(sinkage > 0.0))
    return 0.0;
  const double z0 = std::min(sinkage, radius);
  const double theta1 = std::acos(1.0 - z0 / radius);
  const double p_max = bekkerPressure(soil, width, z0);
  const double rise = soil.k_unload > 0.0 ? std::min(p_max / soil.k_unload, z0) : 0.0;
  const double theta2 = std::acos(1.0 - rise / radius);
  const double lead = radius * std::sin(theta1);  // the leading edge, ahead of the bottom
  const double s = std::abs(slip);
  double out = 0.0;
  // theta from the leading edge (theta1) back to the rear's end (-theta2), + ahead of the bottom.
  const double dtheta = (theta1 + theta2) / samples;
  for (int k = 0; k < samples; ++k)
  {
    const double theta = theta1 - (k + 0.5) * dtheta;
    const double p = theta >= 0.0 ? bekkerPressure(soil, width, radius * std::cos(theta) - (radius - z0))
                                  : std::max(p_max - soil.k_unload * radius * (1.0 - std::cos(theta)), 0.0);
    const double x = lead - radius * std::sin(theta);
    out += shearStress(soil, p, s * x) * width * radius * std::cos(theta) * dtheta;
  }
  return slip < 0.0 ? -out : out;
}

double rollingWheelSinkage(const SoilParameters& soil, double radius, double width, double load)
{
  return sinkageCarrying("rollingWheelSinkage", soil, radius, load,
                         [&](double z) { return rollingWheelOnBekkerSoil(soil, radius, width, z).normal_force; });
}

double bekkerStaticSinkageClosedForm(const SoilParameters& soil, double diameter, double width, double load)
{
  const double n = soil.n;
  return std::pow(3.0 * load / ((3.0 - n) * (soil.k_c + width * soil.k_phi) * std::sqrt(diameter)),
                  2.0 / (2.0 * n + 1.0));
}

double bekkerCompactionResistanceClosedForm(const SoilParameters& soil, double width, double sinkage)
{
  return (soil.k_c + width * soil.k_phi) * std::pow(sinkage, soil.n + 1.0) / (soil.n + 1.0);
}

}  // namespace terrain
}  // namespace avsp
