#pragma once
/**
 * @file deformable_terrain.hpp
 * @brief Terrain that ruts: base heights (ElevationGrid), a soil per grid point (a palette of
 *        up to 256 soils and a uint8 soil map), per-point deformation (docs/MODELS.md T2-T6)
 *        stored sparsely in tiles allocated only where running gear has touched, and the
 *        rigid-wheel and track-patch soil contacts (T7-T13) that deform it, with grass
 *        resistance and toppling vegetation (docs/MODELS.md section 3).
 */
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "avsp_terrain/contact_soil.hpp"
#include "avsp_terrain/elevation_grid.hpp"
#include "avsp_terrain/soil.hpp"
#include "avsp_terrain/terrain_objects.hpp"

namespace avsp
{
namespace terrain
{
/// A rigid wheel touching the ground (upright: axle horizontal, perpendicular to heading).
struct WheelPatch
{
  Eigen::Vector3d centre;    ///< m, wheel centre in map
  double radius = 0.0;       ///< m, > 0
  double width = 0.0;        ///< m, > 0
  double heading = 0.0;      ///< rad, direction the wheel rolls towards, from map x (CCW)
  double spin_rate = 0.0;    ///< rad/s, positive rolls the wheel forward
  Eigen::Vector3d velocity;  ///< m/s, velocity of the wheel centre in map
  /// The shear slip (longitudinal, lateral) the soil's shear is mobilised at (T7, T11): the
  /// direction of the shear force on the wheel (+x forward, +y to its left) and its magnitude,
  /// j = |s| x behind the contact's leading edge. Used when `shear_slip_given`; otherwise the
  /// kinematic slip of the speeds (regularisedSlip(), lateral -v_lat over the same speed).
  /// A vehicle gives its own when the shear must lag the kinematics (a wheel at rest holds by
  /// the soil's displacement, not by a ratio of two speeds near 0).
  Eigen::Vector2d shear_slip = Eigen::Vector2d::Zero();
  bool shear_slip_given = false;
  /// m: the largest shear displacement any of the contact's soil has, j = min(|s| x, shear_cap)
  /// (with shear_slip_given). A contact at rest on its soil has displaced all of it alike (the
  /// cap: its displacement), a rolling one renews it from the leading edge (j = |s| x).
  double shear_cap = std::numeric_limits<double>::infinity();
  /// Which way the contact's leading edge faces (+1 ahead, -1 behind: where the shear
  /// displacement starts, T11); 0: the way the wheel moves (a caller that keeps it through a
  /// standstill's tiny reversals keeps the shear from jumping front to back).
  int travel = 0;
  /// dz/du of the ground along the heading (+ uphill ahead): Bekker's compaction resistance is
  /// the rim's push along the ground, so on a slope the rim's angles count from its normal (the
  /// vertical pressures would otherwise count the slope's own share of the weight as resistance).
  double ground_slope = 0.0;
};

/**
 * @brief A track's ground contact, or one segment of it: a flat rectangle (the track's ground
 *        face), level or tilted to a given normal, pressed into the soil, driven by a sprocket
 *        (T10). A plate with no sprocket speed is a sliding plate (a hull's belly).
 *
 * A vehicle may split a track into segments (one per road wheel, each at its own height):
 * give each its place on the whole track (track_length, segment_offset) so that the shear
 * displacement j = s x keeps growing from the whole track's leading edge (T7, T11) instead
 * of restarting at every segment.
 */
struct TrackPatch
{
  Eigen::Vector3d centre;           ///< m, centre of the rectangle in map; z = height of the ground face
  double heading = 0.0;             ///< rad, direction of the track's length (forward), from map x (CCW)
  double length = 0.0;              ///< m, along heading, > 0
  double width = 0.0;               ///< m, > 0
  double sprocket_pitch = 0.0;      ///< m, track pitch p of T10, > 0
  int sprocket_teeth = 0;           ///< N of T10, > 0
  double sprocket_spin_rate = 0.0;  ///< rad/s, positive drives the vehicle forward
  Eigen::Vector3d velocity;         ///< m/s, velocity of the patch in map
  double track_length = 0.0;        ///< m, ground contact length of the whole track; 0: this patch is all of it
  double segment_offset = 0.0;      ///< m, this patch's centre from the whole track's centre, + forward
  /// Unit normal of the ground face (up, n_z >= 0.25): a segment lying on a slope follows it.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  /// As WheelPatch::shear_slip (longitudinal along heading).
  Eigen::Vector2d shear_slip = Eigen::Vector2d::Zero();
  bool shear_slip_given = false;
  /// As WheelPatch::shear_cap.
  double shear_cap = std::numeric_limits<double>::infinity();
  /// As WheelPatch::travel.
  int travel = 0;
};

/// What the soil (and vegetation) does to one wheel or track patch this step. Forces act on the
/// running gear, in its frame (longitudinal along heading, lateral to its left, normal up).
struct ContactForces
{
  double normal_force = 0.0;        ///< N
  double longitudinal_force = 0.0;  ///< N, traction (T7, T11), + pushes forward
  double lateral_force = 0.0;       ///< N, + pushes to the left
  double resistance_force = 0.0;    ///< N, opposes motion (>= 0): T12 or Bekker compaction, plus grass
  double grass_resistance = 0.0;    ///< N, the part of resistance_force due to grass patches
  double sinkage = 0.0;             ///< m, deepest grid point below the undeformed surface (incl. elastic)
  double elastic_sinkage = 0.0;     ///< m, largest elastic part under the patch (recovers on unloading)
  double slip = 0.0;                ///< T8 regularised at low speed (regularisedSlip()), [-1, 1]
  double slip_angle = 0.0;          ///< rad, atan(v_lat / max(|v_long|, kSlipRegularisationSpeed))
  int contact_points = 0;           ///< grid points under load
  /// N: Mohr-Coulomb limit of the loaded soil, sum of (c + sigma tan phi) A: the most its shear
  /// can give in any direction at any slip (T7 at full shear displacement).
  double shear_strength = 0.0;
  double shear_slope = 0.0;      ///< N per unit slip: d |shear force| / d |shear slip| at this slip (T11)
  double shear_cap_slope = 0.0;  ///< N/m: d |shear force| / d shear_cap (the soil displaced to the cap)
  /// N/m: d |shear force| / d j at j = 0 with all the soil under the gear displaced alike, the
  /// strength over Janosi's K: the slope its elastic part unloads on (a gear that stops sliding
  /// springs back by force / this, of the order of K, not by its whole slip).
  double shear_elastic_slope = 0.0;
  double contact_length = 0.0;    ///< m, loaded length along travel (a track: the whole track's)
  double normal_stiffness = 0.0;  ///< N/m, d normal_force / d sinkage pressing deeper (loading)
  double unload_stiffness = 0.0;  ///< N/m, the same coming back up (the soil's elastic part)
  /// Share (0-1) of the footprint on rigid surfaces (near a wheel's bottom, or the whole plate):
  /// the soil there carries nothing, a tyre or track pad pressed on it does (the vehicle's model).
  double rigid_share = 0.0;
  int rigid_soil = -1;                          ///< palette index of that surface, -1 when none
  std::vector<std::uint32_t> toppled_objects;   ///< object ids this step pushed over
  std::vector<std::uint32_t> standing_objects;  ///< object ids under the footprint still standing
};

/// Deformation of one grid point (what a rut remembers).
struct PointDeformation
{
  float plastic = 0.f;    ///< m, z_p (T2; Bekker soils: the sinkage reached), only grows
  float displaced = 0.f;  ///< m, z_f - z_n (T4, T5): soil pushed away minus soil received
  float sigma_max = 0.f;  ///< Pa, largest normal stress seen (governs T2 and T4's b1 term)
};

/// One grid point's deformation before and after an interval (DeformableTerrain change
/// tracking): what a dynamics partition sends the others so they drive on the same ruts.
struct PointChange
{
  std::uint32_t i = 0, j = 0;  ///< grid point
  PointDeformation before;     ///< at the start of the interval
  PointDeformation after;      ///< at its end
};

/**
 * @brief Elevation grid + soil map + sparse deformation state + wheel and track contact.
 *
 * Height of a point = base - z_p - (z_f - z_n); while loaded also - z_e (T3, T6).
 * Tiles of kTileSize x kTileSize points are allocated the first time a point in them
 * deforms; untouched terrain costs its base heights, one soil byte per point (none with a
 * single soil) and one pointer per tile (a dense directory: 8 B per 64 points, so lookups
 * are an index, not a hash).
 *
 * Per point the contact uses that point's soil:
 * - `simple` soils: the normal stress at which T2 compaction + T4 bearing flow (b1) + T3
 *   elastic sinkage absorb the penetration; T12 resistance.
 * - `bekker` soils: p = (k_c / b + k_phi) z^n with z the point's sinkage below its
 *   undeformed surface and b the wheel's width (as in T13) or a track's smaller dimension.
 *   The soil is rigid-plastic: the sinkage stays (no rebound; a rut carries the pressure it
 *   was made with before it sinks further), which is what the rigid-wheel theory behind T13
 *   assumes when the rear of a rolling wheel unloads. Resistance is Bekker's compaction
 *   resistance: for a wheel the horizontal component of the rim pressure (so a wheel at
 *   rest, loaded front and back alike, has none), for a track the compaction work per metre
 *   travelled, b k z^(n+1) / (n + 1). No T3 or T4-b1 terms: Bekker's law is the whole
 *   static sinkage; T4's slip-driven flow (b2) and T5 transport still apply, so a slipping
 *   wheel in sand digs and piles soil.
 * - Both: T7 Mohr-Coulomb/Janosi shear with j = s x behind the leading edge (T11).
 *
 * Grid points along the footprint's side edges (and a track's ends) carry the share of their
 * cell the footprint covers (half when the edge passes through the point; the outermost point
 * inside also takes the sliver of the next cell), so the loaded width (and a track's length)
 * equals the running gear's for any alignment with the grid instead of rounding to whole cells.
 *
 * Vegetation (docs/MODELS.md section 3), when the contact is given the ObjectSet:
 * - A grass patch adds rolling resistance: its `rolling_resistance` f times the normal load
 *   carried by the grid points inside it (the largest f where patches overlap: grass on grass
 *   is still one sward). The default course gives its patches f = 0.05-0.10, an assumption
 *   of the same order as a tyre on medium-hard soil (0.04-0.08 in the usual tables of
 *   rolling-resistance coefficients); no public table gives grass alone.
 * - Any other object standing (not toppled) whose footprint overlaps the loaded footprint is
 *   run over and takes the running gear's whole contact force |(N, F_long, F_lat)| towards
 *   the direction of travel -- an assumption: a stem or post under a wheel or track bears its
 *   load until it gives. If that reaches its strength it topples (ObjectSet::push) and is
 *   listed in `toppled_objects`; rigid or stronger ones are listed in `standing_objects` for
 *   the dynamics to collide with (the soil contact cannot know the vehicle's momentum).
 *   Probes (deform = false) push nothing over.
 */
class DeformableTerrain
{
public:
  static constexpr int kTileSize = 8;
  /// Largest palette: soil indices are one byte.
  static constexpr std::size_t kMaxSoils = 256;

