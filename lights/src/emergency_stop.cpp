#include "psrig/lights/emergency_stop.h"

#include <atomic>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <pthread.h>
#include <set>
#include <signal.h>
#include <thread>
#include <unistd.h>

#include "psrig/lights/safe_lights.h"

namespace psrig::lights {
namespace {

std::mutex& registry_mutex() {
  static std::mutex mutex;
  return mutex;
}
std::set<SafeLights*>& registry() {
  static std::set<SafeLights*> lights;
  return lights;
}
std::atomic<bool> requested{false};

}  // namespace

void register_lights(SafeLights* lights) {
  std::lock_guard lock(registry_mutex());
  registry().insert(lights);
}

void unregister_lights(SafeLights* lights) {
  std::lock_guard lock(registry_mutex());
  registry().erase(lights);
}

void emergency_all_off() {
  std::lock_guard lock(registry_mutex());
  for (SafeLights* lights : registry()) lights->emergency_off();
}

bool stop_requested() { return requested; }

void install_emergency_stop(std::function<void(int)> on_signal) {
  static std::once_flag once;
  std::call_once(once, [&] {
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // inherited by every thread made from now on
    std::thread([signals, on_signal = std::move(on_signal)] {
      for (;;) {
        int signal = 0;
        if (sigwait(&signals, &signal) != 0) continue;
        // Requested first: a scan that checks before switching an LED on
        // sees it, so none comes on again after the all-off below.
        const bool again = requested.exchange(true);
        emergency_all_off();
        if (again) _exit(128 + signal);  // second signal: do not wait any longer
        if (on_signal) on_signal(signal);
      }
    }).detach();
    std::set_terminate([] {
      emergency_all_off();
      std::abort();
    });
  });
}

}  // namespace psrig::lights
