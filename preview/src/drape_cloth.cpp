#include "psrig/preview/drape_cloth.h"

#include "psrig/preview/patch_tile.h"
#include "psrig/preview/swatch_maps.h"

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

KnitView drape_view(double yaw_deg, double pitch_deg, double distance_mm) {
  KnitView view;
  view.yaw_deg = yaw_deg;
  view.pitch_deg = pitch_deg;
  view.distance_mm = distance_mm;
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

Result<std::string> use_scan_maps(DrapeRenderers& renderers, const std::filesystem::path& maps) {
  auto loaded = load_swatch_maps(maps);
  if (!loaded) return std::unexpected(loaded.error());
  const PatchTile tile = patch_tile(*loaded);
  if (auto ok = renderers.yarns->use_scan(tile); !ok) return std::unexpected(ok.error());
  return tile.source;
}

Eigen::AlignedBox3f drape_bounds(const cloth::DrapeAnimation& animation) {
  Eigen::AlignedBox3f bounds;
  for (const Eigen::Vector3f& vertex : animation.cloth().mesh().vertices)
    bounds.extend(vertex);
  if (!bounds.isEmpty()) {
    const float reach = animation.fabric().dimensions().yarn_diameter_mm;  // two radii
    bounds.min().array() -= reach;
    bounds.max().array() += reach;
  }
  return bounds;
}

KnitFrame update_drape(cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                       const KnitView& view, cv::Size size) {
  const Eigen::AlignedBox3f bounds = drape_bounds(animation);
  const KnitFrame frame = knit_frame(bounds, view, size);
  if (!renderers.far_without_yarns ||
      !renderers.yarns->update_far_only(animation.surface(), animation.fabric().style(), frame,
                                        bounds)) {
    animation.yarns(renderers.curves);
    renderers.yarns->update(renderers.curves);
  }
  return frame;
}

void draw_drape_frame(const cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                      const KnitFrame& frame, const KnitView& view, cv::Size size) {
  // The floor and the table reach well beyond the cloth, under it.
  const Eigen::AlignedBox3f bounds = drape_bounds(animation);
  renderers.props->update(animation.cloth().colliders, bounds.center(), 4 * bounds.diagonal().norm());
  renderers.yarns->render(frame, view, size,
                          [&](const KnitFrame& beneath) { renderers.props->draw(beneath); });
}

void draw_drape(cloth::DrapeAnimation& animation, DrapeRenderers& renderers, const KnitView& view,
                cv::Size size) {
  const KnitFrame frame = update_drape(animation, renderers, view, size);
  draw_drape_frame(animation, renderers, frame, view, size);
}

}  // namespace psrig::preview
