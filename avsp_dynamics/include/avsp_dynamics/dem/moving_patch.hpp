#pragma once
/**
 * @file moving_patch.hpp
 * @brief The moving terrain patch (MTP): a DEM bed that travels with a wheel (or a vehicle
 *        side) along a segment of the terrain, so a long traverse holds a bounded number of
 *        particles. Behind, a block of particles is retired and its settled surface written back
 *        into the DeformableTerrain (ruts persist; sensors see them); ahead, a fresh block cut
 *        to the terrain's (deformed) heights is inserted. Blocks are one template length long.
 */
#include <cstddef>

#include <avsp_terrain/deformable_terrain.hpp>

#include "avsp_dynamics/dem/dem_world.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// Where the patch runs.
struct PatchSpec
{
  double x_start = 0.0;        ///< m, the patch's rear end at the start (map x)
  double x_end = 0.0;          ///< m, the segment's end: the patch stops there
  double y_min = 0.0;          ///< m, the patch's side at lower y (it is the template's width wide)
  double length = 2.0;         ///< m, a whole number of template lengths
  double front_margin = 0.75;  ///< m: the patch moves on when what it follows is nearer its front
  double clearance = 0.6;      ///< m of domain above the highest ground (room for the wheels)
  /// m of domain before x_start and after x_end, no bed there: room for wheels that roll on
  /// and off the bed (a wheel's mesh must stay in the domain while the patch lives), >= 0
  double domain_before = 0.0, domain_after = 0.0;
};

/**
 * @brief A DemWorld whose bed follows a point (a wheel's centre) along +x over a terrain.
 *
 * Its domain covers the whole segment [x_start, x_end] and the margins before and after it
 * (LIGGGHTS' bins scale with it, a few bytes per (2 largest radii)^3; the particles are
 * bounded by the patch).
 */
class MovingPatch
{
public:
  /**
   * @param terrain read for the ground heights, written where blocks are retired
   * @throw DemParameterError naming the key: length not whole blocks or longer than the segment,
   *        front_margin not in (0, length), a domain margin < 0, the ground's relief along the strip deeper than the
   *        template allows ("ground"), the memory budget
   */
  MovingPatch(const BedTemplate& bed, terrain::DeformableTerrain& terrain, const PatchSpec& spec);

  DemWorld& world() { return *world_; }
  const DemWorld& world() const { return *world_; }

  /**
   * @brief Moves the patch one block ahead when `x` (the followed point) is nearer its front
   *        than front_margin and the segment goes on: retires the rear block (its surface
   *        written into the terrain), inserts a fresh block at the front, moves the end walls.
   * @return true when it moved
   */
  bool follow(double x);

  /**
   * @brief Ends the patch: the whole bed's surface written into the terrain, its particles
   *        removed (the segment's crossing is over). Idempotent; follow() does nothing after.
   */
  void finish();
  bool finished() const { return finished_; }

  double rear() const { return rear_; }
  double front() const { return rear_ + spec_.length; }
  int relocations() const { return relocations_; }
  /// Terrain grid points written back so far.
  std::size_t pointsWritten() const { return points_written_; }

private:
  /// Writes the bed's surface over [x0, x1) into the terrain.
  void writeBack(double x0, double x1);

  BedTemplate bed_;
  terrain::DeformableTerrain& terrain_;
  PatchSpec spec_;
  std::unique_ptr<DemWorld> world_;
  double rear_ = 0.0;
  int relocations_ = 0;
  std::size_t points_written_ = 0;
  bool finished_ = false;
};

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
