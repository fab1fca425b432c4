// psrig-preview bench MAPS_DIR: how fast the kiosk's frame is drawn,
// headless, with the light orbiting as on the kiosk.

#include <GLES3/gl3.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "command.h"
#include "psrig/preview/scene_motion.h"

namespace psrig::preview::cli {
namespace {

struct BenchArgs {
  std::string maps;
  std::string size = "1920x1080";
  int frames = 200;
  int warmup = 10;
  int samples = kDefaultSamples;
  ViewArgs view;
};

double percentile(std::vector<double> values, double fraction) {
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(fraction * static_cast<double>(values.size() - 1));
  return values[index];
}

int bench(const BenchArgs& args) {
  auto maps = load_maps_argument(args.maps);
  if (!maps) return report_error("bench", maps.error());
  auto size = parse_size(args.size, "--size");
  if (!size) return report_error("bench", size.error());
  auto canvas = open_headless_canvas(*size, args.samples);
  if (!canvas) return report_error("bench", canvas.error());
  auto renderer = SwatchRenderer::create(*maps, renderer_options(*canvas->context));
  if (!renderer) return report_error("bench", renderer.error());

  const SceneView base = scene_view(args.view);
  const SceneMotion motion;
  canvas->target->bind();
  std::vector<double> frame_ms;
  for (int frame = -args.warmup; frame < args.frames; ++frame) {
    const auto frame_start = Clock::now();
    (*renderer)->draw(motion.at(frame / 60.0, base), *size);
    glFinish();  // the frame is done, as before a page flip
    if (frame >= 0)
      frame_ms.push_back(
          std::chrono::duration<double, std::milli>(Clock::now() - frame_start).count());
  }
  double total_ms = 0;
  for (const double ms : frame_ms)
    total_ms += ms;
  std::printf(
      "{\"renderer\": \"%s\", \"size\": [%d, %d], \"samples\": %d, \"view\": \"%s\", "
      "\"frames\": %d, \"fps\": %.1f, \"frame_ms\": {\"mean\": %.2f, \"p50\": %.2f, \"p90\": "
      "%.2f, \"p99\": %.2f, \"max\": %.2f}}\n",
      canvas->context->describe().c_str(), size->width, size->height, canvas->target->samples(),
      args.view.view.c_str(), args.frames, 1000.0 * args.frames / total_ms, total_ms / args.frames,
      percentile(frame_ms, 0.5), percentile(frame_ms, 0.9), percentile(frame_ms, 0.99),
      percentile(frame_ms, 1.0));
  return 0;
}

}  // namespace

Command add_bench_command(CLI::App& parent) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* app = parent.add_subcommand(
      "bench", "Time the kiosk's frames headless; prints fps and frame-time percentiles as JSON");
  app->add_option("maps", args->maps, "Maps directory")->required();
  app->add_option("--size", args->size, "Frame size WxH")->capture_default_str();
  app->add_option("--frames", args->frames, "Frames timed")
      ->check(psrig::cli::positive_number())
      ->capture_default_str();
  app->add_option("--warmup", args->warmup, "Frames drawn first and not timed")
      ->check(psrig::cli::non_negative_number())
      ->capture_default_str();
  add_samples_option(*app, args->samples);
  add_view_options(*app, args->view);
  return {app, [args] { return bench(*args); }};
}

}  // namespace psrig::preview::cli
