#include "mesh_placement.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace psrig::cloth::placement {

MeshPlacement::MeshPlacement(const StitchMesh& mesh, const Eigen::Matrix2f& to_rest)
    : to_rest_(to_rest),
      columns_(mesh.columns),
      rows_(mesh.rows),
      inverse_w_(1 / mesh.face_width_mm),
      inverse_h_(1 / mesh.face_height_mm) {
  const int columns = mesh.columns, rows = mesh.rows;
  std::vector<Eigen::Vector3f> vertex_normal(static_cast<std::size_t>((rows + 1) * (columns + 1)),
                                             Eigen::Vector3f::Zero());
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column) {
      const Eigen::Vector3f normal = mesh.frame(column, row).normal;
      for (int corner = 0; corner < 4; ++corner)
        vertex_normal[static_cast<std::size_t>((row + (corner >> 1)) * (columns + 1) + column +
                                               (corner & 1))] += normal;
    }
  for (Eigen::Vector3f& n : vertex_normal)
    n.normalize();
  const auto normal = [&](int column, int row) {
    return vertex_normal[static_cast<std::size_t>(row * (columns + 1) + column)];
  };
  patches_.resize(static_cast<std::size_t>(columns * rows));
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column) {
      const Eigen::Vector3f& p00 = mesh.vertex(column, row);
      const Eigen::Vector3f& p10 = mesh.vertex(column + 1, row);
      const Eigen::Vector3f& p01 = mesh.vertex(column, row + 1);
      const Eigen::Vector3f& p11 = mesh.vertex(column + 1, row + 1);
      patches_[static_cast<std::size_t>(row * columns + column)] = {
          p00, p10 - p00, p01 - p00, p11 - p10 - p01 + p00,
          normal(column, row), normal(column + 1, row), normal(column, row + 1),
          normal(column + 1, row + 1)};
      FacePatch& patch = patches_[static_cast<std::size_t>(row * columns + column)];
      patch.flat = patch.n00.isApprox(patch.n10, 1e-7f) && patch.n00.isApprox(patch.n01, 1e-7f) &&
                   patch.n00.isApprox(patch.n11, 1e-7f);
    }
}

Eigen::Matrix2f mean_deformation(const StitchMesh& mesh) {
  Eigen::Matrix2f sum = Eigen::Matrix2f::Zero();
  int count = 0;
  const int step_c = std::max(1, mesh.columns / 16), step_r = std::max(1, mesh.rows / 16);
  for (int row = 0; row < mesh.rows; row += step_r)
    for (int column = 0; column < mesh.columns; column += step_c) {
      sum += mesh.deformation_gradient(column, row);
      ++count;
    }
  return count > 0 ? Eigen::Matrix2f(sum / static_cast<float>(count)) : Eigen::Matrix2f::Identity();
}

}  // namespace psrig::cloth::placement
