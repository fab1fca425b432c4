#include "psrig/rig/scan_sequencer.h"

#include <cctype>
#include <cmath>
#include <ctime>
#include <optional>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "psrig/base/log.h"
#include "psrig/formats/light_matrix.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/rig/storage_settings.h"

namespace psrig::rig {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono;

// A camera that keeps delivering frames from before the switch has broken
// timestamps or a stuck queue: give up rather than wait forever.
constexpr int kMaxStaleFrames = 64;

std::tm utc_now() {
  const std::time_t now = system_clock::to_time_t(system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  return utc;
}
// 2026-11-21T17:05:00Z, for the record.
std::string iso_time() {
  const std::tm utc = utc_now();
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}
// 20261121-170500, for a directory name that sorts by time.
std::string compact_time() {
  const std::tm utc = utc_now();
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &utc);
  return text;
}

// Turns the lights off and stops the camera however acquire() ends.
struct RigGuard {
  lights::SafeLights& lights;
  cameras::Camera& camera;
  ~RigGuard() {
    (void)lights.all_off();
    (void)camera.stop();
  }
};

// Slack on either side of a switch timed into the readout gap, for the
// scheduler's jitter.
constexpr auto kSwitchMargin = 1ms;

// Whether the calibration's flats fit frames like `frame` (one per light,
// same size and channels).
bool use_flats(const std::optional<AppliedCalibration>& calibration, const cv::Mat& frame) {
  if (!calibration || calibration->flats.empty() ||
      calibration->flats.size() != calibration->directions.size())
    return false;
  for (const auto& flat : calibration->flats)
    if (flat.size() != frame.size() || flat.channels() != frame.channels()) return false;
  return true;
}

// The scan's light for `channel` (its frame `stored`): direction and
// intensity as calibrated, else from rig.toml; near-field LEDs with their
// position, relative to the swatch's top (swatch_height_mm above the plane
// they were measured from).
formats::ScanLight scan_light(const config::RigConfig& config, const ScanRequest& request,
                              int phase_channel, const cv::Mat& stored,
                              const std::vector<double>& intensity) {
  const auto channel = static_cast<std::size_t>(phase_channel);
  const auto& calibrated = request.calibration;
  const bool use_calibration = calibrated && channel < calibrated->directions.size() &&
                               channel < calibrated->intensities.size();
  const bool flat_fielded = use_flats(calibrated, stored);
  formats::ScanLight light{formats::scan_files::led_frame(phase_channel, stored.depth()),
                           use_calibration
                               ? calibrated->directions[channel]
                               : formats::light_direction(config.geometry.tilts_deg.at(channel),
                                                          config.geometry.slant_deg),
                           cv::Vec3d::all(flat_fielded      ? 1.0
                                          : use_calibration ? calibrated->intensities[channel]
                                                            : intensity[phase_channel]),
                           false, std::nullopt};
  const auto positions = config::led_positions_mm(config.geometry);
  const bool measured =
      calibrated &&
      calibrated->led_positions_mm.size() == static_cast<std::size_t>(config.lights.channels) &&
      channel < calibrated->led_positions_mm.size();
  std::optional<cv::Vec3d> position;
  if (measured)
    position = calibrated->led_positions_mm[channel];
  else if (channel < positions.size())
    position = cv::Vec3d(positions[channel][0], positions[channel][1], positions[channel][2]);
  if (position) {
    (*position)[2] -= config.geometry.swatch_height_mm;
    light.position_mm = position;
  }
  return light;
}

// What the rig's calibration brings to the scan: the flats as frames, the
// colour matrix for colour frames, and scan.json's `calibration` saying
// which parts were applied.
void apply_calibration(const config::RigConfig& config, const ScanRequest& request, bool scaled,
                       formats::Scan& scan) {
  auto& d = scan.description;
  // The calibration's flats, as frames of this scan: its dark (or black
  // level) plus the card's signal, so processing's dark subtraction leaves
  // the signal; 0.9 of the range at full scale.
  const bool flat_fielded =
      !scan.frames.empty() && use_flats(request.calibration, scan.frames.front());
  if (flat_fielded) {
    const double range = 0.9 * (*d.white_level - d.black_level) / 65535.0;
    for (const auto& flat : request.calibration->flats) {
      cv::Mat code;
      flat.convertTo(code, CV_32F, range);
      if (!scan.dark.empty()) {
        cv::Mat dark;
        scan.dark.convertTo(dark, CV_32F);
        code += dark;
      } else {
        code += d.black_level;
      }
      cv::Mat stored;
      code.convertTo(stored, CV_16U);
      scan.flats.push_back(stored);
      d.flats.push_back(
          formats::scan_files::flat_frame(static_cast<int>(scan.flats.size() - 1), stored.depth()));
    }
  } else if (request.calibration && !request.calibration->flats.empty()) {
    logger("capture")->warn(
        "the flat field of {} does not fit this camera's frames (size or channels), so this "
        "scan goes without flats: run psrig calibrate flat again",
        request.calibration->file.string());
  }
  nlohmann::json applied = nlohmann::json::array({"lights"});
  if (flat_fielded) applied.push_back("flat");
  if (scaled) applied.push_back("scale");
  if (request.calibration &&
      request.calibration->led_positions_mm.size() ==
          static_cast<std::size_t>(config.lights.channels) &&
      d.near_field())
    applied.push_back("led_positions_mm");
  // The colour matrix goes with colour frames only; processing applies it.
  const bool coloured = request.calibration && request.calibration->colour_matrix &&
                        !scan.frames.empty() && scan.frames.front().channels() == 3;
  if (coloured) {
    const cv::Matx33d& m = *request.calibration->colour_matrix;
    d.document["colour_correction"] = {
        {"matrix",
         {{m(0, 0), m(0, 1), m(0, 2)}, {m(1, 0), m(1, 1), m(1, 2)}, {m(2, 0), m(2, 1), m(2, 2)}}},
        {"space", "sRGB D65"},
        {"calibration", request.calibration->colour_version}};
    applied.push_back("colour");
  }
  d.document["calibration"] = request.calibration
                                  ? nlohmann::json{{"file", request.calibration->file.string()},
                                                   {"created", request.calibration->created},
                                                   {"applied", applied}}
                                  : nlohmann::json(nullptr);
}

}  // namespace

