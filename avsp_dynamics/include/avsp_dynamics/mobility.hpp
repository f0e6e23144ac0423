#pragma once
/**
 * @file mobility.hpp
 * @brief The mobility matrix: vehicle x surface x manoeuvre cases run through the same World as
 *        every other job, each figure set against its reference: a closed form computed here
 *        from the vehicle's and the soil's parameters (docs/MODELS.md: Bekker-Wong-Janosi, the brush
 *        tyre, the drivetrain's force), a public figure, or an acceptance limit. The cases are
 *        data (config/mobility_matrix.yaml); test_mobility_matrix asserts each, bench_mobility
 *        prints the table (docs/mobility_matrix.md keeps it).
 */
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include <avsp_terrain/deformable_terrain.hpp>

#include "avsp_dynamics/vehicle_model.hpp"

namespace avsp
{
namespace dynamics
{
namespace mobility
{
/// How a case's figure is judged.
enum class Check
{
  kClosedForm,  ///< |value - closed form| <= tolerance x |closed form|
  kPublic,      ///< |value - public figure| <= tolerance x |public figure|
  kAtMost,      ///< value <= limit
  kAtLeast,     ///< value >= limit
};

/// One row of the matrix (config/mobility_matrix.yaml, one map per case).
struct Case
{
  std::string id;         ///< unique, e.g. "brake-10-fed_alpha-asphalt-1ms"
  std::string vehicle;    ///< config/vehicles/<vehicle>.yaml
  std::string soil;       ///< config/soils.yaml name
  std::string manoeuvre;  ///< see manoeuvres()
  Check check = Check::kClosedForm;
  double slope_deg = 0.0;  ///< the ground's slope (side slope, grade, plane), degrees
  double speed = 0.0;      ///< m/s: initial speed (braking), held speed (turn)
  double steering = 0.0;   ///< [-1, 1] (turn)
  double slip = 0.0;       ///< single-wheel rig's slip
  double duration = 0.0;   ///< s, 0: the manoeuvre's own
  double step = 0.001;     ///< s, physics step
  double tolerance = 0.1;  ///< relative (closed form, public figure)
  /// Absolute, in the figure's unit (closed form only; NaN: the relative tolerance applies)
  double tolerance_abs = std::numeric_limits<double>::quiet_NaN();
  double value = std::numeric_limits<double>::quiet_NaN();  ///< the public figure or the limit
  std::string unit;                                         ///< of the figure
  std::string source;  ///< what the reference is: the closed form's name or the public figure's source
};

/// What one case gave.
struct Result
{
  double value = 0.0;      ///< AVSP's figure
  double reference = 0.0;  ///< closed form, public figure or limit
  /// A closed form's lower bound where it has two (NaN otherwise): `reference` is the upper one,
  /// and a figure between them has no error.
  double reference_low = std::numeric_limits<double>::quiet_NaN();
  double error = 0.0;  ///< relative to the reference (the nearer bound), or value - limit
  bool pass = false;
  std::string detail;  ///< what else the run measured (one line)
  double wall = 0.0;   ///< s of wall time the case took
};

/// Where the vehicles and soils are.
struct Setup
{
  std::string vehicle_dir;  ///< directory of <model>.yaml
  std::string soils_yaml;   ///< soil library
};

/// The manoeuvres a case may name, with one line on what each measures.
const std::vector<std::pair<std::string, std::string>>& manoeuvres();

/**
 * @brief Reads the matrix.
 * @throw std::runtime_error naming the file and the key (case index and field) for anything
 *        missing, mistyped, unknown or out of range, a duplicate id or an unknown manoeuvre
 */
std::vector<Case> loadMatrix(const std::string& yaml_path);

/**
 * @brief Runs one case (deterministic: the same case gives the same figure bit for bit).
 * @throw std::runtime_error for a vehicle or soil the setup does not have, or a manoeuvre the
 *        vehicle cannot do (e.g. a steering radius for a tracked vehicle)
 */
Result run(const Case& c, const Setup& setup);

/**
 * @brief base_link's pose at (x, y) with `yaw`, tilted by `roll` and `pitch` (rad, to lie on a
 *        plane), lowered until its lowest running gear is `clearance` m above the ground: how
 *        every manoeuvre sets a vehicle down on a slope.
 * @throw std::runtime_error if the running gear is off the terrain
 */
Eigen::Isometry3d placeOnGround(const terrain::DeformableTerrain& ground, const VehicleModel& model, double x, double y,
                                double yaw, double roll, double pitch, double clearance);

/// m, the radius of the least-squares circle through `points` (Kasa fit; at least 3).
double circleRadius(const std::vector<Eigen::Vector2d>& points);

/// The check's sign: "<=", ">=", or "+-<tolerance %>" for a case.
std::string criterion(const Case& c);

}  // namespace mobility
}  // namespace dynamics
}  // namespace avsp
