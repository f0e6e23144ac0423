#pragma once
/**
 * @file soil.hpp
 * @brief Soil parameters (simple terramechanics model T2-T12 and Bekker-Wong-Janosi T13)
 *        and the soil library loaded from config/soils.yaml.
 */
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace avsp
{
namespace terrain
{
/// A soil library file that cannot be used; what() names the file and the key.
class SoilError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Which pressure-sinkage law a soil's contacts use.
enum class SinkageModel
{
  kSimple,  ///< compaction + elastic + flow (docs/MODELS.md T2-T6)
  kBekker,  ///< p = (k_c / b + k_phi) z^n on first loading, k_unload z below it (docs/MODELS.md B1, B2)
  kRigid    ///< pavement, concrete, rock: no sinkage; tyres and track pads deflect instead
};

/// Hydrostatic compression curve rho(sigma) of the simple model (T2), piecewise linear.
class CompressionCurve
{
public:
  CompressionCurve() = default;
  /// @param points (sigma Pa, rho kg/m^3), sigma strictly increasing from 0, rho non-decreasing, > 0
  /// @throw std::invalid_argument when that does not hold
  explicit CompressionCurve(std::vector<std::pair<double, double>> points);
  /// kg/m^3 at normal stress sigma (Pa); held at the last value beyond the table.
  double density(double sigma) const;
  const std::vector<std::pair<double, double>>& points() const { return points_; }

private:
  std::vector<std::pair<double, double>> points_;
};

/// Strength and Bekker-Wong parameters of a soil at one moisture (a row of its table).
struct MoistureRow
{
  double moisture = 0.0;        ///< mass of water / mass of dry soil
  double cohesion = 0.0;        ///< Pa
  double friction_angle = 0.0;  ///< rad
  double n = 0.0;
  double k_c = 0.0;    ///< N/m^(n+1)
  double k_phi = 0.0;  ///< N/m^(n+2)
};

/// How a soil's moisture evolves and what it changes (docs/MODELS.md section 3).
struct MoistureSpec
{
  double initial = 0.0;               ///< moisture at which `strength`/`bekker` were given
  double dry = 0.0;                   ///< moisture the soil dries towards without rain
  double saturated = 0.0;             ///< moisture it cannot exceed (> 0)
  double wetting_per_mm = 0.0;        ///< moisture added per mm of rain, times (1 - w / saturated)
  double drying_time_constant = 0.0;  ///< s, e-folding time of drying towards `dry`
  std::vector<MoistureRow> table;     ///< other moistures; empty: strength independent of moisture
};

/// Everything the contact model needs to know about one soil, in SI units.
struct SoilParameters
{
  std::string name;
  std::string source;  ///< where the published values come from
  SinkageModel model = SinkageModel::kSimple;
  // Simple model (T2-T6, T12).
  double h0 = 0.0;                  ///< m, depth to the hard layer
  double rho0 = 0.0;                ///< kg/m^3, initial bulk density
  CompressionCurve compression;     ///< rho(sigma)
  double elastic_e = 0.0;           ///< 1/Pa (T3)
  double b1 = 0.0;                  ///< m/Pa, bearing flow factor (T4)
  double b2 = 0.0;                  ///< 1/Pa, shearing flow factor (T4)
  double rolling_resistance = 0.0;  ///< f (T12); rigid surfaces: a tyre's rolling resistance coefficient
  // Strength (T7).
  double cohesion = 0.0;        ///< c, Pa
  double friction_angle = 0.0;  ///< phi, rad
  double shear_modulus = 0.0;   ///< K, m (Janosi-Hanamoto)
  // Bekker-Wong (T13).
  double n = 0.0;      ///< sinkage exponent
  double k_c = 0.0;    ///< N/m^(n+1)
  double k_phi = 0.0;  ///< N/m^(n+2)
  /// N/m^3: Bekker soils' unloading and reloading stiffness: below the largest sinkage reached a
  /// point springs back and is reloaded at p = k_unload z_r (z_r below its rebounded surface), as
  /// the elastic modulus K of Project Chrono's SCM terrain; first loading follows k z^n.
  double k_unload = 0.0;
  // Rigid surfaces (model kRigid): what a tyre or a track pad meets there.
  double friction_peak = 0.0;     ///< peak coefficient of adhesion
  double friction_sliding = 0.0;  ///< locked-wheel (sliding) coefficient, <= friction_peak
  MoistureSpec moisture;
};

/// The soils of config/soils.yaml by name.
class SoilLibrary
{
public:
  /**
   * @brief Loads and validates a soil library file.
   * @throw SoilError naming the file and the key (e.g. "soils.mud.strength.cohesion_kpa")
   */
  static SoilLibrary load(const std::string& path);

  /// @throw SoilError if there is no soil of that name
  const SoilParameters& get(const std::string& name) const;
  bool contains(const std::string& name) const { return soils_.count(name) > 0; }
  std::vector<std::string> names() const;

private:
  std::map<std::string, SoilParameters> soils_;
  std::string path_;
};

}  // namespace terrain
}  // namespace avsp
