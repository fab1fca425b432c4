#pragma once
// The neural woven BSDF's decoder per pixel in GLSL ES 3.0
// (shaders/woven_decoder.frag), the twin of cloth::WovenNetwork::decode:
// for now a standalone full-screen pass whose per-pixel queries (footprint
// centre and size, wi, wo) come as float images, shaded as E f with the
// material's colours (f carries eq. 3's cosine) and written sRGB encoded
// into the bound target. The yarn renderer's far view is where it goes
// next. The decoder's weights live in an RGBA32F texture (or a uniform
// block, where the context takes one that large); the material's latent
// in uniforms (folded into the first fusion
// layer's bias, WovenDecoderMaterial): a colour edit is a uniform, a
// pattern or (alpha, beta) edit re-runs the encoder on the CPU. A network
// that takes the footprint's features reads them from the material's
// table (cloth::WovenFootprintFeatures), a texture set with the material.

#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/cloth/woven_network.h"

namespace psrig::preview {

// The colours of eq. 8 (linear) and the light.
struct WovenColours {
  cv::Vec3f kd_warp{0.5F, 0.1F, 0.1F}, kd_weft{0.1F, 0.1F, 0.5F};
  cv::Vec3f ks_warp{0.3F, 0.3F, 0.3F}, ks_weft{0.3F, 0.3F, 0.3F};
  float irradiance = 3.0F;  // at normal incidence
};

// What the shader writes for one pixel, before its sRGB encoding, from the
// CPU decoder's components: the reference the GLSL pass is tested against.
[[nodiscard]] cv::Vec3f woven_radiance(const cloth::WovenComponents& components,
                                       const WovenColours& colours, float cos_incoming);

enum class WovenWeightStorage {
  texture,        // any GLES 3.0; on llvmpipe 1.5x faster than the uniform block
  uniform_block,  // 26 KB at the default sizes: an error where GL_MAX_UNIFORM_BLOCK_SIZE is less
};

// Where the per-pixel queries come from: float images (set_queries, a
// full-screen pass), or the woven far level's mesh (woven_far_cloth.h: the
// caller draws it with use()'s program; woven_far.vert).
enum class WovenQuerySource { images, mesh };

class WovenDecoderPass {
 public:
  // Compiles the shader for the network's sizes and uploads its decoder
  // weights. Needs a current GLES 3 context.
  [[nodiscard]] static Result<std::unique_ptr<WovenDecoderPass>> create(
      const cloth::WovenNetwork& network, WovenWeightStorage storage = WovenWeightStorage::texture,
      WovenQuerySource source = WovenQuerySource::images);
  ~WovenDecoderPass();
  WovenDecoderPass(const WovenDecoderPass&) = delete;
  WovenDecoderPass& operator=(const WovenDecoderPass&) = delete;

  void set_material(const cloth::WovenDecoderMaterial& material);
  // Per pixel, all the same size (the frame's), row 0 the frame's top:
  // footprints (u, v, size in repeats), incoming and outgoing directions,
  // CV_32FC3.
  [[nodiscard]] Status set_queries(const cv::Mat& footprints, const cv::Mat& incoming,
                                   const cv::Mat& outgoing);
  // Draws the pass over the bound target's viewport.
  void draw(const WovenColours& colours) const;
  // Binds the program with the weights and colours, for a caller that
  // draws its own geometry; and that program's uniforms.
  void use(const WovenColours& colours) const;
  [[nodiscard]] int uniform(const std::string& name) const;
  [[nodiscard]] bool weights_in_uniform_block() const;

 private:
  WovenDecoderPass() = default;
  struct Gl;
  std::unique_ptr<Gl> gl_;
};

}  // namespace psrig::preview
