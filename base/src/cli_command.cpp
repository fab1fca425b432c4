#include "psrig/base/cli_command.h"

#include <exception>
#include <iostream>
#include <utility>

#include "psrig/base/log.h"

namespace psrig::cli {

int report_error(std::string_view program, std::string_view command, const Error& error) {
  std::cerr << program << ' ' << command << ": error: " << error.describe() << '\n';
  return exit_code(error);
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
