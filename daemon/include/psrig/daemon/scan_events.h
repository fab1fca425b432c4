#pragma once
// What the scanning service tells whoever listens (the HTTP API's
// server-sent events): a scan's progress, its completion, its failure. The
// latest events are kept in a ring with increasing sequence numbers, so a
// listener reads at its own pace, resumes after a reconnect (Last-Event-ID),
// and never slows the scan down; one too slow to keep up misses the oldest.
// Thread-safe.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace psrig::daemon {

struct ScanEvent {
  std::uint64_t sequence = 0;  // 1, 2, 3, ...: the SSE id
  std::string type;            // "progress", "done", "error"
  nlohmann::json data;         // always carries the scan's "id"
};

class ScanEvents {
 public:
  explicit ScanEvents(std::size_t capacity = 256) : capacity_(capacity) {}

  void publish(std::string type, nlohmann::json data);

  // The events after `after` still held, waiting at most `timeout` for one;
  // empty on timeout or once closed.
  [[nodiscard]] std::vector<ScanEvent> wait_after(std::uint64_t after,
                                                  std::chrono::milliseconds timeout) const;
  [[nodiscard]] std::uint64_t last_sequence() const;

  // Wakes every waiter for good: the daemon is stopping.
  void close();
  [[nodiscard]] bool closed() const;

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::deque<ScanEvent> events_;
  std::uint64_t last_ = 0;
  bool closed_ = false;
};

}  // namespace psrig::daemon
