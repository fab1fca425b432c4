#pragma once
// Carrying a relaxed repeat's yarn onto a stitch mesh: what the knitted
// and the woven fabric share. A point of the repeat, in the deformed
// plane, is taken back to the cloth at rest by the repeat's deformation,
// found on its mesh face, and put on the face's (bilinear) surface with its
// depth along the surface's normal (the corners' normals blended, so that
// yarn crossing from face to face on a curved cloth does not kink).

#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/stitch_mesh.h"

namespace psrig::cloth::placement {

struct FacePatch {
  Eigen::Vector3f origin, du, dv, duv;
  Eigen::Vector3f n00, n10, n01, n11;
};

class MeshPlacement {
 public:
  // `to_rest`: the inverse of the deformation the repeat was relaxed for.
  MeshPlacement(const StitchMesh& mesh, const Eigen::Matrix2f& to_rest);

  // A repeat point (x, y in the deformed plane, z its depth), moved by
  // `shift` (a lattice step), on the mesh: its position and normal.
  void place(const Eigen::Vector3f& point, const Eigen::Vector2f& shift, Eigen::Vector3f& position,
             Eigen::Vector3f& normal) const;

 private:
  std::vector<FacePatch> patches_;
  Eigen::Matrix2f to_rest_;
  int columns_ = 0, rows_ = 0;
  float face_w_ = 1, face_h_ = 1;
};

// The mesh's in-plane deformation, averaged over up to 16 x 16 faces.
[[nodiscard]] Eigen::Matrix2f mean_deformation(const StitchMesh& mesh);

}  // namespace psrig::cloth::placement
