// psrig-preview render MAPS_DIR --out FILE.png: one frame, headless.

#include <iostream>

#include "command.h"
#include "psrig/formats/image_io.h"
#include "psrig/preview/patch_tile.h"

namespace psrig::preview::cli {
namespace {

struct RenderArgs {
  std::string maps;
  std::string out;
  std::string size;  // default: the maps' size (flat), 1280x960 (patch)
  int samples = kDefaultSamples;
  ViewArgs view;
};

int render(const RenderArgs& args) {
  auto maps = load_maps_argument(args.maps);
  if (!maps) return report_error("render", maps.error());
  const SceneView view = scene_view(args.view);
  if (view.kind == ViewKind::patch) {
    // The sheet repeats the seamless tile, not the scan's own edges.
    PatchTile tile = patch_tile(*maps);
    std::cout << "patch: tile " << tile.repeats_u << "x" << tile.repeats_v << " repeats, "
              << tile.source << (tile.periodic ? "" : " (no repeat found: whole scan)") << "\n";
    maps = std::move(tile.maps);
  }
  cv::Size size = view.kind == ViewKind::flat ? maps->size() : cv::Size(1280, 960);
  if (!args.size.empty()) {
    auto parsed = parse_size(args.size, "--size");
    if (!parsed) return report_error("render", parsed.error());
    size = *parsed;
  }
  auto canvas = open_headless_canvas(size, args.samples);
  if (!canvas) return report_error("render", canvas.error());
  auto renderer = SwatchRenderer::create(*maps, renderer_options(*canvas->context));
  if (!renderer) return report_error("render", renderer.error());
  canvas->target->bind();
  (*renderer)->draw(view, size);
  if (auto ok = formats::write_image(args.out, canvas->target->read()); !ok)
    return report_error("render", ok.error());
  std::cout << "preview: " << args.out << " (" << size.width << "x" << size.height << ", "
            << args.view.view << " view, " << args.view.light << " light at tilt "
            << args.view.light_tilt << ", slant " << args.view.light_slant << ")\n";
  return 0;
}

}  // namespace

Command add_render_command(CLI::App& parent) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* app = parent.add_subcommand("render", "Draw one frame of a maps directory to a PNG");
  app->add_option("maps", args->maps, "Maps directory (albedo, normal, height, ...)")->required();
  app->add_option("--out", args->out, "PNG file to write")->required();
  app->add_option("--size", args->size,
                  "Frame size WxH (default: the maps' size for --view flat, else 1280x960)");
  add_samples_option(*app, args->samples);
  add_view_options(*app, args->view);
  return {app, [args] { return render(*args); }};
}

}  // namespace psrig::preview::cli
