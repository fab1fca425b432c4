// What several `psrig` commands share.

#include <atomic>
#include <cstdio>
#include <iostream>

#include "command.h"
#include "psrig/base/log.h"
#include "psrig/config/config_loader.h"

namespace psrig::cli {

namespace {
std::atomic<bool> graceful{false};
}

void stop_gracefully_on_signals() {
  graceful = true;
}

bool signals_end_at_once() {
  return !graceful;
}

void print_maps_summary(const processing::ProcessSummary& summary) {
  const auto& r = summary.report;
  const auto& px = r["pixels"];
  const double total = px["total"].get<double>();
  const auto percent = [&](const char* key) { return 100.0 * px[key].get<double>() / total; };
  std::printf("maps: %s\n", summary.maps_directory.string().c_str());
  // Pixels the scan's mask leaves out count against the valid ones: name
  // them when there are any, so that the parts account for the whole.
  char outside[48] = "";
  if (px["outside_mask"].get<double>() > 0)
    std::snprintf(outside, sizeof outside, "outside mask %.1f %%, ", percent("outside_mask"));
  std::printf("valid pixels: %.1f %% (%sshadowed %.1f %%, saturated %.1f %%, low signal %.1f %%)\n",
              percent("valid"), outside, percent("shadowed"), percent("saturated"),
              percent("low_signal"));
  std::printf("residual: mean %.5f of full scale\n", r["residual"]["mean"].get<double>());
  if (r.contains("height")) {
    const auto& h = r["height"];
    const std::string method = h.contains("method")
                                   ? h["method"].get<std::string>()
                                   : r["options"]["integration"].get<std::string>();
    std::printf("height: range %.4f %s (%s)\n", h["range"].get<double>(),
                h["units"].get<std::string>().c_str(), method.c_str());
  }
  if (r.contains("bend") && r["bend"].value("removed", false))
    std::printf("bend removed: %.4f %s peak to valley (cut-off %g %s)\n",
                r["bend"]["peak_to_valley"].get<double>(),
                r["bend"]["units"].get<std::string>().c_str(), r["bend"]["cutoff"].get<double>(),
                r["bend"]["cutoff_units"].get<std::string>().c_str());
  if (r.contains("ground_truth") && r["ground_truth"].contains("angular_error_deg")) {
    const auto& e = r["ground_truth"]["angular_error_deg"];
    std::printf(
        "ground truth: mean angular error %.3f deg (median %.3f, p95 %.3f) over valid pixels\n",
        e["mean"].get<double>(), e["median"].get<double>(), e["p95"].get<double>());
  }
  if (r.contains("fabric") && r["fabric"].contains("summary"))
    std::printf("fabric: %s\n", r["fabric"]["summary"].get<std::string>().c_str());
  std::printf("time: %.0f ms\n", r["timings_ms"]["total"].get<double>());
}

void add_capture_facts(ScanSummary& summary, const nlohmann::json& capture) {
  if (!capture.is_object()) return;
  const auto integer = [&](const char* key) -> std::optional<int> {
    if (!capture.contains(key) || !capture[key].is_number_integer()) return std::nullopt;
    return capture[key].get<int>();
  };
  summary.frames_kept = integer("frames_kept");
  summary.frames_skipped = integer("frames_skipped");
  if (capture.contains("capture_ms") && capture["capture_ms"].is_number())
    summary.capture_ms = capture["capture_ms"].get<double>();
}

void print_scan_summary(const ScanSummary& summary) {
  if (summary.frames_kept && summary.frames_skipped && summary.capture_ms)
    std::printf("scan: %s (%d frames kept, %d skipped, %.0f ms capturing)\n",
                summary.directory.string().c_str(), *summary.frames_kept, *summary.frames_skipped,
                *summary.capture_ms);
  else
    std::printf("scan: %s\n", summary.directory.string().c_str());
  if (summary.maps) print_maps_summary(*summary.maps);
}

std::optional<config::RigConfig> load_config_or_report(const std::string& command,
                                                       const std::string& file, int& exit_code) {
  std::vector<std::string> warnings;
  auto loaded = config::load_config(file, &warnings);
  for (const auto& warning : warnings)
    std::cerr << "psrig " << command << ": warning: " << warning << '\n';
  if (!loaded) {
    exit_code = report_error(command, loaded.error());
    return std::nullopt;
  }
  return std::move(*loaded);
}

}  // namespace psrig::cli
