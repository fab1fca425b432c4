// psrig lights --config FILE --cycle: each LED on in turn, for checking the
// wiring (which LED is which tilt); --off: every LED off, now.

#include <chrono>
#include <cstdio>
#include <memory>
#include <thread>

#include "command.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/rig/rig.h"

namespace psrig::cli {
namespace {

struct LightsArgs {
  std::string config;
  bool cycle = false;
  bool off = false;
  int on_ms = 1000;
  int rounds = 1;
};

}  // namespace

Command add_lights_command(CLI::App& parent) {
  auto args = std::make_shared<LightsArgs>();
  CLI::App* app =
      parent.add_subcommand("lights", "Switch the rig's LEDs by hand, for wiring checks");
  app->add_option("--config", args->config, "Rig configuration")->required();
  auto* cycle_flag =
      app->add_flag("--cycle", args->cycle, "Each LED on in turn, with its tilt printed");
  auto* off_flag = app->add_flag("--off", args->off, "Every LED off");
  cycle_flag->excludes(off_flag);
  app->add_option("--on-ms", args->on_ms, "How long each LED stays on")
      ->check(CLI::Range(1, 60000));
  app->add_option("--rounds", args->rounds, "How many times to go round")
      ->check(CLI::Range(1, 1000));

  return {app, [args] {
            if (!args->cycle && !args->off) {
              std::fprintf(stderr, "psrig lights: say --cycle or --off\n");
              return 2;
            }
            stop_gracefully_on_signals();
            int exit_code = 0;
            auto config = load_config_or_report("lights", args->config, exit_code);
            if (!config) return exit_code;
            auto rig = rig::open_rig(*config, false);
            if (!rig) return report_error("lights", rig.error());
            std::printf("lights: %s\n", rig->lights->describe().c_str());
            if (args->off) return rig->lights->all_off() ? 0 : 1;
            for (int round = 0; round < args->rounds && !lights::stop_requested(); ++round) {
              for (int k = 0; k < rig->lights->channel_count() && !lights::stop_requested(); ++k) {
                const double tilt = config->geometry.tilts_deg.at(static_cast<std::size_t>(k));
                std::printf("LED %d on (tilt %.0f deg, slant %.0f deg)\n", k, tilt,
                            config->geometry.slant_deg);
                std::fflush(stdout);
                if (auto on = rig->lights->turn_on(k); !on)
                  return report_error("lights", on.error());
                std::this_thread::sleep_for(std::chrono::milliseconds(args->on_ms));
                if (auto off = rig->lights->all_off(); !off)
                  return report_error("lights", off.error());
              }
            }
            if (lights::stop_requested()) {
              std::printf("interrupted: all LEDs off\n");
              return psrig::cli::exit_interrupted;
            }
            if (auto overlap = rig->lights->log().overlap()) {
              std::fprintf(stderr, "psrig lights: error: %s\n", overlap->c_str());
              return 1;
            }
            std::printf("all LEDs off\n");
            return 0;
          }};
}

}  // namespace psrig::cli
