#pragma once
// One `psrig` subcommand: its CLI11 definition and what runs when chosen.

#include <filesystem>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "psrig/base/cli_command.h"
#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"
#include "psrig/processing/pipeline.h"

namespace psrig::cli {

using psrig::cli::Command;

Command add_process_command(CLI::App& parent);
Command add_integrate_command(CLI::App& parent);
Command add_synth_command(CLI::App& parent);
Command add_scan_command(CLI::App& parent);
Command add_lights_command(CLI::App& parent);
Command add_config_command(CLI::App& parent);
Command add_devices_command(CLI::App& parent);
Command add_status_command(CLI::App& parent);
Command add_calibrate_command(CLI::App& parent);
Command add_import_command(CLI::App& parent);
Command add_export_command(CLI::App& parent);
Command add_measure_command(CLI::App& parent);
Command add_tile_command(CLI::App& parent);

// A command that drives lights polls lights::stop_requested() and
// winds down by itself on SIGINT/SIGTERM (after the lights are already off);
// every other command ends at once.
void stop_gracefully_on_signals();
// What main's signal watcher asks: end at once, or leave it to the command?
bool signals_end_at_once();

// The maps summary `process` and `scan` print.
void print_maps_summary(const processing::ProcessSummary& summary);

// What `psrig scan` prints once a scan is done, on the rig here or on psrigd
// (`--remote`): the scan directory, its frames and capture time, then the
// maps summary.
struct ScanSummary {
  std::filesystem::path directory;
  // Unknown (a scan.json from an older writer): left out of the summary.
  std::optional<int> frames_kept;
  std::optional<int> frames_skipped;  // stale or discarded
  std::optional<double> capture_ms;   // camera start to the last frame
  std::optional<processing::ProcessSummary> maps;
};

// The frames and capture time from scan.json's `capture` facts (also the
// report's `inputs.capture`), as the sequencer wrote them.
void add_capture_facts(ScanSummary& summary, const nlohmann::json& capture);

void print_scan_summary(const ScanSummary& summary);

// Loads --config, printing its warnings; errors as report_error would.
std::optional<config::RigConfig> load_config_or_report(const std::string& command,
                                                       const std::string& file, int& exit_code);

// Prints "psrig COMMAND: error: ..." to stderr and returns the exit code.
inline int report_error(const std::string& command, const Error& error) {
  return psrig::cli::report_error("psrig", command, error);
}

}  // namespace psrig::cli
