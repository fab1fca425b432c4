#pragma once
// Yarns drawn from their centrelines (yarn_curves.h) in GLES 3.0: strips as
// wide as each yarn's elliptical section looks, shaded as plied, twisted
// fibres (yarn_shading.h) from one precomputed slice of the yarn swept
// along it (yarn_slice.h, the lumislice of chen2003-lumislice-knitwear.txt
// section 5), lit by a light and an environment map, shadowed by a
// yarn-level shadow map, with a halo of flyaway fibres drawn over them.
// One level of detail, continuous: the slice's mipmaps average the fibres
// as the yarn shrinks, a yarn narrower than a few pixels loses its halo
// and takes statistical shadows for the map's, and one narrower than
// `min_strip_px` is drawn that wide and that much transparent. Draws into
// whatever framebuffer is bound; needs its GLES context current for its
// whole life.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "psrig/cloth/yarn_curves.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/environment_light.h"
#include "psrig/preview/knit_view.h"
#include "psrig/preview/strip_points.h"
#include "psrig/preview/woven_far_cloth.h"
#include "psrig/preview/yarn_shading.h"
#include "psrig/preview/yarn_slice.h"

namespace psrig::preview {

// Which level of detail draws the yarns: chosen from their width in pixels,
// or forced (`--lod near|far`: tests hold the far level to the near one).
enum class YarnLevel { automatic, near, far };

// How a weave's far level is drawn (`knit --woven-far neural|baked`).
enum class WovenFar { neural, baked };

struct YarnRendererOptions {
  YarnLevel level = YarnLevel::automatic;
  FibreShading shading;
  EnvironmentLight environment = EnvironmentLight::studio();
  YarnSliceOptions slice;
  // The framebuffer stores linear values (a window surface without an sRGB
  // colour space): the shader encodes sRGB itself.
  bool encode_srgb = false;
  int shadow_map_size = 2048;  // texels a side, at most what the context allows
  // The near view's per-fragment detail grows in over the far view's
  // per-vertex colour as a yarn widens from `detail_from_px` to
  // `detail_full_px`; a frame whose yarns are all narrower draws the far
  // view alone.
  float detail_from_px = 3.0f;
  float detail_full_px = 5.0f;
  // Far frames whose yarns are thinner than `prefilter_until_px` blend
  // them in order (strip_points.h's layers) as strips widened either side
  // by `prefilter_px`, their coverage prefiltered (the yarn's width
  // convolved with a tent that wide, about a pixel: the antialiasing filter
  // 4 samples cannot be for a yarn under a pixel wide, which then shows as
  // its share of a soft band, not as samples hit or missed). The widening
  // fades out as the yarn widens from `prefilter_from_px` to
  // `prefilter_until_px` (up to where the near level takes over: with the
  // short pieces, hard 4x MSAA edges on 1-2 px yarns step visibly from
  // frame to frame as a view recedes); once under a quarter pixel
  // everywhere, far frames draw opaque strips and test depth as near ones do.
  float prefilter_px = 1.0f;
  float prefilter_from_px = 0.8f;
  float prefilter_until_px = 3.0f;
  // A yarn narrower than this (pixels) is drawn this wide and as
  // transparent as it is narrower: thinner strips alias under 4x MSAA.
  float min_strip_px = 1.5f;
  // The flyaway halo grows in as the yarn widens from `halo_from_px` to
  // `halo_full_px`; below it no halo pass is drawn.
  float halo_from_px = 4.0f;
  float halo_full_px = 10.0f;
  // The shadow map takes over from the statistical shadows as a yarn grows
  // from `map_from_texels` to `map_full_texels` wide in it; below, no map
  // is drawn (a yarn a texel or two wide in a depth map aliases).
  float map_from_texels = 2.5f;
  float map_full_texels = 5.0f;
  // Which centreline points a frame draws (strip_points.h), and the
  // longest piece while the shadow map is in use (its shadows are looked up
  // at the vertices).
  PieceLimits pieces;
  float shadowed_piece_px = 6.0f;
  // No piece shorter than this many yarn widths, up to `min_piece_cap_px`
  // (falling to a pixel, and the lift's tolerance to `near_lift_tolerance`,
  // as the yarn widens from 2 to 6 px: the loops' shape shows there);
  // under a pixel, the chord keeps within `tolerance_widths` of the yarn's
  // width of the curve (a loop's shape, and the gaps beside it, hold).
  float min_piece_widths = 1.5f;
  float min_piece_cap_px = 3.0f;
  float tolerance_widths = 0.0625f;
  float near_lift_tolerance = 0.15f;
  float piece_dither = 0.3f;  // PieceLimits::dither once the yarn is 3 px wide
  // Short pieces (issue 30): a strip's sides take turns, so a piece longer
  // than the yarn is wide cuts across the loops' bends and opens the
  // stitch gaps into a net, at either level (stockinette 0.61x as bright
  // as the near level filtered: preview/README.md). As a yarn widens from
  // `short_pieces_from_px` to `short_pieces_full_px` the limits above go
  // over (continuously: a jump in the points drawn would show) to pieces of
  // at most `short_piece_max_px`, no shorter than `short_piece_widths` yarn
  // widths up to `short_piece_cap_px`, their chord within
  // `short_piece_tolerance_px` of the curve. Thinner yarns keep the long
  // pieces: their prefiltered strips hide the bends, and short pieces there
  // only add sparkle. From `short_pieces_until_px` to `short_pieces_off_px`
  // the long pieces come back: a yarn that wide keeps its shape with the
  // tolerance alone, and a piece a pixel long there is only cost.
  float short_pieces_from_px = 0.3f;
  float short_pieces_full_px = 0.6f;
  float short_pieces_until_px = 9.6f;
  float short_pieces_off_px = 13.0f;
  float short_piece_widths = 0.1f;
  float short_piece_cap_px = 0.25f;
  float short_piece_max_px = 1.0f;
  float short_piece_tolerance_px = 0.1f;
  float short_piece_dither = 0.8f;  // PieceLimits::dither at least this, with short pieces
  // The far level (issue 30; repeat_texture.h, far_cloth.h): where its
  // yarns are narrower than `far_cloth_from_px`, cloth that gives its
  // surface (cloth::YarnSet::surface) is drawn as its stitch mesh textured
  // with one repeat baked at the near level, cross-faded per fragment with
  // the yarns until they are `far_cloth_full_px` wide, then alone (no
  // yarns drawn). Cloth without a surface keeps the far view of the yarns
  // above. The repeat is baked at the near level as for a yarn
  // `far_cloth_from_px` wide (where the two levels meet), rasterised at
  // `bake_yarn_texels` a yarn (as a finer frame filtered down), again when the
  // view turns by more than `rebake_degrees` from the bake's, the light or
  // the style changes, or the repeat's edges change by more than
  // `rebake_strain` of their length (less, and the texture stretches with
  // the mesh).
  float far_cloth_from_px = 5.0f;
  float far_cloth_full_px = 2.5f;
  float bake_yarn_texels = 8.0f;
  int bake_phases = 4;  // of the yarns' slice, averaged (repeat_texels)
  float rebake_degrees = 2.0f;
  float rebake_strain = 0.1f;
  // Only cloth whose faces all turn less than this from the middle
  // repeat's has the far level: the bake is lit and seen as that repeat is.
  float far_cloth_flat_degrees = 10.0f;
  // A weave's far level (set_woven, issue 31): `neural`, each of its pixels
  // shaded by the neural woven BSDF (woven_far_cloth.h: the fabric model
  // aggregated over the pixel's footprint, chen2024), decoded at
  // 1/`woven_decode_scale` of the frame's resolution, under a directional
  // light of irradiance `woven_irradiance` (E); or `baked`, the repeat
  // baked at the near level as for knits. Weights: `woven_weights`, empty
  // for the shipped ones (find_woven_weights()). Baked by default: with the
  // shipped weights the neural level is further from the fabric model's
  // converged picture (RMSE 17-36) than the baked one from the near
  // level's (7-12), and on llvmpipe a 1080p frame of it takes seconds
  // (10 us a pixel) against 0.2 s; neural until the network and the GPU
  // are good enough, by asking.
  WovenFar woven_far = WovenFar::baked;
  float woven_decode_scale = 1.0f;
  // E where the two levels' colours meet: the shipped plain, twill and
  // satin's neural far over near were 1.01, 0.74 and 0.74 at E = 2.5, no
  // one E suits all three (woven_far_level_test.cpp); this one leaves each
  // within 19 %.
  float woven_irradiance = 2.85f;
  // The neural level takes over from the yarns as they narrow from this
  // width (to far_cloth_full_px): wider than the baked level's band, as
  // the two models' colours differ by up to 20 %, spread over more frames.
  float woven_far_from_px = 8.0f;
  std::filesystem::path woven_weights;
  // Cloth that is not flat drawn from afar as the repeat's maps on its mesh
  // (repeat_maps.h, scan_surface.h), lit per pixel from the mesh's normals:
  // opaque as the near level, but Lambert is not the yarns' light (the
  // ball's jersey 1.4x too red; preview/README.md), so off until it is.
  bool far_cloth_draped_maps = false;
};

class FarLevel;
struct PatchTile;

// What the yarns' colour is drawn with, besides their own: each linear
// channel times `albedo_gain` (clamped to 1), the fibres' white sheen
// (their R lobe and the environment's mirror term) times `sheen_gain`.
struct ColourMatch {
  Eigen::Vector3f albedo_gain = Eigen::Vector3f::Ones();
  float sheen_gain = 1;
};

class YarnRenderer {
 public:
  [[nodiscard]] static Result<std::unique_ptr<YarnRenderer>> create(
      const YarnRendererOptions& options = {});
  ~YarnRenderer();
  YarnRenderer(const YarnRenderer&) = delete;
  YarnRenderer& operator=(const YarnRenderer&) = delete;

