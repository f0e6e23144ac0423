#include "avsp_dynamics/dem/virtual_bevameter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "avsp_dynamics/dem/wheel_rig.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
namespace
{
constexpr double kGravity = 9.81;

[[noreturn]] void fail(const std::string& key, const std::string& why)
{
  throw DemParameterError("dem.bevameter." + key + ": " + why);
}

/// Slope and intercept of the least-squares line y = a x + b.
std::pair<double, double> line(const std::vector<double>& x, const std::vector<double>& y)
{
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
  {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  const double den = n * sxx - sx * sx;
  if (!(std::abs(den) > 1e-30))
    return { std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN() };
  const double a = (n * sxy - sx * sy) / den;
  return { a, (sy - a * sx) / n };
}
}  // namespace

BekkerFit fitBekker(const std::vector<PlateSinkageCurve>& plates, double z_min, double z_max)
{
  if (plates.size() < 2)
    fail("plate_widths", "Bekker's k_c and k_phi need plates of two or more widths");
  // A common exponent n: the slope of log p against log z, each plate with its own intercept.
  struct Points
  {
    std::vector<double> x, y;
    double mx = 0.0, my = 0.0;
  };
  std::vector<Points> pts(plates.size());
  double num = 0.0, den = 0.0;
  for (std::size_t j = 0; j < plates.size(); ++j)
  {
    auto& P = pts[j];
    for (std::size_t i = 0; i < plates[j].sinkage.size(); ++i)
      if (plates[j].sinkage[i] >= z_min && plates[j].sinkage[i] <= z_max && plates[j].pressure[i] > 0.0)
      {
        P.x.push_back(std::log(plates[j].sinkage[i]));
        P.y.push_back(std::log(plates[j].pressure[i]));
      }
    if (P.x.size() < 3)
      fail("plates", "plate " + std::to_string(j) + " has fewer than 3 loaded points between " + std::to_string(z_min) +
                         " and " + std::to_string(z_max) + " m of sinkage");
    for (std::size_t i = 0; i < P.x.size(); ++i)
    {
      P.mx += P.x[i] / P.x.size();
      P.my += P.y[i] / P.y.size();
    }
    for (std::size_t i = 0; i < P.x.size(); ++i)
    {
      num += (P.x[i] - P.mx) * (P.y[i] - P.my);
      den += (P.x[i] - P.mx) * (P.x[i] - P.mx);
    }
  }
  BekkerFit fit;
  fit.n = num / den;
  // k = k_c / b + k_phi per plate: a line in 1 / b.
  std::vector<double> inv_b, k;
  double se = 0.0;
  int count = 0;
  for (std::size_t j = 0; j < plates.size(); ++j)
  {
    const double intercept = pts[j].my - fit.n * pts[j].mx;
    inv_b.push_back(1.0 / plates[j].width);
    k.push_back(std::exp(intercept));
    for (std::size_t i = 0; i < pts[j].x.size(); ++i)
    {
      const double e = intercept + fit.n * pts[j].x[i] - pts[j].y[i];
      se += e * e;
      ++count;
    }
  }
  const auto [kc, kphi] = line(inv_b, k);
  if (!std::isfinite(kc))
    fail("plate_widths", "the plates must differ in width");
  fit.k_c = kc;
  fit.k_phi = kphi;
  fit.rms_log_error = std::sqrt(se / count);
  return fit;
}

ShearFit fitShear(const std::vector<ShearCurve>& curves)
{
  if (curves.size() < 2)
    fail("normal_stresses", "c and phi need shear tests at two or more normal stresses");
  ShearFit fit;
  std::vector<double> sigma;
  for (const auto& c : curves)
  {
    if (c.displacement.empty())
      fail("shears", "a shear test recorded nothing");
    const double j_end = c.displacement.back();
    double sum = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < c.displacement.size(); ++i)
      if (c.displacement[i] >= 0.75 * j_end)
      {
        sum += c.shear_stress[i];
        ++n;
      }
    fit.peak_stress.push_back(sum / std::max(n, 1));
    sigma.push_back(c.normal_stress);
  }
  auto [tan_phi, c] = line(sigma, fit.peak_stress);
  if (!std::isfinite(tan_phi))
    fail("normal_stresses", "the shear tests must differ in normal stress");
  if (c < 0.0)
  {
    // A granular bed has no tensile strength: a negative intercept is scatter. Refit through
    // the origin (a cohesionless soil).
    double sxy = 0.0, sxx = 0.0;
    for (std::size_t i = 0; i < sigma.size(); ++i)
    {
      sxy += sigma[i] * fit.peak_stress[i];
      sxx += sigma[i] * sigma[i];
    }
    tan_phi = sxy / sxx;
    c = 0.0;
  }
  fit.cohesion = c;
  fit.friction_angle = std::atan(tan_phi);
  // K: least squares of tau / tau_max against 1 - exp(-j / K), golden-section search on log K.
  auto cost = [&](double log_k) {
    const double K = std::exp(log_k);
    double s = 0.0;
    for (std::size_t j = 0; j < curves.size(); ++j)
      for (std::size_t i = 0; i < curves[j].displacement.size(); ++i)
      {
        const double e =
            curves[j].shear_stress[i] / fit.peak_stress[j] - (1.0 - std::exp(-curves[j].displacement[i] / K));
        s += e * e;
      }
    return s;
  };
  double a = std::log(1e-5), b = std::log(1.0);
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 80; ++it)
  {
    const double c1 = b - g * (b - a), c2 = a + g * (b - a);
    if (cost(c1) < cost(c2))
      b = c2;
    else
      a = c1;
  }
  fit.shear_modulus = std::exp(0.5 * (a + b));
  return fit;
}

