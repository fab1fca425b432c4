#pragma once
// psrigd tells systemd how it is doing through the notify protocol
// (sd_notify(3)): READY once it serves, STATUS lines, RELOADING on SIGHUP,
// STOPPING on the way out and WATCHDOG pings. Outside systemd, with
// NOTIFY_SOCKET unset, every call does nothing and succeeds.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <string_view>
#include <thread>

#include "psrig/base/error.h"

namespace psrig::daemon {

class SystemdNotifier {
 public:
  // Whether a service manager listens (NOTIFY_SOCKET is set).
  [[nodiscard]] bool enabled() const;

  // Each sends one datagram; an error when the socket is set but unusable.
  // A daemon may well go on after one: it is logged at warning here too.
  Status ready();                        // READY=1: start-up done, Type=notify units go active
  Status reloading();                    // RELOADING=1: send ready() again when done
  Status status(std::string_view text);  // STATUS=text, one line (newlines become spaces)
  Status stopping();                     // STOPPING=1
  Status watchdog();                     // WATCHDOG=1

  // WatchdogSec= as the service manager passed it (WATCHDOG_USEC, for
  // this process), or nothing when the watchdog is off.
  [[nodiscard]] std::optional<std::chrono::microseconds> watchdog_timeout() const;
  // How often to call watchdog(): half the timeout, as sd_watchdog_enabled(3) advises.
  [[nodiscard]] std::optional<std::chrono::microseconds> watchdog_interval() const;

  // Sends `state` as it is: "KEY=VALUE" lines (see sd_notify(3)).
  Status notify(std::string_view state);
};

// A thread that pets the watchdog every watchdog_interval() for as long as
// `healthy` says so (always, when it is empty): a daemon whose scan loop
// hangs stops answering healthy and systemd restarts it. Does nothing, and
// starts no thread, when the watchdog is off.
class WatchdogPetter {
 public:
  explicit WatchdogPetter(SystemdNotifier& notifier, std::function<bool()> healthy = {});
  ~WatchdogPetter();
  WatchdogPetter(const WatchdogPetter&) = delete;
  WatchdogPetter& operator=(const WatchdogPetter&) = delete;

  // Whether a petting thread runs.
  [[nodiscard]] bool running() const { return thread_.joinable(); }
  // Ends the thread at once; idempotent.
  void stop();

 private:
  void run(std::chrono::microseconds interval);

  SystemdNotifier& notifier_;
  std::function<bool()> healthy_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace psrig::daemon
