#include "psrig/daemon/scan_service.h"

#include <algorithm>
#include <exception>

#include "psrig/base/log.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/rig/scan_sequencer.h"

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;

// Share of the progress bar each part of a scan takes: acquiring the
// frames up to 80 %, writing them 80, processing 85, done 100.
constexpr int kAcquiredPercent = 80;
constexpr int kProcessingPercent = 85;

// While it waits for a scan, the worker wakes this often to show it lives
// (healthy()) and to apply a new configuration.
constexpr auto kIdleBeat = std::chrono::seconds(1);

// Runs `f` however the scope ends, exceptions included.
template <class F>
struct ScopeExit {
  F f;
  explicit ScopeExit(F fn) : f(std::move(fn)) {}
  ScopeExit(const ScopeExit&) = delete;
  ScopeExit& operator=(const ScopeExit&) = delete;
  ~ScopeExit() { f(); }
};

// Whether `directory` holds a whole raw capture (its description is
// written last): frames that can be processed again later.
bool holds_whole_scan(const fs::path& directory) {
  std::error_code ec;
  return !directory.empty() && fs::exists(directory / formats::scan_files::kDescription, ec);
}

std::size_t queue_limit(const config::RigConfig& config) {
  return static_cast<std::size_t>(config.daemon.queue_limit);
}

}  // namespace

ScanService::ScanService(config::RigConfig config, std::unique_ptr<catalogue::Catalogue> catalogue)
    : recorder_(std::move(catalogue)),
      queue_(queue_limit(config), config.source),
      storage_(recorder_.catalogue().rig_root()),
      config_(std::move(config)) {}

Result<std::unique_ptr<ScanService>> ScanService::start(config::RigConfig config) {
  auto catalogue = catalogue::open_catalogue(catalogue::catalogue_options(config));
  if (!catalogue) return std::unexpected(catalogue.error());
  return start(std::move(config), std::move(*catalogue));
}

Result<std::unique_ptr<ScanService>> ScanService::start(
    config::RigConfig config, std::unique_ptr<catalogue::Catalogue> catalogue) {
  // Scan directories are made from the roots the catalogue resolved (a
  // root reached through a symlink, say), or none would lie inside them.
  config.storage.root = catalogue->rig_root();
  config.storage.shared_root = catalogue->storage_root();
  const bool has_rig = config.daemon.role == "rig";
  if (has_rig) {
    auto recovered = catalogue->recover();
    if (!recovered) return std::unexpected(recovered.error());
  }
  std::unique_ptr<ScanService> service(new ScanService(std::move(config), std::move(catalogue)));
  if (has_rig)
    service->worker_ = std::thread([raw = service.get()] { raw->work(); });
  else
    service->recorder_.ready();  // the catalogue's server: nothing to start
  return service;
}

bool ScanService::has_rig() const {
  return config().daemon.role == "rig";
}

Error ScanService::no_rig_error() const {
  return bad_input(config().source, "daemon.role",
                   "this psrigd serves the catalogue only (daemon.role = \"catalogue\") and has "
                   "no rig; name one: POST /v1/scans {\"rig\": \"NAME\"} (GET /v1/rigs lists "
                   "them)");
}

ScanService::~ScanService() {
  stop();
}

DaemonStatus ScanService::status() const {
  std::lock_guard lock(outcome_mutex_);
  DaemonStatus status = recorder_.status();
  status.current_scan = queue_.running();
  // A calibration runs as -id: not a scan.
  if (status.current_scan && *status.current_scan < 0) status.current_scan.reset();
  status.queue_length = queue_.length();
  status.uptime = std::chrono::steady_clock::now() - started_;
  return status;
}

void ScanService::beat() {
  heartbeat_ = std::chrono::steady_clock::now().time_since_epoch().count();
}

bool ScanService::healthy(std::chrono::steady_clock::duration limit) const {
  if (!has_rig()) return true;  // no worker to stall
  const std::chrono::steady_clock::time_point last{
      std::chrono::steady_clock::duration(heartbeat_.load())};
  return std::chrono::steady_clock::now() - last <= limit;
}