PlateSinkageCurve plateSinkageTest(DemWorld& world, double width, double length, double speed, double max_sinkage)
{
  const auto& d = world.domain();
  const double x = 0.5 * (d.x_min + d.x_max), y = 0.5 * (d.y_min + d.y_max);
  PlateSinkageCurve curve;
  curve.width = width;
  curve.length = length;
  const double surface = bedSurface(world, x, y, length, width);
  const double top = world.highestTop(x - 0.5 * length, x + 0.5 * length, y - 0.5 * width, y + 0.5 * width);
  const Eigen::Vector3d centre(x, y, top + 0.002);
  const int plate = world.addBody(plateMesh(centre, length, width), centre, Eigen::Vector3d::Zero());
  world.setBodyVelocity(plate, Eigen::Vector3d(0, 0, -speed), 0.0);
  const int max_steps = static_cast<int>(std::ceil((top + 0.002 - surface + max_sinkage) / speed /
                                                   world.parameters().coupling_interval)) +
                        1;
  for (int k = 0; k < max_steps; ++k)
  {
    world.step();
    const auto load = world.load(plate);
    // Mid-interval height: the interval's mean force belongs to the plate's mean position.
    const double z = surface - (load.reference.z() + 0.5 * speed * world.parameters().coupling_interval);
    curve.sinkage.push_back(z);
    curve.pressure.push_back(load.force.z() / (width * length));
    if (z >= max_sinkage)
      break;
  }
  return curve;
}