  // Uploads the centrelines (every frame while the cloth moves): one packed
  // vertex per point, rewritten in place while the point count stays; the
  // slice is baked again when the style's look changes. Missing normals are
  // +z, missing lifts 1, missing colours the style's; a curve of fewer than
  // three points is not drawn (a strip needs three).
  void update(const cloth::YarnSet& yarns);
  // Cloth a scan feeds: its far level is the scan's own maps on the stitch
  // mesh (scan_surface.h) instead of the baked repeat, drawn where the
  // baked repeat would be (under `far_cloth_from_px`, alone under
  // `far_cloth_full_px` or with --lod far), flat or draped. Nothing to do
  // when the level is forced near; bad input when the scan's pixel size
  // is not known.
  [[nodiscard]] Status use_scan(const PatchTile& tile);
  // In update()'s place for a frame of `frame` the scan draws alone (every
  // yarn of cloth within `bounds` under `far_cloth_full_px`, or the level
  // forced far): takes the stitch mesh only, so no yarn need be built or
  // packed (issue 30: no yarn update at the far level). False, taking
  // nothing, when the frame needs the yarns: then build them and update().
  bool update_far_only(const cloth::YarnSurface& surface, const cloth::YarnStyle& style,
                       const KnitFrame& frame, const Eigen::AlignedBox3f& bounds);
  // The yarns are this weave: with `woven_far` neural its far level is the
  // neural woven BSDF's from now on (the weights loaded the first time, the
  // material encoded when its pattern or (alpha, beta) change; colours are
  // free). Nothing with the level forced near or `woven_far` baked.
  [[nodiscard]] Status set_woven(const WovenFarMaterial& material);
  // From the next frame on (ColourMatch): how a scan's far level brings
  // the yarns' colour to its own (far_level.h).
  void set_colour_match(const ColourMatch& match) { colour_match_ = match; }
  [[nodiscard]] const ColourMatch& colour_match() const { return colour_match_; }
  // The yarns are no longer that weave (a knit, say): the far level is
  // baked again from the next frame.
  void clear_woven();
  // Whether the far level is the neural one.
  [[nodiscard]] bool neural_far() const;
  // Where the far level begins to take over, yarn width in pixels.
  [[nodiscard]] float far_from_px() const;