std::chrono::steady_clock::duration ScanService::heartbeat_limit(const config::RigConfig& config) {
  // Between two heartbeats a scan does at most one phase (the dark frame
  // or one LED). Processing reports nothing while it runs; the 60 s floor
  // is for it (seconds at the rig's sizes).
  return std::max<std::chrono::steady_clock::duration>(std::chrono::seconds(60),
                                                       rig::worst_phase_duration(config));
}

config::RigConfig ScanService::config() const {
  std::lock_guard lock(config_mutex_);
  return config_;
}

Result<std::int64_t> ScanService::submit(catalogue::ScanSubmission submission) {
  if (!has_rig()) return std::unexpected(no_rig_error());
  auto id = queue_.push(std::move(submission), [&](const catalogue::ScanSubmission& queued) {
    return recorder_.add(queued);
  });
  if (!id) {
    Error error = id.error();
    if (error.code == ErrorCode::queue_full) {
      recorder_.refused(catalogue::ScanErrorCode::queue_full, error.message);
      error.message += "; try again when one has run";
    }
    return std::unexpected(std::move(error));
  }
  return *id;
}

Status ScanService::lights_off() {
  if (!has_rig()) return std::unexpected(no_rig_error());
  // The queue stops too: lights-off means stop, not "the next one".
  const auto dropped = queue_.abort_all();
  auto log = logger("daemon");
  log->info("lights off requested");
  auto off = rig_.lights_off(config());
  for (const auto& job : dropped)
    drop(job, "lights off requested", false);
  return off;
}

void ScanService::drop(const ScanJob& job, const std::string& message, bool stopping) {
  if (job.submission.calibration != 0) {
    calibrations_.ended(job.submission.calibration, "aborted", message, "");
    return;
  }
  if (stopping) return recorder_.abandoned(job.id);
  if (auto ok = recorder_.cancelled(job.id, message); !ok)
    logger("daemon")->error("scan {}: {}", job.id, ok.error().describe());
}

Result<std::int64_t> ScanService::submit_calibration(nlohmann::json options,
                                                     rig::CalibrationRequest request) {
  if (!has_rig()) return std::unexpected(no_rig_error());
  const CalibrationJob job = calibrations_.add(options, std::move(request));
  catalogue::ScanSubmission submission;
  submission.source = "http";
  submission.calibration = job.id;
  // The queue knows it as -id: never a scan's (catalogue) id.
  auto queued = queue_.push(std::move(submission), [&](const catalogue::ScanSubmission&) {
    return Result<std::int64_t>(-job.id);
  });
  if (!queued) {
    calibrations_.forget(job.id);
    Error error = queued.error();
    if (error.code == ErrorCode::queue_full) error.message += "; try again when one has run";
    return std::unexpected(std::move(error));
  }
  logger("daemon")->info("calibration {} ({}) queued", job.id, job.kind);
  return job.id;
}

void ScanService::run_calibration(const ScanJob& job) {
  auto log = logger("daemon");
  beat();
  apply_pending_config();
  const std::int64_t id = job.submission.calibration;
  auto queued = calibrations_.get(id);
  if (!queued) return queue_.finish_running();
  const std::string kind = queued->kind;
  if (queue_.abort_requested() || lights::stop_requested()) {
    calibrations_.ended(id, "aborted", "aborted before it started", "");
    recorder_.calibration_ended(id, kind, false, {{"status", "aborted"}, {"error", "aborted"}});
    return queue_.finish_running();
  }
  {
    const DaemonStatus now = recorder_.status();
    calibrations_.started(id, static_cast<std::int64_t>(now.scans_completed + now.scans_failed));
  }
  const config::RigConfig config = this->config();
  // The procedure opens the rig as it needs it (the simulated rig's target
  // and the sphere's places change the world): the daemon's is closed,
  // LEDs off, and opened again by the next scan.
  rig_.close();
  rig::CalibrationRequest request = queued->request;
  request.progress = [&](const std::string& step) {
    beat();
    calibrations_.step(id, step);
    recorder_.calibration_progress(id, kind, step);
  };
  request.warn = [&](const std::string& warning) {
    log->warn("calibration {} ({}): {}", id, kind, warning);
  };
  log->info("calibration {} ({}) running", id, kind);
  Result<rig::CalibrationOutcome> outcome = std::unexpected(internal_error("not run"));
  try {
    outcome = rig::run_calibration(config, request);
  } catch (const std::exception& e) {
    outcome = std::unexpected(internal_error(std::string("internal error: ") + e.what()));
  }
  // However it ended: every LED off (the procedure's rig is gone by now).
  if (auto ok = rig_.lights_off(config); !ok)
    log->error("turning the LEDs off after calibration {}: {}", id, ok.error().describe());
  beat();
  if (!outcome) {
    const std::string message = outcome.error().describe();
    log->error("calibration {} ({}) failed: {}", id, kind, message);
    calibrations_.ended(id, "failed", message, "");
    recorder_.calibration_ended(id, kind, false, {{"status", "failed"}, {"error", message}});
  } else {
    const std::string version = outcome->file.parent_path().filename().string();
    log->info("calibration {} ({}) done: {}", id, kind, outcome->file.string());
    calibrations_.ended(id, "done", "", version);
    recorder_.calibration_ended(
        id, kind, true,
        {{"status", "done"}, {"version", version}, {"file", outcome->file.string()}});
  }
  queue_.finish_running();
}

