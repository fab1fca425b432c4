// psrig process SCAN_DIR: a scan directory to a maps directory.

#include <cstdio>
#include <iostream>
#include <memory>

#include "command.h"
#include "psrig/processing/parallel.h"
#include "psrig/processing/pipeline.h"

namespace psrig::capture::cli {
namespace {

struct ProcessArgs {
  std::string scan;
  std::string out;
  std::string integrate = "fc";
  int threads = 0;
  bool reject = false;
  bool quiet = false;
};

void print_summary(const processing::ProcessSummary& summary) {
  const auto& r = summary.report;
  const auto& px = r["pixels"];
  const double total = px["total"].get<double>();
  const auto percent = [&](const char* key) { return 100.0 * px[key].get<double>() / total; };
  std::printf("maps: %s\n", summary.maps_directory.string().c_str());
  std::printf("valid pixels: %.1f %% (shadowed %.1f %%, saturated %.1f %%, low signal %.1f %%)\n",
              percent("valid"), percent("shadowed"), percent("saturated"), percent("low_signal"));
  std::printf("residual: mean %.5f of full scale\n", r["residual"]["mean"].get<double>());
  if (r.contains("height"))
    std::printf("height: range %.4f %s (%s)\n", r["height"]["range"].get<double>(),
                r["height"]["units"].get<std::string>().c_str(),
                r["options"]["integration"].get<std::string>().c_str());
  if (r.contains("ground_truth") && r["ground_truth"].contains("angular_error_deg")) {
    const auto& e = r["ground_truth"]["angular_error_deg"];
    std::printf(
        "ground truth: mean angular error %.3f deg (median %.3f, p95 %.3f) over valid pixels\n",
        e["mean"].get<double>(), e["median"].get<double>(), e["p95"].get<double>());
  }
  std::printf("time: %.0f ms\n", r["timings_ms"]["total"].get<double>());
}

}  // namespace

Command add_process_command(CLI::App& parent) {
  auto args = std::make_shared<ProcessArgs>();
  CLI::App* app =
      parent.add_subcommand("process", "Process a scan directory into a maps directory");
  app->add_option("scan", args->scan, "Scan directory (psrig-scan/1)")->required();
  app->add_option("--out", args->out, "Maps directory to write (default: SCAN_DIR/maps)");
  app->add_option("--integrate", args->integrate,
                  "Height integration: fc (Frankot-Chellappa), poisson or none")
      ->check(CLI::IsMember({"fc", "poisson", "none"}))
      ->capture_default_str();
  app->add_option("--threads", args->threads, "Worker threads (0: one per core)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app->add_flag("--reject", args->reject,
                "With four or more lights, drop shadowed and saturated measurements per pixel");
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");

  return {app, [args] {
            processing::set_thread_count(args->threads);
            processing::ProcessOptions options;
            options.output = args->out;
            options.integration = *processing::parse_integration_method(args->integrate);
            options.solve.reject_outliers = args->reject;
            auto summary = processing::process_scan(args->scan, options);
            if (!summary) return report_error("process", summary.error());
            if (!args->quiet) print_summary(*summary);
            return 0;
          }};
}

}  // namespace psrig::capture::cli
