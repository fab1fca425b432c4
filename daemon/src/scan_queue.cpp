#include "psrig/daemon/scan_queue.h"

#include <algorithm>
#include <string>

namespace psrig::daemon {

ScanQueue::ScanQueue(std::size_t limit, std::filesystem::path source)
    : limit_(limit), source_(std::move(source)) {}

void ScanQueue::set_limit(std::size_t limit, std::filesystem::path source) {
  std::lock_guard lock(mutex_);
  limit_ = limit;
  source_ = std::move(source);
}

Result<std::int64_t> ScanQueue::push(
    catalogue::ScanSubmission submission,
    const std::function<Result<std::int64_t>(const catalogue::ScanSubmission&)>& add_row) {
  std::lock_guard lock(mutex_);
  if (stopping_) return std::unexpected(io_error("psrigd", "stopping; no more scans are taken"));
  if (jobs_.size() >= limit_)
    return std::unexpected(bad_input(source_, "daemon.queue_limit",
                                     "queue full: " + std::to_string(limit_) + " scans waiting")
                               .with(ErrorCode::queue_full));
  auto id = add_row(submission);
  if (!id) return std::unexpected(id.error());
  jobs_.push_back({*id, std::move(submission)});
  wake_.notify_one();
  return *id;
}

ScanQueue::Next ScanQueue::wait_next(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, timeout, [&] { return stopping_ || !jobs_.empty() || poked_; });
  poked_ = false;
  if (stopping_) return {.job = std::nullopt, .stopping = true};
  if (jobs_.empty()) return {};
  Next next{.job = std::move(jobs_.front()), .stopping = false};
  jobs_.pop_front();
  running_ = next.job->id;
  abort_running_ = false;
  return next;
}

void ScanQueue::poke() {
  std::lock_guard lock(mutex_);
  poked_ = true;
  wake_.notify_one();
}

void ScanQueue::set_stopper(std::function<void()> stop) {
  std::lock_guard lock(mutex_);
  stop_running_ = std::move(stop);
  if (stop_running_ && abort_running_) stop_running_();
}

bool ScanQueue::abort_requested() const {
  std::lock_guard lock(mutex_);
  return abort_running_;
}

void ScanQueue::finish_running() {
  std::lock_guard lock(mutex_);
  running_.reset();
  stop_running_ = nullptr;
}

void ScanQueue::abort_running_locked() {
  if (!running_) return;
  abort_running_ = true;
  if (stop_running_) stop_running_();
}

ScanQueue::Found ScanQueue::cancel(std::int64_t id) {
  std::lock_guard lock(mutex_);
  if (running_ == id) {
    abort_running_locked();
    return Found::running;
  }
  const auto queued =
      std::find_if(jobs_.begin(), jobs_.end(), [&](const ScanJob& job) { return job.id == id; });
  if (queued == jobs_.end()) return Found::neither;
  jobs_.erase(queued);
  return Found::queued;
}

std::deque<ScanJob> ScanQueue::abort_all() {
  std::lock_guard lock(mutex_);
  abort_running_locked();
  std::deque<ScanJob> dropped;
  dropped.swap(jobs_);
  return dropped;
}

std::deque<ScanJob> ScanQueue::stop() {
  std::deque<ScanJob> dropped;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    abort_running_locked();
    dropped.swap(jobs_);
  }
  wake_.notify_all();
  return dropped;
}

std::size_t ScanQueue::length() const {
  std::lock_guard lock(mutex_);
  return jobs_.size();
}

std::optional<std::int64_t> ScanQueue::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

}  // namespace psrig::daemon
