#include "avsp_dynamics/dem/dem_world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "liggghts.hpp"
#include "parameter_error.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
// ------------------------------------------------------------------------------------------
// Liggghts: one instance.

Liggghts::Liggghts(const std::string& log_path)
{
  // Screen output goes to /dev/null, not "none": LIGGGHTS 3.8 prints some mesh messages to
  // the screen without checking it exists. The log keeps everything for diagnosis.
  std::string a0 = "liggghts", a1 = "-screen", a2 = "/dev/null", a3 = "-log", a4 = log_path;
  char* argv[] = { a0.data(), a1.data(), a2.data(), a3.data(), a4.data() };
  lammps_open_no_mpi(5, argv, &handle_);
  if (!handle_)
    throw std::runtime_error("LIGGGHTS could not be started (log: " + log_path + ")");
}

Liggghts::~Liggghts()
{
  if (handle_)
    lammps_close(handle_);
}

void Liggghts::command(const char* format, ...)
{
  char buffer[1024];
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  if (n < 0 || n >= static_cast<int>(sizeof buffer))
    throw std::logic_error("LIGGGHTS command longer than 1023 characters");
  lammps_command(handle_, buffer);
}

double Liggghts::fixVector(const std::string& id, int index) const
{
  // Global vector element: style 0 (global), type 1 (vector); LIGGGHTS returns a copy to free.
  auto* v = static_cast<double*>(lammps_extract_fix(handle_, id.c_str(), 0, 1, index, 0));
  if (!v)
    throw std::logic_error("LIGGGHTS fix " + id + " has no vector element " + std::to_string(index));
  const double value = *v;
  lammps_free(v);
  return value;
}

int Liggghts::localAtoms() const
{
  return *static_cast<int*>(lammps_extract_global(handle_, "nlocal"));
}
double** Liggghts::positions() const
{
  return static_cast<double**>(lammps_extract_atom(handle_, "x"));
}
double** Liggghts::velocities() const
{
  return static_cast<double**>(lammps_extract_atom(handle_, "v"));
}
double** Liggghts::angularVelocities() const
{
  return static_cast<double**>(lammps_extract_atom(handle_, "omega"));
}
double* Liggghts::radii() const
{
  return static_cast<double*>(lammps_extract_atom(handle_, "radius"));
}
double* Liggghts::masses() const
{
  return static_cast<double*>(lammps_extract_atom(handle_, "rmass"));
}
int* Liggghts::types() const
{
  return static_cast<int*>(lammps_extract_atom(handle_, "type"));
}

