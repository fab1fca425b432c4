#pragma once
// The swatch as a per-pixel bump-mapped surface (VirTex, Robb et al. 2003):
// the maps on a Bezier patch, lit per pixel in tangent space, the light
// drawn as a sphere. Draws into whatever framebuffer is bound (an
// OffscreenTarget headless, the KMS surface on the kiosk); needs its GLES
// context current for its whole life.

#include <memory>

#include <opencv2/core.hpp>

#include "psrig/preview/scene_view.h"
#include "psrig/preview/shading.h"
#include "psrig/preview/swatch_maps.h"

namespace psrig::preview {

struct RendererOptions {
  ShadingParams shading;
  cv::Vec3f background{0.02f, 0.02f, 0.025f};  // linear
  // The framebuffer stores linear values (a window surface without an sRGB
  // colour space): the shader encodes sRGB itself.
  bool encode_srgb = false;
  // Anisotropic filtering, when the context offers
  // GL_EXT_texture_filter_anisotropic (0: off).
  float max_anisotropy = 0;
  int segments = 48;  // patch tessellation per side
  // Off only to show what mipmapping saves (tests, comparisons): the base
  // level alone shimmers on fine knit seen from afar.
  bool mipmaps = true;
};

class SwatchRenderer {
 public:
  [[nodiscard]] static Result<std::unique_ptr<SwatchRenderer>> create(
      const SwatchMaps& maps, const RendererOptions& options);
  ~SwatchRenderer();
  SwatchRenderer(const SwatchRenderer&) = delete;
  SwatchRenderer& operator=(const SwatchRenderer&) = delete;

  // Clears and draws one frame into the bound framebuffer of `viewport`.
  void draw(const SceneView& view, cv::Size viewport);

  [[nodiscard]] cv::Size2d swatch_extent() const { return extent_; }
  [[nodiscard]] int texture_levels() const { return levels_; }
  [[nodiscard]] const RendererOptions& options() const { return options_; }

 private:
  struct Gl;
  SwatchRenderer() = default;
  std::unique_ptr<Gl> gl_;
  RendererOptions options_;
  cv::Size2d extent_;
  int levels_ = 0;
};

}  // namespace psrig::preview
