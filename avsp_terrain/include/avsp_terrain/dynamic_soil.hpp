#pragma once
/**
 * @file dynamic_soil.hpp
 * @brief Soil that changes during a run (docs/MODELS.md section 3): moisture per region rises
 *        with rain and dries with a time constant, moisture changes strength and Bekker
 *        moduli through the soil's table, and snow builds a layer. No ROS: driven by plain
 *        rates (the environment node feeds them from /environment).
 */
#include <cstddef>
#include <vector>

#include "avsp_terrain/soil.hpp"

namespace avsp
{
namespace terrain
{
/**
 * @brief The soil's strength and Bekker-Wong parameters at moisture w: linear in moisture
 *        between the rows of its table (the row at moisture.initial being `strength` and
 *        `bekker`), held beyond the first and last rows. Soils with an empty table return
 *        unchanged.
 */
SoilParameters soilAtMoisture(const SoilParameters& soil, double moisture);

/**
 * @brief Moisture after dt (s) of rain at `rain_rate_mm_h`: rain adds wetting_per_mm per mm
 *        times (1 - w / saturated); without rain w relaxes to `dry` as exp(-dt / tau), exactly.
 */
double advanceMoisture(const MoistureSpec& spec, double moisture, double dt, double rain_rate_mm_h);

/// Moisture and snow depth on a coarse grid of regions over the terrain.
class SoilWeatherField
{
public:
  /**
   * @param origin_x, origin_y m, south-west corner of region (0, 0)
   * @param region_size m, side of a square region (> 0)
   * @param columns, rows regions along x and y (>= 1)
   * @param soil the soil whose moisture rules apply (its moisture.initial everywhere)
   * @param fresh_snow_density kg/m^3, density of new snow (converts water equivalent to depth)
   * @throw std::invalid_argument naming the argument that is out of range
   */
  SoilWeatherField(double origin_x, double origin_y, double region_size, std::size_t columns, std::size_t rows,
                   const SoilParameters& soil, double fresh_snow_density = 100.0);

  /// Advances every region by dt (s) with rain and snowfall rates (mm/h, water equivalent).
  void advance(double dt, double rain_rate_mm_h, double snow_rate_mm_h);

  /// Moisture and snow depth (m) of the region containing (x, y), clamped to the field.
  double moistureAt(double x, double y) const;
  double snowDepthAt(double x, double y) const;
  /// The soil as it is in the region containing (x, y).
  SoilParameters soilAt(double x, double y) const;

private:
  std::size_t regionIndex(double x, double y) const;

  double origin_x_, origin_y_, region_size_;
  std::size_t columns_, rows_;
  SoilParameters soil_;
  double fresh_snow_density_;
  std::vector<double> moisture_;
  std::vector<double> snow_depth_;
};

}  // namespace terrain
}  // namespace avsp
