#pragma once
// One `psrig` subcommand: its CLI11 definition and what runs when chosen.

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

#include "psrig/processing/error.h"

namespace psrig::capture::cli {

struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;  // returns the exit code
};

Command add_process_command(CLI::App& parent);
Command add_synth_command(CLI::App& parent);

// Prints "psrig COMMAND: error: ..." to stderr and returns the exit code.
int report_error(const std::string& command, const processing::Error& error);

}  // namespace psrig::capture::cli
