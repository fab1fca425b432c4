#pragma once
// The stitch mesh (Yuksel et al., as huang2025-realtime-knit-deformation-
// rendering.txt uses it): one quad face per stitch (or per weave cell), laid
// over the cloth's surface. The yarns follow the faces, so stretching or
// shearing the mesh is how the cloth deforms.

#include <vector>

#include <Eigen/Core>

namespace psrig::cloth {

enum class ClothShape { flat, draped };  // draped: over the swatch preview's Bezier patch

// The cloth's in-plane deformation, about its centre: x' = stretch x + shear y
// (x along the courses, y along the wales). stretch 1.2 is 20 % wider;
// shear 0.3 leans each wale 0.3 mm sideways per mm up.
struct ClothDeformation {
  float stretch = 1;
  float shear = 0;
};

// An orthonormal frame on one face: e1 along the course (the face's u
// edges), e2 in the face toward the next course, normal out of the front.
struct FaceFrame {
  Eigen::Vector3f e1, e2, normal;
};

struct StitchMesh {
  int columns = 0, rows = 0;  // faces
  float face_width_mm = 0;    // at rest
  float face_height_mm = 0;
  std::vector<Eigen::Vector3f> vertices;  // (rows + 1) x (columns + 1), row 0 at the bottom

  [[nodiscard]] const Eigen::Vector3f& vertex(int column, int row) const {
    return vertices[static_cast<std::size_t>(row * (columns + 1) + column)];
  }
  // A point of face (column, row) at face coordinates u, v in [0, 1]
  // (bilinear; u, v outside [0, 1] extrapolate).
  [[nodiscard]] Eigen::Vector3f point(int column, int row, float u, float v) const;
  [[nodiscard]] FaceFrame frame(int column, int row) const;
  // The face's 2-D deformation gradient in its own frame: rest face
  // coordinates in millimetres to (e1, e2) millimetres.
  [[nodiscard]] Eigen::Matrix2f deformation_gradient(int column, int row) const;
  // The same, given the face's frame when it is already at hand.
  [[nodiscard]] Eigen::Matrix2f deformation_gradient(int column, int row,
                                                     const FaceFrame& frame) const;
};

// A mesh of columns x rows faces, each face_width x face_height mm at rest,
// centred on the origin, deformed, then laid on the shape.
[[nodiscard]] StitchMesh make_stitch_mesh(int columns, int rows, float face_width_mm,
                                          float face_height_mm, ClothShape shape,
                                          ClothDeformation deformation = {});

}  // namespace psrig::cloth
