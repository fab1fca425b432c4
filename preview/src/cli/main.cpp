// psrig-preview: the scanned swatch as a per-pixel bump-mapped surface,
// headless to PNG, full screen on the kiosk, or timed. Errors become a
// message and an exit code here: 0 done, 2 bad input or usage, 1 anything
// else.

#include <exception>
#include <iostream>
#include <vector>

#include "command.h"
#include "psrig/base/log.h"

int main(int argc, char** argv) {
  using namespace psrig::preview::cli;
  CLI::App app{"psrig-preview: the GLES preview of a scanned swatch"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Log what each stage does");
  const std::vector<Command> commands = {add_render_command(app), add_kiosk_command(app),
                                         add_bench_command(app), add_knit_command(app)};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? 0 : 2;
  }
  psrig::set_log_level(verbose ? spdlog::level::debug : spdlog::level::info);
  try {
    for (const auto& command : commands)
      if (command.app->parsed()) return command.run();
  } catch (const std::exception& e) {
    std::cerr << "psrig-preview: internal error: " << e.what() << '\n';
    return 1;
  }
  return 2;
}
