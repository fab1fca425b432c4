#pragma once
// Which of a yarn's centreline points a frame draws its strip through, and
// in which layer of the cloth each piece lies.
//
// A software rasteriser's cost grows with the triangles (each is set up and
// visits its 4x4 blocks on its own, once per sample under MSAA) far more
// than with their pixels, and a knitted yarn is densely sampled for its
// tightest bends: where it runs straight, or is small on screen, most of
// its points add triangles, not shape. So a piece of the strip runs on
// while its chord stays within `tolerance_px` of the curve (a circular
// arc's sagitta: length x turning / 8, and the strip's outer edge, half a
// yarn out, as much again: half width x turning^2 / 8), its lift stays within
// `lift_tolerance` of a straight line between its ends (length x the
// lift's change of slope / 4) and its colour holds, up to `max_px` long,
// and no piece is shorter than `min_px` (sub-pixel bends are detail no one
// sees; the slice's mipmaps average them).
//
// Indices go into one element buffer for all yarns, a strip per yarn ended
// by the primitive-restart index, their parity alternating along each
// strip: yarn.vert takes a vertex's side from gl_VertexID's parity (the
// index, in an indexed draw), so where the next point to draw has the
// parity of the last one, its neighbour is drawn instead.
//
// Layers: far away the renderer blends its yarns in order instead of
// testing depth (chen2003-lumislice-knitwear.txt 5.2.3 sorts its slices
// and blends them back to front). Cloth is a sheet a few yarns thick, so
// the order that matters is through the sheet: each triangle of the strips
// goes to one of kLayers layers, back to front, by its middle point's lift
// as the eye sees it, as separate triangles (a yarn changes layer every
// stitch, too often to cut its strip there).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace psrig::preview {

struct PieceLimits {
  float tolerance_px = 0.5f;
  float min_px = 0.25f;
  float max_px = 16.0f;
  float lift_tolerance = 0.5f;  // in yarn radii (yarn_curves.h's lift)
  float half_width_px = 0;       // the strip's, for its outer edge
  // Each piece's limits scaled by its own factor, 1 +- dither (from a hash
  // of its first point): a cloth's loops are all alike, and with one limit
  // they would all change their points at the same scale, a jump the eye
  // sees as the cloth grows.
  float dither = 0;
};

// What the choice needs of each point, made once per update.
struct CentrelinePoint {
  float length_mm = 0;  // to the next point
  float turn = 0;       // radians between the pieces before and after it
  float lift_turn = 0;  // change of the lift's slope there, per mm
  bool keep = false;    // drawn whatever the limits say (its colour changes here)
};

inline constexpr std::uint32_t kRestartIndex = 0xFFFFFFFFU;
inline constexpr int kLayers = 8;  // from the back of the cloth to its front

// The layer of a point whose lift, turned to face the eye, is `lift`.
[[nodiscard]] int cloth_layer(float lift_toward_eye);

// Appends the strip of the yarn whose points are points[first, first +
// count) (indices in the same numbering), then a restart, for `px_per_mm`.
// Nothing for a yarn of fewer than three points.
void append_strip(std::span<const CentrelinePoint> points, std::size_t first, std::size_t count,
                  float px_per_mm, const PieceLimits& limits, std::vector<std::uint32_t>& indices);

// The triangles of `strips` (as append_strip() makes them) as separate
// triangles, into the list of their layer (`layer_of(index)` of each
// triangle's middle vertex).
template <class LayerOf>
void layer_triangles(std::span<const std::uint32_t> strips, LayerOf layer_of,
                     std::array<std::vector<std::uint32_t>, kLayers>& triangles) {
  for (std::size_t k = 2; k < strips.size(); ++k) {
    const std::uint32_t a = strips[k - 2], b = strips[k - 1], c = strips[k];
    if (a == kRestartIndex || b == kRestartIndex || c == kRestartIndex) continue;
    auto& list = triangles[static_cast<std::size_t>(layer_of(b))];
    list.insert(list.end(), {a, b, c});
  }
}

}  // namespace psrig::preview
