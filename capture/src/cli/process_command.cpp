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
      ->check(psrig::cli::thread_count())
      ->capture_default_str();
  app->add_flag("--reject", args->reject,
                "With four or more lights, drop each pixel's shadowed, saturated and "
                "highlighted measurements (robust fit; report.json names the method)");
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");

  return {app, [args] {
            processing::set_thread_count(args->threads);
            processing::ProcessOptions options;
            options.output = args->out;
            options.integration = *processing::parse_integration_method(args->integrate);
            options.solve.reject_outliers = args->reject;
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

}  // namespace psrig::capture::cli
