// psrig-preview knit CHART_OR_WEAVE --out FILE.png: knitted (or woven) cloth
// at yarn level, headless; --bench times the yarn update and the frames at
// 1 K, 10 K and 50 K stitches.

#include <GLES3/gl3.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>
#include <sys/resource.h>
#include <vector>

#include <opencv2/core.hpp>

#include "command.h"
#include "psrig/base/median.h"
#include "psrig/cloth/srgb.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/formats/image_io.h"
#include "psrig/preview/cloth_model.h"
#include "psrig/preview/patch_tile.h"
#include "psrig/preview/scan_cloth.h"
#include "psrig/preview/woven_far_cloth.h"
#include "psrig/preview/yarn_renderer.h"

namespace psrig::preview::cli {
namespace {

struct KnitArgs {
  std::string pattern;
  std::string out;
  std::string size;  // default: 1280x960, --bench 1920x1080
  int stitches = 24;
  int rows = 20;
  float stretch = 1;
  float shear = 0;
  ClothSize cloth_size;
  std::string yarn_colour;
  std::string from_scan;
  std::string environment = "studio";
  std::string lod = "auto";
  std::string woven_far = "baked";
  float woven_decode_scale = 1;
  double yaw = 0, pitch = 0, distance = 0;
  double light_tilt = 45, light_slant = 45;
  int samples = kDefaultSamples;
  bool bench = false;
  bool draped = false;
  bool no_shadows = false;
  bool plain_fibres = false;
  int frames = 30;
  std::vector<int> bench_stitches{1000, 10000, 50000};
};

// The lean --shear allows: within it yarns still find room.
constexpr float kMaxShear = 0.6f;

// CPU time of every thread of the process (llvmpipe's rasterising threads
// included), in ms: on a busy machine a steadier measure than wall time.
double process_cpu_ms() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto ms = [](const timeval& t) { return t.tv_sec * 1e3 + t.tv_usec / 1e3; };
  return ms(usage.ru_utime) + ms(usage.ru_stime);
}

// The yarn's colour when given, or none (the chart's).
Result<std::optional<Eigen::Vector3f>> yarn_colour(const KnitArgs& args) {
  if (args.yarn_colour.empty()) return std::optional<Eigen::Vector3f>{};
  const auto colour = cloth::parse_srgb_hex(args.yarn_colour);
  if (!colour)
    return std::unexpected(bad_input(
        {}, "--yarn-color", "'" + args.yarn_colour + "' is not #RRGGBB (sRGB, hexadecimal)"));
  return colour;
}

// The cloth to draw: the pattern as given; with --from-scan at the scan's
// gauge and in its colours (each stitch's, when the scan's chart has more
// than one), or without a pattern the chart read off the scan.
Result<ClothModel> cloth_for(const KnitArgs& args, const std::optional<ScanCloth>& scan,
                             cloth::ClothShape shape) {
  auto colour = yarn_colour(args);
  if (!colour) return std::unexpected(colour.error());
  if (!scan) return ClothModel::load(args.pattern, args.stitches, args.rows, *colour, shape,
                                     args.cloth_size);
  const ClothSize size = scan->cloth_size(args.cloth_size, !cloth::looks_like_weave(args.pattern));
  if (args.pattern.empty()) {
    if (!scan->knit)
      return std::unexpected(bad_input(
          scan->maps, "--from-scan",
          "no stitch chart could be read off these maps (" + scan->why +
              "); give the chart or weave to draw as well"));
    return ClothModel::knit(scan->knit->chart, args.stitches, args.rows, std::nullopt, {}, shape,
                            size);
  }
  const bool colourful = scan->knit && scan->knit->chart.palette.size() > 1;
  if (colourful && !cloth::looks_like_weave(args.pattern)) {
    auto chart = cloth::load_stitch_chart(args.pattern);
    if (!chart) return std::unexpected(chart.error());
    return ClothModel::knit(std::move(*chart), args.stitches, args.rows, std::nullopt,
                            scan->stitch_colours(args.stitches, args.rows), shape, size);
  }
  const Eigen::Vector3f yarn = scan->knit ? scan->knit->chart.palette.front() : scan->mean_colour;
  return ClothModel::load(args.pattern, args.stitches, args.rows, yarn, shape, size);
}

KnitView knit_view(const KnitArgs& args) {
  KnitView view;
  view.yaw_deg = args.yaw;
  view.pitch_deg = args.pitch;
  view.distance_mm = args.distance;
  view.light.tilt_deg = args.light_tilt;
  view.light.slant_deg = args.light_slant;
  view.shadows = !args.no_shadows;
  view.fibre_detail = !args.plain_fibres;
  return view;
}

cloth::ClothShape cloth_shape(const KnitArgs& args) {
  return args.draped ? cloth::ClothShape::draped : cloth::ClothShape::flat;
}

// What both render and bench draw with.
struct YarnCanvas : HeadlessCanvas {
  std::unique_ptr<YarnRenderer> renderer;  // destroyed first
};

// The light from all around: the built-in studio, none, or a map's file.
Result<EnvironmentLight> environment_light(const std::string& name) {
  if (name == "studio") return EnvironmentLight::studio();
  if (name == "none") return EnvironmentLight{};
  return EnvironmentLight::load(name);
}

Result<YarnCanvas> open_canvas(const KnitArgs& args, cv::Size size) {
  auto environment = environment_light(args.environment);
  if (!environment) return std::unexpected(environment.error());
  auto canvas = open_headless_canvas(size, args.samples);
  if (!canvas) return std::unexpected(canvas.error());
  YarnRendererOptions options;
  options.environment = *environment;
  options.level = yarn_level(args.lod);
  options.woven_far = args.woven_far == "neural" ? WovenFar::neural : WovenFar::baked;
  options.woven_decode_scale = args.woven_decode_scale;
  auto renderer = YarnRenderer::create(options);
  if (!renderer) return std::unexpected(renderer.error());
  return YarnCanvas{std::move(*canvas), std::move(*renderer)};
}

// A weave's far level is its own material's with --woven-far neural (set_woven does
// nothing otherwise).
Status give_weave(YarnRenderer& renderer, const ClothModel& cloth) {
  const cloth::WovenFabric* woven = cloth.woven_fabric();
  if (woven == nullptr) return {};
  return renderer.set_woven(
      woven_far_material(woven->weave(), woven->warp_colour(), woven->weft_colour()));
}

int render(const KnitArgs& args, bool shear_given) {
  auto size = parse_size(args.size.empty() ? "1280x960" : args.size, "--size");
  if (!size) return report_error("knit", size.error());
  std::optional<ScanCloth> scan;
  if (!args.from_scan.empty()) {
    auto read = read_scan_cloth_argument(args.from_scan);
    if (!read) return report_error("knit", read.error());
    for (const std::string& warning : read->warnings)
      std::cerr << "psrig-preview knit: warning: " << warning << '\n';
    if (!read->knit && !args.pattern.empty())
      std::cerr << "psrig-preview knit: warning: no stitch chart read off " << args.from_scan
                << " (" << read->why << "): its gauge and mean colour only\n";
    scan = std::move(*read);
  }
  auto cloth = cloth_for(args, scan, cloth_shape(args));
  if (!cloth) return report_error("knit", cloth.error());
  // The scan's skew leans the wales, unless --shear says otherwise.
  const float shear =
      scan && !shear_given ? std::clamp(scan->shear, -kMaxShear, kMaxShear) : args.shear;
  cloth::YarnSet yarns;
  cloth->update({args.stretch, shear}, yarns);

  auto canvas = open_canvas(args, *size);
  if (!canvas) return report_error("knit", canvas.error());
  // The scan's own chart: from afar, the scan's own maps (scan_surface.h).
  if (scan && args.pattern.empty()) {
    auto maps = load_swatch_maps(scan->maps);
    const Status ok = maps ? canvas->renderer->use_scan(patch_tile(*maps))
                           : Status(std::unexpected(maps.error()));
    if (!ok)
      std::cerr << "psrig-preview knit: warning: " << ok.error().describe()
                << " (the far level is the knit's own repeat)\n";
  }
  if (auto given = give_weave(*canvas->renderer, *cloth); !given)
    return report_error("knit", given.error());
  canvas->renderer->update(yarns);
  canvas->target->bind();
  canvas->renderer->render(knit_view(args), *size);
  if (auto ok = formats::write_image(args.out, canvas->target->read()); !ok)
    return report_error("knit", ok.error());
  std::cout << "knit: " << args.out << " (" << size->width << "x" << size->height << ", "
            << args.stitches << "x" << args.rows << (cloth->woven() ? " threads" : " stitches")
            << " at " << cloth->describe() << ", " << yarns.point_count() << " yarn points, stretch " << args.stretch << ", shear "
            << shear << ")\n";
  if (scan) std::cout << "knit: from the scan: " << scan->describe() << "\n";
  return 0;
}

// Per size: the yarn update (deformation changing every frame), the
// renderer's upload of it, then the frame drawn with that update, at
// 1920x1080 unless --size says otherwise. Means and medians of wall time,
// and the process's CPU time per frame.
int bench(const KnitArgs& args) {
  auto size = parse_size(args.size.empty() ? "1920x1080" : args.size, "--size");
  if (!size) return report_error("knit", size.error());
  auto canvas = open_canvas(args, *size);
  if (!canvas) return report_error("knit", canvas.error());
  std::cout << "{\"renderer\": \"" << canvas->context->describe() << "\", \"size\": ["
            << size->width << ", " << size->height << "], \"samples\": " << args.samples
            << ", \"runs\": [";
  bool first = true;
  for (const int stitches : args.bench_stitches) {
    const int side = static_cast<int>(std::lround(std::sqrt(stitches)));
    auto cloth = ClothModel::load(args.pattern, side, side, std::nullopt, cloth_shape(args),
                                  args.cloth_size);
    if (!cloth) return report_error("knit", cloth.error());
    if (auto given = give_weave(*canvas->renderer, *cloth); !given)
      return report_error("knit", given.error());
    cloth::YarnSet yarns;
    std::vector<double> update_ms, upload_ms, frame_ms, cpu_ms, render_cpu_ms;
    for (int frame = -2; frame < args.frames; ++frame) {  // two untimed warm-up frames
      const float phase = 0.2f * static_cast<float>(frame);
      const double cpu_start = process_cpu_ms();
      const auto start = Clock::now();
      cloth->update({1.15f + 0.1f * std::sin(phase), 0.1f * std::cos(phase)}, yarns);
      const auto updated = Clock::now();
      canvas->renderer->update(yarns);
      const auto uploaded = Clock::now();
      const double cpu_uploaded = process_cpu_ms();
      canvas->target->bind();
      canvas->renderer->render(knit_view(args), *size);
      glFinish();  // the frame is done, as before a page flip
      const auto drawn = Clock::now();
      if (frame < 0) continue;
      const double cpu_drawn = process_cpu_ms();
      cpu_ms.push_back(cpu_drawn - cpu_start);
      render_cpu_ms.push_back(cpu_drawn - cpu_uploaded);
      update_ms.push_back(milliseconds(updated - start));
      upload_ms.push_back(milliseconds(uploaded - updated));
      frame_ms.push_back(milliseconds(drawn - start));
    }
    const auto mean = [](const std::vector<double>& values) {
      double sum = 0;
      for (const double value : values) sum += value;
      return sum / static_cast<double>(values.size());
    };
    std::cout << (first ? "" : ", ") << "{\"stitches\": " << side * side
              << ", \"yarn_points\": " << yarns.point_count()
              << ", \"strip_vertices\": " << canvas->renderer->last_strip_vertices()
              << ", \"far_cloth\": "
              << (!canvas->renderer->last_drew_far_cloth() ? "null"
                  : canvas->renderer->neural_far()         ? "\"neural\""
                                                           : "\"baked\"")
              << ", \"yarn_update_ms\": " << mean(update_ms)
              << ", \"yarn_upload_ms\": " << mean(upload_ms) << ", \"frame_ms\": " << mean(frame_ms)
              << ", \"frame_ms_median\": " << median(frame_ms)
              << ", \"frame_cpu_ms\": " << mean(cpu_ms)
              << ", \"render_cpu_ms\": " << mean(render_cpu_ms)
              << ", \"fps\": " << 1000.0 / mean(frame_ms) << "}";
    first = false;
  }
  std::cout << "]}\n";
  return 0;
}

}  // namespace

