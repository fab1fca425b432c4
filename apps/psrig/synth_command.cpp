// psrig synth --out DIR: a synthetic scan of a procedural swatch, with its
// ground truth, for demos and tests before (or without) a rig.

#include <cstdio>
#include <filesystem>
#include <memory>

#include "command.h"
#include "psrig/base/width_height.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/sim/synthetic_scan.h"

namespace psrig::cli {
namespace {

struct SynthArgs {
  std::string out;
  std::string pattern = "jersey";
  std::string size = "640x480";
  double slant = 45;
  double noise = 0;
  std::uint64_t seed = 1;
  double pixel_size = 0.025;
  int bits = 16;
  double rotate = 0;
  bool no_fabric_metadata = false;
  bool quiet = false;
};

}  // namespace

Command add_synth_command(CLI::App& parent) {
  auto args = std::make_shared<SynthArgs>();
  CLI::App* app =
      parent.add_subcommand("synth", "Render a synthetic swatch scan with ground truth");
  app->add_option("--out", args->out,
                  "Scan directory to create (must not exist; missing parents are made)")
      ->required();
  app->add_option("--pattern", args->pattern,
                  "Swatch: a stitch chart (.chart) or weave (.weave) file, or a shipped "
                  "pattern: stockinette, garter, rib-1x1, rib-2x2, seed, basketweave, stripes "
                  "(knitted), plain, twill-2x2, satin-5 (woven); jersey, rib and twill are "
                  "stockinette, rib-1x1 and twill-2x2")
      ->capture_default_str();
  app->add_option("--size", args->size, "Image size WxH in pixels")->capture_default_str();
  app->add_option("--slant", args->slant, "Light slant from the camera axis, degrees")
      ->check(CLI::Range(1.0, 89.0))
      ->capture_default_str();
  app->add_option("--noise", args->noise,
                  "Gaussian noise, standard deviation as a fraction of full scale")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  app->add_option("--seed", args->seed, "Random seed: same seed, same swatch")
      ->capture_default_str();
  app->add_option("--pixel-size", args->pixel_size, "Millimetres per pixel on the swatch")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  app->add_option("--bits", args->bits, "Bit depth of the frames")
      ->check(CLI::IsMember({8, 16}))
      ->capture_default_str();
  app->add_option("--rotate", args->rotate,
                  "Turn the fabric counterclockwise by this many degrees (its gauge truth says so)")
      ->check(CLI::Range(-45.0, 45.0))
      ->capture_default_str();
  app->add_flag("--no-fabric-metadata", args->no_fabric_metadata,
                "Leave scan.json's fabric (construction, structure) out");
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");

  return {app, [args] {
            const auto size = parse_width_height(args->size);
            constexpr int kMaxSide = 16384;  // 268 MP: beyond any camera the rig takes
            if (!size || size->width < 8 || size->height < 8 || size->width > kMaxSide ||
                size->height > kMaxSide)
              return report_error(
                  "synth", bad_input({}, "--size",
                                     "expected WxH from 8x8 to 16384x16384, e.g. 640x480; got '" +
                                         args->size + "'"));
            auto pattern = sim::load_swatch_pattern(args->pattern, {}, {}, "--pattern");
            if (!pattern) return report_error("synth", pattern.error());
            sim::SyntheticScanParams params;
            params.swatch.pattern = std::move(*pattern);
            params.swatch.size = {size->width, size->height};
            params.swatch.pixel_size_mm = args->pixel_size;
            params.swatch.seed = args->seed;
            params.swatch.rotation_deg = args->rotate;
            params.fabric_metadata = !args->no_fabric_metadata;
            params.slant_deg = args->slant;
            params.noise = args->noise;
            params.depth = args->bits == 8 ? CV_8U : CV_16U;
            const auto scan = sim::make_synthetic_scan(params);
            if (!scan) return report_error("synth", scan.error());
            // As `psrig scan --out`: missing parents are made (write_scan
            // still refuses an existing scan directory).
            std::error_code ec;
            std::filesystem::create_directories(std::filesystem::path(args->out).parent_path(), ec);
            if (auto ok = formats::write_scan(*scan, args->out); !ok)
              return report_error("synth", ok.error());
            if (!args->quiet)
              std::printf("scan: %s (%s, %dx%d, %.3f mm/px, slant %.0f deg, noise %g)\n",
                          args->out.c_str(), params.swatch.pattern.name.c_str(),
                          params.swatch.size.width, params.swatch.size.height, args->pixel_size,
                          args->slant, args->noise);
            return 0;
          }};
}

}  // namespace psrig::cli