  /// Behaviour switches.
  struct Options
  {
    bool transport = true;  ///< T5 on: flowed soil arrives at neighbours (berms); off: z_n = 0
  };

  /**
   * @brief One soil everywhere (no soil map is stored).
   * @throw std::invalid_argument naming the soil field when `soil` is unusable (see ContactSoil)
   */
  DeformableTerrain(ElevationGrid base, SoilParameters soil, Options options);

  /**
   * @brief A soil per grid point.
   * @param palette the soils, 1 to kMaxSoils of them
   * @param soil_map index into `palette` per grid point (index j * columns + i), columns * rows entries
   * @throw std::invalid_argument naming `palette` or `soil_map` and the reason: empty or too
   *        large palette, an unusable soil, a map of the wrong size, an index not in the palette
   */
  DeformableTerrain(ElevationGrid base, std::vector<SoilParameters> palette, std::vector<std::uint8_t> soil_map,
                    Options options);

  /// Deformed (unloaded) height at (x, y), bilinear, m; nullopt outside the grid.
  std::optional<double> height(double x, double y) const;

  /// Deformed (unloaded) height of grid point (i, j), m. @throw std::out_of_range outside the grid
  double pointHeight(std::size_t i, std::size_t j) const;

  /// Deformation of grid point (i, j) (zeros where never touched). @throw std::out_of_range outside the grid
  PointDeformation deformation(std::size_t i, std::size_t j) const;

