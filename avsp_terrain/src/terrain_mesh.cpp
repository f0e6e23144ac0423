#include "avsp_terrain/terrain_mesh.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace avsp
{
namespace terrain
{
namespace
{
std::array<float, 3> vertexAt(const DeformableTerrain& terrain, std::size_t i, std::size_t j, float lift)
{
  const ElevationGrid& g = terrain.base();
  return { static_cast<float>(g.originX() + i * g.dx()), static_cast<float>(g.originY() + j * g.dy()),
           static_cast<float>(terrain.pointHeight(i, j)) + lift };
}

/// Appends the two triangles of the quad (i0, j0)-(i1, j1), counter-clockwise from above.
void addQuad(MeshChunk& chunk, const DeformableTerrain& terrain, const PointColour& colour, std::size_t i0,
             std::size_t j0, std::size_t i1, std::size_t j1, float lift)
{
  const std::size_t corners[6][2] = { { i0, j0 }, { i1, j0 }, { i1, j1 }, { i0, j0 }, { i1, j1 }, { i0, j1 } };
  for (const auto& c : corners)
  {
    chunk.vertices.push_back(vertexAt(terrain, c[0], c[1], lift));
    chunk.colours.push_back(colour(c[0], c[1]));
  }
}
}  // namespace

TerrainMesher::TerrainMesher(std::size_t columns, std::size_t rows, std::size_t step, std::size_t chunk_cells)
  : columns_(columns), rows_(rows), step_(step), chunk_cells_(chunk_cells)
{
  if (columns < 2 || rows < 2)
    throw std::invalid_argument("TerrainMesher: the grid needs at least 2 x 2 points, got " + std::to_string(columns) +
                                " x " + std::to_string(rows));
  if (step < 1)
    throw std::invalid_argument("TerrainMesher: step must be >= 1");
  if (chunk_cells < step || chunk_cells % step != 0)
    throw std::invalid_argument("TerrainMesher: chunk_cells " + std::to_string(chunk_cells) +
                                " must be a positive multiple of step " + std::to_string(step));
  chunks_x_ = (columns - 2) / chunk_cells + 1;
  chunks_y_ = (rows - 2) / chunk_cells + 1;
}

PointRange TerrainMesher::chunkPoints(std::size_t id) const
{
  if (id >= chunkCount())
    throw std::out_of_range("TerrainMesher: chunk " + std::to_string(id) + " of " + std::to_string(chunkCount()));
  const std::size_t cx = id % chunks_x_, cy = id / chunks_x_;
  PointRange r;
  r.i0 = cx * chunk_cells_;
  r.j0 = cy * chunk_cells_;
  r.i1 = std::min(columns_ - 1, r.i0 + chunk_cells_);
  r.j1 = std::min(rows_ - 1, r.j0 + chunk_cells_);
  return r;
}

std::vector<std::size_t> TerrainMesher::chunksTouching(const PointRange& range) const
{
  std::vector<std::size_t> ids;
  if (range.i0 >= columns_ || range.j0 >= rows_)
    return ids;
  // A point on a chunk border belongs to both chunks, hence the "- 1" on the lower end.
  auto firstChunk = [this](std::size_t p, std::size_t n) {
    return std::min(n - 1, p == 0 ? 0 : (p - 1) / chunk_cells_);
  };
  auto lastChunk = [this](std::size_t p, std::size_t n) { return std::min(n - 1, p / chunk_cells_); };
  const std::size_t i1 = std::min(range.i1, columns_ - 1), j1 = std::min(range.j1, rows_ - 1);
  for (std::size_t cy = firstChunk(range.j0, chunks_y_); cy <= lastChunk(j1, chunks_y_); ++cy)
    for (std::size_t cx = firstChunk(range.i0, chunks_x_); cx <= lastChunk(i1, chunks_x_); ++cx)
    {
      const std::size_t id = cy * chunks_x_ + cx;
      const PointRange c = chunkPoints(id);
      if (c.i1 >= range.i0 && c.i0 <= i1 && c.j1 >= range.j0 && c.j0 <= j1)
        ids.push_back(id);
    }
  return ids;
}

std::vector<std::size_t> TerrainMesher::vertexIndices(std::size_t first, std::size_t last, std::size_t step)
{
  std::vector<std::size_t> out;
  for (std::size_t p = first; p < last; p += step)
    out.push_back(p);
  out.push_back(last);
  return out;
}

MeshChunk TerrainMesher::build(std::size_t id, const DeformableTerrain& terrain, const PointColour& colour) const
{
  const PointRange r = chunkPoints(id);
  const auto xs = vertexIndices(r.i0, r.i1, step_), ys = vertexIndices(r.j0, r.j1, step_);
  // Each vertex is shared by up to six triangles: evaluate its position and colour once.
  const std::size_t nx = xs.size();
  std::vector<std::array<float, 3>> position(nx * ys.size()), tint(nx * ys.size());
  for (std::size_t b = 0; b < ys.size(); ++b)
    for (std::size_t a = 0; a < nx; ++a)
    {
      position[b * nx + a] = vertexAt(terrain, xs[a], ys[b], 0.f);
      tint[b * nx + a] = colour(xs[a], ys[b]);
    }
  MeshChunk chunk;
  chunk.id = id;
  chunk.vertices.reserve(6 * (nx - 1) * (ys.size() - 1));
  chunk.colours.reserve(chunk.vertices.capacity());
  for (std::size_t b = 0; b + 1 < ys.size(); ++b)
    for (std::size_t a = 0; a + 1 < nx; ++a)
    {
      // Same corner order as addQuad(): counter-clockwise from above.
      const std::size_t k00 = b * nx + a, k10 = k00 + 1, k01 = k00 + nx, k11 = k01 + 1;
      for (std::size_t k : { k00, k10, k11, k00, k11, k01 })
      {
        chunk.vertices.push_back(position[k]);
        chunk.colours.push_back(tint[k]);
      }
    }
  return chunk;
}

MeshChunk TerrainMesher::buildDeformed(std::size_t id, const DeformableTerrain& terrain, const PointColour& colour,
                                       float lift) const
{
  const PointRange r = chunkPoints(id);
  const std::size_t tile = DeformableTerrain::kTileSize;
  MeshChunk chunk;
  chunk.id = id;
  // Tile by tile (tiles of the deformation store, aligned to multiples of kTileSize): a
  // tile with any deformed point is drawn cell by cell, others not at all.
  for (std::size_t tj = r.j0 / tile * tile; tj < r.j1; tj += tile)
    for (std::size_t ti = r.i0 / tile * tile; ti < r.i1; ti += tile)
    {
      const std::size_t i_begin = std::max(ti, r.i0), j_begin = std::max(tj, r.j0);
      const std::size_t i_end = std::min(ti + tile, r.i1), j_end = std::min(tj + tile, r.j1);
      bool deformed = false;
      for (std::size_t j = j_begin; j <= j_end && !deformed; ++j)
        for (std::size_t i = i_begin; i <= i_end && !deformed; ++i)
        {
          const PointDeformation d = terrain.deformation(i, j);
          deformed = d.plastic != 0.f || d.displaced != 0.f;
        }
      if (!deformed)
        continue;
      for (std::size_t cj = j_begin; cj < j_end; ++cj)
        for (std::size_t ci = i_begin; ci < i_end; ++ci)
          addQuad(chunk, terrain, colour, ci, cj, ci + 1, cj + 1, lift);
    }
  return chunk;
}

}  // namespace terrain
}  // namespace avsp