// What the LEDs did over a stretch of time: `channel` (-1: all off) was
// lit from at latest `since` until at earliest `until`.
struct ScanSequencer::Lighting {
  int channel = -1;
  lights::Clock::time_point since;
  lights::Clock::time_point until = lights::Clock::time_point::max();
};

// One lighting state the scan records: dark or one LED.
struct ScanSequencer::Phase {
  int channel = -1;
  std::string label;
};

ScanSequencer::ScanSequencer(const config::RigConfig& config, lights::SafeLights& lights,
                             cameras::Camera& camera)
    : config_(config), lights_(lights), camera_(camera) {}

Result<ScanSequencer::Lighting> ScanSequencer::switch_lights(int channel, Lighting& previous) {
  const auto stopping = [&] { return stop_ || lights::stop_requested(); };
  const auto interrupted = [&]() -> Result<Lighting> {
    (void)lights_.all_off();
    return std::unexpected(internal_error("scan interrupted; all LEDs are off"));
  };
  // A stop (lights-off, abort, a signal) is flagged first, then every LED
  // is switched off: checked just before a switch, so that no LED comes
  // on again after that all-off, and just after it, for a stop flagged
  // between the check and the switch (its all-off may have come first).
  if (channel >= 0 && stopping()) return interrupted();
  const auto before = lights::Clock::now();
  if (auto ok = channel < 0 ? lights_.all_off() : lights_.turn_on(channel); !ok)
    return std::unexpected(ok.error());
  if (channel >= 0 && stopping()) return interrupted();
  const auto after = lights::Clock::now();
  switch_time_ = std::max(switch_time_, after - before);
  previous.until = before;  // the old state may have ended as soon as the call began...
  const auto lit = lights_.lit();
  return Lighting{
      channel, channel < 0 || !lit ? after : lit->second};  // ...the new one began when it returned
}

Result<cameras::Frame> ScanSequencer::grab() {
  if (stop_ || lights::stop_requested())
    return std::unexpected(internal_error("scan interrupted; all LEDs are off"));
  auto frame = camera_.grab(milliseconds(config_.camera.timeout_ms));
  if (!frame) return frame;
  // What the frames show beats what the camera says.
  if (last_frame_ && frame->sequence > last_frame_->sequence &&
      frame->exposure_start > last_frame_->exposure_start)
    period_ = (frame->exposure_start - last_frame_->exposure_start) /
              static_cast<std::int64_t>(frame->sequence - last_frame_->sequence);
  else if (frame->frame_interval > lights::Clock::duration::zero())
    period_ = frame->frame_interval;
  last_frame_ = *frame;
  return frame;
}

