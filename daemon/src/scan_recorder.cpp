#include "psrig/daemon/scan_recorder.h"

#include <fcntl.h>
#include <unistd.h>
#include <vector>

#include "psrig/base/log.h"

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;

// The maps are written atomically but not flushed (process_scan makes
// them again from the raw frames if need be); a row that says `done` must
// not outlive them in a power cut, so they are flushed before it commits.
Status flush_tree(const fs::path& directory) {
  std::error_code ec;
  std::vector<fs::path> paths;
  for (fs::recursive_directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec))
    paths.push_back(it->path());
  if (ec) return std::unexpected(io_error(directory, "cannot list: " + ec.message()));
  paths.push_back(directory);
  paths.push_back(directory.parent_path());
  for (const auto& path : paths) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return std::unexpected(io_error(path, "cannot open to flush"));
    const bool flushed = ::fsync(fd) == 0;
    ::close(fd);
    if (!flushed) return std::unexpected(io_error(path, "cannot flush to disk"));
  }
  return {};
}

nlohmann::json scan_event(std::int64_t id) {
  return {{"id", id}};
}

}  // namespace

ScanRecorder::ScanRecorder(std::unique_ptr<catalogue::Catalogue> catalogue)
    : catalogue_(std::move(catalogue)) {}

DaemonStatus ScanRecorder::status() const {
  std::lock_guard lock(mutex_);
  return status_;
}

Result<std::int64_t> ScanRecorder::add(const catalogue::ScanSubmission& submission) {
  auto id = catalogue_->add(submission);
  if (!id) return std::unexpected(id.error());
  logger("daemon")->info("scan {} queued (sample '{}', from {})", *id, submission.sample_id,
                         submission.source.empty() ? "?" : submission.source);
  std::lock_guard lock(mutex_);
  if (status_.state == DaemonState::error) status_.state = DaemonState::idle;
  return *id;
}

void ScanRecorder::refused(catalogue::ScanErrorCode code, std::string message) {
  std::lock_guard lock(mutex_);
  status_.last_error_code = code;
  status_.last_error = std::move(message);
}

void ScanRecorder::ready() {
  std::lock_guard lock(mutex_);
  if (!stopping_) status_.state = DaemonState::idle;
}

void ScanRecorder::stopping() {
  std::lock_guard lock(mutex_);
  stopping_ = true;
  status_.state = DaemonState::stopping;
}

Status ScanRecorder::running(std::int64_t id, const fs::path& directory) {
  if (auto ok = catalogue_->mark_running(id, directory); !ok) return ok;
  logger("daemon")->info("scan {} running into {}", id, directory.string());
  return {};
}

void ScanRecorder::progress(std::int64_t id, const std::string& step, int percent,
                            DaemonState state) {
  {
    std::lock_guard lock(mutex_);
    status_.step = step;
    status_.progress_percent = percent;
    if (!stopping_) status_.state = state;
  }
  auto event = scan_event(id);
  event.update({{"step", step}, {"percent", percent}, {"state", to_string(state)}});
  events_.publish("progress", std::move(event));
}

void ScanRecorder::failed(std::int64_t id, catalogue::ScanStatus status,
                          catalogue::ScanErrorCode code, const std::string& message,
                          bool files_kept) {
  auto log = logger("daemon");
  // A row that cannot be written now waits in the catalogue (catalogue.h).
  if (auto ok = catalogue_->mark_failed(id, status, code, message, files_kept); !ok)
    log->error("scan {}: cannot record its failure yet: {}", id, ok.error().describe());
  log->error("scan {} {}: {}", id, to_string(status), message);
  {
    std::lock_guard lock(mutex_);
    status_.last_scan = id;
    status_.last_error_code = code;
    status_.last_error = message;
    ++status_.scans_failed;
    status_.step.clear();
    status_.progress_percent = 0;
    if (!stopping_)
      status_.state =
          status == catalogue::ScanStatus::failed ? DaemonState::error : DaemonState::idle;
  }
  auto event = scan_event(id);
  event.update({{"status", to_string(status)},
                {"code", static_cast<int>(code)},
                {"code_name", to_string(code)},
                {"error", message}});
  events_.publish("error", std::move(event));
}

void ScanRecorder::calibration_progress(std::int64_t id, const std::string& kind,
                                        const std::string& step) {
  {
    std::lock_guard lock(mutex_);
    status_.step = "calibrating " + kind + ": " + step;
    status_.progress_percent = 0;
    if (!stopping_) status_.state = DaemonState::scanning;
  }
  events_.publish("progress", {{"calibration", id}, {"kind", kind}, {"step", step}});
}

void ScanRecorder::calibration_ended(std::int64_t id, const std::string& kind, bool ok,
                                     const nlohmann::json& details) {
  {
    std::lock_guard lock(mutex_);
    status_.step.clear();
    status_.progress_percent = 0;
    if (!stopping_) status_.state = DaemonState::idle;
  }
  nlohmann::json event = {{"calibration", id}, {"kind", kind}};
  event.update(details);
  events_.publish(ok ? "done" : "error", std::move(event));
}

Status ScanRecorder::make_durable(const fs::path& scan_directory,
                                  const fs::path& maps_directory) const {
  return flush_tree(maps_directory.empty() ? scan_directory : maps_directory);
}

Status ScanRecorder::done(std::int64_t id, const fs::path& scan_directory,
                          const fs::path& maps_directory, const nlohmann::json& report) {
  if (auto ok = catalogue_->mark_done(id, maps_directory, report); !ok) return ok;
  logger("daemon")->info("scan {} done: {}", id, scan_directory.string());
  {
    std::lock_guard lock(mutex_);
    status_.last_scan = id;
    status_.last_error_code = catalogue::ScanErrorCode::none;
    status_.last_error.clear();
    ++status_.scans_completed;
    status_.step.clear();
    status_.progress_percent = 0;
    if (!stopping_) status_.state = DaemonState::idle;
  }
  auto event = scan_event(id);
  event.update({{"status", "done"},
                {"percent", 100},
                {"scan_directory", scan_directory.string()},
                {"maps_directory", maps_directory.string()}});
  if (const nlohmann::json::json_pointer mean("/ground_truth/angular_error_deg/mean");
      report.contains(mean))
    event["angular_error_deg"] = report.at(mean);
  events_.publish("done", std::move(event));
  return {};
}

Status ScanRecorder::cancelled(std::int64_t id, const std::string& message) {
  // The scan has left the queue, so it is cancelled whether or not its row
  // can be written now: the catalogue keeps its end until it can.
  if (auto ok = catalogue_->mark_failed(id, catalogue::ScanStatus::aborted,
                                        catalogue::ScanErrorCode::aborted, message, false);
      !ok)
    logger("daemon")->error("scan {}: {}", id, ok.error().describe());
  auto event = scan_event(id);
  event.update({{"status", "aborted"},
                {"code", static_cast<int>(catalogue::ScanErrorCode::aborted)},
                {"error", message}});
  events_.publish("error", std::move(event));
  logger("daemon")->info("scan {} cancelled: {}", id, message);
  return {};
}

void ScanRecorder::abandoned(std::int64_t id) {
  if (auto ok = catalogue_->mark_failed(id, catalogue::ScanStatus::aborted,
                                        catalogue::ScanErrorCode::aborted,
                                        "psrigd stopped before this scan started", false);
      !ok)
    logger("daemon")->error("scan {}: {}", id, ok.error().describe());
}

void ScanRecorder::close() {
  events_.close();
}

}  // namespace psrig::daemon
