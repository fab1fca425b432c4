#include "psrig/capture/scan_sequencer.h"

#include <opencv2/imgproc.hpp>

#include <cctype>
#include <cmath>
#include <ctime>
#include <numbers>
#include <thread>

#include "psrig/capture/scan_writer.h"
#include "psrig/firmware_host/emergency_stop.h"
#include "psrig/processing/log.h"

namespace psrig::capture {
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

cv::Vec3d light_direction(const config::RigConfig& config, int channel) {
  const double slant = config.geometry.slant_deg * std::numbers::pi / 180;
  const double tilt = config.geometry.tilts_deg.at(static_cast<std::size_t>(channel)) * std::numbers::pi / 180;
  return {std::cos(tilt) * std::sin(slant), std::sin(tilt) * std::sin(slant), std::cos(slant)};
}

// Turns the lights off and stops the camera however acquire() ends.
struct RigGuard {
  firmware_host::SafeLights& lights;
  Camera& camera;
  ~RigGuard() {
    (void)lights.all_off();
    (void)camera.stop();
  }
};

}  // namespace

ScanSequencer::ScanSequencer(const config::RigConfig& config, firmware_host::SafeLights& lights, Camera& camera)
    : config_(config), lights_(lights), camera_(camera) {}

Result<Frame> ScanSequencer::next_valid_frame(Clock::time_point valid_from, int& skipped) {
  for (int stale = 0;; ++stale) {
    if (stop_ || firmware_host::stop_requested())
      return std::unexpected(processing::internal_error("scan interrupted; all LEDs are off"));
    auto frame = camera_.grab(milliseconds(config_.camera.timeout_ms));
    if (!frame) return frame;
    // A frame counts only if its exposure began after the LED was on and settled.
    if (frame->exposure_start >= valid_from) return frame;
    ++skipped;
    if (stale >= kMaxStaleFrames)
      return std::unexpected(processing::io_error(camera_.describe(),
                                                  "every frame started exposing before the LED switched on: the "
                                                  "camera's timestamps or queue are wrong"));
  }
}

Result<cv::Mat> ScanSequencer::average(Clock::time_point valid_from, CaptureTiming& timing, Frame& first) {
  for (int i = 0; i < config_.camera.frames_discard; ++i) {
    auto frame = next_valid_frame(valid_from, timing.frames_skipped);
    if (!frame) return std::unexpected(frame.error());
    ++timing.frames_skipped;
  }
  cv::Mat sum;
  for (int i = 0; i < config_.camera.frames_average; ++i) {
    auto frame = next_valid_frame(valid_from, timing.frames_skipped);
    if (!frame) return std::unexpected(frame.error());
    if (sum.empty()) {
      first = *frame;
      sum = cv::Mat::zeros(frame->image.size(), CV_MAKETYPE(CV_32F, frame->image.channels()));
    } else if (frame->image.size() != first.image.size() || frame->image.channels() != first.image.channels()) {
      return std::unexpected(processing::io_error(camera_.describe(), "the frame size or format changed mid-scan"));
    }
    cv::accumulate(frame->image, sum);
    ++timing.frames_kept;
  }
  sum.convertTo(sum, CV_32F, 1.0 / config_.camera.frames_average);
  return sum;
}

