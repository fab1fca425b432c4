#pragma once
// Where each scan's life is told: its catalogue row (queued -> running ->
// done | failed | aborted), the event stream, and the status page's state,
// step and counts. Thread-safe.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/catalogue/catalogue.h"
#include "psrig/daemon/scan_control.h"
#include "psrig/daemon/scan_events.h"

namespace psrig::daemon {

class ScanRecorder {
 public:
  explicit ScanRecorder(std::unique_ptr<catalogue::Catalogue> catalogue);

  [[nodiscard]] catalogue::Catalogue& catalogue() { return *catalogue_; }
  [[nodiscard]] const ScanEvents& events() const { return events_; }
  // The status page, but for what the queue knows (the running scan and
  // how many wait) and the uptime.
  [[nodiscard]] DaemonStatus status() const;

  // A submission's row, `queued`; an error state gives way to the new
  // scan. Called before the worker can see the scan (under the queue's
  // lock), so that the scan's own failure is never overwritten.
  [[nodiscard]] Result<std::int64_t> add(const catalogue::ScanSubmission& submission);
  // A submission was refused for the service's state (a full queue).
  void refused(catalogue::ScanErrorCode code, std::string message);
  // The worker is ready for scans; the daemon is stopping (the state says
  // so from now on).
  void ready();
  void stopping();

  [[nodiscard]] Status running(std::int64_t id, const std::filesystem::path& directory);
  void progress(std::int64_t id, const std::string& step, int percent, DaemonState state);

  // A scan's end: its row, then the status page and the event.
  void failed(std::int64_t id, catalogue::ScanStatus status, catalogue::ScanErrorCode code,
              const std::string& message, bool files_kept);
  // Flushes the maps (or the scan, without maps) to disk: a row that says
  // `done` must not outlive them in a power cut. Before done().
  [[nodiscard]] Status make_durable(const std::filesystem::path& scan_directory,
                                    const std::filesystem::path& maps_directory) const;
  // Nothing but the error when the row cannot be written.
  [[nodiscard]] Status done(std::int64_t id, const std::filesystem::path& scan_directory,
                            const std::filesystem::path& maps_directory,
                            const nlohmann::json& report);

  // A queued scan that will not run: its row `aborted` with `message`
  // (now, or once the catalogue can write), and its event.
  [[nodiscard]] Status cancelled(std::int64_t id, const std::string& message);
  // A queued scan dropped as the daemon stops: its row only.
  void abandoned(std::int64_t id);

  // Writes the scans' ends the catalogue could not write when they came
  // (a full disk); the worker calls it between scans and every idle second.
  void retry_pending() { (void)catalogue_->flush_pending(); }

  // A calibration's life on the status page (state scanning, its step)
  // and the event stream: `progress`, `done` or `error` events carrying
  // `calibration` (its id) and `kind` in place of a scan's `id`.
  void calibration_progress(std::int64_t id, const std::string& kind, const std::string& step);
  void calibration_ended(std::int64_t id, const std::string& kind, bool ok,
                         const nlohmann::json& details);
  // The event stream ends: the daemon is stopping.
  void close();

 private:
  std::unique_ptr<catalogue::Catalogue> catalogue_;
  ScanEvents events_;
  mutable std::mutex mutex_;  // status_ and stopping_
  DaemonStatus status_;
  bool stopping_ = false;
};

}  // namespace psrig::daemon
