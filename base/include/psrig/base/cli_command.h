#pragma once
// What the command-line programs (psrig, psrig-preview) share: a subcommand
// as CLI11 defines it, the exit codes, an Error turned into a message and an
// exit code, and main()'s parse and dispatch. Target psrig_cli, apart from
// psrig_base, so that only programs bring CLI11 along.

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/common.h>

#include "psrig/base/error.h"

namespace psrig::cli {

// exit_code(Error) picks between failed and bad input; 130 is what shells
// report for SIGINT (128 + 2).
inline constexpr int exit_done = 0;
inline constexpr int exit_failed = 1;
inline constexpr int exit_bad_input = 2;
inline constexpr int exit_interrupted = 130;

struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;  // returns the exit code
};

// Prints "PROGRAM COMMAND: error: ..." to stderr and returns the exit code.
int report_error(std::string_view program, std::string_view command, const Error& error);

// Option checks whose messages say the range in a few words (CLI11's
// NonNegativeNumber and PositiveNumber print the largest double there is).
[[nodiscard]] CLI::Validator non_negative_number();
[[nodiscard]] CLI::Validator positive_number();
// --threads: a whole number, 0 (one per core) or more.
[[nodiscard]] CLI::Validator thread_count();

// A program of subcommands, exactly one of which runs. The common flags go
// before or after the subcommand, as a user types them: -v/--verbose logs at
// debug level, else at quiet_level; -q/--quiet is the subcommand's own where
// it has one (print nothing on success), else logs warnings and errors only;
// --version prints "NAME VERSION" and exits 0.
class SubcommandProgram {
 public:
  SubcommandProgram(std::string name, std::string_view version, std::string description,
                    spdlog::level::level_enum quiet_level);

  // Where the subcommands are added.
  [[nodiscard]] CLI::App& app() { return app_; }

  // Help and --version are exit 0 and a usage error 2 (CLI11 prints both); an exception
  // that escapes a command is "PROGRAM: internal error: ..." and exit 1.
  int run(int argc, char** argv, const std::vector<Command>& commands);

 private:
  std::string name_;
  spdlog::level::level_enum quiet_level_;
  CLI::App app_;
  bool verbose_ = false;
  bool quiet_ = false;
};

}  // namespace psrig::cli
