#pragma once
/**
 * @file dem_soil_config.hpp
 * @brief The `dem:` section of a scenario and dynamics_node's `~dem` (the same YAML text):
 *        the DEM soil's parameters, the bed template's size and the segment where vehicles
 *        with `terramechanics: dem` run on the moving patch. One reader for both, so the
 *        scenario check refuses what the node would.
 *
 * @code{.yaml}
 * segment: {x_min: 120.0, x_max: 130.08}   # m, map x; whole template lengths
 * patch: {length: 2.4, front_margin: 0.5, settle_time: 0.2, facets: 36, max_yaw_deg: 10}
 * template: {length: 0.12, width: 0.4, depth: 0.1}
 * particles: [{radius: 0.018, mass_fraction: 0.5}, {radius: 0.022, mass_fraction: 0.5}]
 * youngs_modulus: 2.0e7
 * timestep: 2.0e-4
 * coupling_interval: 1.0e-3
 * @endcode
 * Every key but `segment` is optional (defaults: DemParameters, DemSegmentSpec, DemSoilSpec).
 */
#include <string>

#include "avsp_dynamics/dem/dem_parameters.hpp"

namespace avsp
{
namespace dynamics
{
namespace dem
{
/// Where the vehicle meets the DEM soil and how its patches run (map frame, SI units).
struct DemSegmentSpec
{
  double x_min = 0.0;         ///< m: the segment's start, crossed along +x
  double x_max = 0.0;         ///< m: its end; x_max - x_min a whole number of template lengths
  double patch_length = 2.0;  ///< m per vehicle side, a whole number of template lengths
  double front_margin = 0.5;  ///< m: a patch moves on when its side's front wheel is nearer its front
  double settle_time = 0.2;   ///< s of DEM time a fresh patch settles before the wheels come on, >= 0
  int facets = 36;            ///< flat faces round each wheel's rim mesh, >= 12
  double max_yaw_deg = 10.0;  ///< a wheel's axle may turn this far (deg) from where it came on
};

/**
 * @brief What the contact mode needs besides the segment: the soil's DEM parameters and the
 *        template's size (a bed template is settled from them when the run starts).
 */
struct DemSoilSpec
{
  DemParameters parameters;
  double template_length = 0.12;  ///< m, >= 4 largest radii
  double template_width = 0.3;    ///< m: a side's strip, wider than its wheels by 4 largest radii
  double template_depth = 0.1;    ///< m of bed under the ground's highest point along a strip
  DemSegmentSpec segment;
};

/**
 * @brief The segment's checks against the template's length (m): ends finite, x_max > x_min,
 *        the segment and the patch whole template lengths, the patch no longer than the
 *        segment, front_margin in (0, patch length), settle_time in [0, 10] s, facets >= 12,
 *        max_yaw_deg in (0, 45].
 * @throw DemParameterError naming the key ("dem.segment.x_max: ...")
 */
void checkSegment(const DemSegmentSpec& spec, double template_length);

/**
 * @brief Reads the section from YAML text. `where` prefixes every error ("scenario.yaml: dem",
 *        "~dem").
 * @throw DemParameterError naming `where` and the key: YAML that does not parse, an unknown
 *        key, a value of the wrong type, and everything checkDemSoilSpec() refuses
 */
DemSoilSpec parseDemSoilSpec(const std::string& yaml_text, const std::string& where);

/**
 * @brief Every check that can be made before a bed is settled: validate(parameters), the
 *        template's size against the particles and the memory budget, the segment
 *        (DemVehicleSoil's constructor checks).
 * @throw DemParameterError naming the key
 */
void checkDemSoilSpec(const DemSoilSpec& spec);

}  // namespace dem
}  // namespace dynamics
}  // namespace avsp
