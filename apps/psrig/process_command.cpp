// psrig process SCAN_DIR: a scan directory to a maps directory.

#include <cstdio>
#include <iostream>
#include <memory>

#include "command.h"
#include "psrig/base/parallel.h"
#include "psrig/processing/pipeline.h"

namespace psrig::cli {
namespace {

struct ProcessArgs {
  std::string scan;
  std::string out;
  std::string integrate = "auto";
  std::string flatten = "auto";
  double flatten_cutoff = processing::kDefaultFlattenCutoffMm;
  int threads = 0;
  bool reject = false;
  std::string normal_convention = "opengl";
  std::string exr_compression = formats::to_string(formats::StorageOptions{}.exr_compression);
  int png_level = formats::StorageOptions{}.png_level;
  std::string map_precision = formats::to_string(formats::StorageOptions{}.map_precision);
  bool quiet = false;
};

}  // namespace

Command add_process_command(CLI::App& parent) {
  auto args = std::make_shared<ProcessArgs>();
  CLI::App* app =
      parent.add_subcommand("process", "Process a scan directory into a maps directory");
  app->add_option("scan", args->scan, "Scan directory (psrig-scan/1)")->required();
  app->add_option("--out", args->out, "Maps directory to write (default: SCAN_DIR/maps)");
  app->add_option("--integrate", args->integrate,
                  "Height integration: auto (masked where pixels are unsolved, else fc), fc "
                  "(Frankot-Chellappa), poisson, masked (least squares over the solved pixels) "
                  "or none")
      ->check(CLI::IsMember({"auto", "fc", "poisson", "masked", "none"}))
      ->capture_default_str();
  app->add_option("--flatten", args->flatten,
                  "Remove the low-frequency bend from the height: auto (for scans with "
                  "pixel_size_mm, i.e. swatches), on or off")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  app->add_option("--flatten-cutoff", args->flatten_cutoff,
                  "The bend's cut-off wavelength in mm (pixels for a scan without "
                  "pixel_size_mm)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app->add_option("--threads", args->threads, "Worker threads (0: one per core)")
      ->check(psrig::cli::thread_count())
      ->capture_default_str();
  app->add_flag("--reject", args->reject,
                "With four or more lights, drop each pixel's shadowed, saturated and "
                "highlighted measurements (robust fit; report.json names the method)");
  app->add_option("--normal-convention", args->normal_convention,
                  "opengl (normal.png, +Y up, as glTF and U3M), or directx to add "
                  "normal_directx.png (+Y down) for Substance and Unreal")
      ->check(CLI::IsMember({"opengl", "directx"}))
      ->capture_default_str();
  app->add_option("--exr-compression", args->exr_compression,
                  "Lossless compression of the EXR maps: auto (PIZ for the half-float albedo, "
                  "none for the float maps, whose noise does not compress), zip, piz or none "
                  "([storage] exr_compression in rig.toml for psrig scan and psrigd)")
      ->check(CLI::IsMember({"auto", "zip", "piz", "none"}))
      ->capture_default_str();
  app->add_option("--png-level", args->png_level,
                  "Deflate level of the PNG maps: 0 (stored) to 9 ([storage] png_level)")
      ->check(CLI::Range(0, 9))
      ->capture_default_str();
  app->add_option(
         "--map-precision", args->map_precision,
         "p.exr, q.exr and height.exr as half floats (1 part in 2048: at most 0.028° "
         "of angle, far below the solve's noise) or 32-bit float ([storage] map_precision)")
      ->check(CLI::IsMember({"half", "float"}))
      ->capture_default_str();
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");

  return {app, [args] {
            psrig::set_thread_count(args->threads);
            processing::ProcessOptions options;
            options.output = args->out;
            options.integration = *processing::parse_integration_method(args->integrate);
            options.flatten = *processing::parse_flatten(args->flatten);
            options.flatten_cutoff_mm = args->flatten_cutoff;
            options.solve.reject_outliers = args->reject;
            options.directx_normal = args->normal_convention == "directx";
            options.storage.exr_compression =
                *formats::parse_exr_compression(args->exr_compression);
            options.storage.png_level = args->png_level;
            options.storage.map_precision = *formats::parse_map_precision(args->map_precision);
            auto summary = processing::process_scan(args->scan, options);
            if (!summary) return report_error("process", summary.error());
            // The solve drops a pixel's outliers only where enough lights remain.
            if (const auto lights = summary->report["inputs"]["lights"].get<std::size_t>();
                args->reject && lights < 4)
              std::cerr << "psrig process: warning: --reject needs four or more lights; this scan "
                           "has "
                        << lights << ", so it rejects nothing\n";
            if (!args->quiet) print_maps_summary(*summary);
            return 0;
          }};
}

}  // namespace psrig::cli
