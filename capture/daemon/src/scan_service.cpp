#include "psrig/daemon/scan_service.h"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <fcntl.h>
#include <unistd.h>

#include "fault_recording_devices.h"
#include "psrig/base/log.h"
#include "psrig/capture/scan_sequencer.h"
#include "psrig/firmware_host/emergency_stop.h"
#include "psrig/firmware_host/sim/sim_world.h"

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;

// Share of the progress bar each part of a scan takes: acquiring the
// frames up to 80 %, writing them 80, processing 85, done 100.
constexpr int kAcquiredPercent = 80;
constexpr int kProcessingPercent = 85;

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

// Room the catalogue keeps after a scan: its rows for this scan (and for
// a failure) go to SQLite's write-ahead log, which needs space to grow.
constexpr std::uintmax_t kCatalogueHeadroom = 1 << 20;

std::string human_bytes(std::uintmax_t bytes) {
  char text[32];
  if (bytes >= (1U << 20))
    std::snprintf(text, sizeof text, "%.1f MiB", static_cast<double>(bytes) / (1 << 20));
  else
    std::snprintf(text, sizeof text, "%.0f KiB", static_cast<double>(bytes) / (1 << 10));
  return text;
}

// What one scan and its maps take on disk, over-estimated: every frame
// (each LED's and the dark) as 16-bit colour, the simulator's ground truth
// (float normals and heights) and the maps (about 30 bytes a pixel). 0
// when the frame size is the camera's own, known only once it has scanned.
std::uintmax_t expected_scan_bytes(const config::RigConfig& config) {
  const bool sim = config.camera.backend == "sim";
  int width = config.camera.width, height = config.camera.height;
  if ((width <= 0 || height <= 0) && sim) {
    width = config.sim.width;
    height = config.sim.height;
  }
  if (width <= 0 || height <= 0) return 0;
  const auto frames =
      static_cast<std::uintmax_t>(config.lights.channels + (config.capture.dark_frame ? 1 : 0));
  std::uintmax_t per_pixel = frames * 3 * 2;
  if (sim) per_pixel += 16;
  if (config.capture.process) per_pixel += 32;
  return static_cast<std::uintmax_t>(width) * static_cast<std::uintmax_t>(height) * per_pixel;
}

// What a finished scan takes on disk, maps included.
std::uintmax_t tree_bytes(const fs::path& directory) {
  std::uintmax_t bytes = 0;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(directory, ec), end; !ec && it != end;
       it.increment(ec)) {
    std::error_code size_ec;
    if (it->is_regular_file(size_ec)) bytes += it->file_size(size_ec);
  }
  return bytes;
}

// Runs `f` however the scope ends, exceptions included.
template <class F>
struct ScopeExit {
  F f;
  explicit ScopeExit(F fn) : f(std::move(fn)) {}
  ScopeExit(const ScopeExit&) = delete;
  ScopeExit& operator=(const ScopeExit&) = delete;
  ~ScopeExit() { f(); }
};

nlohmann::json scan_event(std::int64_t id) {
  return {{"id", id}};
}

}  // namespace

ScanService::ScanService(config::RigConfig config, std::unique_ptr<Catalogue> catalogue)
    : catalogue_(std::move(catalogue)), config_(std::move(config)) {}

Result<std::unique_ptr<ScanService>> ScanService::start(config::RigConfig config) {
  auto catalogue = Catalogue::open(config.storage.root);
  if (!catalogue) return std::unexpected(catalogue.error());
  // Scan directories are made from the root the catalogue resolved (a
  // root reached through a symlink, say), or none would lie inside it.
  config.storage.root = (*catalogue)->storage_root();
  auto recovered = (*catalogue)->recover();
  if (!recovered) return std::unexpected(recovered.error());
  std::unique_ptr<ScanService> service(new ScanService(std::move(config), std::move(*catalogue)));
  service->worker_ = std::thread([raw = service.get()] { raw->work(); });
  return service;
}

ScanService::~ScanService() {
  stop();
}

DaemonStatus ScanService::status() const {
  std::lock_guard lock(mutex_);
  DaemonStatus status = status_;
  status.queue_length = queue_.size();
  status.uptime = std::chrono::steady_clock::now() - started_;
  return status;
}

void ScanService::beat() {
  heartbeat_ = std::chrono::steady_clock::now().time_since_epoch().count();
}

