#pragma once
// The daemon's scanning service: one worker thread that runs the queued
// scans one at a time on the rig and tells how each goes. A device that
// fails fails its scan, never the daemon: the rig is closed and opened
// again for the next scan. Thread-safe. Its parts, one job each: the
// queue (ScanQueue), the rig (RigHolder), the room on disk
// (StorageBudget) and the telling (ScanRecorder).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "psrig/catalogue/catalogue.h"
#include "psrig/config/rig_config.h"
#include "psrig/daemon/calibration_jobs.h"
#include "psrig/daemon/rig_holder.h"
#include "psrig/daemon/scan_control.h"
#include "psrig/daemon/scan_events.h"
#include "psrig/daemon/scan_queue.h"
#include "psrig/daemon/scan_recorder.h"
#include "psrig/daemon/storage_budget.h"

namespace psrig::daemon {

// What DELETE /v1/scans/{id} did.
enum class ScanRemoval {
  not_found,
  cancelled,  // it was queued: it will not run (its row says aborted)
  aborting,   // it is running: it stops, LEDs off, and its row will say aborted
  deleted,    // it had finished: files and row are gone
};

// What POST /v1/scans/{id}/cancel did: never a deletion.
enum class ScanCancel {
  not_found,
  cancelled,         // it was queued: it will not run (its row says aborted)
  aborting,          // it is running: it stops, LEDs off, and its row will say aborted
  already_finished,  // done, failed or aborted already: left as it is
};

class ScanService final : public ScanControl {
 public:
  // Opens the catalogue config names (cleaning what this rig's interrupted
  // run left), tries the rig (a rig that cannot open now is tried again at
  // the next scan) and starts the worker. With daemon.role "catalogue"
  // there is no rig and no worker: the service serves the catalogue, and
  // refuses scans, calibrations and lights-off (no_rig_error()).
  [[nodiscard]] static Result<std::unique_ptr<ScanService>> start(config::RigConfig config);
  // The same over a catalogue already open (a benchmark's, measuring it).
  [[nodiscard]] static Result<std::unique_ptr<ScanService>> start(
      config::RigConfig config, std::unique_ptr<catalogue::Catalogue> catalogue);
  ~ScanService() override;
  ScanService(const ScanService&) = delete;
  ScanService& operator=(const ScanService&) = delete;

  [[nodiscard]] DaemonStatus status() const override;
  [[nodiscard]] Result<std::int64_t> submit(catalogue::ScanSubmission submission) override;
  [[nodiscard]] Status lights_off() override;
  // Queues a calibration with the scans (rig/rig_calibration.h): it
  // runs when the scans before it have, with the rig to itself, LEDs off
  // after. Its id in calibrations(); a full queue as submit() says.
  [[nodiscard]] Result<std::int64_t> submit_calibration(nlohmann::json options,
                                                        rig::CalibrationRequest request);
  [[nodiscard]] const CalibrationJobs& calibrations() const { return calibrations_; }

  // Cancels a queued scan, aborts the running one, or deletes a finished one.
  [[nodiscard]] Result<ScanRemoval> remove(std::int64_t id);
  // Cancels a queued scan or aborts the running one; a scan that has
  // finished is left alone (already_finished), whenever it finished: what
  // a client that gives up on a scan asks, where remove() would delete a
  // scan that finished between its polls. Decided under the queue's lock.
  [[nodiscard]] Result<ScanCancel> cancel(std::int64_t id);

  // A new configuration (SIGHUP), applied between scans: the rig is opened
  // again with it. storage.root and the daemon's addresses keep their
  // start-up values until a restart (the catalogue and the sockets stay
  // open); queue_limit applies with it.
  void reload(config::RigConfig config);

  // Aborts the running scan (LEDs off), marks the queued ones aborted and
  // joins the worker. Idempotent; the destructor calls it.
  void stop();

  // The worker is alive: it has stamped its heartbeat (at each step and
  // progress report of a scan, and every second while it waits for one)
  // within `limit`. For the systemd watchdog, which otherwise only proves
  // the main loop lives: pet it only while this holds.
  [[nodiscard]] bool healthy(std::chrono::steady_clock::duration limit) const;
  // The longest a working worker goes without a heartbeat under `config`:
  // max(60 s, the sequencer's worst phase).
  [[nodiscard]] static std::chrono::steady_clock::duration heartbeat_limit(
      const config::RigConfig& config);

  [[nodiscard]] catalogue::Catalogue& catalogue() { return recorder_.catalogue(); }
  // Whether this psrigd runs a rig (daemon.role "rig"), and what it says
  // when asked to scan without one.
  [[nodiscard]] bool has_rig() const;
  [[nodiscard]] Error no_rig_error() const;
  [[nodiscard]] const ScanEvents& events() const { return recorder_.events(); }
  [[nodiscard]] DeviceStatus devices() const { return rig_.devices(); }
  // The configuration the next scan uses.
  [[nodiscard]] config::RigConfig config() const;

 private:
  // How far a scan got, for blaming the right part when it fails.
  enum class Stage { acquiring, writing, processing };

  ScanService(config::RigConfig config, std::unique_ptr<catalogue::Catalogue> catalogue);
  void work();
  void run(const ScanJob& job);
  void run_calibration(const ScanJob& job);
  // A queued job dropped (lights off, stopping): its row, or its calibration.
  void drop(const ScanJob& job, const std::string& message, bool stopping);
  void apply_pending_config();
  // The scan's files removed unless kept, then its end recorded.
  void finish(const ScanJob& job, catalogue::ScanStatus status, catalogue::ScanErrorCode code,
              const std::string& message, const std::filesystem::path& scan_directory,
              bool keep_files);
  void set_step(std::int64_t id, const std::string& step, int percent, DaemonState state);
  [[nodiscard]] catalogue::ScanErrorCode classify(const Error& error, Stage stage) const;
  void beat();

  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  ScanRecorder recorder_;
  ScanQueue queue_;
  RigHolder rig_;
  CalibrationJobs calibrations_;
  StorageBudget storage_;

  // Held while a scan's end is recorded (its row, the status page, the
  // queue), and by status() and cancel(): whoever sees a scan finished
  // anywhere finds it finished everywhere. Taken before the queue's and
  // the recorder's locks, never after. The row's write is a few ms; only
  // another process holding the SQLite catalogue's lock stretches it, up
  // to the busy timeout (5 s), or a shared catalogue's database gone
  // silent, up to 6 s (postgres_link.cpp; one that refuses costs nothing),
  // well inside the watchdog's 30 s.
  mutable std::mutex outcome_mutex_;
  mutable std::mutex config_mutex_;
  config::RigConfig config_;
  std::optional<config::RigConfig> pending_config_;

  // The running scan's directory and whether it has been written: what an
  // exception out of run() must keep or remove. The worker's.
  struct Attempt {
    std::filesystem::path directory;
    bool committed = false;
  } attempt_;

  // steady_clock time of the worker's last sign of life.
  std::atomic<std::chrono::steady_clock::rep> heartbeat_{
      std::chrono::steady_clock::now().time_since_epoch().count()};
  std::atomic<bool> stopped_{false};
  std::thread worker_;
};

}  // namespace psrig::daemon