Command add_knit_command(CLI::App& parent) {
  auto args = std::make_shared<KnitArgs>();
  CLI::App* app = parent.add_subcommand(
      "knit", "Draw knitted (.chart) or woven (.weave) cloth at yarn level to a PNG, or time it");
  app->add_option("pattern", args->pattern,
                  "Stitch chart (.chart) or weave matrix (.weave); with --from-scan, the chart "
                  "read off the scan when left out");
  auto* out = app->add_option("--out", args->out, "PNG file to write");
  app->add_option("--size", args->size, "Frame size WxH (default 1280x960; --bench: 1920x1080)");
  app->add_option("--stitches", args->stitches, "Stitches per course (woven: warp threads)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app->add_option("--rows", args->rows, "Courses (woven: weft threads)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  // The range in which yarns still find room without passing through each other.
  app->add_option("--stretch", args->stretch, "Width factor along the courses (1.2: 20 % wider)")
      ->check(CLI::Range(0.5, 2.0))
      ->capture_default_str();
  auto* shear = app->add_option("--shear", args->shear,
                                "Sideways lean of the wales, mm per mm (--from-scan: the scan's)")
      ->check(CLI::Range(-kMaxShear, kMaxShear))
      ->capture_default_str();
  const auto size_option = [&](const char* name, float& value, const char* what) {
    app->add_option(name, value, what)->check(psrig::cli::positive_number());
  };
  size_option("--wales-per-cm", args->cloth_size.wales_per_cm,
              "Knit gauge across (over the chart's wales_per_cm)");
  size_option("--courses-per-cm", args->cloth_size.courses_per_cm,
              "Knit gauge up (over the chart's courses_per_cm)");
  size_option("--ends-per-cm", args->cloth_size.ends_per_cm, "Woven warp density (over the weave's)");
  size_option("--picks-per-cm", args->cloth_size.picks_per_cm, "Woven weft density (over the weave's)");
  size_option("--yarn-mm", args->cloth_size.yarn_mm, "Yarn diameter in mm (over the pattern's)");
  auto* colour = app->add_option("--yarn-color", args->yarn_colour, "Yarn colour #RRGGBB (sRGB)");
  app->add_option("--from-scan", args->from_scan,
                  "A scan's maps directory: its gauge and skew, each stitch's colour, and its "
                  "stitch chart when no pattern is given (read off the maps)")
      ->excludes(colour);
  app->add_option("--environment", args->environment,
                  "Light from all around: studio, none, or an equirectangular map (EXR, PNG)")
      ->capture_default_str();
  app->add_option("--yaw", args->yaw, "Camera yaw in degrees (180: the back)")
      ->capture_default_str();
  app->add_option("--pitch", args->pitch, "Camera pitch in degrees")->capture_default_str();
  app->add_option("--distance", args->distance, "Camera distance in mm (0: fit the cloth)")
      ->check(psrig::cli::non_negative_number())
      ->capture_default_str();
  app->add_option("--light-tilt", args->light_tilt, "Light tilt in degrees from +x toward +y")
      ->capture_default_str();
  app->add_option("--light-slant", args->light_slant, "Light slant in degrees from the normal")
      ->check(CLI::Range(0.0, 90.0))
      ->capture_default_str();
  add_lod_option(*app, args->lod);
  app->add_option("--woven-far", args->woven_far,
                  "A weave's far level: baked (one repeat drawn at the near level, as for knits) "
                  "or neural (each pixel the neural woven BSDF, chen2024; seconds a frame on "
                  "llvmpipe)")
      ->check(CLI::IsMember({"neural", "baked"}))
      ->capture_default_str();
  app->add_option("--woven-decode-scale", args->woven_decode_scale,
                  "The neural far level decodes at 1/SCALE of the frame's resolution (cheaper)")
      ->check(CLI::Range(1.0, 8.0))
      ->capture_default_str();
  add_samples_option(*app, args->samples);
  app->add_flag("--no-shadows", args->no_shadows,
                "No yarn-on-yarn shadows (no shadow map: cheaper on a weak GPU)");
  app->add_flag("--plain-fibres", args->plain_fibres,
                "No ply grooves or fibre striation (cheaper on a weak GPU)");
  app->add_flag("--draped", args->draped,
                "Lay the cloth over the swatch preview's draped Bezier patch instead of flat");
  auto* timed = app->add_flag(
      "--bench", args->bench,
      "Time the yarn update and the frames at 1 K, 10 K and 50 K stitches; prints JSON");
  app->add_option("--frames", args->frames, "Frames timed per size (--bench)")
      ->check(psrig::cli::positive_number())
      ->capture_default_str();
  app->add_option("--bench-stitches", args->bench_stitches,
                  "Stitch counts timed (--bench; default 1000 10000 50000)")
      ->check(CLI::Range(1, 1000000))
      ->expected(1, -1);
  out->excludes(timed);
  return {app, [args, out, shear] {
            if (args->pattern.empty() && (args->bench || args->from_scan.empty())) {
              std::cerr << "psrig-preview knit: error: give a stitch chart or weave matrix (or "
                           "--from-scan MAPS_DIR to draw the chart read off a scan)\n";
              return 2;
            }
            if (args->bench) return bench(*args);
            if (out->count() == 0) {
              std::cerr << "psrig-preview knit: error: --out FILE.png is required (or --bench)\n";
              return 2;
            }
            return render(*args, shear->count() > 0);
          }};
}

}  // namespace psrig::preview::cli