// A scan that has not finished is cancelled or aborted, never deleted: the
// delete applies only to what cancel() found already finished.
Result<ScanRemoval> ScanService::remove(std::int64_t id) {
  auto cancelled = cancel(id);
  if (!cancelled) return std::unexpected(cancelled.error());
  switch (*cancelled) {
    case ScanCancel::not_found:
      return ScanRemoval::not_found;
    case ScanCancel::cancelled:
      return ScanRemoval::cancelled;
    case ScanCancel::aborting:
      return ScanRemoval::aborting;
    case ScanCancel::already_finished:
      break;
  }
  auto removed = recorder_.catalogue().remove(id);
  if (!removed) return std::unexpected(removed.error());
  if (*removed) logger("daemon")->info("scan {} deleted", id);
  return *removed ? ScanRemoval::deleted : ScanRemoval::not_found;
}

Result<ScanCancel> ScanService::cancel(std::int64_t id) {
  ScanQueue::Found found = ScanQueue::Found::neither;
  {
    std::lock_guard lock(outcome_mutex_);
    found = queue_.cancel(id);
  }
  switch (found) {
    case ScanQueue::Found::running:
      logger("daemon")->info("scan {}: abort requested", id);
      if (auto ok = rig_.lights_off(config()); !ok) return std::unexpected(ok.error());
      return ScanCancel::aborting;
    case ScanQueue::Found::queued:
      if (auto ok = recorder_.cancelled(id, "cancelled before it started"); !ok)
        return std::unexpected(ok.error());
      return ScanCancel::cancelled;
    case ScanQueue::Found::neither:
      break;
  }
  // Neither queued nor running: finished, if it exists (rows are added
  // under the queue's lock, and leave it only to run).
  auto entry = recorder_.catalogue().get(id);
  if (!entry) return std::unexpected(entry.error());
  return *entry ? ScanCancel::already_finished : ScanCancel::not_found;
}

void ScanService::reload(config::RigConfig config) {
  {
    std::lock_guard lock(config_mutex_);
    auto log = logger("daemon");
    std::error_code ec;
    if (fs::weakly_canonical(config.storage.root, ec) != config_.storage.root ||
        config.catalogue != config_.catalogue)
      log->warn("storage.root or [catalogue] changed; it takes effect at the next start");
    const auto& now = config_.daemon;
    const auto& next = config.daemon;
    if (next.listen_address != now.listen_address || next.port != now.port ||
        next.token != now.token || next.modbus_address != now.modbus_address ||
        next.modbus_port != now.modbus_port || next.modbus_allow != now.modbus_allow ||
        next.rig_name != now.rig_name || next.role != now.role || next.public_url != now.public_url)
      log->warn("daemon addresses, token, rig name and role take effect at the next start");
    pending_config_ = std::move(config);
  }
  queue_.poke();
}

void ScanService::apply_pending_config() {
  {
    std::lock_guard lock(config_mutex_);
    if (!pending_config_) return;
    config::RigConfig next = std::move(*pending_config_);
    pending_config_.reset();
    // What stays open keeps what it was opened with.
    next.storage.root = config_.storage.root;
    next.storage.shared_root = config_.storage.shared_root;
    next.catalogue = config_.catalogue;
    const int limit = next.daemon.queue_limit;
    next.daemon = config_.daemon;
    next.daemon.queue_limit = limit;
    config_ = std::move(next);
    queue_.set_limit(queue_limit(config_), config_.source);
  }
  rig_.close();
  catalogue::ScanErrorCode ignored;
  if (auto ok = rig_.open(config(), ignored); ok)
    logger("daemon")->info("configuration reloaded; rig opened again");
}

