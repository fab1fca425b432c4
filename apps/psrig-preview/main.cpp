// psrig-preview: the scanned swatch as a per-pixel bump-mapped surface,
// headless to PNG, full screen on the kiosk, or timed. Errors become a
// message and an exit code (psrig/base/cli_command.h): 0 done, 2 bad input
// or usage, 1 anything else.

#include "command.h"
#include "psrig/base/cli_command.h"

int main(int argc, char** argv) {
  using namespace psrig::preview::cli;
  psrig::cli::SubcommandProgram program("psrig-preview", PSRIG_VERSION,
                                        "psrig-preview: the GLES preview of a scanned swatch",
                                        spdlog::level::info);
  CLI::App& app = program.app();
  return program.run(argc, argv,
                     {add_render_command(app), add_kiosk_command(app), add_bench_command(app),
                      add_knit_command(app), add_drape_command(app)});
}
