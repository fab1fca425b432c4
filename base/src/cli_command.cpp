#include "psrig/base/cli_command.h"

#include <exception>
#include <iostream>
#include <string>
#include <utility>

#include "psrig/base/log.h"

namespace psrig::cli {

int report_error(std::string_view program, std::string_view command, const Error& error) {
  std::cerr << program << ' ' << command << ": error: " << error.describe() << '\n';
  return exit_code(error);
}

namespace {

// A validator accepting what parses as T and is at least `minimum` (above
// it when `strictly`); its message says `expected`.
template <class T>
CLI::Validator at_least(T minimum, bool strictly, std::string expected, std::string description) {
  return CLI::Validator(
      [=](std::string& input) -> std::string {
        T value{};
        if (CLI::detail::lexical_cast(input, value) &&
            (strictly ? value > minimum : value >= minimum))
          return {};
        return "expected " + expected + "; got '" + input + "'";
      },
      std::move(description));
}

}  // namespace

CLI::Validator non_negative_number() {
  return at_least(0.0, false, "a number, 0 or more", "NONNEGATIVE");
}

CLI::Validator positive_number() {
  return at_least(0.0, true, "a number above 0", "POSITIVE");
}

CLI::Validator thread_count() {
  return at_least(0L, false, "a whole number of threads, 0 (one per core) or more", "NONNEGATIVE");
}

SubcommandProgram::SubcommandProgram(std::string name, std::string_view version,
                                     std::string description, spdlog::level::level_enum quiet_level)
    : name_(std::move(name)), quiet_level_(quiet_level), app_(std::move(description)) {
  app_.require_subcommand(1);
  app_.set_version_flag("--version", name_ + ' ' + std::string(version),
                        "Print the program's version and exit");
  app_.add_flag("-v,--verbose", verbose_, "Log what each stage does");
}

int SubcommandProgram::run(int argc, char** argv, const std::vector<Command>& commands) {
  try {
    app_.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app_.exit(e);  // prints help, the version or the usage error
    return code == 0 ? exit_done : exit_bad_input;
  }
  set_log_level(verbose_ ? spdlog::level::debug : quiet_level_);
  try {
    for (const auto& command : commands)
      if (command.app->parsed()) return command.run();
  } catch (const std::exception& e) {
    std::cerr << name_ << ": internal error: " << e.what() << '\n';
    return exit_failed;
  }
  return exit_bad_input;
}

}  // namespace psrig::cli
