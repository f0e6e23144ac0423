#pragma once
/**
 * @file dem_world.hpp
 * @brief A discrete-element soil bed run by LIGGGHTS in this process (serial, no MPI ranks),
 *        with rigid triangle-mesh bodies (wheels, plates) moved kinematically by the caller and
 *        the soil's force and torque on each read back, averaged over a coupling interval.
 *
 * The co-simulation contract (docs/MODELS.md, "DEM soil"): every coupling interval the caller
 * sets each body's velocity (linear, and spin about its axle), step() runs the interval's DEM
 * steps with the bodies moving at those velocities, and load() gives the force and torque the
 * particles exerted, averaged over the interval's steps, and where the body's reference point
 * is now. Everything is a function of the inputs: the same calls give the same bits.
 *
 * Beds are tiled from a BedTemplate: a block of particles settled once, periodic along x, cut
 * to the ground's height, so a bed (and every fresh bed a moving patch inserts ahead) starts
 * settled at the bulk density the template measured.
 */
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "avsp_dynamics/dem/dem_parameters.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// One particle: centre (m), radius (m).
struct Particle
{
  Eigen::Vector3d x;
  double radius = 0.0;
  int size_class = 0;  ///< index into DemParameters::particles
};

/// A triangle of a body's surface mesh (m); its normal (b - a) x (c - a) points out of the body.
struct Triangle
{
  Eigen::Vector3d a, b, c;
};

/**
 * @brief A settled block of particles, periodic along x: x in [0, length), y in [0, width)
 *        between two walls, z from its floor (0) up to `depth` (particles whose centre settled
 *        above `depth` were removed, then the block settled again).
 */
class BedTemplate
{
public:
  /**
   * @brief Fills the block on a jittered lattice (deterministic in p.seed), lets it settle
   *        under gravity, cuts it to `depth` and measures its solid fraction in the interior
   *        (two largest radii clear of the floor and the top); the particles' density is then
   *        set so that the block has p.bulk_density.
   * @param length m, along x (a bed is a whole number of these), >= 4 largest radii
   * @param width m, across (the walls of every bed tiled from it), >= 4 largest radii
   * @param depth m, > 2 largest radii
   * @throw DemParameterError naming the parameter (validate(), a size too small, the memory budget)
   */
  static BedTemplate settle(const DemParameters& p, double length, double width, double depth);

  const DemParameters& parameters() const { return params_; }
  double length() const { return length_; }
  double width() const { return width_; }
  double depth() const { return depth_; }
  /// Solid fraction measured in the interior of the settled block.
  double packing() const { return packing_; }
  /// kg/m^3: bulk_density / packing().
  double particleDensity() const { return params_.bulk_density / packing_; }
  const std::vector<Particle>& particles() const { return particles_; }
  /// m: mean of surfaceProbe() over the block's top minus depth(): what the probe reads above
  /// the cut on undisturbed soil, subtracted when a bed's surface is written back.
  double surfaceBias() const { return surface_bias_; }
  /// s of DEM time the block took to settle.
  double settleTime() const { return settle_time_; }

private:
  DemParameters params_;
  double length_ = 0.0, width_ = 0.0, depth_ = 0.0;
  double packing_ = 0.0;
  double surface_bias_ = 0.0;
  double settle_time_ = 0.0;
  std::vector<Particle> particles_;
};

/**
 * @brief Height (m) of the highest particle surface a vertical probe at (x, y) meets, averaged
 *        over a 3 x 3 pattern of probes `spacing` apart: how a bed's surface is read (the top
 *        of a granular surface, as a plate laid on it would rest). -inf where no particle is.
 */
double surfaceProbe(const std::vector<Particle>& particles, double x, double y, double spacing);

/// The box a DemWorld's particles and bodies live in (m): walls at y_min, y_max and the floor z_min.
struct DemDomain
{
  double x_min = 0.0, x_max = 0.0;
  double y_min = 0.0, y_max = 0.0;
  double z_min = 0.0, z_max = 0.0;
};

/// What the soil did to one body over the last coupling interval.
struct BodyLoad
{
  Eigen::Vector3d force = Eigen::Vector3d::Zero();      ///< N, mean over the interval's DEM steps
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();     ///< N m about the reference point, mean
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();  ///< m, the body's reference point now
};

/**
 * @brief The DEM world: one LIGGGHTS instance, its bed, its bodies.
 *
 * LIGGGHTS ends the process on an input error; every input is checked here first and a bad
 * one throws DemParameterError naming it.
 */
