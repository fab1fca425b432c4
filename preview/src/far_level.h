#pragma once
// What the yarn renderer keeps for its far level (issue 30): the repeat
// nearest the mesh's middle, the yarns near it, a near-level renderer of
// its own that bakes them (repeat_texture.h) and the textured stitch mesh
// (far_cloth.h). A bake is made when a frame needs the far level and the
// last one no longer stands for it: the light, the view's direction, the
// style or the repeat's shape changed (by more than the options allow).
// With it, the window's mean colour as if at 3 x 3 places over the cloth,
// the lamp and the eye as they are from each (FarCloth::set_shade).
// Cloth a scan feeds has the scan as its far level instead (scan_surface.h):
// no bake, and the surface alone is enough to draw it. Draped cloth a chart
// feeds (not flat) has the repeat's maps (repeat_maps.h), baked as the
// repeat is and drawn the scan's way, lit from the mesh's normals.
// A weave given its material (set_woven) is drawn by the neural woven BSDF
// instead (woven_far_cloth.h): no bake.

#include <memory>
#include <optional>

#include "psrig/preview/far_cloth.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/repeat_texture.h"
#include "psrig/preview/scan_surface.h"
#include "psrig/preview/woven_far_cloth.h"
#include "psrig/preview/yarn_renderer.h"

namespace psrig::preview {

class FarLevel {
 public:
  [[nodiscard]] static Result<std::unique_ptr<FarLevel>> create(const YarnRendererOptions& options);

  // The scan's tile stands for the cloth from now on (scan_surface.h).
  [[nodiscard]] Status use_scan(const PatchTile& tile);
  [[nodiscard]] bool scanned() const { return scan_ != nullptr; }
  // The weave the yarns are, drawn by the neural decoder from now on
  // (the weights loaded from `weights` the first time).
  [[nodiscard]] Status set_woven(const WovenFarMaterial& material,
                                 const std::filesystem::path& weights);
  void clear_woven() { woven_.reset(); }
  // A scan, where there is one, is the far level, whatever the yarns are.
  [[nodiscard]] bool neural() const { return woven_ != nullptr && !scan_; }
  [[nodiscard]] const WovenFarCloth* woven() const { return woven_.get(); }

  // The cloth's yarns and surface; false when they have none to draw with.
  bool update(const cloth::YarnSet& yarns);
  // The surface alone, for a frame that draws no yarn: false unless the
  // scan is the far level (a bake needs the yarns about its repeat).
  bool update_surface(const cloth::YarnSurface& surface);
  [[nodiscard]] bool available() const {
    if (scan_) return scan_mesh_;
    if (!window_) return false;
    if (draped_now_) return draped_ != nullptr;
    return woven_ ? woven_->ready() : cloth_->ready();
  }
  [[nodiscard]] bool has_surface() const { return scan_ ? scan_mesh_ : window_.has_value(); }
  // Bakes the repeat when the last bake no longer stands for `frame` and
  // `view`; then framebuffer `target` is bound again with `viewport`.
  void prepare(const KnitFrame& frame, const KnitView& view, unsigned target, cv::Size viewport);
  void draw(const KnitFrame& frame, const FarClothDraw& how) const;
  // With a scan as the far level, the gain per channel on the yarns' colour
  // and on their sheen (YarnRenderer::set_colour_match) that makes the
  // near level's repeat, as the bakes draw it along `frame`'s view and
  // light, the scan's colour there: the kiosk's dolly from yarns to the
  // scan then keeps its hue (the yarns' sheen is white, so yarns of the
  // scan's own colour are paler than it: the sheen is dimmed where it
  // alone outshines a channel). Worked out when the yarns about the middle
  // repeat are first given, and again when they or the light change;
  // nullopt otherwise (and where there is no scan). Then framebuffer
  // `target` is bound again.
  [[nodiscard]] std::optional<ColourMatch> match_scan(const KnitFrame& frame, const KnitView& view,
                                                      unsigned target, cv::Size viewport);

  [[nodiscard]] int bakes() const { return bakes_; }
  [[nodiscard]] int triangles() const {
    if (scan_) return scan_->triangles();
    return draped_now_ && draped_ ? draped_->triangles() : cloth_->triangles();
  }

