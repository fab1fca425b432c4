// psrig-preview drape CHART_OR_MAPS --scene hang|table|sphere|arm --out
// DIR: a knit (a stitch chart, or the chart read off a scan's maps at its
// gauge and in its colours) hanging, falling over a table's edge, over a ball or an arm that
// swings, simulated at stitch level (cloth/stitch_cloth.h) with its yarns
// following, drawn headless to DIR/frame-NNNN.png and a contact sheet of
// the run (DIR/contact-sheet.png); --bench times the simulation step, the
// yarn update and the frame. A scan's drape is drawn from afar as the
// scan's own maps on the cloth (scan_surface.h), its yarns then not built.

#include <GLES3/gl3.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include <opencv2/imgproc.hpp>

#include "command.h"
#include "psrig/cloth/drape_scene.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/image_io.h"
#include "psrig/preview/drape_cloth.h"

namespace psrig::preview::cli {
namespace {

struct DrapeArgs {
  std::string pattern;
  std::string scene = "hang";
  std::string out;
  std::string size = "640x480";
  int stitches = 48, rows = 56;
  double seconds = 4, fps = 30;
  double yaw = 20, pitch = 25, distance = 0;
  int samples = kDefaultSamples;
  std::string lod = "auto";
  bool bench = false;
  ClothSize cloth_size;
};

// drape_fabric for what the user named: a scan's maps read as
// read_scan_cloth_argument reads them, so a scan directory is pointed at
// its maps.
Result<cloth::KnitFabric> fabric_argument(const DrapeArgs& args, int stitches, int rows) {
  if (!std::filesystem::is_directory(args.pattern))
    return drape_fabric(args.pattern, stitches, rows, args.cloth_size);
  auto scan = read_scan_cloth_argument(args.pattern);
  if (!scan) return std::unexpected(scan.error());
  return knit_of_scan(*scan, stitches, rows, args.cloth_size);
}

// A scan's drape has the scan's own maps as its far level; maps that
// cannot be (no pixel size) leave the knit's own.
void use_scan(const DrapeArgs& args, DrapeRenderers& renderers) {
  if (!std::filesystem::is_directory(args.pattern)) return;
  if (auto source = use_scan_maps(renderers, args.pattern); !source)
    std::cerr << "psrig-preview drape: warning: " << source.error().describe()
              << " (from afar, the knit's own yarns)\n";
}

YarnRendererOptions yarn_options(const DrapeArgs& args) {
  YarnRendererOptions options;
  options.level = yarn_level(args.lod);
  return options;
}

Result<cloth::DrapeAnimation> animation(const DrapeArgs& args, int stitches, int rows) {
  const auto scene = cloth::parse_drape_scene(args.scene);
  if (!scene)
    return std::unexpected(bad_input({}, "--scene",
                                     "'" + args.scene + "' is not a scene: hang, table, sphere or arm"));
  auto fabric = fabric_argument(args, stitches, rows);
  if (!fabric) return std::unexpected(fabric.error());
  return cloth::DrapeAnimation(std::move(*fabric), *scene);
}

// Up to 12 frames, evenly through the run, in a grid, each with its time.
cv::Mat contact_sheet(const std::vector<std::pair<double, cv::Mat>>& frames) {
  const std::size_t shown = std::min<std::size_t>(12, frames.size());
  if (shown == 0) return {};
  const int columns = 4, rows = static_cast<int>((shown + 3) / 4);
  const cv::Size cell(320, 240);
  cv::Mat sheet(rows * cell.height, columns * cell.width, CV_8UC3, cv::Scalar(16, 16, 16));
  for (std::size_t i = 0; i < shown; ++i) {
    const std::size_t pick = shown == 1 ? 0 : i * (frames.size() - 1) / (shown - 1);
    cv::Mat small;
    cv::resize(frames[pick].second, small, cell, 0, 0, cv::INTER_AREA);
    char label[32];
    std::snprintf(label, sizeof label, "t = %.2f s", frames[pick].first);
    cv::putText(small, label, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(230, 230, 230), 1,
                cv::LINE_AA);
    small.copyTo(sheet(cv::Rect(static_cast<int>(i % 4) * cell.width,
                                static_cast<int>(i / 4) * cell.height, cell.width, cell.height)));
  }
  return sheet;
}

int render(const DrapeArgs& args) {
  auto size = parse_size(args.size, "--size");
  if (!size) return report_error("drape", size.error());
  auto scene = animation(args, args.stitches, args.rows);
  if (!scene) return report_error("drape", scene.error());
  auto canvas = open_headless_canvas(*size, args.samples);
  if (!canvas) return report_error("drape", canvas.error());
  auto renderers = drape_renderers(yarn_options(args));
  if (!renderers) return report_error("drape", renderers.error());
  use_scan(args, *renderers);
  const std::filesystem::path out(args.out);
  if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path());
  auto staging = formats::AtomicDirectory::create(out);
  if (!staging) return report_error("drape", staging.error());

