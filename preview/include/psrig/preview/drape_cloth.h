#pragma once
// The knit a drape shows (`psrig-preview drape`, the kiosk's drape): a
// stitch chart at the gauge its file or the command line gives, or a
// scan's own, the chart read off its maps (scan_cloth.h) knitted at the
// scan's gauge and yarn in each stitch's colour.

#include <filesystem>
#include <string>

#include "psrig/cloth/drape_scene.h"
#include "psrig/cloth/knit_fabric.h"
#include "psrig/preview/cloth_model.h"
#include "psrig/preview/knit_view.h"
#include "psrig/preview/prop_renderer.h"
#include "psrig/preview/scan_cloth.h"
#include "psrig/preview/yarn_renderer.h"

namespace psrig::preview {

// `chart_or_maps`: a .chart file, or a maps directory (read_scan_cloth).
// `size` over the chart's or the scan's gauge where given.
[[nodiscard]] Result<cloth::KnitFabric> drape_fabric(const std::filesystem::path& chart_or_maps,
                                                     int stitches, int rows,
                                                     const ClothSize& size = {});
// The scan's knit; bad input naming the maps when no chart was read off
// them (woven, no repeat, not knitted: `scan.why`).
[[nodiscard]] Result<cloth::KnitFabric> knit_of_scan(const ScanCloth& scan, int stitches, int rows,
                                                     const ClothSize& size = {});

// The camera and light a drape is seen with; `distance_mm` 0 fits the cloth.
[[nodiscard]] KnitView drape_view(double yaw_deg, double pitch_deg, double distance_mm = 0);

// What draws a drape's frames: the yarns and what they lie on.
struct DrapeRenderers {
  std::unique_ptr<YarnRenderer> yarns;
  std::unique_ptr<PropRenderer> props;
  cloth::YarnSet curves;  // storage reused frame to frame
  // A frame the scan's far level draws alone builds no yarn (false: every
  // frame builds them, as tests compare).
  bool far_without_yarns = true;
};
[[nodiscard]] Result<DrapeRenderers> drape_renderers(const YarnRendererOptions& options = {});
// A scan's drape: the scan's own maps (their seamless tile, patch_tile.h)
// as the far level (scan_surface.h). Returns where the tile came from.
[[nodiscard]] Result<std::string> use_scan_maps(DrapeRenderers& renderers,
                                                const std::filesystem::path& maps);

// The cloth's bounds as a drape frames it: the stitch mesh grown by two
// yarn radii (about where the yarns reach), so that the camera is the same
// whether or not a frame builds its yarns.
[[nodiscard]] Eigen::AlignedBox3f drape_bounds(const cloth::DrapeAnimation& animation);
// The animation's cloth as it is now into the renderers: the yarns (into
// renderers.curves), or only the stitch mesh when the scan's far level
// draws the frame alone (YarnRenderer::update_far_only). Returns the
// frame's camera.
KnitFrame update_drape(cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                       const KnitView& view, cv::Size size);
// That frame and what the cloth meets, drawn into the bound framebuffer.
void draw_drape_frame(const cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                      const KnitFrame& frame, const KnitView& view, cv::Size size);
// Both.
void draw_drape(cloth::DrapeAnimation& animation, DrapeRenderers& renderers, const KnitView& view,
                cv::Size size);

}  // namespace psrig::preview
