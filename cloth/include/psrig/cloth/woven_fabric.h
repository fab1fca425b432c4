#pragma once
// Woven cloth at thread level (durupinar2007-procedural-knit-woven.txt
// section 2.2, with Peirce's crimp and flattened threads, woven_cell.h):
// a weave matrix tiled over warps x wefts threads at a real density, its
// threads laid on a stitch mesh with one face per crossing. As for knits
// (knit_fabric.h), the repeat is relaxed for the mesh's in-plane
// deformation, so threads never pass through each other.

#include <array>
#include <map>
#include <memory>
#include <optional>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "psrig/cloth/stitch_mesh.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/woven_cell.h"
#include "psrig/cloth/relaxed_repeats.h"
#include "psrig/cloth/yarn_cell.h"
#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

struct WovenParameters {
  WovenGauge gauge;  // over the weave's
  int plies = 2;
  float twist_pitch_mm = 1.0f;
  // Linear RGB, over the weave's; without either, a blue warp and an ecru weft.
  std::optional<Eigen::Vector3f> warp_colour, weft_colour;
  int samples_per_crossing = 8;
  ClothShape shape = ClothShape::flat;
  RelaxOptions relax;
};

class WovenFabric {
 public:
  // Bad input: a density and yarn that cannot be woven (woven_cell.h).
  [[nodiscard]] static Result<WovenFabric> build(const WeaveMatrix& weave, int warps, int wefts,
                                                 const WovenParameters& parameters);

  // warps x wefts faces, one per crossing, deformed as asked.
  [[nodiscard]] StitchMesh mesh(ClothDeformation deformation = {}) const;

  // Warps first (one per mesh column), then wefts, into `yarns`.
  void update(const StitchMesh& mesh, YarnSet& yarns);

  [[nodiscard]] const WovenDimensions& dimensions() const { return dimensions_; }
  [[nodiscard]] const Eigen::Vector3f& warp_colour() const { return warp_colour_; }
  [[nodiscard]] const Eigen::Vector3f& weft_colour() const { return weft_colour_; }
  [[nodiscard]] const WeaveMatrix& weave() const { return weave_; }
  [[nodiscard]] int warps() const { return warps_; }
  [[nodiscard]] int wefts() const { return wefts_; }
  [[nodiscard]] YarnStyle style() const;
  // The cross-section contact keeps (yarn_clearance.h).
  [[nodiscard]] const YarnSection& section() const { return rest_.section; }
  // How the repeat's relaxations went: the worst clearance and strain of
  // every deformation relaxed so far.

 private:
  WeaveMatrix weave_;
  int warps_ = 0, wefts_ = 0;
  WovenParameters parameters_;
  WovenDimensions dimensions_;
  YarnCell rest_;
  Eigen::Vector3f warp_colour_, weft_colour_;
  // The repeat relaxed for deformations as they come (shared by copies).
  std::shared_ptr<RelaxedRepeats> repeats_;
};

}  // namespace psrig::cloth
