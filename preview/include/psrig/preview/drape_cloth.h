#pragma once
// The knit a drape shows (`psrig-preview drape`, the kiosk's drape): a
// stitch chart at the gauge its file or the command line gives, or a
// scan's own, the chart read off its maps (scan_cloth.h) knitted at the
// scan's gauge and yarn in each stitch's colour.

#include <filesystem>

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

// The camera and light a drape is seen with.
[[nodiscard]] KnitView drape_view(double yaw_deg, double pitch_deg);

// What draws a drape's frames: the yarns and what they lie on.
struct DrapeRenderers {
  std::unique_ptr<YarnRenderer> yarns;
  std::unique_ptr<PropRenderer> props;
  cloth::YarnSet curves;  // storage reused frame to frame
};
[[nodiscard]] Result<DrapeRenderers> drape_renderers(const YarnRendererOptions& options = {});
// The animation's yarns (into renderers.curves) and colliders as they are
// now, drawn into the bound framebuffer; draw_drape_frame() draws the
// curves already there.
void draw_drape(cloth::DrapeAnimation& animation, DrapeRenderers& renderers, const KnitView& view,
                cv::Size size);
void draw_drape_frame(const cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                      const KnitView& view, cv::Size size);

}  // namespace psrig::preview