  // Clears and draws one frame into the bound framebuffer of `viewport`
  // (the shadow pass borrows its own framebuffer and gives the caller's back).
  // `beneath`, when given, draws into the cleared frame before the yarns,
  // with this frame's camera (what the cloth lies on: prop_renderer.h).
  void render(const KnitView& view, cv::Size viewport,
              const std::function<void(const KnitFrame&)>& beneath = {});
  // The same with a frame made elsewhere (the far level's bakes draw an
  // orthographic one: repeat_texture.h).
  void render(const KnitFrame& frame, const KnitView& view, cv::Size viewport,
              const std::function<void(const KnitFrame&)>& beneath = {});

  // The last frame's yarn width in pixels at the bounds centre, and what it drew.
  [[nodiscard]] float last_yarn_width_px() const { return last_width_px_; }
  [[nodiscard]] bool last_drew_shadow_map() const { return last_shadow_map_; }
  [[nodiscard]] bool last_drew_halo() const { return last_halo_; }
  [[nodiscard]] bool last_drew_far_only() const { return last_far_; }
  // The far level's textured stitch mesh, and the yarns (either or both).
  [[nodiscard]] bool last_drew_far_cloth() const { return last_far_cloth_; }
  [[nodiscard]] bool last_drew_yarns() const { return last_yarns_; }
  // How often the far level's repeat was baked.
  [[nodiscard]] int repeat_bakes() const;
  // Vertices (and restarts) of the last frame's strips.
  [[nodiscard]] int last_strip_vertices() const { return last_strip_vertices_; }
  // How often update() packed yarns (update_far_only() packs none).
  [[nodiscard]] int yarn_updates() const { return yarn_updates_; }
  // How often update() had to allocate GL storage (the point count changed).
  [[nodiscard]] int buffer_allocations() const { return allocations_; }
  [[nodiscard]] int slice_bakes() const { return bakes_; }
  [[nodiscard]] const Eigen::AlignedBox3f& bounds() const { return bounds_; }
  [[nodiscard]] const cloth::YarnStyle& style() const { return style_; }
  [[nodiscard]] const YarnSlice& slice() const { return slice_; }
  [[nodiscard]] const YarnRendererOptions& options() const { return options_; }

