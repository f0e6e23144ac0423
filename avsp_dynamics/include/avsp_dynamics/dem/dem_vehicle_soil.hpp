#pragma once
/**
 * @file dem_vehicle_soil.hpp
 * @brief The DEM contact mode for a wheeled vehicle (terramechanics: dem): over a segment of
 *        the terrain, each side of the vehicle runs on a moving DEM patch (MovingPatch) whose
 *        wheels are rigid meshes moved by ODE every coupling interval; the DEM's force and
 *        torque on each mesh go back to ODE through World::setExternalWheelSoil. Before and
 *        after the segment the terrain's own contact carries the wheels; rolling on and off
 *        the bed, a wheel's share of each goes linearly with the part of its diameter over the
 *        bed. When the vehicle has crossed, the beds' settled surfaces are in the terrain.
 */
#include <cstdint>
#include <memory>
#include <vector>

#include <avsp_terrain/deformable_terrain.hpp>

#include "avsp_dynamics/dem/dem_soil_config.hpp"
#include "avsp_dynamics/dem/moving_patch.hpp"
#include "avsp_dynamics/external_wheel_soil.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// What the crossing did (deterministic: a function of the run's inputs).
struct DemSoilReport
{
  int relocations = 0;                   ///< patch moves, all sides
  std::size_t peak_particles = 0;        ///< most particles alive at once, all sides
  std::uint64_t coupling_intervals = 0;  ///< DEM coupling intervals run, all sides
  double entered = -1.0;                 ///< s (world time) a wheel first had a share of the DEM, -1: never
  double left = -1.0;                    ///< s the last patch finished, -1: not yet
  double mean_sinkage = 0.0;             ///< m, over the steps and wheels carried wholly by the DEM
  double mean_slip = 0.0;                ///< likewise
  double max_sinkage = 0.0;              ///< m
  double energy = 0.0;                   ///< J the wheels did on the DEM soil (- the soil's power on them)
  std::size_t points_written = 0;        ///< terrain grid points the patches wrote back
  bool crossed = false;                  ///< every side's patch has finished
};

/**
 * @brief The ExternalWheelSoil of one wheeled vehicle over one DEM segment.
 *
 * The wheels are grouped into sides by their y at the first step (wheels within half the
 * template's width of each other); each side gets a strip the template's width wide centred
 * on its wheels, and a patch that is made (and settled) when the side's front wheel comes
 * within its radius + 5 cm of the segment, follows that wheel, and is finished when the side's
 * last wheel has rolled off the end. Serial and deterministic, like World.
 */
class DemVehicleSoil : public ExternalWheelSoil
{
public:
  /**
   * @param bed the template of every patch (its parameters are the soil's)
   * @param terrain read for the ground, written where the patches retire soil; must outlive this
   * @throw DemParameterError naming the key ("dem.segment.x_max: ...") for a spec out of range
   */
  DemVehicleSoil(BedTemplate bed, terrain::DeformableTerrain& terrain, const DemSegmentSpec& spec);
  ~DemVehicleSoil() override;

  /**
   * @throw DemParameterError naming the key or the wheel: the step not a whole number of
   *        coupling intervals, sides whose strips overlap or whose wheels do not fit one,
   *        a patch too short for its side's wheels, a wheel already on the segment when its
   *        patch would be made, a wheel that leaves its strip sideways or turns more than
   *        max_yaw_deg on the bed, a wheel mesh outside the DEM domain
   */
  void advance(double time, double step, const std::vector<WheelKinematics>& wheels,
               std::vector<ExternalWheelLoad>& loads) override;

  const DemSoilReport& report() const { return report_; }
  const DemSegmentSpec& spec() const { return spec_; }
  const BedTemplate& bed() const { return bed_; }
  /// Patches alive now (0 before and after the crossing).
  std::size_t activePatches() const;
  /// Particles alive now, all sides.
  std::size_t particleCount() const;

private:
  struct Side;
  void buildSides(const std::vector<WheelKinematics>& wheels);
  void startSide(Side& side, const std::vector<WheelKinematics>& wheels);
  void runSide(Side& side, double step, const std::vector<WheelKinematics>& wheels,
               std::vector<ExternalWheelLoad>& loads);
  double share(double x, double radius) const;

  BedTemplate bed_;
  terrain::DeformableTerrain& terrain_;
  DemSegmentSpec spec_;
  std::vector<std::unique_ptr<Side>> sides_;
  bool sides_built_ = false;
  DemSoilReport report_;
  double sinkage_sum_ = 0.0, slip_sum_ = 0.0;
  std::uint64_t carried_ = 0;  ///< wheel-steps wholly on the DEM
};

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
