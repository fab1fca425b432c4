#pragma once
// Carrying a relaxed repeat's yarn onto a stitch mesh: what the knitted
// and the woven fabric share. A point of the repeat, in the deformed
// plane, is taken back to the cloth at rest by the repeat's deformation,
// found on its mesh face, and put on the face's (bilinear) surface with its
// depth along the surface's normal (the corners' normals blended, so that
// yarn crossing from face to face on a curved cloth does not kink).

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/stitch_mesh.h"

namespace psrig::cloth::placement {

struct FacePatch {
  Eigen::Vector3f origin, du, dv, duv;
  Eigen::Vector3f n00, n10, n01, n11;
  bool flat = false;  // one normal at every corner: nothing to blend
};

class MeshPlacement {
 public:
  // `to_rest`: the inverse of the deformation the repeat was relaxed for.
  MeshPlacement(const StitchMesh& mesh, const Eigen::Matrix2f& to_rest);

  // A repeat point (x, y in the deformed plane, z its depth), moved by
  // `shift` (a lattice step), on the mesh: its position and normal.
  void place(const Eigen::Vector3f& point, const Eigen::Vector2f& shift, Eigen::Vector3f& position,
             Eigen::Vector3f& normal) const {
    const Eigen::Vector2f rest = to_rest_ * (point.head<2>() + shift);
    const float fx = rest.x() * inverse_w_, fy = rest.y() * inverse_h_;
    // Beyond the mesh's edge the edge face extrapolates.
    const int fc = std::clamp(static_cast<int>(std::floor(fx)), 0, columns_ - 1);
    const int fr = std::clamp(static_cast<int>(std::floor(fy)), 0, rows_ - 1);
    const float u = fx - static_cast<float>(fc), v = fy - static_cast<float>(fr);
    const FacePatch& f = patches_[static_cast<std::size_t>(fr * columns_ + fc)];
    if (f.flat) {
      normal = f.n00;
    } else {
      normal = (1 - v) * ((1 - u) * f.n00 + u * f.n10) + v * ((1 - u) * f.n01 + u * f.n11);
      normal.normalize();
    }
    position = f.origin + u * f.du + v * f.dv + (u * v) * f.duv + point.z() * normal;
  }

 private:
  std::vector<FacePatch> patches_;
  Eigen::Matrix2f to_rest_;
  int columns_ = 0, rows_ = 0;
  float inverse_w_ = 1, inverse_h_ = 1;  // of the face's size at rest
};

// The mesh's in-plane deformation, averaged over up to 16 x 16 faces.
[[nodiscard]] Eigen::Matrix2f mean_deformation(const StitchMesh& mesh);

}  // namespace psrig::cloth::placement
