#include "psrig/catalogue/rig_presence.h"

#include "psrig/base/log.h"

namespace psrig::catalogue {

RigPresence::RigPresence(Catalogue& catalogue, RigRecord self,
                         std::function<nlohmann::json()> status, std::chrono::milliseconds interval)
    : catalogue_(catalogue),
      self_(std::move(self)),
      status_(std::move(status)),
      interval_(interval),
      thread_([this] { beat(); }) {}

RigPresence::~RigPresence() {
  stop();
}

void RigPresence::announce(nlohmann::json status) {
  RigRecord record = self_;
  record.status = std::move(status);
  auto written = catalogue_.announce(record);
  if (!written && !failing_)
    logger("catalogue")
        ->warn("rig {}: cannot write its status to the rigs list (tried again every {} s): {}",
               self_.name, std::chrono::duration<double>(interval_).count(),
               written.error().describe());
  else if (written && failing_)
    logger("catalogue")->info("rig {}: its status is in the rigs list again", self_.name);
  failing_ = !written;
}

void RigPresence::beat() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    lock.unlock();
    announce(status_());
    lock.lock();
    wake_.wait_for(lock, interval_, [this] { return stopping_; });
  }
}

void RigPresence::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  nlohmann::json last = status_();
  last["state"] = "stopped";
  announce(std::move(last));
}

}  // namespace psrig::catalogue
