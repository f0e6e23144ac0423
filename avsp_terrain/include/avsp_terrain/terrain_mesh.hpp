#pragma once
/**
 * @file terrain_mesh.hpp
 * @brief Decimated triangle meshes of a terrain in square chunks, for RViz: a chunk can be
 *        rebuilt alone when ruts change it, so a viewer never reloads the whole course.
 */
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "avsp_terrain/deformable_terrain.hpp"
#include "avsp_terrain/height_patch.hpp"

namespace avsp
{
namespace terrain
{
/// Triangles of one chunk: vertices in threes (a triangle list), one colour per vertex.
struct MeshChunk
{
  std::size_t id = 0;
  std::vector<std::array<float, 3>> vertices;  ///< m, map
  std::vector<std::array<float, 3>> colours;   ///< RGB in [0, 1], one per vertex
};

/// Colour (RGB in [0, 1]) of grid point (i, j): soil, wetness, snow, as the caller sees them.
using PointColour = std::function<std::array<float, 3>(std::size_t i, std::size_t j)>;

/**
 * @brief Splits a grid into square chunks of chunk_points x chunk_points cells and meshes
 *        each at a stride of `step` grid points (the decimation).
 *
 * Chunk k covers grid points [ci * chunk_points, (ci + 1) * chunk_points] along x (the last
 * point is shared with the next chunk, so chunks meet without gaps); the grid's last row and
 * column are always included even when the stride does not land on them.
 */
class TerrainMesher
{
public:
  /**
   * @param columns, rows grid points of the terrain (>= 2)
   * @param step decimation: every step-th grid point becomes a vertex (>= 1)
   * @param chunk_cells grid cells along each side of a chunk (a multiple of step, >= step)
   * @throw std::invalid_argument naming the argument that is out of range
   */
  TerrainMesher(std::size_t columns, std::size_t rows, std::size_t step, std::size_t chunk_cells);

  std::size_t chunkCount() const { return chunks_x_ * chunks_y_; }
  std::size_t chunksX() const { return chunks_x_; }
  std::size_t chunksY() const { return chunks_y_; }

  /// Grid points covered by chunk `id` (inclusive).
  PointRange chunkPoints(std::size_t id) const;

  /// Chunks whose points overlap `range` (a changed patch), in increasing id.
  std::vector<std::size_t> chunksTouching(const PointRange& range) const;

  /// Grid indices of the vertices along one axis of a chunk: first, first + step, ..., last.
  static std::vector<std::size_t> vertexIndices(std::size_t first, std::size_t last, std::size_t step);

  /**
   * @brief The chunk's mesh at the stride: two triangles per quad, counter-clockwise seen
   *        from above (normals up), vertices at the terrain's deformed point heights.
   */
  MeshChunk build(std::size_t id, const DeformableTerrain& terrain, const PointColour& colour) const;

  /**
   * @brief Full-resolution triangles of the deformed tiles of chunk `id` (ruts and berms
   *        in detail), lifted by `lift` m so they draw over the decimated mesh; empty when
   *        nothing in the chunk is deformed.
   */
  MeshChunk buildDeformed(std::size_t id, const DeformableTerrain& terrain, const PointColour& colour,
                          float lift) const;

private:
  std::size_t columns_, rows_, step_, chunk_cells_;
  std::size_t chunks_x_, chunks_y_;
};

}  // namespace terrain
}  // namespace avsp
