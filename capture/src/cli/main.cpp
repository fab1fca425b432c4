// psrig: the rig's command line. Errors become a message and an exit code
// here: 0 done, 2 bad input or usage, 1 anything else.

#include <cstdio>
#include <exception>
#include <iostream>
#include <unistd.h>
#include <vector>

#include "command.h"
#include "psrig/base/log.h"
#include "psrig/firmware_host/emergency_stop.h"

namespace psrig::capture::cli {

int report_error(const std::string& command, const Error& error) {
  std::cerr << "psrig " << command << ": error: " << error.describe() << '\n';
  return exit_code(error);
}

}  // namespace psrig::capture::cli

int main(int argc, char** argv) {
  using namespace psrig::capture::cli;
  // Before any thread exists: SIGINT/SIGTERM switch every LED off at once,
  // then end the program or let the command wind down.
  psrig::firmware_host::install_emergency_stop([](int signal) {
    if (signals_end_at_once()) _exit(128 + signal);
  });
  CLI::App app{"psrig: photometric-stereo capture rig for textile swatches"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Log what each stage does");

  const std::vector<Command> commands = {add_process_command(app), add_synth_command(app),
                                         add_scan_command(app),    add_lights_command(app),
                                         add_config_command(app),  add_devices_command(app),
                                         add_status_command(app)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? 0 : 2;
  }
  psrig::set_log_level(verbose ? spdlog::level::debug : spdlog::level::warn);
  try {
    for (const auto& command : commands)
      if (command.app->parsed()) return command.run();
  } catch (const std::exception& e) {
    std::cerr << "psrig: internal error: " << e.what() << '\n';
    return 1;
  }
  return 2;
}