  /**
   * @brief Soil contact of a rigid wheel for one step of length dt (s).
   * @param deform true: the step's compaction and flow become permanent (ruts) and objects
   *        pushed hard enough topple; false: a probe that leaves terrain and objects as they were
   * @param objects if given: grass patches under the loaded footprint add resistance, other
   *        objects it overlaps are pushed (see the class notes on vegetation)
   * @throw std::invalid_argument naming the field: non-finite centre, velocity, heading or
   *        spin rate, radius or width not > 0, dt not finite or negative
   */
  ContactForces wheelContact(const WheelPatch& wheel, double dt, bool deform, ObjectSet* objects = nullptr);

  /**
   * @brief Soil contact of a flat track patch for one step of length dt (s): slip from the
   *        sprocket's theoretical speed (T10, T8), pressure per point as for wheels, shear
   *        j = s x from the whole track's leading edge (T7, T11), T12 or Bekker compaction
   *        resistance. Same `deform` and `objects` semantics as wheelContact().
   * @throw std::invalid_argument naming the field: non-finite values; length, width, pitch
   *        or teeth not > 0; track_length neither 0 nor >= length; the patch not within the
   *        track (segment_offset); dt not finite or negative
   */
  ContactForces trackContact(const TrackPatch& track, double dt, bool deform, ObjectSet* objects = nullptr);