bool ScanService::healthy(std::chrono::steady_clock::duration limit) const {
  const std::chrono::steady_clock::time_point last{
      std::chrono::steady_clock::duration(heartbeat_.load())};
  return std::chrono::steady_clock::now() - last <= limit;
}

std::chrono::steady_clock::duration ScanService::heartbeat_limit(const config::RigConfig& config) {
  // Between two heartbeats a scan does at most one phase (the dark frame
  // or one LED): its settling, and up to 64 stale frames (the
  // sequencer's kMaxStaleFrames), the discarded and the averaged ones,
  // each grab allowed camera.timeout_ms. Processing reports nothing
  // while it runs; the 60 s floor is for it (seconds at the rig's sizes).
  constexpr int kMaxStaleFrames = 64;
  const auto grabs = static_cast<std::int64_t>(kMaxStaleFrames + config.camera.frames_discard +
                                               config.camera.frames_average + 1);
  const auto phase =
      std::chrono::milliseconds(grabs * config.camera.timeout_ms + config.capture.settle_ms);
  return std::max<std::chrono::steady_clock::duration>(std::chrono::seconds(60), phase);
}

DeviceStatus ScanService::devices() const {
  std::lock_guard lock(mutex_);
  return devices_;
}

config::RigConfig ScanService::config() const {
  std::lock_guard lock(mutex_);
  return config_;
}

Result<std::int64_t> ScanService::submit(ScanSubmission submission) {
  auto log = logger("daemon");
  std::lock_guard lock(mutex_);
  if (stopping_) return std::unexpected(io_error("psrigd", "stopping; no more scans are taken"));
  const auto limit = static_cast<std::size_t>(config_.daemon.queue_limit);
  if (queue_.size() >= limit) {
    status_.last_error_code = ScanErrorCode::queue_full;
    status_.last_error = "queue full: " + std::to_string(limit) + " scans waiting";
    // The code tells the front ends this is the queue, not the request.
    return std::unexpected(bad_input(config_.source, "daemon.queue_limit",
                                     status_.last_error + "; try again when one has run")
                               .with(ErrorCode::queue_full));
  }
  auto id = catalogue_->add(submission);
  if (!id) return std::unexpected(id.error());
  log->info("scan {} queued (sample '{}', from {})", *id, submission.sample_id,
            submission.source.empty() ? "?" : submission.source);
  queue_.push_back({*id, std::move(submission)});
  if (status_.state == DaemonState::error) status_.state = DaemonState::idle;
  wake_.notify_one();
  return *id;
}

void ScanService::request_abort_locked() {
  if (!status_.current_scan) return;
  abort_current_ = true;
  if (sequencer_) sequencer_->request_stop();
}

Status ScanService::note_lights_off(Status off, const std::string& device) {
  std::lock_guard lock(mutex_);
  if (off) {
    if (!devices_.lights_off_error.empty()) {
      logger("daemon")->info("{}: every LED is off again", device);
      if (devices_.open_error == devices_.lights_off_error) devices_.open_error.clear();
      devices_.lights_off_error.clear();
    }
    return off;
  }
  Error error = off.error();
  error.message =
      "switching every LED off on " + device + " failed (one may still be on): " + error.message;
  devices_.lights_off_error = error.describe();
  devices_.open_error = devices_.lights_off_error;
  return std::unexpected(error);
}

Status ScanService::switch_lights_off() {
  std::lock_guard open_lock(open_mutex_);
  {
    std::lock_guard lock(rig_mutex_);
    if (rig_) return note_lights_off(rig_->lights->all_off(), rig_->lights->describe());
  }
  // Closed: SafeLights switched them off as it went, or tried to; a failure
  // there is not known to be fixed, so the light backend is opened alone to
  // make sure.
  const config::RigConfig config = this->config();
  const std::string backend = "the LED backend '" + config.lights.backend + "'";
  auto lights = capture::open_rig(config, /*with_camera=*/false);
  if (!lights) return note_lights_off(std::unexpected(lights.error()), backend);
  return note_lights_off(lights->lights->all_off(), lights->lights->describe());
}

Status ScanService::lights_off() {
  std::deque<Job> dropped;
  {
    std::lock_guard lock(mutex_);
    request_abort_locked();
    // The queue stops too: lights-off means stop, not "the next one".
    dropped.swap(queue_);
  }
  auto log = logger("daemon");
  log->info("lights off requested");
  auto off = switch_lights_off();
  for (const auto& job : dropped)
    if (auto ok = mark_cancelled(job.id, "lights off requested"); !ok)
      log->error("scan {}: {}", job.id, ok.error().describe());
  return off;
}

