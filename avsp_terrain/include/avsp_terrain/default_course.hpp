#pragma once
/**
 * @file default_course.hpp
 * @brief The embedded default course: a procedural off-road test course built from a seed,
 *        so the simulator has terrain to drive on without downloading anything.
 *
 * The layout (which feature sits where) depends only on the extents; the seed changes the
 * rolling hills, the soil mottling and the vegetation. Features keep their sizes and sit
 * at fractions of the extents, so a smaller course (down to kMinCourseLengthX x
 * kMinCourseLengthY) holds the same features closer together.
 */
#include <cstdint>
#include <string>
#include <vector>

#include "avsp_terrain/elevation_grid.hpp"
#include "avsp_terrain/terrain_objects.hpp"

namespace avsp
{
namespace terrain
{
/// Smallest east-west extent (m) that holds the fixed-size features without overlap.
constexpr double kMinCourseLengthX = 300.0;
/// Smallest north-south extent (m) that holds the fixed-size features without overlap.
constexpr double kMinCourseLengthY = 200.0;

/// Options of makeDefaultCourse().
struct CourseOptions
{
  std::uint64_t seed = 1;   ///< hills, soil mottling and vegetation; not the feature placement
  double cell_size = 0.1;   ///< m, grid spacing along x and y: finite, > 0, <= a tenth of each extent
  double length_x = 600.0;  ///< m, east-west extent: finite, >= kMinCourseLengthX
  double length_y = 400.0;  ///< m, north-south extent: finite, >= kMinCourseLengthY
};

/// A named axis-aligned region of the course (map frame, m), so tests, scenarios and docs
/// can find a feature without knowing the layout.
struct CourseFeature
{
  std::string name;
  double min_x, min_y, max_x, max_y;  ///< m, map
};

/**
 * @brief The built course.
 *
 * Features (names in `features`):
 * - "rolling_hills": open ground where the seeded hills are strongest (a few metres of relief);
 *   the hills also run under everything else, gentler.
 * - "ditch": 1.5 m deep, 3.5 m wide at the top, 40 m long along x; its banks are level across.
 * - "side_slope": a plane of 17.5 deg rising northwards, 40 m (x) by 25 m (y).
 * - "rough_patch": 40 m x 30 m of bumps 0.1-0.3 m high, 1.2-2.2 m across.
 * - "dirt_trail": gravel trail 3.5 m wide running north to the road, level across.
 * - "road": asphalt road 7 m wide across the whole course along x, level across.
 * - "staging_area": flat gravel yard with buildings; "concrete_pad": flat asphalt pad in it.
 * - "barrier_course": flat lane with concrete barriers in a slalom (gates alternate sides).
 * - "fence_line": chain-link fence segments (toppleable, 3500 N) between poles (6000 N).
 * - "pond": elliptic mud hollow 1.2 m deep, below a level rim.
 * - "woods": large trees (rigid), small trees and shrubs (toppleable), rocks (rigid) and
 *   grass patches (never blocking); a few more are scattered over open ground.
 * - "sand_patch", "clay_patch": dry_sand and clay soil patches (ragged edges inside the box).
 */
struct Course
{
  ElevationGrid heights;                ///< m; grid point (0, 0) at the south-west corner, map (0, 0)
  std::vector<std::string> soil_names;  ///< soil index -> soil name in config/soils.yaml
  std::vector<std::uint8_t> soil_map;   ///< per grid point (index j * columns + i), index into soil_names
  ObjectSet objects;
  std::vector<CourseFeature> features;

  /// The feature called `name`. @throw std::out_of_range naming the feature if there is none
  const CourseFeature& feature(const std::string& name) const;
};

/**
 * @brief Builds the default course. Same options give bit-identical heights, soil map and
 *        objects (single-threaded, integer hashing, no library random distributions).
 *
 * Cost: about 24 M grid points at the default options; one pass over the grid plus passes
 * over each feature's neighbourhood.
 * @throw std::invalid_argument naming the option (cell_size, length_x, length_y) when a size
 *        is non-finite or not positive, cell_size exceeds a tenth of an extent, an extent is
 *        below its minimum, or the grid would exceed 2^31 points
 */
Course makeDefaultCourse(const CourseOptions& options);

}  // namespace terrain
}  // namespace avsp