// When to switch to the next phase: just after the exposure now in
// progress ends. Nothing unless that frame is the next one grab() returns,
// it is valid for `lighting`, and the gap after its exposure holds a switch
// and the settling time before the following exposure starts.
std::optional<lights::Clock::time_point> ScanSequencer::switch_time_in_readout_gap(
    const Lighting& lighting) const {
  if (!last_frame_ || !period_ || *period_ <= lights::Clock::duration::zero()) return std::nullopt;
  const auto settle = milliseconds(config_.capture.settle_ms);
  const auto exposure = last_frame_->exposure_end - last_frame_->exposure_start;
  const auto next_start = last_frame_->exposure_start + *period_;
  const auto next_end = next_start + exposure;
  const auto following_start = next_start + *period_;
  if (lights::Clock::now() < next_end && next_start >= lighting.since + settle &&
      next_end + kSwitchMargin + switch_time_ + settle + kSwitchMargin <= following_start)
    return next_end + kSwitchMargin;
  return std::nullopt;
}

Result<cv::Mat> ScanSequencer::collect(const Phase& phase, const Phase* next, Lighting& lighting,
                                       CaptureTiming& timing, cameras::Frame& first) {
  const auto settle = milliseconds(config_.capture.settle_ms);
  const int needed = config_.camera.frames_discard + config_.camera.frames_average;
  int kept = 0, stale = 0;
  bool switch_early = next != nullptr;  // until a timed switch misses once
  cv::Mat sum;
  const auto still_lit = [&]() -> Status {
    const auto lit = lights_.lit();
    if (phase.channel >= 0 && (!lit || lit->first != phase.channel))
      return std::unexpected(internal_error("LED " + std::to_string(phase.channel) +
                                            " went off during its exposures (lights.max_on_ms is " +
                                            std::to_string(config_.lights.max_on_ms) +
                                            " ms: raise it, or shorten the exposure)")
                                 .with(ErrorCode::lights));
    return {};
  };
  while (kept < needed) {
    std::optional<Lighting> switched;
    const auto switch_at =
        switch_early && kept == needed - 1 ? switch_time_in_readout_gap(lighting) : std::nullopt;
    if (switch_at) {
      std::this_thread::sleep_until(*switch_at);
      if (auto ok = still_lit(); !ok) return std::unexpected(ok.error());
      auto now_lit = switch_lights(next->channel, lighting);
      if (!now_lit) return std::unexpected(now_lit.error());
      switched = *now_lit;
    }
    auto frame = grab();
    if (!frame) return std::unexpected(frame.error());
    // A frame counts only if the whole exposure saw this phase's lighting.
    const bool valid =
        frame->exposure_start >= lighting.since + settle && frame->exposure_end <= lighting.until;
    if (switched && !valid) {
      // The camera's timing moved: back to this phase, and no more tricks.
      switch_early = false;
      auto again = switch_lights(phase.channel, *switched);
      if (!again) return std::unexpected(again.error());
      lighting = *again;
      switched.reset();
    }
    if (!valid) {
      ++timing.frames_skipped;
      if (++stale > kMaxStaleFrames)
        return std::unexpected(
            io_error(camera_.describe(), "no frame exposed wholly under " + phase.label +
                                             ": the camera's timestamps or queue are wrong")
                .with(ErrorCode::camera));
      continue;
    }
    if (++kept <= config_.camera.frames_discard) {
      ++timing.frames_skipped;
    } else {
      if (sum.empty()) {
        // Its settings only: at 12 MP a frame held to the end is 72 MB.
        first = *frame;
        first.image = cv::Mat();
        // In 16 bits where the frames cannot overflow them (a 12-bit sensor
        // averaging up to 16), else in float: at 12 MP that halves the sum.
        const bool exact_in_16 = frame->image.depth() <= CV_16U &&
                                 frame->white_level * config_.camera.frames_average <= 65535;
        sum = cv::Mat::zeros(frame->image.size(),
                             CV_MAKETYPE(exact_in_16 ? CV_16U : CV_32F, frame->image.channels()));
      } else if (frame->image.size() != sum.size() || frame->image.channels() != sum.channels()) {
        return std::unexpected(
            io_error(camera_.describe(), "the frame size or format changed mid-scan")
                .with(ErrorCode::camera));
      }
      if (sum.depth() == CV_16U)
        cv::add(frame->image, sum, sum, cv::noArray(), CV_16U);
      else
        cv::accumulate(frame->image, sum);
      ++timing.frames_kept;
    }
    if (switched) {
      lighting = *switched;  // the next phase is already lit
      break;
    }
  }
  if (lighting.channel == phase.channel)
    if (auto ok = still_lit(); !ok) return std::unexpected(ok.error());
  return sum;
}

