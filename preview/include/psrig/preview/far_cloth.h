#pragma once
// The far level's geometry (issue 30): the stitch mesh the yarns lie on
// (cloth::YarnSurface), two triangles a face, each vertex's (u, v) its face
// coordinates over the repeat's faces, drawn with the repeat's texture
// (repeat_texture.h), each pixel its footprint's mean from the repeat's
// summed-area table. A few triangles a stitch and no yarn:
// what makes far frames cheap. Draws into whatever framebuffer is bound;
// needs its GLES context current for its whole life.

#include <array>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/cloth/yarn_curves.h"
#include "psrig/preview/knit_view.h"
#include "psrig/preview/repeat_texture.h"

namespace psrig::preview {

struct FarClothDraw {
  float yarn_width_mm = 1;
  // The far level takes over as the yarn narrows from `from_px` to
  // `full_px` (per fragment); over_yarns: the near level's yarns lie
  // beneath, the cloth cross-fades with them over `background`.
  float from_px = 4, full_px = 2.5f;
  bool over_yarns = false;
  cv::Vec3f background{0, 0, 0};
  bool encode_srgb = false;
};

class FarCloth {
 public:
  [[nodiscard]] static Result<std::unique_ptr<FarCloth>> create();
  ~FarCloth();
  FarCloth(const FarCloth&) = delete;
  FarCloth& operator=(const FarCloth&) = delete;

  // The mesh's vertices (every frame while the cloth moves), (u, v) counted
  // from `window`'s first face.
  void update(const cloth::YarnSurface& surface, const RepeatWindow& window);
  // The texture's levels (repeat_levels): the area table of the finest
  // level at most 512 texels a side replaces the last one.
  void upload(const std::vector<cv::Mat>& levels);
  // The repeat's colour across the cloth: a factor per channel at each
  // point of a kShadeGrid x kShadeGrid grid over the mesh's faces (row by
  // row from face (0, 0), the grid's ends at the mesh's), bilinear
  // between. One bake is lit and seen as the middle repeat is; the grid
  // carries how the lamp and the eye change across the cloth (FarLevel).
  static constexpr int kShadeGrid = 3;
  using ShadeGrid = std::array<Eigen::Vector3f, kShadeGrid * kShadeGrid>;
  void set_shade(const ShadeGrid& shade) { shade_ = shade; }
  // Every factor 1: the repeat's colour as baked, everywhere.
  [[nodiscard]] static ShadeGrid uniform_shade() {
    ShadeGrid ones;
    ones.fill(Eigen::Vector3f::Ones());
    return ones;
  }
  void draw(const KnitFrame& frame, const FarClothDraw& how) const;

  [[nodiscard]] bool ready() const { return index_count_ > 0 && has_texture_; }
  [[nodiscard]] int triangles() const { return index_count_ / 3; }

 private:
  struct Gl;
  FarCloth() = default;
  std::unique_ptr<Gl> gl_;
  std::vector<float> vertices_;
  int columns_ = -1, rows_ = -1;
  int index_count_ = 0;
  bool has_texture_ = false;
  ShadeGrid shade_ = uniform_shade();
};

}  // namespace psrig::preview