namespace
{
constexpr double kGravity = 9.81;  // m/s^2, as the ODE vehicles (WorldOptions::gravity)

using detail::fail;
using detail::str;

/// splitmix64: a portable, seedable generator (std distributions differ between libraries).
struct Random
{
  std::uint64_t state;
  std::uint64_t next()
  {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return (next() >> 11) * (1.0 / 9007199254740992.0); }
};

/// A directory of its own for LIGGGHTS' log and the bodies' STL files, removed with it.
class ScratchDir
{
public:
  ScratchDir()
  {
    std::string pattern = (std::filesystem::temp_directory_path() / "avsp_dem_XXXXXX").string();
    if (!mkdtemp(pattern.data()))
      throw std::runtime_error("cannot create a scratch directory for LIGGGHTS under " + pattern);
    path_ = pattern;
  }
  ~ScratchDir()
  {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
  std::filesystem::path path_;
};

/// Material type of the walls and meshes: one after the particles' size classes.
int wallType(const DemParameters& p)
{
  return static_cast<int>(p.particles.size()) + 1;
}

std::string contactModel()
{
  return "model hertz tangential history rolling_friction epsd2";
}

/// Units, box, materials, contact law, gravity, integration: what every instance shares.
void setUp(Liggghts& l, const DemParameters& p, const char* boundary, const DemDomain& box)
{
  const int types = wallType(p);
  l.command("atom_style granular");
  l.command("atom_modify map array");
  // Sorting bins of a fixed size: LIGGGHTS derives them from the particles otherwise, and stops
  // the process when there are none (an empty world before its bed is added).
  l.command("atom_modify sort 1000 %.17g", 2.0 * maxRadius(p));
  l.command("boundary %s", boundary);
  l.command("newton off");
  l.command("communicate single vel yes");
  l.command("units si");
  l.command("region domain block %.17g %.17g %.17g %.17g %.17g %.17g units box", box.x_min, box.x_max, box.y_min,
            box.y_max, box.z_min, box.z_max);
  l.command("create_box %d domain", types);
  // Skin: 40 % of the largest radius; rebuilt whenever a particle may have crossed it.
  l.command("neighbor %.17g bin", 0.4 * maxRadius(p));
  l.command("neigh_modify delay 0");
  l.command("thermo 0");
  l.command("thermo_modify lost ignore norm no");
  std::string e, nu, pair_e, pair_mu, pair_mur;
  for (int i = 1; i <= types; ++i)
  {
    e += " " + str(p.youngs_modulus);
    nu += " " + str(p.poisson_ratio);
    for (int j = 1; j <= types; ++j)
    {
      const bool wall = i == types || j == types;
      pair_e += " " + str(p.restitution);
      pair_mu += " " + str(wall ? p.wall_friction : p.friction);
      pair_mur += " " + str(p.rolling_friction);
    }
  }
  l.command("fix m1 all property/global youngsModulus peratomtype%s", e.c_str());
  l.command("fix m2 all property/global poissonsRatio peratomtype%s", nu.c_str());
  l.command("fix m3 all property/global coefficientRestitution peratomtypepair %d%s", types, pair_e.c_str());
  l.command("fix m4 all property/global coefficientFriction peratomtypepair %d%s", types, pair_mu.c_str());
  l.command("fix m5 all property/global coefficientRollingFriction peratomtypepair %d%s", types, pair_mur.c_str());
  l.command("pair_style gran %s", contactModel().c_str());
  l.command("pair_coeff * *");
  l.command("timestep %.17g", p.timestep);
  l.command("fix gravity all gravity %.17g vector 0 0 -1", kGravity);
  l.command("fix integrate all nve/sphere");
}

void wall(Liggghts& l, const DemParameters& p, const std::string& id, const char* plane, double at)
{
  l.command("fix %s all wall/gran %s primitive type %d %s %.17g", id.c_str(), contactModel().c_str(), wallType(p),
            plane, at);
}

/// Gives every particle of each size class its diameter and the density `rho`.
void setSizes(Liggghts& l, const DemParameters& p, double rho)
{
  for (std::size_t k = 0; k < p.particles.size(); ++k)
  {
    l.command("set type %zu diameter %.17g", k + 1, 2.0 * p.particles[k].radius);
    l.command("set type %zu density %.17g", k + 1, rho);
  }
}

std::vector<Particle> readParticles(const Liggghts& l, const DemParameters& p)
{
  const int n = l.localAtoms();
  double** x = l.positions();
  double* r = l.radii();
  int* t = l.types();
  std::vector<Particle> out(n);
  for (int i = 0; i < n; ++i)
  {
    out[i].x = Eigen::Vector3d(x[i][0], x[i][1], x[i][2]);
    out[i].radius = r[i];
    out[i].size_class = std::clamp(t[i] - 1, 0, static_cast<int>(p.particles.size()) - 1);
  }
  return out;
}

double kineticEnergyOf(const Liggghts& l)
{
  const int n = l.localAtoms();
  if (n == 0)
    return 0.0;
  double** v = l.velocities();
  double** w = l.angularVelocities();
  double* m = l.masses();
  double* r = l.radii();
  double e = 0.0;
  for (int i = 0; i < n; ++i)
  {
    const double v2 = v[i][0] * v[i][0] + v[i][1] * v[i][1] + v[i][2] * v[i][2];
    const double w2 = w[i][0] * w[i][0] + w[i][1] * w[i][1] + w[i][2] * w[i][2];
    e += 0.5 * m[i] * v2 + 0.2 * m[i] * r[i] * r[i] * w2;
  }
  return e;
}

/// Runs in chunks of 0.02 s until the particles' kinetic energy is below 1e-5 of their
/// weight times the mean radius (at rest, up to the contacts' elastic jitter) or `max_time`
/// has passed. Returns the time run. Deterministic: the test is on simulated state only.
double settleRun(Liggghts& l, const DemParameters& p, double rho, double max_time, bool first)
{
  const int chunk = std::max(1, static_cast<int>(std::lround(0.02 / p.timestep)));
  double t = 0.0;
  const double r_mean = std::cbrt(meanParticleVolume(p) * 3.0 / (4.0 * M_PI));
  while (t < max_time)
  {
    l.command(first ? "run %d" : "run %d pre no post no", chunk);
    first = false;
    t += chunk * p.timestep;
    const int n = l.localAtoms();
    const double weight = n * rho * meanParticleVolume(p) * kGravity;
    if (kineticEnergyOf(l) < 1e-5 * weight * r_mean)
      break;
  }
  return t;
}
}  // namespace

double surfaceProbe(const std::vector<Particle>& particles, double x, double y, double spacing)
{
  double sum = 0.0;
  int hits = 0;
  for (int a = -1; a <= 1; ++a)
    for (int b = -1; b <= 1; ++b)
    {
      const double px = x + a * spacing, py = y + b * spacing;
      double top = -std::numeric_limits<double>::infinity();
      for (const auto& q : particles)
      {
        const double dx = q.x.x() - px, dy = q.x.y() - py;
        const double d2 = dx * dx + dy * dy;
        if (d2 < q.radius * q.radius)
          top = std::max(top, q.x.z() + std::sqrt(q.radius * q.radius - d2));
      }
      if (std::isfinite(top))
      {
        sum += top;
        ++hits;
      }
    }
  return hits ? sum / hits : -std::numeric_limits<double>::infinity();
}

// ------------------------------------------------------------------------------------------
// BedTemplate

BedTemplate BedTemplate::settle(const DemParameters& p, double length, double width, double depth)
{
  validate(p);
  const double rmax = maxRadius(p);
  if (!(std::isfinite(length) && length >= 4.0 * rmax))
    fail("bed.length", str(length) + " m is shorter than 4 largest particle radii (" + str(4.0 * rmax) + " m)");
  if (!(std::isfinite(width) && width >= 4.0 * rmax))
    fail("bed.width", str(width) + " m is narrower than 4 largest particle radii (" + str(4.0 * rmax) + " m)");
  if (!(std::isfinite(depth) && depth > 2.0 * rmax))
    fail("bed.depth", str(depth) + " m is not deeper than 2 largest particle radii (" + str(2.0 * rmax) + " m)");

  // Lattice: spacing 2.1 r_max (no initial overlap), a whole number of columns along x so the
  // block is periodic; filled high enough that it still reaches `depth` once it has settled.
  const double s = 2.1 * rmax;
  const int nx = std::max(1, static_cast<int>(std::floor(length / s)));
  const double sx = length / nx;
  const double y0 = 1.05 * rmax, y1 = width - 1.05 * rmax;
  const int ny = std::max(1, static_cast<int>(std::floor((y1 - y0) / s)) + 1);
  const double sy = ny > 1 ? (y1 - y0) / (ny - 1) : 0.0;
  const double lattice_packing = meanParticleVolume(p) / (sx * std::max(sy, s) * s);
  const double fill = depth * 0.64 / lattice_packing + 2.0 * s;
  const int nz = static_cast<int>(std::ceil(fill / s));
  checkParticleBudget(p, length * width * fill * lattice_packing / kNominalPacking, "dem bed template");

  BedTemplate t;
  t.params_ = p;
  t.length_ = length;
  t.width_ = width;
  t.depth_ = depth;
  ScratchDir scratch;
  Liggghts l(scratch.file("log.liggghts"));
  const DemDomain box{ 0.0, length, 0.0, width, 0.0, (nz + 2) * s };
  setUp(l, p, "p f f", box);
  wall(l, p, "floor", "zplane", 0.0);
  wall(l, p, "side0", "yplane", 0.0);
  wall(l, p, "side1", "yplane", width);

  // Size class by number share (mass share over particle volume), drawn per lattice site.
  std::vector<double> cumulative;
  double total = 0.0;
  for (const auto& c : p.particles)
    cumulative.push_back(total += c.mass_fraction / (c.radius * c.radius * c.radius));
  Random rng{ p.seed };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
      {
        const double u = rng.uniform() * total;
        const int cls =
            static_cast<int>(std::upper_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin());
        const double jitter_x = 0.05 * rmax * (rng.uniform() - 0.5), jitter_y = 0.05 * rmax * (rng.uniform() - 0.5);
        l.command("create_atoms %d single %.17g %.17g %.17g units box",
                  std::min(cls, static_cast<int>(p.particles.size()) - 1) + 1, (i + 0.5) * sx + jitter_x,
                  y0 + j * sy + jitter_y, (k + 0.5) * s + 0.05 * rmax);
      }
  const double rho_guess = p.bulk_density / kNominalPacking;
  setSizes(l, p, rho_guess);
  t.settle_time_ = settleRun(l, p, rho_guess, 3.0, true);

  // Cut to depth and let the cut surface settle; then measure the interior's solid fraction
  // and give the particles the density that makes the bulk density the soil's (the weight
  // changes by a few per cent: a last short settle).
  l.command("region cut block INF INF INF INF %.17g INF units box", depth);
  l.command("delete_atoms region cut");
  t.settle_time_ += settleRun(l, p, rho_guess, 1.0, true);
  auto ps = readParticles(l, p);
  const double z0 = 2.0 * rmax, z1 = depth - 2.0 * rmax;
  double solid = 0.0;
  for (const auto& q : ps)
    if (q.x.z() >= z0 && q.x.z() < z1)
      solid += 4.0 / 3.0 * M_PI * q.radius * q.radius * q.radius;
  t.packing_ = z1 > z0 ? solid / (length * width * (z1 - z0)) : kNominalPacking;
  if (!(t.packing_ > 0.3 && t.packing_ < 0.75))
    throw std::runtime_error("dem bed template: measured solid fraction " + str(t.packing_) +
                             " is not that of a settled bed (log: kept only while running)");
  setSizes(l, p, t.particleDensity());
  t.settle_time_ += settleRun(l, p, t.particleDensity(), 0.02, true);

  ps = readParticles(l, p);
  for (auto& q : ps)
    q.x.x() = q.x.x() - length * std::floor(q.x.x() / length);  // periodic image in [0, length)
  t.particles_ = std::move(ps);

  // What the probe reads on this undisturbed surface, away from the walls and the periodic seam.
  const double spacing = 2.0 * rmax;
  double sum = 0.0;
  int n = 0;
  for (double x = 2.0 * rmax; x <= length - 2.0 * rmax; x += spacing)
    for (double y = 3.0 * rmax; y <= width - 3.0 * rmax; y += spacing)
    {
      const double h = surfaceProbe(t.particles_, x, y, 0.5 * rmax);
      if (std::isfinite(h))
      {
        sum += h;
        ++n;
      }
    }
  t.surface_bias_ = n ? sum / n - depth : 0.0;
  return t;
}

// ------------------------------------------------------------------------------------------
// DemWorld

struct DemWorld::Impl
{
  ScratchDir scratch;
  std::unique_ptr<Liggghts> l;
  int steps_per_interval = 1;
  bool needs_setup = true;
  bool ends = false;
  struct Body
  {
    std::string id;
    bool spins = false;
    bool stepped = false;
    Eigen::Vector3d extent =
        Eigen::Vector3d::Zero();  ///< m, half-size of the box the mesh can take about its reference
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  };
  std::vector<Body> bodies;
};

DemWorld::DemWorld(const DemParameters& p, const DemDomain& d, BedTemplate bed)
  : impl_(std::make_unique<Impl>()), params_(p), domain_(d), bed_(std::move(bed))
{
  validate(p);
  for (double v : { d.x_min, d.x_max, d.y_min, d.y_max, d.z_min, d.z_max })
    if (!std::isfinite(v))
      fail("domain", "a bound is not finite");
  if (!(d.x_max > d.x_min && d.y_max > d.y_min && d.z_max > d.z_min))
    fail("domain", "is empty (every max must exceed its min)");
  if (std::abs((d.y_max - d.y_min) - bed_.width()) > 1e-9)
    fail("domain",
         "width " + str(d.y_max - d.y_min) + " m differs from the bed template's " + str(bed_.width()) + " m");
  if (d.z_max - d.z_min < bed_.depth())
    fail("domain", "height " + str(d.z_max - d.z_min) + " m is less than the bed's depth " + str(bed_.depth()) + " m");
  const auto& q = bed_.parameters();
  if (q.particles.size() != p.particles.size() || q.youngs_modulus != p.youngs_modulus ||
      q.bulk_density != p.bulk_density || q.timestep != p.timestep)
    fail("bed", "the template was settled with other particle parameters");
  for (std::size_t k = 0; k < p.particles.size(); ++k)
    if (q.particles[k].radius != p.particles[k].radius)
      fail("bed", "the template was settled with other particle sizes");
  impl_->steps_per_interval = static_cast<int>(std::lround(p.coupling_interval / p.timestep));
  impl_->l = std::make_unique<Liggghts>(impl_->scratch.file("log.liggghts"));
  setUp(*impl_->l, p, "f f f", d);
  wall(*impl_->l, p, "floor", "zplane", d.z_min);
  wall(*impl_->l, p, "side0", "yplane", d.y_min);
  wall(*impl_->l, p, "side1", "yplane", d.y_max);
}

DemWorld::~DemWorld() = default;

std::string DemWorld::logPath() const
{
  return impl_->scratch.file("log.liggghts");
}

std::size_t DemWorld::addBed(double x0, double x1, const std::function<double(double, double)>& ground, bool trim_start,
                             bool trim_end)
{
  const double L = bed_.length();
  if (!(x0 >= domain_.x_min - 1e-9 && x1 <= domain_.x_max + 1e-9 && x1 > x0))
    fail("bed", "[" + str(x0) + ", " + str(x1) + ") is not inside the domain's x range [" + str(domain_.x_min) + ", " +
                    str(domain_.x_max) + "]");
  const double blocks = (x1 - x0) / L;
  const int nb = static_cast<int>(std::lround(blocks));
  if (nb < 1 || std::abs(blocks - nb) > 1e-6)
    fail("bed", "length " + str(x1 - x0) + " m is not a whole number of template lengths (" + str(L) + " m)");
  checkParticleBudget(
      params_,
      (particleCount() / kNominalPacking) * meanParticleVolume(params_) + (x1 - x0) * bed_.width() * bed_.depth(),
      "dem bed");
  std::size_t added = 0;
  auto& l = *impl_->l;
  for (int b = 0; b < nb; ++b)
    for (const auto& q : bed_.particles())
    {
      const double x = x0 + b * L + q.x.x(), y = domain_.y_min + q.x.y(), z = domain_.z_min + q.x.z();
      const double g = ground(x, y);
      if (!std::isfinite(g))
        fail("ground", "not finite at (" + str(x) + ", " + str(y) + ")");
      if (g - domain_.z_min > bed_.depth() + 1e-9)
        fail("ground", "at (" + str(x) + ", " + str(y) + ") is " + str(g - domain_.z_min) +
                           " m above the floor, deeper than the bed template (" + str(bed_.depth()) + " m)");
      if (z > g || (trim_start && x - q.radius < x0) || (trim_end && x + q.radius > x1))
        continue;
      l.command("create_atoms %d single %.17g %.17g %.17g units box", q.size_class + 1, x, y, z);
      ++added;
    }
  setSizes(l, params_, bed_.particleDensity());
  impl_->needs_setup = true;
  return added;
}

std::vector<Particle> DemWorld::removeParticles(double x0, double x1)
{
  std::vector<Particle> out;
  for (const auto& q : particles())
    if (q.x.x() >= x0 && q.x.x() < x1)
      out.push_back(q);
  auto& l = *impl_->l;
  l.command("region retire block %.17g %.17g INF INF INF INF units box", x0, x1);
  l.command("delete_atoms region retire");
  l.command("region retire delete");
  impl_->needs_setup = true;
  return out;
}

void DemWorld::setBedEnds(double x0, double x1)
{
  auto& l = *impl_->l;
  if (impl_->ends)
  {
    l.command("unfix end0");
    l.command("unfix end1");
  }
  wall(l, params_, "end0", "xplane", x0);
  wall(l, params_, "end1", "xplane", x1);
  impl_->ends = true;
  impl_->needs_setup = true;
}

int DemWorld::addBody(const std::vector<Triangle>& mesh, const Eigen::Vector3d& reference,
                      const Eigen::Vector3d& spin_axis)
{
  if (mesh.empty())
    fail("body.mesh", "has no triangle");
  auto inside = [&](const Eigen::Vector3d& v) {
    return v.allFinite() && v.x() >= domain_.x_min && v.x() <= domain_.x_max && v.y() >= domain_.y_min &&
           v.y() <= domain_.y_max && v.z() >= domain_.z_min && v.z() <= domain_.z_max;
  };
  for (const auto& t : mesh)
    for (const auto* v : { &t.a, &t.b, &t.c })
      if (!inside(*v))
        fail("body.mesh", "vertex (" + str(v->x()) + ", " + str(v->y()) + ", " + str(v->z()) +
                              ") is outside the domain or not finite");
  if (!reference.allFinite())
    fail("body.reference", "not finite");
  const double axis_norm = spin_axis.norm();
  if (!(axis_norm == 0.0 || std::abs(axis_norm - 1.0) < 1e-9))
    fail("body.spin_axis", "must be zero or a unit vector (norm " + str(axis_norm) + ")");

  const int index = static_cast<int>(impl_->bodies.size());
  Impl::Body body;
  body.id = "body" + std::to_string(index);
  body.spins = axis_norm > 0.0;
  // The box the mesh can take about its reference: its own box, or for a spinning body the one
  // of the solid of revolution it sweeps about the axis.
  for (const auto& t : mesh)
    for (const auto* v : { &t.a, &t.b, &t.c })
    {
      const Eigen::Vector3d d = *v - reference;
      for (int a = 0; a < 3; ++a)
      {
        double half = std::abs(d[a]);
        if (body.spins)
        {
          const double along = d.dot(spin_axis);
          const double radial = std::sqrt(std::max(0.0, d.squaredNorm() - along * along));
          half = radial * std::sqrt(std::max(0.0, 1.0 - spin_axis[a] * spin_axis[a])) + std::abs(along * spin_axis[a]);
        }
        body.extent[a] = std::max(body.extent[a], half);
      }
    }
  const std::string stl = impl_->scratch.file(body.id + ".stl");
  {
    std::ofstream f(stl);
    f.precision(17);
    f << "solid " << body.id << "\n";
    for (const auto& t : mesh)
    {
      const Eigen::Vector3d n = (t.b - t.a).cross(t.c - t.a).normalized();
      f << "facet normal " << n.x() << " " << n.y() << " " << n.z() << "\n outer loop\n";
      for (const auto* v : { &t.a, &t.b, &t.c })
        f << "  vertex " << v->x() << " " << v->y() << " " << v->z() << "\n";
      f << " endloop\nendfacet\n";
    }
    f << "endsolid " << body.id << "\n";
    if (!f)
      throw std::runtime_error("cannot write " + stl);
  }
  auto& l = *impl_->l;
  const std::string& id = body.id;
  l.command("fix %s all mesh/surface/stress file %s type %d reference_point %.17g %.17g %.17g", id.c_str(), stl.c_str(),
            wallType(params_), reference.x(), reference.y(), reference.z());
  // LIGGGHTS takes one mesh wall/gran fix: every body's mesh is in it (made again with each body).
  if (!impl_->bodies.empty())
    l.command("unfix body_walls");
  std::string meshes;
  for (const auto& b : impl_->bodies)
    meshes += b.id + " ";
  meshes += id;
  l.command("fix body_walls all wall/gran %s mesh n_meshes %d meshes %s", contactModel().c_str(),
            static_cast<int>(impl_->bodies.size()) + 1, meshes.c_str());
  for (const char* c : { "vx", "vy", "vz", "w" })
    l.command("variable %s_%s equal 0", id.c_str(), c);
  // The translation first, the spin second: a second fix move/mesh moves with the first, so the
  // spin axis goes through the moving reference point.
  l.command("fix %s_lin all move/mesh mesh %s linear/variable v_%s_vx v_%s_vy v_%s_vz", id.c_str(), id.c_str(),
            id.c_str(), id.c_str(), id.c_str());
  if (body.spins)
    l.command(
        "fix %s_rot all move/mesh mesh %s rotate/variable origin %.17g %.17g %.17g axis %.17g %.17g %.17g omega "
        "v_%s_w",
        id.c_str(), id.c_str(), reference.x(), reference.y(), reference.z(), spin_axis.x(), spin_axis.y(),
        spin_axis.z(), id.c_str());
  // Mean force and torque over each coupling interval's steps.
  const int n = impl_->steps_per_interval;
  l.command("fix %s_avg all ave/time 1 %d %d f_%s[1] f_%s[2] f_%s[3] f_%s[4] f_%s[5] f_%s[6]", id.c_str(), n, n,
            id.c_str(), id.c_str(), id.c_str(), id.c_str(), id.c_str(), id.c_str());
  impl_->bodies.push_back(body);
  impl_->needs_setup = true;
  return index;
}

void DemWorld::setBodyVelocity(int body, const Eigen::Vector3d& velocity, double spin_rate)
{
  if (body < 0 || body >= static_cast<int>(impl_->bodies.size()))
    fail("body", "no body " + std::to_string(body));
  if (!velocity.allFinite() || !std::isfinite(spin_rate))
    fail("body.velocity", "not finite");
  impl_->bodies[body].velocity = velocity;
  const std::string& id = impl_->bodies[body].id;
  auto& l = *impl_->l;
  l.command("variable %s_vx equal %.17g", id.c_str(), velocity.x());
  l.command("variable %s_vy equal %.17g", id.c_str(), velocity.y());
  l.command("variable %s_vz equal %.17g", id.c_str(), velocity.z());
  l.command("variable %s_w equal %.17g", id.c_str(), spin_rate);
}

void DemWorld::step()
{
  // A mesh leaving the box ends the process in LIGGGHTS: refuse the interval instead, naming
  // the body (the box its mesh can take, where its reference point will be).
  for (std::size_t k = 0; k < impl_->bodies.size(); ++k)
  {
    const auto& b = impl_->bodies[k];
    const Eigen::Vector3d end = load(static_cast<int>(k)).reference + b.velocity * params_.coupling_interval;
    const Eigen::Vector3d lo = end - b.extent, hi = end + b.extent;
    if (lo.x() < domain_.x_min || hi.x() > domain_.x_max || lo.y() < domain_.y_min || hi.y() > domain_.y_max ||
        lo.z() < domain_.z_min || hi.z() > domain_.z_max)
      fail("body", "body " + std::to_string(k) + " would leave the domain this interval (reference at (" +
                       str(end.x()) + ", " + str(end.y()) + ", " + str(end.z()) + "))");
  }
  auto& l = *impl_->l;
  if (impl_->needs_setup)
    l.command("run %d", impl_->steps_per_interval);
  else
    l.command("run %d pre no post no", impl_->steps_per_interval);
  impl_->needs_setup = false;
  for (auto& b : impl_->bodies)
    b.stepped = true;
  time_ += impl_->steps_per_interval * params_.timestep;
}

double DemWorld::settle(double max_time)
{
  const double r_mean = std::cbrt(meanParticleVolume(params_) * 3.0 / (4.0 * M_PI));
  const double weight = particleCount() * bed_.particleDensity() * meanParticleVolume(params_) * kGravity;
  double t = 0.0;
  while (t < max_time)
  {
    step();
    t += params_.coupling_interval;
    if (kineticEnergy() < 1e-5 * weight * r_mean)
      break;
  }
  return t;
}

double DemWorld::highestTop(double x0, double x1, double y0, double y1) const
{
  double top = -std::numeric_limits<double>::infinity();
  for (const auto& q : particles())
    if (q.x.x() + q.radius >= x0 && q.x.x() - q.radius <= x1 && q.x.y() + q.radius >= y0 && q.x.y() - q.radius <= y1)
      top = std::max(top, q.x.z() + q.radius);
  return top;
}

BodyLoad DemWorld::load(int body) const
{
  if (body < 0 || body >= static_cast<int>(impl_->bodies.size()))
    fail("body", "no body " + std::to_string(body));
  const auto& b = impl_->bodies[body];
  BodyLoad out;
  out.reference =
      Eigen::Vector3d(impl_->l->fixVector(b.id, 6), impl_->l->fixVector(b.id, 7), impl_->l->fixVector(b.id, 8));
  if (!b.stepped)
    return out;
  const std::string avg = b.id + "_avg";
  for (int i = 0; i < 3; ++i)
  {
    out.force[i] = impl_->l->fixVector(avg, i);
    out.torque[i] = impl_->l->fixVector(avg, 3 + i);
  }
  return out;
}

std::size_t DemWorld::particleCount() const
{
  return static_cast<std::size_t>(impl_->l->localAtoms());
}

std::vector<Particle> DemWorld::particles() const
{
  return readParticles(*impl_->l, params_);
}

double DemWorld::kineticEnergy() const
{
  return kineticEnergyOf(*impl_->l);
}

// ------------------------------------------------------------------------------------------
// Meshes

std::vector<Triangle> wheelMesh(const Eigen::Vector3d& centre, const Eigen::Vector3d& axle, double radius, double width,
                                int facets, int grousers, double grouser_height)
{
  if (!(radius > 0.0) || !(width > 0.0) || facets < 3 || !centre.allFinite() || !axle.allFinite() ||
      std::abs(axle.norm() - 1.0) > 1e-9)
    fail("wheel", "radius and width must be > 0, facets >= 3, the axle a unit vector");
  if (grousers < 0 || (grousers > 0 && !(grouser_height > 0.0 && grouser_height < radius)))
    fail("wheel.grousers", "a count >= 0 and, with grousers, a height in (0, radius)");
  // Two unit vectors spanning the wheel's plane.
  Eigen::Vector3d u = axle.cross(Eigen::Vector3d::UnitZ());
  if (u.norm() < 1e-6)
    u = axle.cross(Eigen::Vector3d::UnitX());
  u.normalize();
  const Eigen::Vector3d w = axle.cross(u);
  const Eigen::Vector3d half = 0.5 * width * axle;
  std::vector<Triangle> mesh;
  for (int i = 0; i < facets; ++i)
  {
    const double t0 = 2.0 * M_PI * i / facets, t1 = 2.0 * M_PI * (i + 1) / facets;
    const Eigen::Vector3d p0 = centre + radius * (std::cos(t0) * u + std::sin(t0) * w);
    const Eigen::Vector3d p1 = centre + radius * (std::cos(t1) * u + std::sin(t1) * w);
    // Rim: outward normals; sides: normals along -axle and +axle.
    mesh.push_back({ p0 - half, p1 - half, p1 + half });
    mesh.push_back({ p0 - half, p1 + half, p0 + half });
    mesh.push_back({ centre - half, p1 - half, p0 - half });
    mesh.push_back({ centre + half, p0 + half, p1 + half });
  }
  for (int i = 0; i < grousers; ++i)
  {
    // A radial plate across the rim (contact with a triangle is two-sided in LIGGGHTS).
    const double t = 2.0 * M_PI * (i + 0.5) / grousers;
    const Eigen::Vector3d dir = std::cos(t) * u + std::sin(t) * w;
    const Eigen::Vector3d in = centre + 0.98 * radius * dir, out = centre + (radius + grouser_height) * dir;
    mesh.push_back({ in - half, out - half, out + half });
    mesh.push_back({ in - half, out + half, in + half });
  }
  return mesh;
}

std::vector<Triangle> plateMesh(const Eigen::Vector3d& centre, double length, double width)
{
  if (!(length > 0.0) || !(width > 0.0) || !centre.allFinite())
    fail("plate", "length and width must be > 0 and the centre finite");
  const Eigen::Vector3d a = centre + Eigen::Vector3d(-0.5 * length, -0.5 * width, 0.0);
  const Eigen::Vector3d b = centre + Eigen::Vector3d(0.5 * length, -0.5 * width, 0.0);
  const Eigen::Vector3d c = centre + Eigen::Vector3d(0.5 * length, 0.5 * width, 0.0);
  const Eigen::Vector3d d = centre + Eigen::Vector3d(-0.5 * length, 0.5 * width, 0.0);
  // Normal down (-z): the face that meets the soil.
  return { { a, c, b }, { a, d, c } };
}

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
