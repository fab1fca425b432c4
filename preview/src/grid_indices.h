#pragma once
// The element indices of a grid of (columns + 1) x (rows + 1) vertices,
// row by row: two triangles a face, as the far level's meshes (the repeat
// textured, far_cloth.h, and the scan's surface, scan_surface.h) draw the
// stitch mesh.

#include <cstdint>
#include <vector>

namespace psrig::preview {

[[nodiscard]] inline std::vector<std::uint32_t> grid_triangle_indices(int columns, int rows) {
  std::vector<std::uint32_t> indices;
  indices.reserve(static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows) * 6);
  const auto vertex = [columns](int column, int row) {
    return static_cast<std::uint32_t>(row * (columns + 1) + column);
  };
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
      for (const std::uint32_t index :
           {vertex(column, row), vertex(column + 1, row), vertex(column + 1, row + 1),
            vertex(column, row), vertex(column + 1, row + 1), vertex(column, row + 1)})
        indices.push_back(index);
  return indices;
}

}  // namespace psrig::preview