  /// m^3: soil volume that left points by flow so far, and volume that arrived by transport.
  double flowedVolume() const { return flowed_volume_; }
  double arrivedVolume() const { return arrived_volume_; }

  /// Points whose deformation is not all zero, and bytes held by the deformation tiles.
  std::size_t deformedPoints() const;
  std::size_t deformationBytes() const;
  /// Bytes of the tile directory: fixed per grid (8 B per kTileSize^2 points).
  std::size_t directoryBytes() const;
  /// Bytes of the soil map: fixed per grid, 1 B per grid point (0 with a single soil).
  std::size_t soilMapBytes() const { return soil_map_.size(); }

  /// Grid points (i, j) that carry state (all points of allocated tiles), in row-major tile
  /// order then row-major within the tile: what a save must write to restore bit-exactly.
  std::vector<std::pair<std::size_t, std::size_t>> statefulPoints() const;

  /// Restores one point's deformation (loading a saved terrain). @throw std::out_of_range outside the grid
  void setDeformation(std::size_t i, std::size_t j, const PointDeformation& d);
  /// Restores the flow accounting (loading a saved terrain).
  void setVolumes(double flowed, double arrived)
  {
    flowed_volume_ = flowed;
    arrived_volume_ = arrived;
  }
  const Options& options() const { return options_; }

  /**
   * @brief Records which points change from now on (on), or stops and forgets (off). The
   *        first change of a tile in an interval copies the tile as it was (768 B), so
   *        tracking costs one flag test per contact point and a copy per tile per interval.
   */
  void setChangeTracking(bool on);
  bool changeTracking() const { return tracking_; }
  /**
   * @brief The points whose deformation differs from the start of the interval (when tracking
   *        began or the last call), with both states, in tile order then row-major within the
   *        tile; starts the next interval. Empty when tracking is off.
   */
  std::vector<PointChange> takeChanges();
  /// takeChanges() into `out` (replaced; its capacity kept, so a steady run allocates nothing).
  void takeChanges(std::vector<PointChange>& out);
  /**
   * @brief Applies another terrain's changes (takeChanges() there, same grid). A point still
   *        exactly at `before` becomes `after` bit for bit (so processes that never touch the
   *        same point in one interval hold identical terrains); a point this terrain changed
   *        too is merged: plastic and sigma_max take the larger, displaced adds the other's
   *        change (after - before). Applied changes are not reported by takeChanges() as
   *        this terrain's own; the flow accounting (flowedVolume) is not changed.
   * @return the number of merged points (both changed them in the same interval)
   * @throw std::out_of_range naming the point when one is outside the grid (nothing applied);
   *        std::invalid_argument when a value is not finite (nothing applied)
   */
  std::size_t applyChanges(const std::vector<PointChange>& changes);

  const ElevationGrid& base() const { return base_; }

