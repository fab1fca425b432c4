// psrigd --config FILE: the rig as a service. Owns the lights and the
// camera, runs queued scans one at a time into the catalogue, serves the
// HTTP API. SIGTERM/SIGINT abort a scan safely (LEDs off first) and end
// with exit code 0; SIGHUP reloads the configuration (a bad one is logged
// and the old one kept). Serves a PLC over Modbus TCP when
// daemon.modbus_port is set. Under systemd (Type=notify) it says READY,
// STATUS, RELOADING and STOPPING and pets the watchdog while its main loop
// and scanning service answer. Logs to stderr, with journald priority
// prefixes when stderr is the journal.

#include <atomic>
#include <chrono>
#include <ctime>
#include <exception>
#include <iostream>
#include <memory>
#include <signal.h>
#include <string>

#include <CLI/CLI.hpp>

#include "psrig/base/log.h"
#include "psrig/catalogue/rig_presence.h"
#include "psrig/config/config_loader.h"
#include "psrig/daemon/http_api.h"
#include "psrig/daemon/modbus_server.h"
#include "psrig/daemon/scan_service.h"
#include "psrig/daemon/status_json.h"
#include "psrig/daemon/systemd_notify.h"
#include "psrig/lights/emergency_stop.h"

namespace {

std::atomic<bool> stop_signalled{false};

// How often the main loop looks up from waiting for SIGHUP: the latency
// of a shutdown, and the rhythm of the systemd watchdog pings.
constexpr long kLoopNanoseconds = 200'000'000;

using Clock = std::chrono::steady_clock;
// The main loop counts as alive while it came round this recently.
constexpr auto kHealthyLoop = std::chrono::seconds(5);

// systemd's one-line STATUS=: what `systemctl status psrigd` shows.
std::string status_line(const psrig::daemon::DaemonStatus& status) {
  std::string line = psrig::daemon::to_string(status.state);
  if (status.current_scan)
    line += " scan " + std::to_string(*status.current_scan) + " (" + status.step + ", " +
            std::to_string(status.progress_percent) + " %)";
  line += "; " + std::to_string(status.queue_length) + " queued; " +
          std::to_string(status.scans_completed) + " done, " + std::to_string(status.scans_failed) +
          " failed since start";
  if (status.last_error_code != psrig::catalogue::ScanErrorCode::none)
    line += "; last error: " + status.last_error;
  return line;
}

psrig::Result<psrig::config::RigConfig> load(const std::string& file) {
  std::vector<std::string> warnings;
  auto config = psrig::config::load_config(file, &warnings);
  for (const auto& warning : warnings)
    psrig::logger("psrigd")->warn("{}", warning);
  return config;
}

int run(const std::string& config_file) {
  using namespace psrig;
  auto log = psrig::logger("psrigd");
  auto config = load(config_file);
  if (!config) {
    log->error("{}", config.error().describe());
    return psrig::exit_code(config.error());
  }
  auto service = daemon::ScanService::start(*config);
  if (!service) {
    log->error("{}", service.error().describe());
    return psrig::exit_code(service.error());
  }
  auto http = daemon::HttpApi::start(**service, daemon::http_api_options(config->daemon));
  if (!http) {
    log->error("{}", http.error().describe());
    (*service)->stop();
    return psrig::exit_code(http.error());
  }
  std::unique_ptr<daemon::ModbusServer> modbus;
  if (config->daemon.modbus_port != 0) {
    auto server = daemon::ModbusServer::start(**service, {.address = config->daemon.modbus_address,
                                                          .port = config->daemon.modbus_port,
                                                          .allow = config->daemon.modbus_allow});
    if (!server) {
      log->error("{}", server.error().describe());
      (*http)->stop();
      (*service)->stop();
      return psrig::exit_code(server.error());
    }
    modbus = std::move(*server);
    log->info("Modbus TCP for the PLC on {}", modbus->endpoint());
  }

  // The watchdog is petted from its own thread for as long as this loop
  // has come round lately and the scan worker's heartbeat is recent: the
  // loop asks the scanning service for its status every tick, so a service
  // that deadlocks, or a worker stuck in a device call, stops the pings and
  // systemd restarts the daemon.
  daemon::SystemdNotifier systemd;
  std::atomic<Clock::rep> last_tick{Clock::now().time_since_epoch().count()};
  std::atomic<bool> worker_alive{true};
  // How long the worker may go without a heartbeat under the configuration
  // in use; worked out again when SIGHUP brings a new one.
  auto heartbeat_limit = daemon::ScanService::heartbeat_limit(*config);
  daemon::WatchdogPetter petter(systemd, [&] {
    return worker_alive &&
           Clock::now() - Clock::time_point(Clock::duration(last_tick.load())) < kHealthyLoop;
  });
  // In the catalogue's rigs list from now on: the lab's other psrigd show
  // this rig's state and can forward scans to it.
  std::unique_ptr<catalogue::RigPresence> presence;
  if ((*service)->has_rig()) {
    catalogue::RigRecord self;
    self.name = config->daemon.rig_name;
    self.api_url = config->daemon.public_url;
    self.token = config->daemon.token;
    presence = std::make_unique<catalogue::RigPresence>(
        (*service)->catalogue(), std::move(self),
        [&service] { return daemon::status_json(**service); });
  }
  log->info("ready: rig {} ({}), {} catalogue, scans in {}", config->daemon.rig_name,
            config->daemon.role, (*service)->catalogue().backend(),
            (*service)->catalogue().rig_root().string());
  (void)systemd.ready();
  std::string last_status;

  sigset_t hangup;
  sigemptyset(&hangup);
  sigaddset(&hangup, SIGHUP);
  const timespec tick{0, kLoopNanoseconds};
  while (!stop_signalled) {
    if (sigtimedwait(&hangup, nullptr, &tick) == SIGHUP) {
      log->info("SIGHUP: reloading {}", config_file);
      (void)systemd.reloading();
      auto fresh = load(config_file);
      if (fresh) {
        heartbeat_limit = daemon::ScanService::heartbeat_limit(*fresh);
        (*service)->reload(std::move(*fresh));
      } else {
        log->error("keeping the running configuration: {}", fresh.error().describe());
      }
      (void)systemd.ready();
    }
    const bool alive = (*service)->healthy(heartbeat_limit);
    if (alive && !worker_alive) log->info("the scan worker is answering again");
    if (!alive && worker_alive)
      log->error(
          "the scan worker has not answered within its limit; the watchdog is no longer "
          "petted");
    worker_alive = alive;
    std::string status = status_line((*service)->status());
    if (!alive) status = "worker stalled; " + status;
    if (status != last_status) (void)systemd.status(status);
    last_status = status;
    last_tick = Clock::now().time_since_epoch().count();
  }

  (void)systemd.stopping();
  petter.stop();
  log->info("stopping: the running scan is aborted, every LED is off");
  if (presence) presence->stop();
  if (modbus) modbus->stop();
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
  psrig::lights::install_emergency_stop([](int) { stop_signalled = true; });

  CLI::App app{"psrigd: the photometric-stereo rig's daemon (HTTP API, catalogue, scans)"};
  std::string config_file;
  bool verbose = false;
  bool quiet = false;
  app.set_version_flag("--version", std::string("psrigd ") + PSRIG_VERSION,
                       "Print the program's version and exit");
  app.add_option("--config", config_file, "Rig configuration (e.g. /etc/psrig/rig.toml)")
      ->required();
  app.add_flag("-v,--verbose", verbose, "Log every request and stage");
  app.add_flag("-q,--quiet", quiet, "Log warnings and errors only");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  if (psrig::stderr_is_journal()) psrig::log_to_stderr_for_journal();
  psrig::set_log_level(verbose ? spdlog::level::debug
                       : quiet ? spdlog::level::warn
                               : spdlog::level::info);
  try {
    return run(config_file);
  } catch (const std::exception& e) {
    std::cerr << "psrigd: internal error: " << e.what() << '\n';
    return 1;
  }
}