ShearCurve shearTest(DemWorld& world, const BevameterSpec& spec, double normal_stress)
{
  const auto& d = world.domain();
  const double L = spec.shear_plate_length, b = spec.shear_plate_width, area = L * b;
  const double x = d.x_min + 0.5 * L + 2.0 * maxRadius(world.parameters()) + 0.01;
  const double y = 0.5 * (d.y_min + d.y_max);
  if (x + 0.5 * L + spec.shear_travel > d.x_max - 2.0 * maxRadius(world.parameters()))
    fail("shear_travel", "the plate and its travel do not fit in the bed");
  const double top = world.highestTop(x - 0.5 * L, x + 0.5 * L, y - 0.5 * b, y + 0.5 * b);
  const Eigen::Vector3d centre(x, y, top + 0.002 + spec.grouser_height);
  auto mesh = plateMesh(centre, L, b);
  for (int g = 0; g < spec.grousers; ++g)
  {
    // Transverse lugs under the plate, evenly along it.
    const double gx = x - 0.5 * L + (g + 0.5) * L / spec.grousers;
    const Eigen::Vector3d a(gx, y - 0.5 * b, centre.z()), c(gx, y + 0.5 * b, centre.z() - spec.grouser_height);
    mesh.push_back({ a, Eigen::Vector3d(gx, y + 0.5 * b, centre.z()), c });
    mesh.push_back({ a, c, Eigen::Vector3d(gx, y - 0.5 * b, centre.z() - spec.grouser_height) });
  }
  const int plate = world.addBody(mesh, centre, Eigen::Vector3d::Zero());
  const double weight = normal_stress * area, h = world.parameters().coupling_interval;
  world.setBodyVelocity(plate, Eigen::Vector3d(0, 0, -0.1), 0.0);
  for (int k = 0; k < 2000 && world.load(plate).force.z() < weight; ++k)
    world.step();
  // A dead weight: free vertically (mass weight / g), pulled at constant speed.
  const double mass = weight / kGravity;
  double vz = 0.0, z = world.load(plate).reference.z();
  const double x0 = world.load(plate).reference.x();
  ShearCurve curve;
  curve.normal_stress = normal_stress;
  const int steps = static_cast<int>(std::ceil(spec.shear_travel / spec.shear_speed / h));
  for (int k = 0; k < steps; ++k)
  {
    world.setBodyVelocity(plate, Eigen::Vector3d(spec.shear_speed, 0.0, vz + (z - world.load(plate).reference.z()) / h),
                          0.0);
    world.step();
    const auto load = world.load(plate);
    vz += (load.force.z() / mass - kGravity) * h;
    z += vz * h;
    curve.displacement.push_back(load.reference.x() - x0 - 0.5 * spec.shear_speed * h);
    curve.shear_stress.push_back(-load.force.x() / area);
  }
  return curve;
}

BevameterResult runBevameter(const BedFactory& fresh_bed, const BevameterSpec& spec)
{
  if (spec.plate_widths.size() < 2)
    fail("plate_widths", "two or more plate widths are needed");
  for (double w : spec.plate_widths)
    if (!(w > 0.0 && w <= spec.plate_length))
      fail("plate_widths", "each width must be > 0 and not more than plate_length (Bekker's b is the smaller side)");
  if (!(spec.press_speed > 0.0) || !(spec.max_sinkage > spec.fit_min_sinkage) || !(spec.fit_min_sinkage > 0.0))
    fail("press_speed", "press_speed > 0 and 0 < fit_min_sinkage < max_sinkage are needed");
  if (spec.normal_stresses.size() < 2)
    fail("normal_stresses", "two or more normal stresses are needed");
  if (!(spec.shear_speed > 0.0 && spec.shear_travel > 0.0 && spec.grousers >= 1 && spec.grouser_height > 0.0))
    fail("shear_speed", "shear_speed, shear_travel, grouser_height > 0 and grousers >= 1 are needed");
  BevameterResult r;
  for (double w : spec.plate_widths)
  {
    auto world = fresh_bed();
    r.plates.push_back(plateSinkageTest(*world, w, spec.plate_length, spec.press_speed, spec.max_sinkage));
  }
  for (double s : spec.normal_stresses)
  {
    auto world = fresh_bed();
    r.shears.push_back(shearTest(*world, spec, s));
  }
  r.bekker = fitBekker(r.plates, spec.fit_min_sinkage, spec.max_sinkage);
  r.shear = fitShear(r.shears);
  return r;
}

terrain::SoilParameters fittedSoil(const BevameterResult& r, double bulk_density, const std::string& name)
{
  terrain::SoilParameters s;
  s.name = name;
  s.source = "AVSP virtual bevameter and shear plate in the DEM (avsp_dynamics_dem)";
  s.model = terrain::SinkageModel::kBekker;
  s.n = r.bekker.n;
  s.k_c = r.bekker.k_c;
  s.k_phi = r.bekker.k_phi;
  s.cohesion = r.shear.cohesion;
  s.friction_angle = r.shear.friction_angle;
  s.shear_modulus = r.shear.shear_modulus;
  s.rho0 = bulk_density;
  return s;
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
