#pragma once
// This rig in the catalogue's rigs list: its name, where its API answers,
// its token (so another psrigd can forward a scan to it) and its status
// (GET /v1/status's), written every few seconds from a thread of its own,
// so every psrigd of a lab shows each rig's state. A rig not heard from
// for kOfflineAfter is offline; one that stops says so on its way out. A
// write the database refuses (it is away) is logged once and tried again
// at the next beat: presence is news, never queued.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include <nlohmann/json.hpp>

#include "psrig/catalogue/catalogue.h"

namespace psrig::catalogue {

class RigPresence {
 public:
  static constexpr std::chrono::seconds kInterval{3};
  static constexpr std::chrono::seconds kOfflineAfter{15};

  // Announces at once, then every `interval`; `status` is asked each time.
  RigPresence(Catalogue& catalogue, RigRecord self, std::function<nlohmann::json()> status,
              std::chrono::milliseconds interval = kInterval);
  ~RigPresence();
  RigPresence(const RigPresence&) = delete;
  RigPresence& operator=(const RigPresence&) = delete;

  // Stops the beat and announces the rig stopped. Idempotent.
  void stop();

 private:
  void announce(nlohmann::json status);
  void beat();

  Catalogue& catalogue_;
  RigRecord self_;
  std::function<nlohmann::json()> status_;
  std::chrono::milliseconds interval_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool failing_ = false;  // the last write failed (logged once)
  std::thread thread_;
};

// Whether a rig is online: heard from lately, and not stopped.
[[nodiscard]] inline bool rig_online(const RigRecord& rig) {
  return rig.seen_seconds_ago <=
             std::chrono::duration<double>(RigPresence::kOfflineAfter).count() &&
         rig.status.value("state", "") != "stopped";
}

}  // namespace psrig::catalogue