Status ScanService::mark_cancelled(std::int64_t id, const std::string& message) {
  if (auto ok =
          catalogue_->mark_failed(id, ScanStatus::aborted, ScanErrorCode::aborted, message, false);
      !ok)
    return ok;
  auto event = scan_event(id);
  event.update({{"status", "aborted"},
                {"code", static_cast<int>(ScanErrorCode::aborted)},
                {"error", message}});
  events_.publish("error", std::move(event));
  logger("daemon")->info("scan {} cancelled: {}", id, message);
  return {};
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
  auto removed = catalogue_->remove(id);
  if (!removed) return std::unexpected(removed.error());
  if (*removed) logger("daemon")->info("scan {} deleted", id);
  return *removed ? ScanRemoval::deleted : ScanRemoval::not_found;
}

Result<ScanCancel> ScanService::cancel(std::int64_t id) {
  bool was_queued = false, was_running = false;
  {
    std::lock_guard lock(mutex_);
    if (status_.current_scan == id) {
      request_abort_locked();
      was_running = true;
    } else {
      const auto queued =
          std::find_if(queue_.begin(), queue_.end(), [&](const Job& job) { return job.id == id; });
      if (queued != queue_.end()) {
        queue_.erase(queued);
        was_queued = true;
      }
    }
  }
  if (was_running) {
    logger("daemon")->info("scan {}: abort requested", id);
    if (auto ok = switch_lights_off(); !ok) return std::unexpected(ok.error());
    return ScanCancel::aborting;
  }
  if (was_queued) {
    if (auto ok = mark_cancelled(id, "cancelled before it started"); !ok)
      return std::unexpected(ok.error());
    return ScanCancel::cancelled;
  }
  // Neither queued nor running: finished, if it exists (rows are added
  // under the same lock as the queue, and leave it only to run).
  auto entry = catalogue_->get(id);
  if (!entry) return std::unexpected(entry.error());
  return *entry ? ScanCancel::already_finished : ScanCancel::not_found;
}

void ScanService::reload(config::RigConfig config) {
  std::lock_guard lock(mutex_);
  auto log = logger("daemon");
  std::error_code ec;
  if (fs::weakly_canonical(config.storage.root, ec) != config_.storage.root)
    log->warn("storage.root changed to {}; it takes effect at the next start",
              config.storage.root.string());
  const auto& now = config_.daemon;
  const auto& next = config.daemon;
  if (next.listen_address != now.listen_address || next.port != now.port ||
      next.token != now.token || next.modbus_address != now.modbus_address ||
      next.modbus_port != now.modbus_port)
    log->warn("daemon addresses and token take effect at the next start");
  pending_config_ = std::move(config);
  wake_.notify_one();
}

void ScanService::apply_pending_config() {
  {
    std::lock_guard lock(mutex_);
    if (!pending_config_) return;
    config::RigConfig next = std::move(*pending_config_);
    pending_config_.reset();
    // What stays open keeps what it was opened with.
    next.storage.root = config_.storage.root;
    const int queue_limit = next.daemon.queue_limit;
    next.daemon = config_.daemon;
    next.daemon.queue_limit = queue_limit;
    config_ = std::move(next);
  }
  close_rig();
  ScanErrorCode ignored;
  if (auto ok = open_rig_if_closed(ignored); ok)
    logger("daemon")->info("configuration reloaded; rig opened again");
}

