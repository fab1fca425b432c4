#pragma once
// The element indices of a grid of (columns + 1) x (rows + 1) vertices,
// row by row: two triangles a face, as the far level's meshes (the repeat
// textured, far_cloth.h; the scan's surface, scan_surface.h; the neural
// weave, woven_far_cloth.h) draw the stitch mesh.

#include <GLES3/gl3.h>
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

// Those indices into element buffer `buffer` (bound to the current vertex
// array); how many.
inline int upload_grid_indices(GLuint buffer, int columns, int rows) {
  const std::vector<std::uint32_t> indices = grid_triangle_indices(columns, rows);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, buffer);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)), indices.data(),
               GL_STATIC_DRAW);
  return static_cast<int>(indices.size());
}

}  // namespace psrig::preview