Result<processing::Scan> ScanSequencer::acquire(const ScanRequest& request, CaptureTiming& timing,
                                                const std::function<void(const ScanProgress&)>& progress) {
  const int lights = lights_.channel_count();
  const int steps = lights + (config_.capture.dark_frame ? 1 : 0);
  int step = 0;
  const auto report = [&](const std::string& what) {
    if (progress) progress({what, step, steps});
  };
  const auto settle = milliseconds(config_.capture.settle_ms);
  const std::string started = iso_time();
  RigGuard guard{lights_, camera_};
  const auto start = Clock::now();
  if (auto ok = lights_.all_off(); !ok) return std::unexpected(ok.error());
  if (auto ok = camera_.start(); !ok) return std::unexpected(ok.error());

  // Frames are averaged in float and stored as 16-bit integers scaled up to
  // use the whole range, so the averaging's extra precision is kept.
  processing::Scan scan;
  Frame reference;
  double scale = 1;
  const auto store = [&](const cv::Mat& mean) {
    cv::Mat stored;
    mean.convertTo(stored, CV_16U, scale);
    return stored;
  };

  if (config_.capture.dark_frame) {
    report("dark frame");
    const auto off_at = Clock::now();
    std::this_thread::sleep_until(off_at + settle);
    auto dark = average(off_at + settle, timing, reference);
    if (!dark) return std::unexpected(dark.error());
    scale = std::max(1.0, std::floor(65535.0 / reference.white_level));
    scan.dark = store(*dark);
    ++step;
  }
  std::vector<double> intensity = config_.lights.intensity;
  intensity.resize(static_cast<std::size_t>(lights), 1.0);
  for (int k = 0; k < lights; ++k) {
    report("light " + std::to_string(k + 1) + " of " + std::to_string(lights));
    if (auto ok = lights_.set_intensity(k, intensity[k]); !ok) return std::unexpected(ok.error());
    if (auto ok = lights_.turn_on(k); !ok) return std::unexpected(ok.error());
    const auto lit_since = lights_.lit()->second;
    std::this_thread::sleep_until(lit_since + settle);
    Frame first;
    auto mean = average(lit_since + settle, timing, first);
    if (!mean) return std::unexpected(mean.error());
    // The watchdog may have stepped in while we averaged.
    const auto still = lights_.lit();
    if (!still || still->first != k)
      return std::unexpected(processing::internal_error(
          "LED " + std::to_string(k) + " went off during its exposures (lights.max_on_ms is " +
          std::to_string(config_.lights.max_on_ms) + " ms: raise it, or shorten the exposure)"));
    if (auto ok = lights_.all_off(); !ok) return std::unexpected(ok.error());
    if (reference.image.empty()) {
      reference = first;
      scale = std::max(1.0, std::floor(65535.0 / reference.white_level));
    }
    scan.frames.push_back(store(*mean));
    scan.description.lights.push_back(
        {"led" + std::to_string(k) + ".png", light_direction(config_, k), cv::Vec3d::all(intensity[k]), false});
    ++step;
  }
  timing.total = Clock::now() - start;

  scan.ground_truth_normal = request.ground_truth_normal;
  scan.ground_truth_height = request.ground_truth_height;
  auto& d = scan.description;
  d.sample_id = request.sample_id;
  d.sample_description = request.description;
  d.encoding = processing::Encoding::linear;
  d.black_level = reference.black_level * scale;
  d.white_level = reference.white_level * scale;
  scan.white_level = *d.white_level;
  d.pixel_size_mm = config_.geometry.pixel_size_mm;
  d.document = {{"capture",
                 {{"camera", camera_.describe()},
                  {"lights", lights_.describe()},
                  {"exposure_us", reference.exposure_us},
                  {"gain", reference.gain},
                  {"frames_averaged", config_.camera.frames_average},
                  {"frames_discarded", config_.camera.frames_discard},
                  {"frames_skipped_stale", timing.frames_skipped - config_.camera.frames_discard * steps},
                  {"settle_ms", config_.capture.settle_ms},
                  {"stored_scale", scale},
                  {"started", started},
                  {"finished", iso_time()}}}};
  return scan;
}

Result<ScanOutcome> ScanSequencer::capture(const ScanRequest& request,
                                           const std::function<void(const ScanProgress&)>& progress) {
  ScanOutcome outcome;
  auto scan = acquire(request, outcome.timing, progress);
  if (!scan) return std::unexpected(scan.error());
  outcome.directory = request.directory.empty() ? default_scan_directory(config_, request.sample_id) : request.directory;
  if (progress) progress({"writing", 0, 1});
  std::error_code ec;
  fs::create_directories(outcome.directory.parent_path(), ec);
  if (auto ok = write_scan(*scan, outcome.directory); !ok) return std::unexpected(ok.error());
  if (request.process.value_or(config_.capture.process)) {
    if (progress) progress({"processing", 0, 1});
    auto maps = processing::process_scan(outcome.directory);
    if (!maps) return std::unexpected(maps.error());
    outcome.maps = std::move(*maps);
  }
  return outcome;
}

fs::path default_scan_directory(const config::RigConfig& config, const std::string& sample_id) {
  std::string name = compact_time() + "-";
  for (char c : sample_id.empty() ? std::string("scan") : sample_id)
    name += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.') ? c : '_';
  fs::path path = config.storage.root / name;
  std::error_code ec;
  for (int n = 2; fs::exists(path, ec); ++n) path = config.storage.root / (name + "-" + std::to_string(n));
  return path;
}

}  // namespace psrig::capture
