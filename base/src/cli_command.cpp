#include "psrig/base/cli_command.h"

#include <algorithm>
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
  // Subcommands (added later, inheriting this) hand the options they do not
  // know to the program: `psrig process -v SCAN` as well as `psrig -v process`.
  app_.fallthrough();
  app_.set_version_flag("--version", name_ + ' ' + std::string(version),
                        "Print the program's version and exit");
  app_.add_flag("-v,--verbose", verbose_, "Log what each stage does");
  app_.add_flag("-q,--quiet", quiet_, "Print nothing on success (warnings still go to stderr)");
}

namespace {

bool is_quiet_flag(std::string_view arg) {
  return arg == "-q" || arg == "--quiet";
}

// -q before the subcommand moves after it, so that a subcommand with a -q of
// its own (print nothing on success) gets it; one without hands it back.
std::vector<std::string> quiet_after_subcommand(int argc, char** argv, const CLI::App& app) {
  std::vector<std::string> args(argv + 1, argv + argc);
  // The program's own options take no values: the first word is the subcommand.
  const auto named = std::find_if(args.begin(), args.end(),
                                  [](const std::string& arg) { return !arg.starts_with('-'); });
  if (named == args.end() ||
      app.get_subcommands([&](const CLI::App* sub) { return sub->check_name(*named); }).empty())
    return args;
  std::vector<std::string> before, after;
  for (auto it = args.begin(); it != named; ++it)
    (is_quiet_flag(*it) ? after : before).push_back(*it);
  before.push_back(*named);
  before.insert(before.end(), after.begin(), after.end());
  before.insert(before.end(), named + 1, args.end());
  return before;
}

}  // namespace

int SubcommandProgram::run(int argc, char** argv, const std::vector<Command>& commands) {
  try {
    std::vector<std::string> args = quiet_after_subcommand(argc, argv, app_);
    std::reverse(args.begin(), args.end());  // CLI11 takes them last first
    app_.parse(args);
  } catch (const CLI::ParseError& e) {
    const int code = app_.exit(e);  // prints help, the version or the usage error
    return code == 0 ? exit_done : exit_bad_input;
  }
  set_log_level(verbose_ ? spdlog::level::debug
                : quiet_ ? std::max(quiet_level_, spdlog::level::warn)
                         : quiet_level_);
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
