// psrig: the rig's command line. Errors become a message and an exit code
// (psrig/base/cli_command.h): 0 done, 2 bad input or usage, 1 anything else,
// 130 interrupted.

#include <unistd.h>

#include "command.h"
#include "psrig/base/cli_command.h"
#include "psrig/lights/emergency_stop.h"

int main(int argc, char** argv) {
  using namespace psrig::cli;
  // Before any thread exists: SIGINT/SIGTERM switch every LED off at once,
  // then end the program or let the command wind down.
  psrig::lights::install_emergency_stop([](int signal) {
    if (signals_end_at_once()) _exit(128 + signal);
  });
  psrig::cli::SubcommandProgram program(
      "psrig", PSRIG_VERSION, "psrig: photometric-stereo capture rig for textile swatches",
      spdlog::level::warn);
  CLI::App& app = program.app();
  return program.run(argc, argv,
                     {add_process_command(app), add_integrate_command(app), add_synth_command(app),
                      add_scan_command(app), add_lights_command(app), add_config_command(app),
                      add_devices_command(app), add_status_command(app), add_calibrate_command(app),
                      add_import_command(app), add_export_command(app), add_measure_command(app),
                      add_tile_command(app)});
}