  /// The soils, indexed by the soil map.
  const std::vector<SoilParameters>& palette() const { return palette_; }
  /// Palette index of grid point (i, j). @throw std::out_of_range outside the grid
  std::uint8_t soilIndex(std::size_t i, std::size_t j) const;
  /// Soil of grid point (i, j). @throw std::out_of_range outside the grid
  const SoilParameters& soil(std::size_t i, std::size_t j) const { return palette_[soilIndex(i, j)]; }
  /**
   * @brief Replaces palette entry `index` (e.g. the same soil at a new moisture, dynamic_soil.hpp);
   *        every point mapped to it uses the new parameters from the next contact on.
   * @throw std::invalid_argument naming `index` (not in the palette) or the soil field
   */
  void setSoil(std::size_t index, SoilParameters soil);

private:
  using Tile = std::array<PointDeformation, kTileSize * kTileSize>;

  /// A grid point under the running gear this step.
  struct LoadedPoint
  {
    std::uint32_t i, j;
    std::uint8_t soil;      ///< palette index
    bool deforms;           ///< the point itself is under the running gear (its state changes)
    bool virgin;            ///< ... on first loading (it yields: its permanent sinkage grows)
    double weight;          ///< share of the point's cell under the footprint, (0, 2.25)
    double along0, along1;  ///< m, its loaded stretch along the direction of travel (footprint frame)
    double x0, x1;          ///< m, its strip behind the leading edge (shear displacement, T11)
    double penetration;     ///< m, below the current unloaded surface, at the point
    double sigma;           ///< Pa, mean over its cell (a wheel's strip: the unpressed part counting 0)
    double pressed;         ///< of its cell along the travel, the part the gear presses (where cohesion acts)
    double sigma_point;     ///< Pa, at the point (what its state records)
    double slope;           ///< Pa/m, d sigma / d penetration, loading
    double unload;          ///< Pa/m, unloading
    double elastic;         ///< m, the part of the sinkage that springs back
    double depth;           ///< m, Bekker soils: sinkage below the undeformed surface (plastic + penetration)
    double rim_slope;       ///< wheel on Bekker soil: horizontal / vertical rim pressure, + opposes travel
    double flow_volume;     ///< m^3 that flowed away this step (T4), for transport (T5)
    double shear_fraction;  ///< of flow_volume, the slip-driven part (T4's b2 term)
  };

  /// Where a contact is and how it moves, shared by wheels and tracks.
  struct Footprint;
  /// A grid point's height and state as a wheel's contact samples them between points.
  struct WindowPoint
  {
    double base = 0.0, plastic = 0.0, displaced = 0.0, sigma_max = 0.0;
    double plastic_min = 0.0;  ///< the least plastic sinkage of the points interpolated from
    double along = 0.0;        ///< m, the point's place along the footprint's travel (+ ahead of its centre)
  };
  /// Copies the points (i0..i1, j0..j1) into window_ (a wheel's footprint and one point round it).
  void fillWindow(std::size_t i0, std::size_t i1, std::size_t j0, std::size_t j1);
  /// The window's state at (x, y), bilinear between its four points; `behind` > 0: a sample
  /// behind a rolling footprint's bottom, interpolated from the points behind it only; < 0:
  /// ahead of it, from the points ahead only. Only the fields the samples read: plastic_min
  /// for behind < 0 (+inf otherwise), sigma_max `with_sigma` (0 otherwise).
  WindowPoint windowState(double x, double y, double behind, bool with_sigma) const;
  /// spreadFlow(): the window offset where soil dragged from the window point `start` (column
  /// a, row b of a width x height window) lands: the first point along the drag not under the
  /// footprint, or the last one in the window. Memoised in landing_.
  long landingOf(long start, long a, long b, long width, long height);