class DemWorld
{
public:
  /**
   * @param bed the template every bed is tiled from; its width must be the domain's
   * @throw DemParameterError naming the parameter: validate(p); a domain that is empty or
   *        narrower than the template; p not the template's parameters
   */
  DemWorld(const DemParameters& p, const DemDomain& domain, BedTemplate bed);
  ~DemWorld();
  DemWorld(const DemWorld&) = delete;
  DemWorld& operator=(const DemWorld&) = delete;

  /**
   * @brief Tiles the template over x in [x0, x1) (x1 - x0 a whole number of template lengths),
   *        its floor on the domain's floor, keeping the particles whose centre is at or below
   *        `ground(x, y)` (m, the heightfield to reproduce).
   * @param trim_start, trim_end leave out the particles that reach across x0 (x1): where the
   *        bed ends at a wall there (the template is periodic: its particles near one end lean
   *        on those near the other), not where it joins a bed already there
   * @return the particles added
   * @throw DemParameterError: [x0, x1) outside the domain or not whole blocks; the ground
   *        deeper than the template anywhere ("ground"); the memory budget exceeded
   */
  std::size_t addBed(double x0, double x1, const std::function<double(double, double)>& ground, bool trim_start,
                     bool trim_end);

  /// Removes every particle whose centre has x in [x0, x1); returns them (their last state).
  std::vector<Particle> removeParticles(double x0, double x1);

  /// Puts the walls that close the bed's ends at x0 and x1 (replacing earlier ones).
  void setBedEnds(double x0, double x1);

  /**
   * @brief A rigid body: its surface mesh in the domain's frame, a reference point (where the
   *        torque is taken, and whose position load() reports) and the axis it spins about.
   * @param spin_axis unit vector, or zero for a body that does not spin
   * @return the body's index
   * @throw DemParameterError when the mesh is empty, a vertex is outside the domain or not
   *        finite, or the axis is neither zero nor of unit length
   */
  int addBody(const std::vector<Triangle>& mesh, const Eigen::Vector3d& reference, const Eigen::Vector3d& spin_axis);

  /// Velocity of the body's reference point (m/s) and its spin rate about its axis (rad/s),
  /// from the next step() on. @throw DemParameterError for an unknown body or a non-finite value
  void setBodyVelocity(int body, const Eigen::Vector3d& velocity, double spin_rate);

  /**
   * @brief Runs one coupling interval (DemParameters::coupling_interval).
   * @throw DemParameterError naming the body when a body's mesh would leave the domain during
   *        it (LIGGGHTS would end the process); nothing is run then
   */
  void step();

  /**
   * @brief Runs coupling intervals until the particles are at rest (kinetic energy below 1e-5
   *        of their weight times their mean radius) or `max_time` (s) has passed: a freshly
   *        tiled bed slumps a little as its contacts' friction builds up again.
   * @return s run
   */
  double settle(double max_time);

  /// m: the highest particle top over the rectangle [x0, x1] x [y0, y1] (-inf when empty).
  double highestTop(double x0, double x1, double y0, double y1) const;

  /// The soil's mean force and torque on a body over the last step(). @throw DemParameterError for an unknown body
  BodyLoad load(int body) const;

  /// s of DEM time since construction.
  double time() const { return time_; }
  std::size_t particleCount() const;
  std::vector<Particle> particles() const;
  /// J: kinetic energy of the particles (translation and rotation).
  double kineticEnergy() const;
  const BedTemplate& bed() const { return bed_; }
  const DemParameters& parameters() const { return params_; }
  const DemDomain& domain() const { return domain_; }
  /// LIGGGHTS' log of this world (for diagnosis).
  std::string logPath() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  DemParameters params_;
  DemDomain domain_;
  BedTemplate bed_;
  double time_ = 0.0;
};

/**
 * @brief The closed cylinder of a wheel's rim (radius, width) with `facets` flat faces round
 *        it and two flat sides, centred at `centre`, its axle along `axle` (unit); with
 *        `grousers` > 0, that many lugs across the rim, radial plates `grouser_height` tall
 *        (the tread of an off-road tyre or a rover wheel).
 */
std::vector<Triangle> wheelMesh(const Eigen::Vector3d& centre, const Eigen::Vector3d& axle, double radius, double width,
                                int facets, int grousers = 0, double grouser_height = 0.0);

/// A flat rectangular plate (length along x, width along y) of negligible thickness, its bottom
/// face at `centre`, normal down: a bevameter's plate.
std::vector<Triangle> plateMesh(const Eigen::Vector3d& centre, double length, double width);

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