 private:
  struct Gl;
  struct Packed;
  YarnRenderer() = default;
  void upload_slice();
  struct Strips;
  class ColourBytes;
  void pack_yarn(const cloth::YarnCurve& curve, std::size_t index, std::size_t first,
                 ColourBytes& colour_bytes, Eigen::Array3f& low, Eigen::Array3f& high);
  Strips choose_points(float px_per_mm, const PieceLimits& limits, const Eigen::Vector4f& eye,
                       bool layered, unsigned which);
  // render()'s steps: what the frame draws, the points it draws them
  // through, the shadow pass (into the shadow map, then framebuffer
  // `target` again) and the yarn and halo passes.
  struct FramePlan;
  FramePlan plan_frame(const KnitFrame& frame, const KnitView& view);
  [[nodiscard]] PieceLimits piece_limits(const FramePlan& plan) const;
  void draw_shadow_map(const KnitFrame& frame, const FramePlan& plan, const PieceLimits& limits,
                       unsigned target);
  void draw_yarns(const KnitFrame& frame, const KnitView& view, const FramePlan& plan,
                  const PieceLimits& limits);

  std::unique_ptr<Gl> gl_;
  std::unique_ptr<Packed> packed_;
  std::unique_ptr<FarLevel> far_;  // none when the level is forced near
  YarnRendererOptions options_;
  cloth::YarnStyle style_;
  YarnSlice slice_;
  Eigen::AlignedBox3f bounds_;
  float last_width_px_ = 0;
  bool last_shadow_map_ = false;
  bool last_halo_ = false;
  bool last_far_ = false;
  bool last_far_cloth_ = false;
  ColourMatch colour_match_;
  bool last_yarns_ = false;
  int last_strip_vertices_ = 0;
  int allocations_ = 0;
  int bakes_ = 0;
  int yarn_updates_ = 0;
  bool surface_only_ = false;  // update_far_only() took the last frame's cloth
};

}  // namespace psrig::preview
