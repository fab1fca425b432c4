#pragma once
// The surface the swatch is drawn on: one bicubic Bezier patch (VirTex drew
// its textiles on Bezier patches because their evaluation gives the
// tangent frame for free). Flat: the swatch as it lay under the camera.
// Draped: a flag-like sheet a few swatches wide, the maps tiled over it at
// their physical scale.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace psrig::cloth {

enum class PatchShape { flat, draped };

class BezierPatch {
 public:
  // Control points row by row: control[4 * j + i] is column i (u) of row j (v).
  explicit BezierPatch(const std::array<Eigen::Vector3f, 16>& control) : control_(control) {}

  // Centred on the origin in the x-y plane, `extent` wide and high
  // (millimetres, or pixels when the pixel size is unknown). Draped: the
  // same span, waved in z along u and sagging along v.
  [[nodiscard]] static BezierPatch make(PatchShape shape, cv::Size2d extent);

  [[nodiscard]] Eigen::Vector3f position(float u, float v) const;
  [[nodiscard]] Eigen::Vector3f d_du(float u, float v) const;  // analytic derivatives
  [[nodiscard]] Eigen::Vector3f d_dv(float u, float v) const;
  [[nodiscard]] const std::array<Eigen::Vector3f, 16>& control() const { return control_; }

 private:
  std::array<Eigen::Vector3f, 16> control_;
};

// One vertex as the swatch shader reads it.
struct PatchVertex {
  float position[3];
  float normal[3];     // unit, the patch's outward normal (d_du x d_dv)
  float tangent[3];    // unit, along d_du: the maps' +x
  float bitangent[3];  // unit, normal x tangent: the maps' +y
  float uv[2];         // texture coordinates, 1 per tile
};

struct PatchMesh {
  std::vector<PatchVertex> vertices;
  std::vector<std::uint32_t> indices;  // triangles
};

// A (segments + 1)^2 grid of vertices. Texture coordinates follow the
// patch's parameters, scaled so one tile covers `tile` of the patch's
// `extent` (u along x, v along y): the maps repeat at their own size.
[[nodiscard]] PatchMesh tessellate(const BezierPatch& patch, int segments, cv::Size2d extent,
                                   cv::Size2d tile);

}  // namespace psrig::cloth