Status ScanService::open_rig_if_closed(ScanErrorCode& code) {
  if (rig_) return {};
  std::lock_guard open_lock(open_mutex_);
  auto log = logger("daemon");
  const config::RigConfig config = this->config();
  auto faults = std::make_shared<DeviceFaults>();
  auto rig = std::make_unique<capture::Rig>();
  const auto failed = [&](ScanErrorCode what, const Error& error) -> Status {
    code = what;
    log->error("cannot open the {}: {}", to_string(what), error.describe());
    std::lock_guard lock(mutex_);
    devices_ = {false, "", "", error.describe(), devices_.lights_off_error};
    return std::unexpected(error);
  };
  try {
    if (config.lights.backend == "sim" || config.camera.backend == "sim")
      rig->world = std::make_shared<firmware_host::SimWorld>(config);
    auto backend = firmware_host::open_lights(config, rig->world);
    if (!backend) return failed(ScanErrorCode::lights, backend.error());
    rig->lights = std::make_unique<firmware_host::SafeLights>(
        record_light_faults(std::move(*backend), faults),
        std::chrono::milliseconds(config.lights.max_on_ms));
    auto camera = capture::open_camera(config, rig->world);
    if (!camera) return failed(ScanErrorCode::camera, camera.error());
    rig->camera = record_camera_faults(std::move(*camera), faults);
  } catch (const std::exception& e) {
    return failed(ScanErrorCode::config,
                  internal_error(std::string("opening the rig: ") + e.what()));
  }
  {
    std::lock_guard lock(mutex_);
    devices_ = {true, rig->lights->describe(), rig->camera->describe(), devices_.lights_off_error,
                devices_.lights_off_error};
  }
  log->info("rig open: {}; {}", rig->lights->describe(), rig->camera->describe());
  std::lock_guard lock(rig_mutex_);
  rig_ = std::move(rig);
  faults_ = std::move(faults);
  return {};
}

void ScanService::close_rig() {
  std::unique_ptr<capture::Rig> closing;
  {
    std::lock_guard lock(rig_mutex_);
    closing = std::move(rig_);
  }
  if (closing) {
    // SafeLights turns every LED off as it goes, but says nothing if that
    // fails: asked here first, so that a failure is logged and shown.
    if (auto off = note_lights_off(closing->lights->all_off(), closing->lights->describe()); !off)
      logger("daemon")->error("closing the rig: {}", off.error().describe());
  }
  closing.reset();
  std::lock_guard lock(mutex_);
  devices_.open = false;
}

Status ScanService::check_free_space(const config::RigConfig& config) const {
  const fs::path& root = catalogue_->storage_root();
  std::error_code ec;
  const auto space = fs::space(root, ec);
  if (ec) return std::unexpected(io_error(root, "cannot read the free space: " + ec.message()));
  const std::uintmax_t scan = std::max(expected_scan_bytes(config), last_scan_bytes_);
  const std::uintmax_t needed = scan + kCatalogueHeadroom;
  if (space.available >= needed) return {};
  return std::unexpected(io_error(
      root, "not enough free space for a scan: " + human_bytes(space.available) +
                " free, a scan needs about " + human_bytes(scan) + " and the catalogue " +
                human_bytes(kCatalogueHeadroom) +
                " (LEDs not switched on); delete or move old scans, or point storage.root at a "
                "larger disk"));
}

void ScanService::set_step(std::string step, int percent, DaemonState state) {
  beat();
  std::int64_t id = 0;
  {
    std::lock_guard lock(mutex_);
    status_.step = step;
    status_.progress_percent = percent;
    if (!stopping_) status_.state = state;
    id = status_.current_scan.value_or(0);
  }
  auto event = scan_event(id);
  event.update({{"step", step}, {"percent", percent}, {"state", to_string(state)}});
  events_.publish("progress", std::move(event));
}

ScanErrorCode ScanService::classify(const Error& error, Stage stage) const {
  switch (stage) {
    case Stage::opening:
      return ScanErrorCode::config;
    case Stage::writing:
    case Stage::recording:
      return ScanErrorCode::storage;
    case Stage::processing:
      return error.kind == ErrorKind::io ? ScanErrorCode::storage : ScanErrorCode::processing;
    case Stage::acquiring:
      break;
  }
  if (faults_ && faults_->camera) return ScanErrorCode::camera;
  if (faults_ && faults_->lights) return ScanErrorCode::lights;
  // The sequencer's own findings: an LED cut off by the safety layer, or
  // a camera whose frames never fit the lighting.
  if (error.code == ErrorCode::lights) return ScanErrorCode::lights;
  if (error.code == ErrorCode::camera) return ScanErrorCode::camera;
  if (error.kind == ErrorKind::bad_input) return ScanErrorCode::storage;
  return ScanErrorCode::camera;
}

