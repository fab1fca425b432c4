#pragma once
// The scenes the kiosk and `psrig-preview drape` show a knit in: hanging
// from a rail (swinging a little, then still), dropped on a table so that
// it falls over the edge, over a ball, and over an arm that then swings.
// GL-free: a scene is a stitch-level simulation (stitch_cloth.h) of a
// knit's stitch mesh and what it meets; the yarns follow through the
// fabric (knit_fabric.h). Millimetres, +y up (the cloth as drawn hangs in
// the x-y plane, its front toward +z, as the yarn renderer looks at it).

#include <optional>
#include <string_view>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/stitch_cloth.h"

namespace psrig::cloth {

enum class DrapeScene { hang, table, sphere, arm };

// "hang" | "table" | "sphere" | "arm".
[[nodiscard]] std::optional<DrapeScene> parse_drape_scene(std::string_view name);
[[nodiscard]] std::string_view to_string(DrapeScene scene);

class DrapeAnimation {
 public:
  DrapeAnimation(KnitFabric fabric, DrapeScene scene, KnitMaterial material = {});

  // One frame of `dt` seconds; then the yarns are where the cloth is.
  void advance(float dt);
  void yarns(YarnSet& out) { fabric_.update(cloth_.mesh(), out); }
  // The surface the yarns lie on, no yarn placed (a far view's frame).
  [[nodiscard]] YarnSurface surface() const { return fabric_.surface(cloth_.mesh()); }

  [[nodiscard]] const StitchCloth& cloth() const { return cloth_; }
  [[nodiscard]] const KnitFabric& fabric() const { return fabric_; }
  [[nodiscard]] double time() const { return time_; }

 private:
  void step(float dt);

  KnitFabric fabric_;
  DrapeScene scene_;
  StitchCloth cloth_;
  double time_ = 0;
  float arm_height_ = 0;  // the arm's lift now, mm
};

}  // namespace psrig::cloth