void ScanService::set_step(std::int64_t id, const std::string& step, int percent,
                           DaemonState state) {
  beat();
  recorder_.progress(id, step, percent, state);
}

catalogue::ScanErrorCode ScanService::classify(const Error& error, Stage stage) const {
  switch (stage) {
    case Stage::writing:
      return catalogue::ScanErrorCode::storage;
    case Stage::processing:
      return error.kind == ErrorKind::io ? catalogue::ScanErrorCode::storage
                                         : catalogue::ScanErrorCode::processing;
    case Stage::acquiring:
      break;
  }
  if (rig_.camera_failed()) return catalogue::ScanErrorCode::camera;
  if (rig_.lights_failed()) return catalogue::ScanErrorCode::lights;
  // The sequencer's own findings: an LED cut off by the safety layer, or
  // a camera whose frames never fit the lighting.
  if (error.code == ErrorCode::lights) return catalogue::ScanErrorCode::lights;
  if (error.code == ErrorCode::camera) return catalogue::ScanErrorCode::camera;
  if (error.kind == ErrorKind::bad_input) return catalogue::ScanErrorCode::storage;
  return catalogue::ScanErrorCode::camera;
}

void ScanService::finish(const ScanJob& job, catalogue::ScanStatus status,
                         catalogue::ScanErrorCode code, const std::string& message,
                         const fs::path& scan_directory, bool keep_files) {
  beat();
  if (!keep_files && !scan_directory.empty()) {
    std::error_code ec;
    fs::remove_all(scan_directory, ec);
    if (ec) logger("daemon")->warn("cannot remove {}: {}", scan_directory.string(), ec.message());
  }
  std::lock_guard lock(outcome_mutex_);
  recorder_.failed(job.id, status, code, message, keep_files);
  queue_.finish_running();
}