void ScanService::finish(const Job& job, ScanStatus status, ScanErrorCode code,
                         const std::string& message, const fs::path& scan_directory,
                         bool keep_files) {
  beat();
  auto log = logger("daemon");
  if (!keep_files && !scan_directory.empty()) {
    std::error_code ec;
    fs::remove_all(scan_directory, ec);
    if (ec) log->warn("cannot remove {}: {}", scan_directory.string(), ec.message());
  }
  if (auto ok = catalogue_->mark_failed(job.id, status, code, message, keep_files); !ok)
    log->error("scan {}: cannot record its failure: {}", job.id, ok.error().describe());
  log->error("scan {} {}: {}", job.id, to_string(status), message);
  {
    std::lock_guard lock(mutex_);
    status_.last_scan = job.id;
    status_.last_error_code = code;
    status_.last_error = message;
    ++status_.scans_failed;
    status_.current_scan.reset();
    status_.step.clear();
    status_.progress_percent = 0;
    if (!stopping_)
      status_.state = status == ScanStatus::failed ? DaemonState::error : DaemonState::idle;
  }
  auto event = scan_event(job.id);
  event.update({{"status", to_string(status)},
                {"code", static_cast<int>(code)},
                {"code_name", to_string(code)},
                {"error", message}});
  events_.publish("error", std::move(event));
}

void ScanService::run(const Job& job) {
  auto log = logger("daemon");
  beat();
  attempt_ = {};
  apply_pending_config();
  const auto aborted = [&] {
    std::lock_guard lock(mutex_);
    return abort_current_ || firmware_host::stop_requested();
  };
  if (aborted())
    return finish(job, ScanStatus::aborted, ScanErrorCode::aborted, "aborted", {}, false);
  set_step("opening the rig", 0, DaemonState::scanning);
  ScanErrorCode open_code = ScanErrorCode::config;
  if (auto ok = open_rig_if_closed(open_code); !ok)
    return finish(job, ScanStatus::failed, open_code, ok.error().describe(), {}, false);

  const config::RigConfig config = this->config();
  // A full disk is found before the LEDs go on, not after the frames are taken.
  if (auto ok = check_free_space(config); !ok)
    return finish(job, ScanStatus::failed, ScanErrorCode::storage, ok.error().describe(), {},
                  false);
  const fs::path directory = capture::default_scan_directory(config, job.submission.sample_id);
  if (auto ok = catalogue_->mark_running(job.id, directory); !ok)
    return finish(job, ScanStatus::failed, ScanErrorCode::storage, ok.error().describe(), {},
                  false);
  log->info("scan {} running into {}", job.id, directory.string());
  attempt_.directory = directory;

  faults_->clear();
  capture::ScanSequencer sequencer(config, *rig_->lights, *rig_->camera);
  {
    std::lock_guard lock(mutex_);
    sequencer_ = &sequencer;
    if (abort_current_) sequencer.request_stop();
  }
  // However run() ends (an exception too): no one reaches the sequencer
  // once it is gone, and the worker knows whether the scan was written.
  const ScopeExit forget_sequencer{[&] {
    attempt_.committed = sequencer.committed();
    std::lock_guard lock(mutex_);
    sequencer_ = nullptr;
  }};
  capture::ScanRequest request = rig_->request(config);
  request.sample_id = job.submission.sample_id;
  request.description = job.submission.description;
  request.directory = directory;
  Stage stage = Stage::acquiring;
  auto outcome = sequencer.capture(request, [&](const capture::ScanProgress& p) {
    if (p.step == "writing") {
      stage = Stage::writing;
      set_step(p.step, kAcquiredPercent, DaemonState::scanning);
    } else if (p.step == "processing") {
      stage = Stage::processing;
      set_step(p.step, kProcessingPercent, DaemonState::processing);
    } else {
      set_step(p.step, kAcquiredPercent * p.done / std::max(1, p.total), DaemonState::scanning);
    }
  });
  {
    std::lock_guard lock(mutex_);
    sequencer_ = nullptr;
  }
  // However it ended (the sequencer did this too; this is the daemon's word).
  if (auto ok = switch_lights_off(); !ok)
    log->error("turning the LEDs off after scan {}: {}", job.id, ok.error().describe());

  // Only what this scan wrote is ever removed: a directory that existed
  // already (a `psrig scan` put it there first) is refused, never deleted.
  const fs::path ours = sequencer.committed() ? directory : fs::path();
  if (aborted())
    return finish(job, ScanStatus::aborted, ScanErrorCode::aborted,
                  "aborted; all LEDs are off and nothing was kept", ours, false);
  if (!outcome) {
    const ScanErrorCode code = classify(outcome.error(), stage);
    // Raw frames that could not be processed are kept: they can be
    // processed again later. Anything less than a whole scan is not.
    std::error_code ec;
    const bool keep =
        !ours.empty() && stage == Stage::processing && fs::exists(directory / "scan.json", ec);
    finish(job, ScanStatus::failed, code, outcome.error().describe(), ours, keep);
    if (code == ScanErrorCode::camera || code == ScanErrorCode::lights) close_rig();
    return;
  }

  stage = Stage::recording;
  fs::path maps;
  nlohmann::json report;
  if (outcome->maps) {
    maps = outcome->maps->maps_directory;
    report = outcome->maps->report;
  }
  if (auto ok = flush_tree(maps.empty() ? outcome->directory : maps); !ok)
    return finish(job, ScanStatus::failed, ScanErrorCode::storage, ok.error().describe(), directory,
                  false);
  if (auto ok = catalogue_->mark_done(job.id, maps, report); !ok)
    return finish(job, ScanStatus::failed, ScanErrorCode::storage, ok.error().describe(), directory,
                  false);
  last_scan_bytes_ = tree_bytes(outcome->directory);
  if (!maps.empty() && maps.parent_path() != outcome->directory)
    last_scan_bytes_ += tree_bytes(maps);
  log->info("scan {} done: {}", job.id, outcome->directory.string());
  {
    std::lock_guard lock(mutex_);
    status_.last_scan = job.id;
    status_.last_error_code = ScanErrorCode::none;
    status_.last_error.clear();
    ++status_.scans_completed;
    status_.current_scan.reset();
    status_.step.clear();
    status_.progress_percent = 0;
    if (!stopping_) status_.state = DaemonState::idle;
  }
  auto event = scan_event(job.id);
  event.update({{"status", "done"},
                {"percent", 100},
                {"scan_directory", outcome->directory.string()},
                {"maps_directory", maps.string()}});
  if (report.contains("ground_truth") && report["ground_truth"].contains("angular_error_deg"))
    event["angular_error_deg"] = report["ground_truth"]["angular_error_deg"]["mean"];
  events_.publish("done", std::move(event));
}

