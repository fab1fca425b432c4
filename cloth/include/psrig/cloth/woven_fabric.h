#pragma once
// Woven cloth at thread level (durupinar2007-procedural-knit-woven.txt
// section 2.2): warp threads up the cloth, weft threads across it, one mesh
// face per crossing; where the weave matrix says warp over weft the warp
// lies a radius in front of the cloth's middle and the weft a radius behind,
// and the other way round elsewhere.

#include "psrig/cloth/stitch_mesh.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

struct WovenParameters {
  YarnStyle style{
      .radius_mm = 0.35f, .plies = 2, .twist_pitch_mm = 1.5f, .colour = {0.16f, 0.22f, 0.45f}};
  float spacing_mm = 1.0f;  // between neighbouring threads at rest
  int samples_per_span = 4;
  ClothShape shape = ClothShape::flat;
  Eigen::Vector3f weft_colour{0.75f, 0.72f, 0.64f};  // linear; the warp takes the style's
};

// warps x wefts faces, one per crossing.
[[nodiscard]] StitchMesh woven_mesh(int warps, int wefts, const WovenParameters& parameters,
                                    ClothDeformation deformation = {});

// The matrix tiled over `mesh`: warps first (one per mesh column), then wefts.
void weave_yarns(const WeaveMatrix& weave, const StitchMesh& mesh,
                 const WovenParameters& parameters, YarnSet& yarns);

}  // namespace psrig::cloth
