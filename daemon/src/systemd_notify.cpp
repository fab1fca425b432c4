#include "psrig/daemon/systemd_notify.h"

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <systemd/sd-daemon.h>

#include "psrig/base/log.h"

namespace psrig::daemon {

bool SystemdNotifier::enabled() const {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  return socket && *socket;
}

Status SystemdNotifier::notify(std::string_view state) {
  // 0 keeps NOTIFY_SOCKET set: the daemon notifies for as long as it runs.
  const int sent = sd_notify(0, std::string(state).c_str());
  if (sent >= 0) return {};  // 0: no service manager listens
  const char* socket = std::getenv("NOTIFY_SOCKET");
  const std::string message = "sd_notify(\"" + std::string(state.substr(0, state.find('\n'))) +
                              "\") to " + (socket ? socket : "?") +
                              " failed: " + std::strerror(-sent);
  logger("daemon")->warn("{}", message);
  return std::unexpected(internal_error(message));
}

Status SystemdNotifier::ready() {
  return notify("READY=1");
}

Status SystemdNotifier::reloading() {
  return notify("RELOADING=1");
}

Status SystemdNotifier::stopping() {
  return notify("STOPPING=1");
}

Status SystemdNotifier::watchdog() {
  return notify("WATCHDOG=1");
}

Status SystemdNotifier::status(std::string_view text) {
  // One assignment per line: a newline in the text would end STATUS= there.
  std::string line = "STATUS=";
  line.reserve(line.size() + text.size());
  for (const char c : text)
    line.push_back(c == '\n' || c == '\r' ? ' ' : c);
  return notify(line);
}

std::optional<std::chrono::microseconds> SystemdNotifier::watchdog_timeout() const {
  std::uint64_t usec = 0;
  // > 0 only when WATCHDOG_USEC is set and WATCHDOG_PID, if set, is this process.
  if (sd_watchdog_enabled(0, &usec) <= 0 || usec == 0) return std::nullopt;
  return std::chrono::microseconds(usec);
}

std::optional<std::chrono::microseconds> SystemdNotifier::watchdog_interval() const {
  const auto timeout = watchdog_timeout();
  if (!timeout) return std::nullopt;
  return std::max(*timeout / 2, std::chrono::microseconds(1));
}

WatchdogPetter::WatchdogPetter(SystemdNotifier& notifier, std::function<bool()> healthy)
    : notifier_(notifier), healthy_(std::move(healthy)) {
  const auto interval = notifier_.watchdog_interval();
  if (!interval || !notifier_.enabled()) return;
  logger("daemon")->debug("petting the systemd watchdog every {} ms", interval->count() / 1000);
  thread_ = std::thread([this, every = *interval] { run(every); });
}

WatchdogPetter::~WatchdogPetter() {
  stop();
}

void WatchdogPetter::stop() {
  {
    const std::scoped_lock lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void WatchdogPetter::run(std::chrono::microseconds interval) {
  std::unique_lock lock(mutex_);
  bool was_healthy = true;
  while (!stopping_) {
    lock.unlock();
    bool healthy = true;
    try {
      healthy = !healthy_ || healthy_();
    } catch (...) {  // a throwing check counts as sick
      healthy = false;
    }
    if (healthy) (void)notifier_.watchdog();
    // Once per change, not once per interval.
    if (healthy != was_healthy)
      logger("daemon")->warn(healthy ? "petting the systemd watchdog again"
                                     : "not petting the systemd watchdog: the "
                                       "daemon reports itself stuck");
    was_healthy = healthy;
    lock.lock();
    wake_.wait_for(lock, interval, [this] { return stopping_; });
  }
}

}  // namespace psrig::daemon