 private:
  // What a bake was made for (besides the yarns taken).
  struct BakeKey {
    Eigen::Vector3f toward_eye;
    Eigen::Vector3f normal;  // the middle repeat's
    Eigen::Vector4f light;
    bool shadows = true, fibre_detail = true;
  };
  FarLevel() = default;
  // Whether `baked`, a bake's key, still stands for `key`.
  [[nodiscard]] bool stands_for(const BakeKey& key, const std::optional<BakeKey>& baked) const;
  [[nodiscard]] bool same_shape(const RepeatWindow& window) const;
  // The yarns about the window (when their style or its shape changed).
  void take_yarns(const cloth::YarnSet& yarns);
  std::optional<KnitFrame> bake_frame(const KnitFrame& frame, const Eigen::Vector3f& toward_eye);
  // False when nothing could be baked (no target).
  bool bake(const KnitFrame& frame, const KnitView& view, const Eigen::Vector3f& toward_eye);
  // How the repeat's colour changes across the cloth (FarCloth::set_shade):
  // the window baked as if at each of shade_points_, the lamp and the eye
  // where they are from there, over the same at the window.
  FarCloth::ShadeGrid shade_across(const KnitFrame& frame, const KnitView& view,
                                   const Eigen::Vector3f& toward_eye);
  // The taken window's yarns at the near level (repeat_texels), averaged
  // over their phases; empty if no target could be made.
  // `phases` 0: `bake_phases`.
  cv::Mat bake_texels(const KnitFrame& frame, const KnitView& view,
                      const Eigen::Vector3f& toward_eye, int phases = 0);
  // Their mean colour (linear RGB); nullopt if nothing could be baked.
  std::optional<Eigen::Vector3f> bake_mean(const KnitFrame& frame, const KnitView& view,
                                           const Eigen::Vector3f& toward_eye, int phases = 0);
  // What a flat white surface facing the eye's side of the repeat gets, as
  // scan_surface.frag shades it: the environment's light, and the lamp's
  // (its colour, falloff and the surface's diffuse weight) before Lambert.
  struct FlatLight {
    Eigen::Vector3f ambient, direct;
  };
  // `flat`: ambient plus direct times Lambert at the frame's lamp.
  std::vector<Eigen::Vector3f> yarn_light_response(const KnitFrame& frame, const KnitView& view,
                                                   const Eigen::Vector3f& toward_eye,
                                                   const Eigen::Vector3f& normal,
                                                   const FlatLight& light,
                                                   const Eigen::Vector3f& flat);
  // The repeat's maps for draped cloth (repeat_maps.h); false when
  // nothing could be baked (no target, no maps).
  bool bake_draped(const KnitFrame& frame, const KnitView& view, const Eigen::Vector3f& toward_eye);

  YarnRendererOptions options_;
  std::unique_ptr<YarnRenderer> baker_;
  std::unique_ptr<FarCloth> cloth_;
  std::unique_ptr<OffscreenTarget> target_;
  std::unique_ptr<WovenFarCloth> woven_;
  // The frame's framebuffer and viewport (prepare's): the neural level
  // decodes into its own first.
  unsigned frame_target_ = 0;
  cv::Size frame_viewport_;
  std::optional<RepeatWindow> window_;  // this frame's
  // The flat cloth's points where FarCloth's shade grid lies, this frame's.
  std::array<Eigen::Vector3f, FarCloth::kShadeGrid * FarCloth::kShadeGrid> shade_points_{};
  // The yarns about the window as last taken, and the window then (what a
  // bake draws: the cloth may have moved since, as long as it kept shape).
  cloth::YarnSet near_yarns_;
  std::optional<RepeatWindow> taken_window_;
  bool baker_stale_ = true;  // near_yarns_ not yet given to the baker
  std::optional<BakeKey> baked_;
  std::optional<Eigen::Vector4f> matched_light_;  // match_scan()'s last
  int bakes_ = 0;
  std::unique_ptr<ScanSurface> scan_;
  bool scan_mesh_ = false;  // the scan has a mesh with faces to lie on
  // Draped chart-fed cloth: this frame's cloth is not flat; the repeat's
  // maps on its mesh.
  bool draped_now_ = false;
  std::unique_ptr<ScanSurface> draped_;
  std::optional<BakeKey> draped_baked_;
  float draped_gain_ = 1;          // repeat_maps' gain, the light's on the maps
  cloth::StitchMesh draped_mesh_;  // this frame's, for maps made after update()
};

}  // namespace psrig::preview