Result<formats::Scan> ScanSequencer::acquire(
    const ScanRequest& request, CaptureTiming& timing,
    const std::function<void(const ScanProgress&)>& progress) {
  const int lights = lights_.channel_count();
  std::vector<Phase> phases;
  if (config_.capture.dark_frame) phases.push_back({-1, "dark frame"});
  for (int k = 0; k < lights; ++k)
    phases.push_back({k, "light " + std::to_string(k + 1) + " of " + std::to_string(lights)});

  const std::string started = iso_time();
  RigGuard guard{lights_, camera_};
  last_frame_.reset();
  period_.reset();
  std::vector<double> intensity = config_.lights.intensity;
  intensity.resize(static_cast<std::size_t>(lights), 1.0);
  auto lit = light_first_phase(phases.front(), intensity);
  if (!lit) return std::unexpected(lit.error());
  Lighting lighting = *lit;
  const auto start = lights::Clock::now();
  if (auto ok = camera_.start(); !ok) return std::unexpected(ok.error());

  // Each phase's frames are summed, then stored as their mean in 16-bit
  // integers scaled up to use the whole range, so the averaging's extra
  // precision is kept.
  formats::Scan scan;
  std::optional<cameras::Frame> reference;  // the first frame's settings
  double scale = 1;
  for (std::size_t p = 0; p < phases.size(); ++p) {
    const Phase& phase = phases[p];
    if (progress)
      progress({ScanStage::acquiring, phase.label, static_cast<int>(p),
                static_cast<int>(phases.size())});
    if (lighting.channel != phase.channel) {
      auto now_lit = switch_lights(phase.channel, lighting);
      if (!now_lit) return std::unexpected(now_lit.error());
      lighting = *now_lit;
    }
    cameras::Frame first;
    auto sum =
        collect(phase, p + 1 < phases.size() ? &phases[p + 1] : nullptr, lighting, timing, first);
    if (!sum) return std::unexpected(sum.error());
    if (!reference) {
      reference = first;
      scale = std::max(1.0, std::floor(65535.0 / reference->white_level));
    }
    cv::Mat stored;
    sum->convertTo(stored, CV_16U, scale / config_.camera.frames_average);
    sum->release();
    if (phase.channel < 0) {
      scan.dark = stored;
    } else {
      scan.frames.push_back(stored);
      scan.description.lights.push_back(
          scan_light(config_, request, phase.channel, stored, intensity));
    }
  }
  if (auto ok = lights_.all_off(); !ok) return std::unexpected(ok.error());
  timing.total = lights::Clock::now() - start;
  describe_scan(request, *reference, scale, timing, static_cast<int>(phases.size()), started, scan);
  return scan;
}

Result<ScanSequencer::Lighting> ScanSequencer::light_first_phase(
    const Phase& first, const std::vector<double>& intensity) {
  for (int k = 0; k < static_cast<int>(intensity.size()); ++k)
    if (auto ok = lights_.set_intensity(k, intensity[k]); !ok) return std::unexpected(ok.error());
  Lighting lighting;
  {
    auto off = switch_lights(-1, lighting);
    if (!off) return std::unexpected(off.error());
    lighting = *off;
  }
  // Start with the first phase lit and settled, so the first frame counts.
  if (first.channel >= 0) {
    auto on = switch_lights(first.channel, lighting);
    if (!on) return std::unexpected(on.error());
    lighting = *on;
  }
  std::this_thread::sleep_until(lighting.since + milliseconds(config_.capture.settle_ms));
  return lighting;
}

