// psrigd --config FILE: the rig as a service. Owns the lights and the
// camera, runs queued scans one at a time into the catalogue, serves the
// HTTP API. SIGTERM/SIGINT abort a scan safely (LEDs off first) and end
// with exit code 0; SIGHUP reloads the configuration (a bad one is logged
// and the old one kept). Logs to stderr.

#include <atomic>
#include <chrono>
#include <ctime>
#include <exception>
#include <iostream>
#include <signal.h>

#include <CLI/CLI.hpp>

#include "psrig/capture/http_api.h"
#include "psrig/capture/scan_service.h"
#include "psrig/config/config_loader.h"
#include "psrig/firmware_host/emergency_stop.h"
#include "psrig/processing/log.h"

namespace {

std::atomic<bool> stop_signalled{false};

// How often the main loop looks up from waiting for SIGHUP: the latency
// of a shutdown, and the rhythm of the systemd watchdog pings.
constexpr long kLoopNanoseconds = 200'000'000;

psrig::processing::Result<psrig::config::RigConfig> load(const std::string& file) {
  std::vector<std::string> warnings;
  auto config = psrig::config::load_config(file, &warnings);
  for (const auto& warning : warnings)
    psrig::processing::logger("psrigd")->warn("{}", warning);
  return config;
}

int run(const std::string& config_file) {
  using namespace psrig;
  auto log = processing::logger("psrigd");
  auto config = load(config_file);
  if (!config) {
    log->error("{}", config.error().describe());
    return processing::exit_code(config.error());
  }
  auto service = capture::ScanService::start(*config);
  if (!service) {
    log->error("{}", service.error().describe());
    return processing::exit_code(service.error());
  }
  auto http = capture::HttpApi::start(**service, capture::http_api_options(config->daemon));
  if (!http) {
    log->error("{}", http.error().describe());
    (*service)->stop();
    return processing::exit_code(http.error());
  }
  // Modbus hook: when config->daemon.modbus_port is not 0, the PLC's Modbus
  // TCP server starts here against the same ScanControl (**service), on
  // config->daemon.modbus_address, and stops before the HTTP API below.

  // systemd hook: READY=1 here, and STATUS= with the state and queue.
  log->info("ready; storage {}", (*service)->catalogue().storage_root().string());

  sigset_t hangup;
  sigemptyset(&hangup);
  sigaddset(&hangup, SIGHUP);
  const timespec tick{0, kLoopNanoseconds};
  while (!stop_signalled) {
    if (sigtimedwait(&hangup, nullptr, &tick) == SIGHUP) {
      log->info("SIGHUP: reloading {}", config_file);
      auto fresh = load(config_file);
      if (fresh)
        (*service)->reload(std::move(*fresh));
      else
        log->error("keeping the running configuration: {}", fresh.error().describe());
    }
    // systemd hook: WATCHDOG=1 here (the loop runs every 200 ms, well
    // inside any WatchdogSec=), and STATUS= when the state changed.
  }

  // systemd hook: STOPPING=1 here.
  log->info("stopping: the running scan is aborted, every LED is off");
  (*http)->stop();
  (*service)->stop();
  log->info("stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread exists: SIGHUP waits for the main loop, and
  // SIGINT/SIGTERM switch every LED off at once, then end the loop.
  sigset_t hangup;
  sigemptyset(&hangup);
  sigaddset(&hangup, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &hangup, nullptr);
  psrig::firmware_host::install_emergency_stop([](int) { stop_signalled = true; });

  CLI::App app{"psrigd: the photometric-stereo rig's daemon (HTTP API, catalogue, scans)"};
  std::string config_file;
  bool verbose = false;
  app.add_option("--config", config_file, "Rig configuration (e.g. /etc/psrig/rig.toml)")
      ->required();
  app.add_flag("-v,--verbose", verbose, "Log every request and stage");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  psrig::processing::set_log_level(verbose ? spdlog::level::debug : spdlog::level::info);
  try {
    return run(config_file);
  } catch (const std::exception& e) {
    std::cerr << "psrigd: internal error: " << e.what() << '\n';
    return 1;
  }
}
