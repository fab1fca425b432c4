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
// arc's sagitta: length x turning / 8), its lift stays within
// `lift_tolerance` of a straight line between its ends (length x the
// lift's change of slope / 4) and its colour holds, up to `max_px` long,
// and no piece is shorter than `min_px` (sub-pixel bends are detail no one
// sees; the slice's mipmaps average them).
//
// Layers: far away the renderer blends its yarns in order instead of
// testing depth (chen2003-lumislice-knitwear.txt 5.2.3 sorts its slices
// and blends them back to front). Cloth is a sheet a few yarns thick, so
// the order that matters is through the sheet: each point goes to the
// back, middle or front layer by its lift as the eye sees it, and a yarn's
// strip is cut where its layer changes (the cut point shared, so no gap;
// a run too short to draw joins the one before it).
//
// Indices go into one element buffer per layer, a strip per run ended by
// the primitive-restart index, their parity alternating along each strip:
// yarn.vert takes a vertex's side from gl_VertexID's parity (the index, in
// an indexed draw), so where the next point to draw has the parity of the
// last one, its neighbour is drawn instead.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace psrig::preview {

struct PieceLimits {
  float tolerance_px = 0.5f;
  float min_px = 1.0f;
  float max_px = 16.0f;
  float lift_tolerance = 0.15f;  // in yarn radii (yarn_curves.h's lift)
};

// What the choice needs of each point, made once per update.
struct CentrelinePoint {
  float length_mm = 0;  // to the next point
  float turn = 0;       // radians between the pieces before and after it
  float lift_turn = 0;  // change of the lift's slope there, per mm
  bool keep = false;    // drawn whatever the limits say (its colour changes here)
};

inline constexpr std::uint32_t kRestartIndex = 0xFFFFFFFFU;
inline constexpr int kLayers = 3;  // back, middle, front

// The layer of a point whose lift, turned to face the eye, is `lift`.
[[nodiscard]] int cloth_layer(float lift_toward_eye);

// Appends the strips of the yarn whose points are points[first, first +
// count) (indices in the same numbering) to the element lists of their
// layers (`layer_of(index)`), for `px_per_mm`. Nothing for a yarn of fewer
// than three points.
template <class LayerOf>
void append_strips(std::span<const CentrelinePoint> points, std::size_t first, std::size_t count,
                   float px_per_mm, const PieceLimits& limits, LayerOf layer_of,
                   std::array<std::vector<std::uint32_t>, kLayers>& indices);

// The points a strip through points[first, first + count) keeps (first and
// last always), in order, into `kept`.
void choose_strip_points(std::span<const CentrelinePoint> points, std::size_t first,
                         std::size_t count, float px_per_mm, const PieceLimits& limits,
                         std::vector<std::uint32_t>& kept);

// Cuts `kept` (of a yarn ending at point `last`) into runs by layer and
// appends them as strips of alternating parity.
void append_layered_strips(std::span<const std::uint32_t> kept, std::span<const std::uint8_t> layers,
                           std::size_t last, std::array<std::vector<std::uint32_t>, kLayers>& indices);

template <class LayerOf>
void append_strips(std::span<const CentrelinePoint> points, std::size_t first, std::size_t count,
                   float px_per_mm, const PieceLimits& limits, LayerOf layer_of,
                   std::array<std::vector<std::uint32_t>, kLayers>& indices) {
  if (count < 3) return;
  thread_local std::vector<std::uint32_t> kept;
  thread_local std::vector<std::uint8_t> layers;
  choose_strip_points(points, first, count, px_per_mm, limits, kept);
  layers.clear();
  for (const std::uint32_t point : kept)
    layers.push_back(static_cast<std::uint8_t>(layer_of(point)));
  append_layered_strips(kept, layers, first + count - 1, indices);
}

}  // namespace psrig::preview
