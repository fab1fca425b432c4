#include "psrig/preview/drape_cloth.h"

namespace psrig::preview {

Result<cloth::KnitFabric> knit_of_scan(const ScanCloth& scan, int stitches, int rows,
                                       const ClothSize& size) {
  if (!scan.knit)
    return std::unexpected(bad_input(scan.maps, {},
                                     "no stitch chart could be read off these maps (" + scan.why +
                                         "): drape shows knits"));
  const ClothSize knit_at = scan.cloth_size(size, true);
  cloth::KnitParameters parameters;
  parameters.gauge = {knit_at.wales_per_cm, knit_at.courses_per_cm, knit_at.yarn_mm};
  return cloth::KnitFabric::build(scan.knit->chart, stitches, rows, parameters,
                                  scan.stitch_colours(stitches, rows));
}

Result<cloth::KnitFabric> drape_fabric(const std::filesystem::path& chart_or_maps, int stitches,
                                       int rows, const ClothSize& size) {
  if (std::filesystem::is_directory(chart_or_maps)) {
    auto scan = read_scan_cloth(chart_or_maps);
    if (!scan) return std::unexpected(scan.error());
    return knit_of_scan(*scan, stitches, rows, size);
  }
  if (cloth::looks_like_weave(chart_or_maps))
    return std::unexpected(bad_input(chart_or_maps, {},
                                     "drape simulates knits; give a stitch chart (.chart) or a "
                                     "knitted scan's maps directory"));
  auto chart = cloth::load_stitch_chart(chart_or_maps);
  if (!chart) return std::unexpected(chart.error());
  cloth::KnitParameters parameters;
  parameters.gauge = {size.wales_per_cm, size.courses_per_cm, size.yarn_mm};
  auto fabric = cloth::KnitFabric::build(*chart, stitches, rows, parameters);
  if (!fabric && fabric.error().file.empty()) fabric.error().file = chart_or_maps;
  return fabric;
}

KnitView drape_view(double yaw_deg, double pitch_deg) {
  KnitView view;
  view.yaw_deg = yaw_deg;
  view.pitch_deg = pitch_deg;
  view.light.tilt_deg = 60;
  view.light.slant_deg = 40;
  return view;
}

Result<DrapeRenderers> drape_renderers(const YarnRendererOptions& options) {
  auto yarns = YarnRenderer::create(options);
  if (!yarns) return std::unexpected(yarns.error());
  auto props = PropRenderer::create(options.encode_srgb);
  if (!props) return std::unexpected(props.error());
  return DrapeRenderers{std::move(*yarns), std::move(*props), {}};
}

void draw_drape(cloth::DrapeAnimation& animation, DrapeRenderers& renderers, const KnitView& view,
                cv::Size size) {
  animation.yarns(renderers.curves);
  draw_drape_frame(animation, renderers, view, size);
}

void draw_drape_frame(const cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                      const KnitView& view, cv::Size size) {
  renderers.yarns->update(renderers.curves);
  // The floor and the table reach well beyond the cloth, under it.
  const Eigen::AlignedBox3f& bounds = renderers.yarns->bounds();
  renderers.props->update(animation.cloth().colliders, bounds.center(), 4 * bounds.diagonal().norm());
  renderers.yarns->render(view, size,
                          [&](const KnitFrame& frame) { renderers.props->draw(frame); });
}

}  // namespace psrig::preview