  /// @throw std::out_of_range naming `function` and the point when (i, j) is outside the grid
  void checkPoint(const char* function, std::size_t i, std::size_t j) const;
  const PointDeformation* find(std::size_t i, std::size_t j) const;
  std::size_t tileIndex(std::size_t i, std::size_t j) const { return (j / kTileSize) * tiles_x_ + i / kTileSize; }
  PointDeformation& touch(std::size_t i, std::size_t j);
  /// T5: hands each loaded point's flow_volume to its 8 neighbours.
  void spreadFlow();
  /// What collect() works out once per contact (grid range, spacings, the wheel's window).
  struct Sweep;
  /// Slip and the points under the footprint with penetration, stress and strip (loaded_).
  void collect(const Footprint& fp, ContactForces& out);
  /// The grid range and spacings of a contact; for a wheel also its window. False: off the grid.
  bool sweepOf(const Footprint& fp, Sweep& sw);
  /// Adds grid point (i, j) at (u, v) in the footprint to loaded_ if the gear loads it.
  void loadPoint(const Footprint& fp, const Sweep& sw, std::size_t i, std::size_t j, double u, double v,
                 double lateral_weight, std::uint8_t soil_index, const PointDeformation& state, double base_z,
                 ContactForces& out);
  /// A wheel's point: its cell's mean pressure over the rim's stretch of it. False: it carries nothing.
  bool loadWheelCell(const Footprint& fp, const Sweep& sw, LoadedPoint& p, double u, double surface,
                     const ContactSoil& soil, double modulus) const;
  /// Whether the rim's lowest point over [lo, hi] along the footprint is above all soil round p.
  bool rimClearsCell(const Footprint& fp, const Sweep& sw, const LoadedPoint& p, double lo, double hi) const;
  /// A track point's strip behind the whole track's leading edge, and its weight along it.
  void placeTrackStrip(const Footprint& fp, const Sweep& sw, LoadedPoint& p, double u) const;
  /// Forces from loaded_, then (deform) makes the step permanent.
  void forcesAndDeform(const Footprint& fp, double dt, bool deform, ObjectSet* objects, ContactForces& out);
  /// Normal force, traction, stiffnesses and resistance of loaded_ into out.
  void sumForces(const Footprint& fp, ContactForces& out) const;
  /// The step made permanent at loaded_'s points (sinkage, stress, soil that flowed away).
  void deformLoaded(const Footprint& fp, double dt);
  /// The grid step (drag_di_, drag_dj_) nearest the direction the gear's slip drags soil.
  void chooseDragStep(const Footprint& fp);
  /// Grass resistance and pushes on the objects under the loaded footprint.
  void vegetation(const Footprint& fp, bool deform, ObjectSet& objects, ContactForces& out) const;

  ElevationGrid base_;
  std::vector<SoilParameters> palette_;
  std::vector<ContactSoil> contact_soils_;  ///< palette_ prepared for the contact's inner loop
  std::vector<std::uint8_t> soil_map_;      ///< per grid point; empty: index 0 everywhere
  Options options_;
  std::size_t tiles_x_;
  std::vector<std::unique_ptr<Tile>> tiles_;  ///< tile directory, row-major, null = untouched
  std::size_t allocated_tiles_ = 0;
  double flowed_volume_ = 0.0;
  double arrived_volume_ = 0.0;
  std::vector<LoadedPoint> loaded_;  ///< scratch of the current contact (kept: no allocation per call)
  std::vector<double> arrivals_;     ///< scratch: soil arriving per point of the contact's window, m
  std::vector<WindowPoint> window_;  ///< scratch: the points round a wheel's footprint (fillWindow)
  std::vector<std::uint8_t> under_;  ///< scratch of spreadFlow(): 1 where a point of the window is loaded
  std::vector<long> landing_;  ///< scratch of spreadFlow(): where soil dragged from a window point lands, -1 unknown
  std::vector<long> landing_path_;  ///< scratch of landingOf()
  int drag_di_ = 0, drag_dj_ = 0;   ///< the grid step along which this contact's slip drags soil
  /// m, length of the grid step (di, dj) at [(dj + 1) * 3 + di + 1] (forcesAndDeform's drag direction)
  std::array<double, 9> step_length_{};
  std::size_t window_i0_ = 0, window_j0_ = 0, window_columns_ = 0, window_rows_ = 0;
  /// m, an upper bound of the surface anywhere in the window (max of base - displaced less the
  /// least plastic sinkage): the rim cannot press where it is above it.
  double window_top_ = 0.0;
  // Change tracking: per tile, its state at the start of the interval once it changed in it.
  bool tracking_ = false;
  std::vector<std::unique_ptr<Tile>> before_;       ///< same indexing as tiles_, null = unchanged
  std::vector<std::size_t> changed_tiles_;          ///< tiles with a before_ copy, in first-change order
  std::vector<std::unique_ptr<Tile>> spare_tiles_;  ///< before_ buffers of past intervals, for reuse
};

/**
 * @brief The palette for `names` (e.g. Course::soil_names) from the soil library, in order.
 * @throw SoilError naming the soil when the library has no soil of that name
 */
std::vector<SoilParameters> paletteFromNames(const std::vector<std::string>& names, const SoilLibrary& library);

}  // namespace terrain
}  // namespace avsp
