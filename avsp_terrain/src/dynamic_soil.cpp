#include "avsp_terrain/dynamic_soil.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace avsp
{
namespace terrain
{
SoilParameters soilAtMoisture(const SoilParameters& soil, double moisture)
{
  if (soil.moisture.table.empty())
    return soil;
  std::vector<MoistureRow> rows = soil.moisture.table;
  rows.push_back({ soil.moisture.initial, soil.cohesion, soil.friction_angle, soil.n, soil.k_c, soil.k_phi });
  std::sort(rows.begin(), rows.end(),
            [](const MoistureRow& a, const MoistureRow& b) { return a.moisture < b.moisture; });
  MoistureRow at = rows.front();
  if (moisture >= rows.back().moisture)
    at = rows.back();
  else if (moisture > rows.front().moisture)
  {
    for (std::size_t k = 1; k < rows.size(); ++k)
    {
      if (moisture <= rows[k].moisture)
      {
        const MoistureRow& a = rows[k - 1];
        const MoistureRow& b = rows[k];
        const double t = (moisture - a.moisture) / (b.moisture - a.moisture);
        const auto mix = [t](double u, double v) { return u + t * (v - u); };
        at = { moisture,      mix(a.cohesion, b.cohesion), mix(a.friction_angle, b.friction_angle),
               mix(a.n, b.n), mix(a.k_c, b.k_c),           mix(a.k_phi, b.k_phi) };
        break;
      }
    }
  }
  SoilParameters out = soil;
  out.cohesion = at.cohesion;
  out.friction_angle = at.friction_angle;
  out.n = at.n;
  out.k_c = at.k_c;
  out.k_phi = at.k_phi;
  return out;
}

double advanceMoisture(const MoistureSpec& spec, double moisture, double dt, double rain_rate_mm_h)
{
  if (rain_rate_mm_h > 0.0)
  {
    // Infiltration slows as the soil nears saturation.
    const double rain_mm = rain_rate_mm_h * dt / 3600.0;
    const double added = spec.wetting_per_mm * rain_mm * std::max(0.0, 1.0 - moisture / spec.saturated);
    return std::min(moisture + added, spec.saturated);
  }
  // Exact solution of dw/dt = -(w - dry) / tau over dt.
  return spec.dry + (moisture - spec.dry) * std::exp(-dt / spec.drying_time_constant);
}

SoilWeatherField::SoilWeatherField(double origin_x, double origin_y, double region_size, std::size_t columns,
                                   std::size_t rows, const SoilParameters& soil, double fresh_snow_density)
  : origin_x_(origin_x),
    origin_y_(origin_y),
    region_size_(region_size),
    columns_(columns),
    rows_(rows),
    soil_(soil),
    fresh_snow_density_(fresh_snow_density)
{
  if (!std::isfinite(origin_x) || !std::isfinite(origin_y))
    throw std::invalid_argument("SoilWeatherField: origin must be finite");
  if (!(region_size > 0.0) || !std::isfinite(region_size))
    throw std::invalid_argument("SoilWeatherField: region_size must be finite and > 0");
  if (columns == 0 || rows == 0)
    throw std::invalid_argument("SoilWeatherField: columns and rows must be >= 1");
  if (!(fresh_snow_density > 0.0) || fresh_snow_density > 1000.0)
    throw std::invalid_argument("SoilWeatherField: fresh_snow_density must be in (0, 1000] kg/m^3");
  moisture_.assign(columns * rows, soil.moisture.initial);
  snow_depth_.assign(columns * rows, 0.0);
}

void SoilWeatherField::advance(double dt, double rain_rate_mm_h, double snow_rate_mm_h)
{
  if (!(dt >= 0.0) || !(rain_rate_mm_h >= 0.0) || !(snow_rate_mm_h >= 0.0))
    throw std::invalid_argument("SoilWeatherField::advance: dt and rates must be >= 0 and finite");
  // Snow: water equivalent (mm) becomes depth through the density ratio water / snow.
  const double snow_depth = snow_rate_mm_h * dt / 3600.0 / 1000.0 * (1000.0 / fresh_snow_density_);
  for (std::size_t k = 0; k < moisture_.size(); ++k)
  {
    moisture_[k] = advanceMoisture(soil_.moisture, moisture_[k], dt, rain_rate_mm_h);
    snow_depth_[k] += snow_depth;
  }
}

std::size_t SoilWeatherField::regionIndex(double x, double y) const
{
  const double fx = std::floor((x - origin_x_) / region_size_);
  const double fy = std::floor((y - origin_y_) / region_size_);
  const auto i = static_cast<std::size_t>(std::clamp(fx, 0.0, static_cast<double>(columns_ - 1)));
  const auto j = static_cast<std::size_t>(std::clamp(fy, 0.0, static_cast<double>(rows_ - 1)));
  return j * columns_ + i;
}

double SoilWeatherField::moistureAt(double x, double y) const
{
  return moisture_[regionIndex(x, y)];
}

double SoilWeatherField::snowDepthAt(double x, double y) const
{
  return snow_depth_[regionIndex(x, y)];
}

SoilParameters SoilWeatherField::soilAt(double x, double y) const
{
  return soilAtMoisture(soil_, moistureAt(x, y));
}

}  // namespace terrain
}  // namespace avsp