void ScanSequencer::describe_scan(const ScanRequest& request, const cameras::Frame& reference,
                                  double scale, const CaptureTiming& timing, int phases,
                                  const std::string& started, formats::Scan& scan) const {
  auto& d = scan.description;
  d.sample_id = request.sample_id;
  d.sample_description = request.description;
  d.encoding = reference.encoding;
  d.black_level = reference.black_level * scale;
  d.white_level = reference.white_level * scale;
  scan.white_level = *d.white_level;
  const bool scaled = request.calibration && request.calibration->pixel_size_mm;
  d.pixel_size_mm = scaled ? *request.calibration->pixel_size_mm : config_.geometry.pixel_size_mm;
  if (d.near_field() && !scan.frames.empty())  // rig.toml's, else the image centre
    d.principal_point_px = config_.camera.principal_point_px
                               ? cv::Point2d((*config_.camera.principal_point_px)[0],
                                             (*config_.camera.principal_point_px)[1])
                               : cv::Point2d(0.5 * (scan.frames.front().cols - 1),
                                             0.5 * (scan.frames.front().rows - 1));
  d.document = {
      {"capture",
       {{"camera", camera_.describe()},
        {"lights", lights_.describe()},
        {"exposure_us", reference.exposure_us},
        {"gain", reference.gain},
        {"frames_averaged", config_.camera.frames_average},
        {"frames_discarded", config_.camera.frames_discard},
        {"frames_skipped_stale", timing.frames_skipped - config_.camera.frames_discard * phases},
        {"frames_kept", timing.frames_kept},
        {"frames_skipped", timing.frames_skipped},
        {"capture_ms", std::round(timing.total.count() * 10) / 10},
        {"settle_ms", config_.capture.settle_ms},
        {"stored_scale", scale},
        {"started", started},
        {"finished", iso_time()}}}};
  apply_calibration(config_, request, scaled, scan);
  camera_.describe_scene(scan);  // a simulated camera's ground truth
}

Result<ScanOutcome> ScanSequencer::capture(
    const ScanRequest& request, const std::function<void(const ScanProgress&)>& progress) {
  committed_ = false;
  ScanOutcome outcome;
  outcome.directory = request.directory.empty() ? default_scan_directory(config_, request.sample_id)
                                                : request.directory;
  // Refused before the LEDs go on, not after (write_scan checks again).
  if (std::error_code ec; fs::exists(outcome.directory, ec))
    return std::unexpected(
        bad_input(outcome.directory, "", "already exists; a scan is never overwritten"));
  auto scan = acquire(request, outcome.timing, progress);
  if (!scan) return std::unexpected(scan.error());
  if (progress) progress({ScanStage::writing, "writing", 0, 1});
  std::error_code ec;
  fs::create_directories(outcome.directory.parent_path(), ec);
  if (auto ok = formats::write_scan(*scan, outcome.directory, storage_options(config_.storage));
      !ok)
    return std::unexpected(ok.error());
  committed_ = true;
  if (request.process.value_or(config_.capture.process)) {
    // The frames go to processing from memory, as stored: not read back.
    auto stored = formats::as_stored(std::move(*scan), outcome.directory);
    if (!stored) return std::unexpected(stored.error());
    if (progress) progress({ScanStage::processing, "processing", 0, 1});
    processing::ProcessOptions options;
    options.solve.reject_outliers = config_.processing.reject;  // [processing] reject
    options.storage = storage_options(config_.storage);         // [storage]
    auto maps = processing::process_scan(std::move(*stored), outcome.directory, options);
    if (!maps) return std::unexpected(maps.error());
    outcome.maps = std::move(*maps);
  }
  return outcome;
}

milliseconds worst_phase_duration(const config::RigConfig& config) {
  const auto grabs = static_cast<std::int64_t>(kMaxStaleFrames + config.camera.frames_discard +
                                               config.camera.frames_average + 1);
  return milliseconds(grabs * config.camera.timeout_ms + config.capture.settle_ms);
}

fs::path default_scan_directory(const config::RigConfig& config, const std::string& sample_id) {
  std::string name = compact_time() + "-";
  for (char c : sample_id.empty() ? std::string("scan") : sample_id)
    name +=
        (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.') ? c : '_';
  fs::path path = config.storage.root / name;
  std::error_code ec;
  for (int n = 2; fs::exists(path, ec); ++n)
    path = config.storage.root / (name + "-" + std::to_string(n));
  return path;
}

}  // namespace psrig::rig
