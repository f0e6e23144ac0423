#pragma once
/**
 * @file wheel_rig.hpp
 * @brief A single-wheel test rig: one rigid wheel as an ODE body, its rim a mesh in a DemWorld,
 *        coupled every coupling interval (the DEM runs with the wheel's ODE pose and velocity,
 *        then its mean force and torque are applied to the ODE body for the ODE step). The
 *        carriage holds the wheel upright on its line and may hold its forward speed; the
 *        drive may hold its spin rate: slip and sinkage tests as on a soil bin's rig.
 */
#include <memory>

#include <Eigen/Core>

#include "avsp_dynamics/dem/dem_world.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// The rig's wheel.
struct WheelRigSpec
{
  double radius = 0.15;         ///< m, > 0
  double width = 0.1;           ///< m, > 0
  double load = 150.0;          ///< N, vertical load on the soil at rest (the wheel's body weighs this), > 0
  int facets = 48;              ///< flat faces round the rim, >= 12
  int grousers = 0;             ///< lugs across the rim (0: a smooth rim)
  double grouser_height = 0.0;  ///< m, their height above the rim, in (0, radius) with grousers
};

/// What the rig measures, at the end of the last step().
struct WheelRigState
{
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();    ///< m, wheel centre (ODE)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s, wheel centre (ODE)
  double spin_rate = 0.0;                              ///< rad/s about +y (+ rolls towards +x)
  BodyLoad soil;                                       ///< the DEM's mean force and torque over the last interval
  double sinkage = 0.0;  ///< m, ground under the wheel before it was set down minus the rim's lowest point
  double slip = 0.0;     ///< 1 - v / (omega r) when the wheel spins forward, else 0
};

/**
 * @brief One wheel on a DemWorld's bed, in ODE (serial, deterministic).
 *
 * ODE holds the wheel body (a solid cylinder whose weight is the load) with an angular motor
 * keeping its axle along y and a linear motor keeping it on the line y = const; vertically it
 * is free. setCarriageSpeed() makes the linear motor hold a forward speed too (a towing
 * carriage; its force is the drawbar pull), setSpinRate() makes the angular motor hold the
 * spin (a drive of unbounded torque): together they impose the slip.
 */
class SingleWheelRig
{
public:
  /**
   * @brief Sets the wheel down on `world`'s bed at (x, mid-width): 2 mm above the highest
   *        particle under it, lowered at 0.1 m/s until the soil carries the load (a wheel put
   *        down, not dropped), then free.
   * @throw DemParameterError naming the spec field (not > 0, facets < 12, grousers) or a wheel
   *        that does not fit in the domain
   */
  SingleWheelRig(DemWorld& world, const WheelRigSpec& spec, double x);
  ~SingleWheelRig();
  SingleWheelRig(const SingleWheelRig&) = delete;
  SingleWheelRig& operator=(const SingleWheelRig&) = delete;

  /// Hold the forward speed (m/s) from now on; NaN releases it (the wheel rolls freely along x).
  void setCarriageSpeed(double v);
  /// Hold the spin rate (rad/s) from now on; NaN releases it (a free, undriven wheel).
  void setSpinRate(double omega);

  /// One coupling interval: the DEM with the ODE state, then ODE with the DEM's force.
  void step();

  const WheelRigState& state() const { return state_; }
  const WheelRigSpec& spec() const { return spec_; }
  /// m: the ground height under the wheel before it was set down.
  double groundHeight() const { return ground_; }

private:
  struct Ode;
  DemWorld& world_;
  WheelRigSpec spec_;
  int body_ = -1;
  double ground_ = 0.0;
  WheelRigState state_;
  std::unique_ptr<Ode> ode_;
};

/**
 * @brief Mean of surfaceProbe() over a `length` x `width` rectangle centred at (x, y) (probes
 *        one largest radius apart) less the template's surfaceBias(): the bed's ground height
 *        there, as the heightfield it was cut to would give it (m).
 */
double bedSurface(const DemWorld& world, double x, double y, double length, double width);

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