void ScanService::run(const ScanJob& job) {
  auto log = logger("daemon");
  beat();
  attempt_ = {};
  apply_pending_config();
  const auto aborted = [&] { return queue_.abort_requested() || lights::stop_requested(); };
  if (aborted())
    return finish(job, catalogue::ScanStatus::aborted, catalogue::ScanErrorCode::aborted, "aborted",
                  {}, false);
  set_step(job.id, "opening the rig", 0, DaemonState::scanning);
  const config::RigConfig config = this->config();
  catalogue::ScanErrorCode open_code = catalogue::ScanErrorCode::config;
  if (auto ok = rig_.open(config, open_code); !ok)
    return finish(job, catalogue::ScanStatus::failed, open_code, ok.error().describe(), {}, false);

  // A full disk is found before the LEDs go on, not after the frames are taken.
  if (auto ok = storage_.check(config); !ok)
    return finish(job, catalogue::ScanStatus::failed, catalogue::ScanErrorCode::storage,
                  ok.error().describe(), {}, false);
  const fs::path directory = rig::default_scan_directory(config, job.submission.sample_id);
  if (auto ok = recorder_.running(job.id, directory); !ok)
    return finish(job, catalogue::ScanStatus::failed, catalogue::ScanErrorCode::storage,
                  ok.error().describe(), {}, false);
  attempt_.directory = directory;

  rig_.clear_faults();
  rig::Rig& rig = rig_.rig();
  rig::ScanSequencer sequencer(config, *rig.lights, *rig.camera);
  queue_.set_stopper([&sequencer] { sequencer.request_stop(); });
  // However run() ends (an exception too): no one reaches the sequencer
  // once it is gone, and the worker knows whether the scan was written.
  const ScopeExit forget_sequencer{[&] {
    attempt_.committed = sequencer.committed();
    queue_.set_stopper({});
  }};
  rig::ScanRequest request = rig.request(config);
  request.sample_id = job.submission.sample_id;
  request.description = job.submission.description;
  request.directory = directory;
  Stage stage = Stage::acquiring;
  auto outcome = sequencer.capture(request, [&](const rig::ScanProgress& p) {
    switch (p.stage) {
      case rig::ScanStage::acquiring:
        set_step(job.id, p.step, kAcquiredPercent * p.done / std::max(1, p.total),
                 DaemonState::scanning);
        break;
      case rig::ScanStage::writing:
        stage = Stage::writing;
        set_step(job.id, p.step, kAcquiredPercent, DaemonState::scanning);
        break;
      case rig::ScanStage::processing:
        stage = Stage::processing;
        set_step(job.id, p.step, kProcessingPercent, DaemonState::processing);
        break;
    }
  });
  queue_.set_stopper({});
  // However it ended (the sequencer did this too; this is the daemon's word).
  if (auto ok = rig_.lights_off(config); !ok)
    log->error("turning the LEDs off after scan {}: {}", job.id, ok.error().describe());

  // Only what this scan wrote is ever removed: a directory that existed
  // already (a `psrig scan` put it there first) is refused, never deleted.
  const fs::path ours = sequencer.committed() ? directory : fs::path();
  if (aborted())
    return finish(job, catalogue::ScanStatus::aborted, catalogue::ScanErrorCode::aborted,
                  "aborted; all LEDs are off and nothing was kept", ours, false);
  if (!outcome) {
    const catalogue::ScanErrorCode code = classify(outcome.error(), stage);
    // Raw frames that could not be processed are kept: they can be
    // processed again later. Anything less than a whole scan is not.
    const bool keep = stage == Stage::processing && holds_whole_scan(ours);
    finish(job, catalogue::ScanStatus::failed, code, outcome.error().describe(), ours, keep);
    if (code == catalogue::ScanErrorCode::camera || code == catalogue::ScanErrorCode::lights)
      rig_.close();
    return;
  }

  fs::path maps;
  nlohmann::json report;
  if (outcome->maps) {
    maps = outcome->maps->maps_directory;
    report = outcome->maps->report;
  }
  if (auto ok = recorder_.make_durable(outcome->directory, maps); !ok)
    return finish(job, catalogue::ScanStatus::failed, catalogue::ScanErrorCode::storage,
                  ok.error().describe(), directory, false);
  Status recorded;
  {
    std::lock_guard lock(outcome_mutex_);
    recorded = recorder_.done(job.id, outcome->directory, maps, report);
    if (recorded) queue_.finish_running();
  }
  if (!recorded)
    return finish(job, catalogue::ScanStatus::failed, catalogue::ScanErrorCode::storage,
                  recorded.error().describe(), directory, false);
  storage_.record_scan(outcome->directory, maps);
}

void ScanService::work() {
  {
    catalogue::ScanErrorCode ignored;
    if (!rig_.open(config(), ignored))
      logger("daemon")->warn("the rig will be tried again at the next scan");
  }
  recorder_.ready();
  for (;;) {
    auto next = queue_.wait_next(kIdleBeat);
    beat();
    // A scan's end the full disk refused is written once there is room:
    // checked every idle second, so it needs no new scan to get there.
    recorder_.retry_pending();
    if (next.stopping) break;
    if (!next.job) {
      apply_pending_config();
      continue;
    }
    const ScanJob& job = *next.job;
    if (job.submission.calibration != 0) {
      run_calibration(job);
      continue;
    }
    try {
      run(job);
    } catch (const std::exception& e) {
      // OpenCV and the standard library may throw; a scan fails, never the
      // daemon. A scan directory already written is not orphaned: whole
      // raw frames are kept with the row naming them (they can be
      // processed again), anything less is removed.
      (void)rig_.lights_off(config());
      const fs::path ours = attempt_.committed ? attempt_.directory : fs::path();
      const bool keep = holds_whole_scan(ours);
      finish(job, catalogue::ScanStatus::failed, catalogue::ScanErrorCode::internal,
             std::string("internal error: ") + e.what() +
                 (keep ? "; raw frames kept, reprocess with psrig process" : ""),
             ours, keep);
    }
    queue_.finish_running();  // already, unless run() missed a way out
  }
  rig_.close();
}

void ScanService::stop() {
  if (stopped_.exchange(true)) return;
  recorder_.stopping();
  const auto abandoned = queue_.stop();
  (void)rig_.lights_off(config());
  if (worker_.joinable()) worker_.join();
  for (const auto& job : abandoned)
    drop(job, "psrigd stopped", true);
  recorder_.close();
}

}  // namespace psrig::daemon