void ScanService::work() {
  auto log = logger("daemon");
  {
    ScanErrorCode ignored;
    if (!open_rig_if_closed(ignored)) log->warn("the rig will be tried again at the next scan");
  }
  {
    std::lock_guard lock(mutex_);
    if (!stopping_) status_.state = DaemonState::idle;
  }
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      // Waking every second to show the worker lives (healthy()).
      while (!wake_.wait_for(lock, std::chrono::seconds(1),
                             [&] { return stopping_ || !queue_.empty() || pending_config_; }))
        beat();
      beat();
      if (stopping_) break;
      if (queue_.empty()) {
        lock.unlock();
        apply_pending_config();
        continue;
      }
      job = std::move(queue_.front());
      queue_.pop_front();
      status_.current_scan = job.id;
      abort_current_ = false;
    }
    try {
      run(job);
    } catch (const std::exception& e) {
      // OpenCV and the standard library may throw; a scan fails, never the
      // daemon. A scan directory already written is not orphaned: whole
      // raw frames are kept with the row naming them (they can be
      // processed again), anything less is removed.
      (void)switch_lights_off();
      const fs::path ours = attempt_.committed ? attempt_.directory : fs::path();
      std::error_code ec;
      const bool keep = !ours.empty() && fs::exists(ours / "scan.json", ec);
      finish(job, ScanStatus::failed, ScanErrorCode::internal,
             std::string("internal error: ") + e.what() +
                 (keep ? "; raw frames kept, reprocess with psrig process" : ""),
             ours, keep);
    }
  }
  close_rig();
}

void ScanService::stop() {
  std::deque<Job> abandoned;
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !worker_.joinable()) return;
    stopping_ = true;
    status_.state = DaemonState::stopping;
    request_abort_locked();
    abandoned.swap(queue_);
  }
  (void)switch_lights_off();
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  for (const auto& job : abandoned)
    if (auto ok = catalogue_->mark_failed(job.id, ScanStatus::aborted, ScanErrorCode::aborted,
                                          "psrigd stopped before this scan started", false);
        !ok)
      logger("daemon")->error("scan {}: {}", job.id, ok.error().describe());
  events_.close();
}

}  // namespace psrig::daemon
