#pragma once
// What a drape's cloth meets, drawn under it: the table, the ball, the arm
// and the floor of a drape scene (cloth/collider.h), matte and plain, lit
// by the knit view's light, so that a kiosk's viewer sees what the cloth
// hangs on. The yarn renderer calls it inside its frame (after the clear,
// before the yarns) with that frame's camera.

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "psrig/cloth/collider.h"
#include "psrig/preview/knit_view.h"

namespace psrig::preview {

// Triangles, three vertices each, with their normals (millimetres): the
// solids' first, then the planes' (drawn darker, so a ball reads against
// the floor).
struct PropMesh {
  std::vector<Eigen::Vector3f> positions, normals;
  std::size_t solid_vertices = 0;
};
// The colliders as triangles; a plane is a square `plane_extent_mm` a side
// round the point of it nearest `centre`.
[[nodiscard]] PropMesh prop_mesh(const std::vector<cloth::Collider>& colliders,
                                 const Eigen::Vector3f& centre, float plane_extent_mm);

class PropRenderer {
 public:
  [[nodiscard]] static Result<std::unique_ptr<PropRenderer>> create(bool encode_srgb = false);
  ~PropRenderer();
  PropRenderer(const PropRenderer&) = delete;
  PropRenderer& operator=(const PropRenderer&) = delete;

  // The colliders to draw from now on (uploaded when they change).
  void update(const std::vector<cloth::Collider>& colliders, const Eigen::Vector3f& centre,
              float plane_extent_mm);
  // Into the bound framebuffer, depth tested and written.
  void draw(const KnitFrame& frame) const;
  [[nodiscard]] int triangles() const { return vertices_ / 3; }

 private:
  struct Gl;
  PropRenderer() = default;
  std::unique_ptr<Gl> gl_;
  bool encode_srgb_ = false;
  int vertices_ = 0, solid_vertices_ = 0;
};

}  // namespace psrig::preview