  const int frames = std::max(1, static_cast<int>(std::lround(args.seconds * args.fps)));
  const auto dt = static_cast<float>(1 / args.fps);
  std::vector<std::pair<double, cv::Mat>> drawn;
  for (int frame = 0; frame < frames; ++frame) {
    scene->advance(dt);
    canvas->target->bind();
    draw_drape(*scene, *renderers, drape_view(args.yaw, args.pitch, args.distance), *size);
    cv::Mat image = canvas->target->read();
    char name[32];
    std::snprintf(name, sizeof name, "frame-%04d.png", frame);
    if (auto ok = formats::write_image(staging->path() / name, image); !ok)
      return report_error("drape", ok.error());
    drawn.emplace_back(scene->time(), std::move(image));
  }
  if (auto ok = formats::write_image(staging->path() / "contact-sheet.png", contact_sheet(drawn));
      !ok)
    return report_error("drape", ok.error());
  if (auto ok = staging->commit(formats::AtomicDirectory::Existing::replace, false); !ok)
    return report_error("drape", ok.error());
  std::cout << "drape: " << args.out << " (" << frames << " frames of " << args.scene << ", "
            << args.stitches << "x" << args.rows << " stitches, " << size->width << "x"
            << size->height << ")\n";
  return 0;
}

// Per size: the simulation step, the yarn update and the frame, averaged
// over a second of the scene after its first half second.
int bench(const DrapeArgs& args) {
  auto size = parse_size(args.size == "640x480" ? "1920x1080" : args.size, "--size");
  if (!size) return report_error("drape", size.error());
  auto canvas = open_headless_canvas(*size, args.samples);
  if (!canvas) return report_error("drape", canvas.error());
  auto renderers = drape_renderers(yarn_options(args));
  if (!renderers) return report_error("drape", renderers.error());
  use_scan(args, *renderers);
  const KnitView view = drape_view(args.yaw, args.pitch, args.distance);
  std::cout << "{\"renderer\": \"" << canvas->context->describe() << "\", \"scene\": \"" << args.scene
            << "\", \"size\": [" << size->width << ", " << size->height << "], \"runs\": [";
  bool first = true;
  for (const int stitches : {1000, 10000}) {
    const int side = static_cast<int>(std::lround(std::sqrt(stitches)));
    auto scene = animation(args, side, side);
    if (!scene) return report_error("drape", scene.error());
    const auto dt = static_cast<float>(1 / args.fps);
    double step_ms = 0, yarn_ms = 0, frame_ms = 0;
    const int updates_before = renderers->yarns->yarn_updates();
    const int warm = static_cast<int>(args.fps / 2), timed = static_cast<int>(args.fps);
    for (int frame = 0; frame < warm + timed; ++frame) {
      const auto start = Clock::now();
      scene->advance(dt);
      const auto stepped = Clock::now();
      const KnitFrame camera = update_drape(*scene, *renderers, view, *size);
      const auto followed = Clock::now();
      canvas->target->bind();
      draw_drape_frame(*scene, *renderers, camera, view, *size);
      glFinish();
      const auto drawn = Clock::now();
      if (frame < warm) continue;
      step_ms += milliseconds(stepped - start);
      yarn_ms += milliseconds(followed - stepped);
      frame_ms += milliseconds(drawn - start);
    }
    std::cout << (first ? "" : ", ") << "{\"stitches\": " << side * side
              << ", \"step_ms\": " << step_ms / timed << ", \"yarn_update_ms\": " << yarn_ms / timed
              << ", \"frame_ms\": " << frame_ms / timed
              << ", \"fps\": " << 1000.0 * timed / frame_ms
              << ", \"yarn_px\": " << renderers->yarns->last_yarn_width_px()
              << ", \"frames\": " << warm + timed
              << ", \"yarn_updates\": " << renderers->yarns->yarn_updates() - updates_before << "}";
    first = false;
  }
  std::cout << "]}\n";
  return 0;
}

}  // namespace

Command add_drape_command(CLI::App& parent) {
  auto args = std::make_shared<DrapeArgs>();
  CLI::App* app = parent.add_subcommand(
      "drape", "Simulate a knit (a chart or a scan's) hanging or draping and draw it to PNG frames, or "
      "time it");
  app->add_option("pattern", args->pattern,
                 "Stitch chart (.chart), or a knitted scan's maps directory (its chart read off)")
      ->required();
  app->add_option("--scene", args->scene, "hang, table, sphere or arm")->capture_default_str();
  auto* out = app->add_option("--out", args->out, "Directory for the frames and contact sheet");
  app->add_option("--size", args->size, "Frame size WxH (--bench: 1920x1080)")->capture_default_str();
  app->add_option("--stitches", args->stitches, "Stitches per course")
      ->check(CLI::Range(2, 400))
      ->capture_default_str();
  app->add_option("--rows", args->rows, "Courses")->check(CLI::Range(2, 400))->capture_default_str();
  app->add_option("--seconds", args->seconds, "Length of the run")
      ->check(CLI::Range(0.05, 60.0))
      ->capture_default_str();
  app->add_option("--fps", args->fps, "Frames per second")
      ->check(CLI::Range(5.0, 240.0))
      ->capture_default_str();
  app->add_option("--yaw", args->yaw, "Camera yaw in degrees")->capture_default_str();
  app->add_option("--pitch", args->pitch, "Camera pitch in degrees")->capture_default_str();
  app->add_option("--distance", args->distance, "Camera distance in mm (0: fit the cloth)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
  app->add_option("--wales-per-cm", args->cloth_size.wales_per_cm, "Knit gauge across")
      ->check(psrig::cli::positive_number());
  app->add_option("--courses-per-cm", args->cloth_size.courses_per_cm, "Knit gauge up")
      ->check(psrig::cli::positive_number());
  app->add_option("--yarn-mm", args->cloth_size.yarn_mm, "Yarn diameter in mm")
      ->check(psrig::cli::positive_number());
  add_samples_option(*app, args->samples);
  add_lod_option(*app, args->lod);
  auto* timed = app->add_flag("--bench", args->bench,
                              "Time the step, the yarn update and the frame at 1 K and 10 K stitches; prints JSON");
  out->excludes(timed);
  return {app, [args, out] {
            if (args->bench) return bench(*args);
            if (out->count() == 0) {
              std::cerr << "psrig-preview drape: error: --out DIR is required (or --bench)\n";
              return 2;
            }
            return render(*args);
          }};
}

}  // namespace psrig::preview::cli
