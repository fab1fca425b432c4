// psrig scan --config FILE: one scan on the rig the file describes, written
// to a scan directory and (unless --no-process) processed into maps; or,
// with --remote URL, one scan queued on a running psrigd and followed.

#include <chrono>
#include <cstdio>
#include <memory>

#include "command.h"
#include "psrig/base/parallel.h"
#include "psrig/calibration/calibration_status.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"
#include "remote_scan.h"

namespace psrig::cli {
namespace {

struct ScanArgs {
  std::string config;
  std::string out;
  std::string sample_id;
  std::string description;
  bool no_process = false;
  bool quiet = false;
  int threads = 0;
  std::string remote;
  std::string token;
  std::vector<std::string> tags;
};

}  // namespace

Command add_scan_command(CLI::App& parent) {
  auto args = std::make_shared<ScanArgs>();
  CLI::App* app = parent.add_subcommand("scan", "Scan a swatch: one frame per LED, then the maps");
  auto* config_option =
      app->add_option("--config", args->config, "Rig configuration (e.g. config/sim.toml)");
  auto* out_option = app->add_option(
      "--out", args->out, "Scan directory to create (default: storage.root/<time>-<sample id>)");
  app->add_option("--sample-id", args->sample_id, "The swatch's label, e.g. J-0042");
  app->add_option("--description", args->description, "Free text about the swatch");
  auto* no_process = app->add_flag("--no-process", args->no_process,
                                   "Capture only; process later with `psrig process`");
  auto* threads =
      app->add_option("--threads", args->threads, "Worker threads for processing (0: one per core)")
          ->check(psrig::cli::thread_count());
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");
  auto* remote = app->add_option("--remote", args->remote,
                                 "Scan on the psrigd at this URL (e.g. http://127.0.0.1:8470) "
                                 "instead of driving the rig from here");
  remote->excludes(config_option)->excludes(out_option)->excludes(no_process)->excludes(threads);
  app->add_option("--tag", args->tags, "A tag for the catalogue (with --remote; repeatable)")
      ->needs(remote);
  app->add_option("--token", args->token, "psrigd's bearer token (default: $PSRIG_TOKEN)")
      ->needs(remote);

  return {app, [args] {
            stop_gracefully_on_signals();
            if (!args->remote.empty())
              return run_remote_scan({args->remote, args->token, args->sample_id, args->description,
                                      args->tags, args->quiet});
            if (args->config.empty()) {
              std::fprintf(stderr,
                           "psrig scan: error: give --config FILE (scan with the rig here) or "
                           "--remote URL (scan on a running psrigd)\n");
              return 2;
            }
            psrig::set_thread_count(args->threads);
            int exit_code = 0;
            auto config = load_config_or_report("scan", args->config, exit_code);
            if (!config) return exit_code;
            // A missing or stale calibration does not stop a scan; it is said
            // (unless -q: nothing on success).
            const auto calibration =
                calibration::calibration_status(calibration::CalibrationStore(config->storage.root),
                                                config->calibration.max_age_days);
            if (const auto warning = calibration::staleness_warning(calibration);
                !warning.empty() && !args->quiet)
              std::fprintf(stderr, "psrig scan: warning: %s\n", warning.c_str());
            auto rig = rig::open_rig(*config);
            if (!rig) return report_error("scan", rig.error());
            rig::ScanSequencer sequencer(*config, *rig->lights, *rig->camera);
            rig::ScanRequest request = rig->request(*config);
            request.sample_id = args->sample_id;
            request.description = args->description;
            request.directory = args->out;
            if (args->no_process) request.process = false;
            auto outcome = sequencer.capture(request, [&](const rig::ScanProgress& p) {
              if (!args->quiet) std::fprintf(stderr, "psrig scan: %s\n", p.step.c_str());
            });
            if (!outcome) {
              const int code = report_error("scan", outcome.error());
              return lights::stop_requested() ? psrig::cli::exit_interrupted : code;
            }
            if (!args->quiet)
              print_scan_summary({outcome->directory, outcome->timing.frames_kept,
                                  outcome->timing.frames_skipped, outcome->timing.total.count(),
                                  outcome->maps});
            return 0;
          }};
}

}  // namespace psrig::cli
