// psrig: the rig's command line. Errors become a message and an exit code
// here: 0 done, 2 bad input or usage, 1 anything else.

#include <cstdio>
#include <exception>
#include <iostream>
#include <vector>

#include "command.h"
#include "psrig/processing/log.h"

namespace psrig::capture::cli {

int report_error(const std::string& command, const processing::Error& error) {
  std::cerr << "psrig " << command << ": error: " << error.describe() << '\n';
  return processing::exit_code(error);
}

}  // namespace psrig::capture::cli

int main(int argc, char** argv) {
  using namespace psrig::capture::cli;
  CLI::App app{"psrig: photometric-stereo capture rig for textile swatches"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Log what each stage does");

  const std::vector<Command> commands = {add_process_command(app), add_synth_command(app)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? 0 : 2;
  }
  psrig::processing::set_log_level(verbose ? spdlog::level::debug : spdlog::level::warn);
  try {
    for (const auto& command : commands)
      if (command.app->parsed()) return command.run();
  } catch (const std::exception& e) {
    std::cerr << "psrig: internal error: " << e.what() << '\n';
    return 1;
  }
  return 2;
}
