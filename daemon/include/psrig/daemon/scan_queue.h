#pragma once
// The scans waiting to run and the one running. What is queued, taken,
// cancelled or aborted is decided under one lock, so a scan is always
// exactly one of queued, running or finished to whoever asks.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>

#include "psrig/base/error.h"
#include "psrig/daemon/scan_control.h"

namespace psrig::daemon {

struct ScanJob {
  std::int64_t id = 0;
  catalogue::ScanSubmission submission;
};

class ScanQueue {
 public:
  // Where a scan named by cancel() was.
  enum class Found { queued, running, neither };
  // What wait_next() woke for.
  struct Next {
    std::optional<ScanJob> job;  // now the running scan
    bool stopping = false;
  };

  // At most `limit` scans wait; `source` is the configuration that says
  // so, named when a submission is refused.
  ScanQueue(std::size_t limit, std::filesystem::path source);
  void set_limit(std::size_t limit, std::filesystem::path source);

  // Queues a scan whose catalogue row `add_row` makes under the queue's
  // lock: a row leaves the queue only to run. Refused while stopping, or
  // when full (ErrorCode::queue_full: the service's state, not the
  // request's fault).
  [[nodiscard]] Result<std::int64_t> push(
      catalogue::ScanSubmission submission,
      const std::function<Result<std::int64_t>(const catalogue::ScanSubmission&)>& add_row);

  // The next scan, which becomes the running one; or, after `timeout` or
  // a poke(), none.
  [[nodiscard]] Next wait_next(std::chrono::milliseconds timeout);
  // Wakes wait_next() with nothing to run (a new configuration to apply).
  void poke();

  // How the running scan is asked to stop, while it can be; called at once
  // if it was asked already. An empty function: it can no longer be.
  void set_stopper(std::function<void()> stop);
  // The running scan was asked to stop.
  [[nodiscard]] bool abort_requested() const;
  // The running scan has finished (its row says how): no scan runs.
  void finish_running();

  // A queued scan is taken out; the running one is asked to stop.
  [[nodiscard]] Found cancel(std::int64_t id);
  // Asks the running scan to stop and empties the queue: what it held.
  [[nodiscard]] std::deque<ScanJob> abort_all();
  // abort_all(), and no more scans are taken.
  [[nodiscard]] std::deque<ScanJob> stop();

  [[nodiscard]] std::size_t length() const;
  [[nodiscard]] std::optional<std::int64_t> running() const;

 private:
  void abort_running_locked();

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::size_t limit_;
  std::filesystem::path source_;
  std::deque<ScanJob> jobs_;
  std::optional<std::int64_t> running_;
  bool abort_running_ = false;
  std::function<void()> stop_running_;
  bool stopping_ = false;
  bool poked_ = false;
};

}  // namespace psrig::daemon
