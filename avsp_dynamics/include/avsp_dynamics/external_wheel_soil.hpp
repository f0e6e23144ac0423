#pragma once
/**
 * @file external_wheel_soil.hpp
 * @brief A soil model outside the terrain's for some of a wheeled vehicle's wheels (the DEM
 *        moving patch of avsp_dynamics_dem): each step it sees every wheel where ODE has it and
 *        gives each a share of its contact and the force and torque of that share. The terrain's
 *        contact carries the rest (scaled by 1 - share); a share of 1 leaves the terrain out.
 *        ROS-free and LIGGGHTS-free: World knows only this interface.
 */
#include <string>
#include <vector>

#include <Eigen/Core>

namespace avsp
{
namespace dynamics
{
/// One wheel as ODE has it at the start of a step (map frame, SI units).
struct WheelKinematics
{
  std::string name;  ///< the wheel's URDF link
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d axle = Eigen::Vector3d::UnitY();  ///< unit, the spin axis (+ spin rolls forward along axle x z)
  double radius = 0.0, width = 0.0;
};

/// What an external soil does to a wheel over the next step.
struct ExternalWheelLoad
{
  /// [0, 1]: the share of the wheel's ground contact this soil takes; the terrain's contact
  /// carries 1 - share (0: the terrain alone, as without an external soil).
  double share = 0.0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< N on the wheel (map), for the step
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();  ///< N m on the wheel about its centre (map)
  double sinkage = 0.0;                              ///< m, reported in the wheel's state when share > 0
  double slip = 0.0;                                 ///< reported likewise
};

/// The interface (World::setExternalWheelSoil).
class ExternalWheelSoil
{
public:
  virtual ~ExternalWheelSoil() = default;
  /**
   * @brief Called at the start of every step of `step` s at world time `time` with the
   *        vehicle's wheels in its model's order; fills `loads` with one entry per wheel.
   * @throw std::exception to stop the step (World::step rethrows it)
   */
  virtual void advance(double time, double step, const std::vector<WheelKinematics>& wheels,
                       std::vector<ExternalWheelLoad>& loads) = 0;
};

}  // namespace dynamics
}  // namespace avsp
