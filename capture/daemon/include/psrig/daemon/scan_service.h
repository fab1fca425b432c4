#pragma once
// The daemon's scanning service: owns the rig and one worker thread that
// runs the queued scans one at a time, records each in the catalogue
// (queued -> running -> done | failed | aborted) and tells the event
// listeners how it goes. A device that fails fails its scan, never the
// daemon: the rig is closed and opened again for the next scan. Thread-safe.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "psrig/capture/rig.h"
#include "psrig/config/rig_config.h"
#include "psrig/daemon/catalogue.h"
#include "psrig/daemon/scan_control.h"
#include "psrig/daemon/scan_events.h"

namespace psrig::daemon {

struct DeviceFaults;

// What the status page says of the devices.
struct DeviceStatus {
  bool open = false;
  std::string lights;  // the backend's description, when open
  std::string camera;
  std::string open_error;  // why the last attempt to open them failed
  // Why the last attempt to switch every LED off failed (closing the rig,
  // or lights-off with the rig closed): an LED may still be on. Cleared
  // when switching them off next succeeds. Also shown in open_error.
  std::string lights_off_error;
};

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
  // Opens the catalogue in config.storage.root (cleaning what an
  // interrupted run left), tries the rig (a rig that cannot open now is
  // tried again at the next scan) and starts the worker.
  [[nodiscard]] static Result<std::unique_ptr<ScanService>> start(config::RigConfig config);
  ~ScanService() override;
  ScanService(const ScanService&) = delete;
  ScanService& operator=(const ScanService&) = delete;

  [[nodiscard]] DaemonStatus status() const override;
  [[nodiscard]] Result<std::int64_t> submit(ScanSubmission submission) override;
  [[nodiscard]] Status lights_off() override;

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
  // open); queue_limit applies at once.
  void reload(config::RigConfig config);

  // Aborts the running scan (LEDs off), marks the queued ones aborted and
  // joins the worker. Idempotent; the destructor calls it.
  void stop();

  // The worker is alive: it has stamped its heartbeat (at each step and
  // progress report of a scan, and every second while it waits for one)
  // within `limit`. For the systemd watchdog, which otherwise only proves
  // the main loop lives: pet it only while this holds.
  [[nodiscard]] bool healthy(std::chrono::steady_clock::duration limit) const;
  // The longest a working worker goes without a heartbeat under `config`,
  // max(60 s, one phase of a scan at its worst: every grab it may make
  // taking camera.timeout_ms).
  [[nodiscard]] static std::chrono::steady_clock::duration heartbeat_limit(
      const config::RigConfig& config);

  [[nodiscard]] Catalogue& catalogue() { return *catalogue_; }
  [[nodiscard]] const ScanEvents& events() const { return events_; }
  [[nodiscard]] DeviceStatus devices() const;
  // The configuration the next scan uses.
  [[nodiscard]] config::RigConfig config() const;

 private:
  struct Job {
    std::int64_t id = 0;
    ScanSubmission submission;
  };
  // How far a scan got, for blaming the right part when it fails.
  enum class Stage { opening, acquiring, writing, processing, recording };

  ScanService(config::RigConfig config, std::unique_ptr<Catalogue> catalogue);
  void work();
  void run(const Job& job);
  void apply_pending_config();
  [[nodiscard]] Status open_rig_if_closed(ScanErrorCode& code);
  void close_rig();
  void finish(const Job& job, ScanStatus status, ScanErrorCode code, const std::string& message,
              const std::filesystem::path& scan_directory, bool keep_files);
  void set_step(std::string step, int percent, DaemonState state);
  [[nodiscard]] ScanErrorCode classify(const Error& error, Stage stage) const;
  // Every LED off: through the open rig, or with the rig closed through
  // the light backend opened alone for it.
  [[nodiscard]] Status switch_lights_off();
  // Records (for status/devices) whether switching the LEDs off worked.
  Status note_lights_off(Status off, const std::string& device);
  // Room in the storage root for one more scan and its catalogue rows.
  [[nodiscard]] Status check_free_space(const config::RigConfig& config) const;
  void request_abort_locked();
  // A queued scan's row `aborted` with `message`, and its event.
  [[nodiscard]] Status mark_cancelled(std::int64_t id, const std::string& message);

  std::unique_ptr<Catalogue> catalogue_;
  ScanEvents events_;
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();

  mutable std::mutex mutex_;  // everything below, but rig_ (see rig_mutex_)
  std::condition_variable wake_;
  config::RigConfig config_;
  std::optional<config::RigConfig> pending_config_;
  std::deque<Job> queue_;
  bool stopping_ = false;
  bool abort_current_ = false;
  capture::ScanSequencer* sequencer_ = nullptr;  // of the running scan
  DaemonStatus status_;
  DeviceStatus devices_;

  // Only the worker replaces the rig; others (lights_off) use its lights
  // under this lock while it is open.
  mutable std::mutex rig_mutex_;
  // Held while the light backend is being opened (the rig, or the lights
  // alone to switch them off), so that one device is never opened twice at
  // once. Taken before rig_mutex_ and mutex_, never after.
  std::mutex open_mutex_;
  std::unique_ptr<capture::Rig> rig_;
  std::shared_ptr<DeviceFaults> faults_;
  std::uintmax_t last_scan_bytes_ = 0;  // on disk, maps included; the worker's
  // The running scan's directory and whether it has been written: what an
  // exception out of run() must keep or remove. The worker's.
  struct Attempt {
    std::filesystem::path directory;
    bool committed = false;
  } attempt_;

  // steady_clock time of the worker's last sign of life.
  std::atomic<std::chrono::steady_clock::rep> heartbeat_{
      std::chrono::steady_clock::now().time_since_epoch().count()};
  void beat();

  std::thread worker_;
};

}  // namespace psrig::daemon
