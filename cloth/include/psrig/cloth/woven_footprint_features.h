#pragma once
// What a footprint of a weave holds, as the neural woven BSDF's decoder
// takes it beside the one-blob (woven_network.h): the material's textures
// averaged over the footprint's square (footprint_in_repeats'), per yarn
// type: how much of it is warp and weft, their mean ply normal and the
// mean of its squared tilts (LEAN mapping's second moments, Olano and
// Baker 2010: a footprint that holds both slopes of a float has a mean
// normal that is flat and moments that are not). The paper's decoder sees
// the footprint only as a position and a size and must learn the pattern's
// layout from the latent; at footprints a fraction of a repeat wide a small
// network does not (config/woven/README.md), and these say it outright.
//
// A texel is warp where its ply orientation runs nearer the warp (v, y)
// than the weft (u, x); a gap (zero orientation) is neither. The means are
// exact for a box over the texels (a summed-area table, Crow 1984, read
// bilinearly between its corners, where the integral of a texel-wise
// constant field is bilinear), the repeat tiling beyond its edges. The
// GLSL decoder reads the same table (woven_decoder.frag).

#include <span>
#include <vector>

#include "psrig/cloth/woven_dataset.h"

namespace psrig::cloth {

// warp, weft, warp n (xyz), weft n (xyz), warp (nx^2, ny^2), weft (nx^2, ny^2)
inline constexpr int woven_footprint_feature_count = 12;
// The smallest footprint averaged, in texels: below it the box is this wide
// (so a point query reads about one texel, not 0 / 0).
inline constexpr float woven_footprint_smallest_texels = 0.5F;

class WovenFootprintFeatures {
 public:
  WovenFootprintFeatures() = default;
  // A material's textures (texture_size T >= 1, T*T*3 floats each: as
  // WovenNetwork::encode checks them; the caller has).
  explicit WovenFootprintFeatures(const WovenMaterialSample& material);

  [[nodiscard]] int texture_size() const { return size_; }
  [[nodiscard]] bool empty() const { return size_ == 0; }

  // The features' mean over the square of width `size` (repeats) about
  // (u, v) (repeats, any value: the repeat tiles) into `out`
  // (woven_footprint_feature_count values).
  void mean(float u, float v, float size, std::span<float> out) const;

  // The table: (T + 1) x (T + 1) corners, row-major (row = v), each
  // woven_footprint_feature_count floats: corner (i, j) holds the sum of
  // texels left of column i and above row j, in texels.
  [[nodiscard]] const std::vector<float>& table() const { return table_; }

 private:
  // The sum over [0, x) x [0, y) in texel units, x and y in [0, T].
  void corner_sum(float x, float y, std::span<float> out) const;
  // The same for any x, y >= 0 (whole repeats beyond T).
  void tiled_sum(float x, float y, std::span<float> out) const;

  int size_ = 0;
  std::vector<float> table_;
};

}  // namespace psrig::cloth
