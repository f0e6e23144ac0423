#pragma once
/**
 * @file terrain_patch.hpp
 * @brief Ruts reaching the sensors: a rectangle of deformed grid-point heights (the content of
 *        avsp_msgs/TerrainPatch on /terrain/ruts, avsp_terrain's HeightPatch) applied to the
 *        ray caster's HeightField, refreshing only the mip blocks above it.
 */
#include <optional>

#include <avsp_terrain/height_patch.hpp>

#include "avsp_sensors/height_field.hpp"

namespace avsp
{
namespace sensors
{
/**
 * @brief Sets the heights of the patch's points inside the grid (points outside are ignored, as
 *        avsp_terrain's applyPatch does) and refreshes the max-mip entries above them only.
 * @return the grid points the patch covers, clipped to the grid; nullopt when it covers none
 * @throw std::invalid_argument naming the field, with avsp_terrain::applyPatch's rules:
 *        resolution not the grid spacing (to 1e-9 relative) or grid not square, origin not on a
 *        grid point (to 1e-6 of a cell) or not finite, width x height not the number of heights,
 *        a non-finite height
 */
std::optional<terrain::PointRange> applyHeightPatch(HeightField& field, const terrain::HeightPatch& patch);

}  // namespace sensors
}  // namespace avsp
