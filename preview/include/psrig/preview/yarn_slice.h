#pragma once
// The yarn's fibre-level look as one precomputed, periodic texture that
// the yarn renderer sweeps along every yarn: chen2003-lumislice-knitwear.txt
// section 5.1's lumislice (one cross-section of the yarn stands for all of
// them) laid out as huang2025-realtime-knit-deformation-rendering.txt
// sections 4.2-4.4 lay out theirs, in the camera-facing strip's own
// coordinates: across the strip (the core and a halo of flyaway fibres
// either side) and along the yarn (a whole number of twist turns, so it
// repeats seamlessly). Baked on the CPU by casting rays at the yarn seen
// along the cloth's normal: the plies twisting about the axis at the
// style's pitch (a flattened section when the style's flatness says so),
// the fibres twisting the other way within each ply, flyaway fibres from
// Zhao et al. 2016's procedural model (huang2025 eq. 12 and 13) drawn only
// where no ply hides them (huang2025 4.4's baked depth test).
//
// Each texel holds, premultiplied by its fibre density: the offset of the
// ply's normal across the ply (-1 to 1), the sine of the fibres' tilt from
// the yarn's axis, and how much light the fibres there get from their
// neighbours (the fibre-level self-shadowing, huang2025 4.3; the grooves
// between plies are dark), with the density itself in alpha. Premultiplied
// so that the mipmaps, averaged 2x2 as chen2003 5.2.2 eq. 11 averages
// lumislice voxels (colour weighted by density, density averaged), give
// the far view the yarn's mean look rather than aliased detail.

#include <array>
#include <cstdint>
#include <vector>

#include "psrig/cloth/yarn_curves.h"

namespace psrig::preview {

struct YarnSliceOptions {
  int width = 128;   // texels across the strip, core and halo
  int height = 256;  // texels along, over `turns` twist turns
  int turns = 2;     // the texture's length in twist pitches
  // Flyaway fibres reach this far beyond the core, in yarn radii.
  float halo = 0.45f;
  float flyaways_per_mm = 4.0f;  // at the style's hairiness 1
  float fibre_diameter = 0.04f;  // in yarn radii
  // Light reaching into the grooves: exp(-groove_shadow * depth below the
  // lower of the ply crests either side, in ply half-thicknesses).
  float groove_shadow = 1.6f;
  float striation = 0.16f;  // fibre-to-fibre brightness, +-
  int fibres_per_ply = 18;  // striation stripes round one ply
  // How far the surface fibres untwist the plies' slant: 0 they follow
  // the ply, 1 the yarn's axis (a balanced plied yarn).
  float balance = 0.6f;
  std::uint32_t seed = 7;
};

struct YarnSliceLevel {
  int width = 0, height = 0;
  std::vector<std::array<std::uint8_t, 4>> texels;  // row-major, row 0 at along 0
};

// What a texel (or a filtered sample) decodes to.
struct SliceSample {
  float ply_offset = 0;  // across the ply: tilts the tube's normal
  float tilt_sin = 0;    // sine of the fibres' angle to the yarn's axis
  float light = 1;       // fibre-level self-shadowing and striation
  float density = 0;     // fibre coverage, 0 to 1
};

struct YarnSlice {
  std::vector<YarnSliceLevel> levels;  // level 0 first, down to 1x1
  float halo = 0;                      // options.halo
  float period_mm = 1;                 // the texture's length along the yarn
  // The plies' pattern repeats this many times along the texture (turns
  // times plies): only the fibres' striation has the whole period.
  int ply_repeats = 1;
  float ply_slant_sin = 0;             // sine of the plies' slant, where they face the eye
  SliceSample core_mean;  // the core's look averaged, density weighted (the far view's)
  // The style it was baked for (renderers bake again when it changes).
  cloth::YarnStyle style;
};

[[nodiscard]] YarnSlice bake_yarn_slice(const cloth::YarnStyle& style,
                                        const YarnSliceOptions& options = {});

// Whether two styles bake the same slice (colour does not enter it).
[[nodiscard]] bool same_slice(const cloth::YarnStyle& a, const cloth::YarnStyle& b);

// Texture coordinates (as yarn.vert makes them) of strip coordinate
// `across` (-1 to 1 over the core, beyond it the halo) at `arc_mm` along.
[[nodiscard]] float slice_u(const YarnSlice& slice, float across);
[[nodiscard]] float slice_v(const YarnSlice& slice, float arc_mm);

// Bilinear filtering of one level as GL_LINEAR does it (u clamped to the
// edge, v repeating), decoded: the CPU twin of yarn.frag's texture read.
[[nodiscard]] SliceSample sample_slice(const YarnSlice& slice, int level, float u, float v);
// One texel, decoded.
[[nodiscard]] SliceSample decode_texel(const std::array<std::uint8_t, 4>& texel);

}  // namespace psrig::preview
