#pragma once
// Yarns drawn from their centrelines (yarn_curves.h) in GLES 3.0: camera-
// facing strips shaded as twisted fibres (yarn_shading.h), shadowed by a
// yarn-level shadow map, and far away drawn as lines, with a blended band
// between the two (durupinar2007-procedural-knit-woven.txt: cylinders near,
// lines far). Draws into whatever framebuffer is bound; needs its GLES
// context current for its whole life.

#include <cstddef>
#include <memory>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "psrig/preview/egl_context.h"
#include "psrig/preview/knit_view.h"
#include "psrig/cloth/yarn_curves.h"
#include "psrig/preview/yarn_shading.h"

namespace psrig::preview {

struct YarnRendererOptions {
  FibreShading shading;
  // The framebuffer stores linear values (a window surface without an sRGB
  // colour space): the shader encodes sRGB itself.
  bool encode_srgb = false;
  int shadow_map_size = 2048;  // texels a side, at most what the context allows
  // Level of detail from the yarn's projected width (2 radii) in pixels:
  // lines only up to `lines_up_to_px`, tubes only from `tubes_from_px`,
  // between them both, blended by the tube weight. A line is a flat ribbon
  // at least a pixel wide, shaded as the tube's middle with the fibre
  // detail averaged (triangles: llvmpipe's multisampled GL lines lose
  // pieces shorter than a pixel); one narrower than a pixel is drawn that
  // much transparent. Yarn shadows fade out with the tubes.
  float lines_up_to_px = 1.0f;
  float tubes_from_px = 3.0f;
  // Where the points along a yarn are closer than this on screen, only
  // every n-th is drawn (up to 32): far yarns cost fewer vertices.
  float min_piece_px = 3.0f;
};

class YarnRenderer {
 public:
  [[nodiscard]] static Result<std::unique_ptr<YarnRenderer>> create(
      const YarnRendererOptions& options = {});
  ~YarnRenderer();
  YarnRenderer(const YarnRenderer&) = delete;
  YarnRenderer& operator=(const YarnRenderer&) = delete;

  // Uploads the centrelines (every frame while the cloth moves): one packed
  // vertex per point, rewritten in place while the point count stays.
  // Missing normals are +z, missing lifts 1, missing colours the style's;
  // a curve of fewer than three points is not drawn (a strip needs three).
  void update(const cloth::YarnSet& yarns);

  // Clears and draws one frame into the bound framebuffer of `viewport`
  // (the shadow pass borrows its own framebuffer and gives the caller's back).
  void render(const KnitView& view, cv::Size viewport);

  // The last frame's yarn width in pixels at the bounds centre, and the
  // tube weight it chose: 0 lines only, 1 tubes only.
  [[nodiscard]] float last_yarn_width_px() const { return last_width_px_; }
  [[nodiscard]] float last_tube_weight() const { return last_tube_weight_; }
  // How often update() had to allocate GL storage (the point count changed).
  [[nodiscard]] int buffer_allocations() const { return allocations_; }
  [[nodiscard]] const Eigen::AlignedBox3f& bounds() const { return bounds_; }
  [[nodiscard]] const cloth::YarnStyle& style() const { return style_; }
  [[nodiscard]] const YarnRendererOptions& options() const { return options_; }

 private:
  struct Gl;
  struct Packed;
  YarnRenderer() = default;

  std::unique_ptr<Gl> gl_;
  std::unique_ptr<Packed> packed_;
  YarnRendererOptions options_;
  cloth::YarnStyle style_;
  Eigen::AlignedBox3f bounds_;
  float last_width_px_ = 0;
  float last_tube_weight_ = 1;
  int allocations_ = 0;
};

}  // namespace psrig::preview
