#include "psrig/cloth/stitch_mesh.h"

#include <algorithm>
#include <limits>

#include <Eigen/Geometry>

#include "psrig/cloth/bezier_patch.h"

namespace psrig::cloth {

Eigen::Vector3f StitchMesh::point(int column, int row, float u, float v) const {
  const Eigen::Vector3f& p00 = vertex(column, row);
  const Eigen::Vector3f& p10 = vertex(column + 1, row);
  const Eigen::Vector3f& p01 = vertex(column, row + 1);
  const Eigen::Vector3f& p11 = vertex(column + 1, row + 1);
  return (1 - v) * ((1 - u) * p00 + u * p10) + v * ((1 - u) * p01 + u * p11);
}

FaceFrame StitchMesh::frame(int column, int row) const {
  const Eigen::Vector3f& p00 = vertex(column, row);
  const Eigen::Vector3f& p10 = vertex(column + 1, row);
  const Eigen::Vector3f& p01 = vertex(column, row + 1);
  const Eigen::Vector3f& p11 = vertex(column + 1, row + 1);
  const Eigen::Vector3f along = (p10 - p00) + (p11 - p01);
  const Eigen::Vector3f normal = (p11 - p00).cross(p01 - p10).normalized();
  const Eigen::Vector3f e1 = (along - along.dot(normal) * normal).normalized();
  return {e1, normal.cross(e1), normal};
}

Eigen::Matrix2f StitchMesh::deformation_gradient(int column, int row) const {
  return deformation_gradient(column, row, frame(column, row));
}

Eigen::Matrix2f StitchMesh::deformation_gradient(int column, int row, const FaceFrame& f) const {
  const Eigen::Vector3f du = 0.5f *
                             ((vertex(column + 1, row) - vertex(column, row)) +
                              (vertex(column + 1, row + 1) - vertex(column, row + 1))) /
                             face_width_mm;
  const Eigen::Vector3f dv = 0.5f *
                             ((vertex(column, row + 1) - vertex(column, row)) +
                              (vertex(column + 1, row + 1) - vertex(column + 1, row))) /
                             face_height_mm;
  Eigen::Matrix2f gradient;
  gradient << f.e1.dot(du), f.e1.dot(dv), f.e2.dot(du), f.e2.dot(dv);
  return gradient;
}

StitchMesh make_stitch_mesh(int columns, int rows, float face_width_mm, float face_height_mm,
                            ClothShape shape, ClothDeformation deformation) {
  StitchMesh mesh;
  mesh.columns = columns;
  mesh.rows = rows;
  mesh.face_width_mm = face_width_mm;
  mesh.face_height_mm = face_height_mm;
  const float width = static_cast<float>(columns) * face_width_mm;
  const float height = static_cast<float>(rows) * face_height_mm;
  mesh.vertices.reserve(static_cast<std::size_t>((rows + 1) * (columns + 1)));
  Eigen::Vector2f low = Eigen::Vector2f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector2f high = -low;
  for (int row = 0; row <= rows; ++row)
    for (int column = 0; column <= columns; ++column) {
      const float x = static_cast<float>(column) * face_width_mm - width / 2;
      const float y = static_cast<float>(row) * face_height_mm - height / 2;
      const Eigen::Vector2f deformed(deformation.stretch * x + deformation.shear * y, y);
      low = low.cwiseMin(deformed);
      high = high.cwiseMax(deformed);
      mesh.vertices.emplace_back(deformed.x(), deformed.y(), 0.0f);
    }
  if (shape == ClothShape::draped) {
    // The deformed cloth's bounding rectangle is the patch's parameter domain.
    const Eigen::Vector2f span = (high - low).cwiseMax(1e-6f);
    const BezierPatch patch = BezierPatch::make(PatchShape::draped, {span.x(), span.y()});
    for (Eigen::Vector3f& vertex : mesh.vertices) {
      const float u = (vertex.x() - low.x()) / span.x();
      const float v = (vertex.y() - low.y()) / span.y();
      vertex = patch.position(std::clamp(u, 0.0f, 1.0f), std::clamp(v, 0.0f, 1.0f));
    }
  }
  return mesh;
}

}  // namespace psrig::cloth
