#pragma once
// The far level of a weave shaded per pixel by the neural woven BSDF
// (issue 31; chen2024 4.3): the stitch mesh drawn once more, each fragment
// making its decoder query (footprint centre in repeats, its size from the
// face coordinates' derivatives, wi and wo in the cloth's warp/weft frame)
// and running shaders/woven_decoder.frag on it, into a target of its own at
// the frame's resolution or a fraction of it; then laid over the frame.
// Only the mesh's pixels are decoded: the rasteriser is the early-out. The
// latent is worked out once per material on the CPU (the encoder); a
// colour edit (k_d, k_s) is uniforms only. Instead of far_cloth.h's baked
// repeat: no bake, and the far level is the fabric model's own aggregate
// over each pixel's footprint. Needs its GLES context current for its life.

#include <memory>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/woven_dataset_generator.h"
#include "psrig/cloth/woven_network.h"
#include "psrig/cloth/woven_reference_render.h"
#include "psrig/cloth/yarn_curves.h"
#include "psrig/preview/far_cloth.h"
#include "psrig/preview/knit_view.h"

namespace psrig::preview {

// What the neural far level shades a weave with: the pattern and (psi, u,
// alpha, beta), which the encoder takes, and the colours, which it does not.
struct WovenFarMaterial {
  cloth::WeaveMatrix weave;
  cloth::WovenMaterialParameters parameters;
  cloth::YarnColours colours;  // k_d and k_s per yarn type, linear
};

// A weave's material as the near level draws its yarns: k_d the warp's and
// the weft's colours (the .weave file's, or the cloth's), k_s
// `kWovenFarSpecular`, alpha and beta Table 2's middle (0.5 and 1; a .weave
// file gives neither), psi 0 and u 30 degrees.
inline constexpr float kWovenFarSpecular = 0.3F;
[[nodiscard]] WovenFarMaterial woven_far_material(const cloth::WeaveMatrix& weave,
                                                  const Eigen::Vector3f& warp_colour,
                                                  const Eigen::Vector3f& weft_colour);

// The shipped weights: <program's folder>/../share/psrig/woven/woven.wnn
// (installed), else the source tree's config/woven/woven.wnn.
[[nodiscard]] std::filesystem::path find_woven_weights();

struct WovenFarDraw {
  FarClothDraw fade;       // the cross-fade with the yarns, as the baked level's
  float irradiance = 1;    // E, normal to the light
  float decode_scale = 1;  // decode at 1/decode_scale of the frame's resolution
  unsigned target = 0;     // the frame's framebuffer, bound again after decoding
  cv::Size viewport;
};

class WovenFarCloth {
 public:
  // Compiles the decoder for `network`'s sizes and uploads its weights.
  [[nodiscard]] static Result<std::unique_ptr<WovenFarCloth>> create(
      std::shared_ptr<const cloth::WovenNetwork> network);
  ~WovenFarCloth();
  WovenFarCloth(const WovenFarCloth&) = delete;
  WovenFarCloth& operator=(const WovenFarCloth&) = delete;

  // Encodes the material's pattern and (alpha, beta) when they changed
  // (milliseconds); the colours are uniforms.
  [[nodiscard]] Status set_material(const WovenFarMaterial& material);
  // The mesh's vertices (every frame while the cloth moves).
  void update(const cloth::YarnSurface& surface);
  // Decodes the mesh's pixels, then lays them over `how.target`.
  void draw(const KnitFrame& frame, const WovenFarDraw& how) const;

  [[nodiscard]] bool ready() const { return index_count_ > 0 && material_set_; }
  [[nodiscard]] const WovenFarMaterial& material() const { return material_; }
  [[nodiscard]] int encodes() const { return encodes_; }

 private:
  struct Gl;
  WovenFarCloth() = default;
  std::unique_ptr<Gl> gl_;
  std::shared_ptr<const cloth::WovenNetwork> network_;
  WovenFarMaterial material_;
  bool material_set_ = false;
  int encodes_ = 0;
  std::vector<float> vertices_;
  int columns_ = -1, rows_ = -1;
  int index_count_ = 0;
};

}  // namespace psrig::preview
