#pragma once
// The neural woven BSDF's training data made from the fabric surface model
// (chen2024 5.1, Table 2): materials (a weave's normal and orientation
// textures with alpha and beta) and, for each, queries on footprints of the
// 8 x 8 grid of centres (jittered in their cells) at 10 sizes in [0, 1]
// repeats and 10 in [1, 5], each footprint asked every pair of a stratified
// set of directions, answered by woven_aggregate.h with 2048 samples.
//
// Deterministic from the seed: every material's and footprint's random
// numbers come from mix_seed(seed, its indices), never from the order the
// pool runs them in, so the same seed gives the same bytes on any number of
// threads.

#include <cstdint>
#include <functional>
#include <vector>

#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/woven_aggregate.h"
#include "psrig/cloth/woven_dataset.h"
#include "psrig/cloth/woven_surface.h"

namespace psrig::cloth {

struct WovenDatasetOptions {
  int texture_size = 64;  // T: texels a side of one repeat
  int centre_grid = 8;    // centres: one jittered in each cell of an n x n grid
  int small_sizes = 10;   // sizes in [0, 1] repeats, stratified
  int large_sizes = 10;   // sizes in [1, max_size]
  float max_size = 5;
  // Directions: (x, y) of wi and of wo each stratified on a grid x grid
  // jitter over [-1, 1]^2, those outside the unit disc dropped (Table 2),
  // every wi with every wo: about (pi/4 grid^2)^2 pairs, 2500 at 8.
  int direction_grid = 8;
  float min_cosine = 0.02f;  // directions closer to grazing are dropped too
  int samples = 2048;        // a query's Monte Carlo samples
  // Materials per pattern: textures (psi, u draws) x appearances (alpha,
  // beta draws); chen2024 takes 9 x 9 for plain and 4 x 16 for the others.
  int shapes_per_pattern = 2;
  int appearances_per_shape = 2;
  // And one material a pattern at WovenMaterialParameters' defaults (the
  // preview's far level draws every weave with them: woven_far_material),
  // after all the drawn ones, so the drawn materials keep their indices.
  bool default_appearance = false;
};

// One material's parameters, as Table 2 draws them.
struct WovenMaterialParameters {
  YarnShape shape;  // psi and u (gap 0.2)
  float alpha = 0.5f, beta = 1;
};

// A weave's own look where its file gives it (`roughness:` alpha,
// `height_scale:` beta), the defaults above, the middle of what the
// network was trained on, where it does not; the default yarn shape.
[[nodiscard]] WovenMaterialParameters weave_parameters(const WeaveMatrix& weave);

// Table 2: psi from {-30, 0, 30}, u from U(15, 45), alpha from U(0.1, 1),
// beta from U(0, 2).
[[nodiscard]] YarnShape draw_yarn_shape(std::uint64_t seed);
[[nodiscard]] WovenMaterialParameters draw_appearance(const YarnShape& shape, std::uint64_t seed);

// The encoder's view of a material: the textures of the yarns' shape at
// beta = 1 (beta is the material's own input, as chen2024 draws it apart
// from the textures), sampled at texel centres.
[[nodiscard]] Result<WovenMaterialSample> generate_woven_material(
    const WeaveMatrix& weave, const WovenMaterialParameters& parameters, int texture_size);

// A material's queries (material index `material` in them), in order of
// centre, size, wi, wo. Runs on the thread pool, a footprint a task.
[[nodiscard]] Result<std::vector<WovenQuery>> generate_woven_queries(
    const WeaveMatrix& weave, const WovenMaterialParameters& parameters, std::uint32_t material,
    const WovenDatasetOptions& options, std::uint64_t seed);

// Called after each material with how many are done of how many, for a
// program's progress line (minutes of work at direction grid 4).
using WovenDatasetProgress = std::function<void(int done, int total)>;

// The whole set: for each pattern, shapes_per_pattern shapes, each with
// appearances_per_shape appearances, materials in that order; then, with
// default_appearance, one a pattern at the default parameters.
[[nodiscard]] Result<WovenDataset> generate_woven_dataset(
    const std::vector<WeaveMatrix>& patterns, const WovenDatasetOptions& options,
    std::uint64_t seed, const WovenDatasetProgress& progress = {});

// How many queries generate_woven_queries makes, on average (the direction
// pairs vary with the jitter), for planning.
[[nodiscard]] double expected_queries_per_material(const WovenDatasetOptions& options);

}  // namespace psrig::cloth
