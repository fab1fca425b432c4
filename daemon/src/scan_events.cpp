#include "psrig/daemon/scan_events.h"

namespace psrig::daemon {

void ScanEvents::publish(std::string type, nlohmann::json data) {
  {
    std::lock_guard lock(mutex_);
    events_.push_back({++last_, std::move(type), std::move(data)});
    while (events_.size() > capacity_)
      events_.pop_front();
  }
  changed_.notify_all();
}

std::vector<ScanEvent> ScanEvents::wait_after(std::uint64_t after,
                                              std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return closed_ || last_ > after; });
  std::vector<ScanEvent> fresh;
  if (closed_) return fresh;
  for (const auto& event : events_)
    if (event.sequence > after) fresh.push_back(event);
  return fresh;
}

std::uint64_t ScanEvents::last_sequence() const {
  std::lock_guard lock(mutex_);
  return last_;
}

void ScanEvents::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  changed_.notify_all();
}

bool ScanEvents::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

}  // namespace psrig::daemon
