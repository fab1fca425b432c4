#pragma once
// One scan: an optional dark frame, then for each LED: on, settle, skip the
// frames whose exposure began before the LED was on or ended after it went
// off (stale) and the frames to discard, average the next ones, off. Once
// the camera's frame period is known, the next LED switches in the readout
// gap after the last exposure a phase needs, so no frame is wasted on the
// switch. The scan directory is written
// atomically with its capture metadata, then processed into maps. Every
// failure, and a stop request (SIGINT/SIGTERM), leaves all LEDs off and
// says what failed.

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "psrig/cameras/camera.h"
#include "psrig/config/rig_config.h"
#include "psrig/formats/scan.h"
#include "psrig/lights/safe_lights.h"
#include "psrig/processing/pipeline.h"

namespace psrig::rig {

// A light calibration applied to a scan: its directions and relative
// intensities replace the configuration's geometry, and scan.json says
// which calibration it was (calibration/README.md).
struct AppliedCalibration {
  std::filesystem::path file;  // the calibration.json
  std::string created;         // its "created"
  std::vector<cv::Vec3d> directions;
  std::vector<double> intensities;
  // Its flat field, one frame per light (linear, dark subtracted, 65535 =
  // full scale), when it has one: written into the scan as its flats, the
  // lights' intensities then 1 (the flats carry the LEDs' brightness).
  std::vector<cv::Mat> flats;
  // Its measured pixel size (psrig calibrate scale), replacing
  // geometry.pixel_size_mm.
  std::optional<double> pixel_size_mm;
  // Its measured LED positions (psrig calibrate lights --places), one per
  // light, mm from the camera axis on the reference plane, replacing
  // rig.toml's geometry; empty: not measured.
  std::vector<cv::Vec3d> led_positions_mm;
  // Its colour matrix (psrig calibrate colour: camera RGB to linear sRGB
  // D65) and the version that measured it, written into colour scans'
  // scan.json as `colour_correction` for processing to apply to the albedo.
  std::optional<cv::Matx33d> colour_matrix;
  std::string colour_version;
};

struct ScanRequest {
  std::string sample_id;  // a technician's label; may be empty
  std::string description;
  std::filesystem::path directory;  // the scan to create; empty: storage.root/<time>-<sample id>
  std::optional<bool> process;      // override capture.process
  // The lights as calibrated (one per channel); absent: rig.toml's
  // geometry and lights.intensity, and scan.json's "calibration" is null.
  std::optional<AppliedCalibration> calibration;
};

// What a scan is doing, for code that acts on it (the step is for people).
enum class ScanStage { acquiring, writing, processing };

struct ScanProgress {
  ScanStage stage = ScanStage::acquiring;
  std::string step;  // "dark frame", "light 1 of 3", "writing", "processing"
  int done = 0;
  int total = 0;
};

// Where the time of one acquisition went, for the scan-cycle benchmark.
struct CaptureTiming {
  std::chrono::duration<double, std::milli> total{};  // camera start to the last frame
  int frames_kept = 0;
  int frames_skipped = 0;  // stale or discarded
};

struct ScanOutcome {
  std::filesystem::path directory;
  std::optional<processing::ProcessSummary> maps;
  CaptureTiming timing;
};

class ScanSequencer {
 public:
  ScanSequencer(const config::RigConfig& config, lights::SafeLights& lights,
                cameras::Camera& camera);

  // Frames only (no files): what capture() writes.
  [[nodiscard]] Result<formats::Scan> acquire(
      const ScanRequest& request, CaptureTiming& timing,
      const std::function<void(const ScanProgress&)>& progress = {});

  // acquire(), then the scan directory, then (if asked) the maps.
  [[nodiscard]] Result<ScanOutcome> capture(
      const ScanRequest& request, const std::function<void(const ScanProgress&)>& progress = {});

  // Something else can ask the scan in progress to stop (the daemon's
  // DELETE, a test); SIGINT/SIGTERM do it through emergency_stop.h.
  void request_stop() { stop_ = true; }

  // The last capture() wrote its scan directory (whatever happened after):
  // what it may clean up. False when it refused a directory that already
  // existed, someone else's scan.
  [[nodiscard]] bool committed() const { return committed_; }

 private:
  struct Lighting;
  struct Phase;
  Result<Lighting> switch_lights(int channel, Lighting& previous);
  // The sum of the phase's frames kept (camera.frames_average of them).
  Result<cv::Mat> collect(const Phase& phase, const Phase* next, Lighting& lighting,
                          CaptureTiming& timing, cameras::Frame& first);
  Result<cameras::Frame> grab();
  // Intensities set, every LED off, then the first phase's LED on and settled.
  Result<Lighting> light_first_phase(const Phase& first, const std::vector<double>& intensity);
  // scan.json's description of an acquired scan: sample, levels, pixel size,
  // the capture record and what the calibration applied.
  void describe_scan(const ScanRequest& request, const cameras::Frame& reference, double scale,
                     const CaptureTiming& timing, int phases, const std::string& started,
                     formats::Scan& scan) const;
  [[nodiscard]] std::optional<lights::Clock::time_point> switch_time_in_readout_gap(
      const Lighting& lighting) const;

  const config::RigConfig& config_;
  lights::SafeLights& lights_;
  cameras::Camera& camera_;
  std::atomic<bool> stop_{false};
  bool committed_ = false;

  // The camera's rhythm, learnt from the frames: the last one seen and the
  // frame period, so the next LED can switch in the gap between one
  // exposure's end and the next one's start.
  std::optional<cameras::Frame> last_frame_;
  std::optional<lights::Clock::duration> period_;
  lights::Clock::duration switch_time_{};  // the longest an LED switch has taken
};

// The longest one phase of a scan (the dark frame or one LED) may take
// under `config`: its settling, and every grab it may make (the stale
// frames it tolerates, the discarded and averaged ones, and the one that
// switches to the next phase) each taking camera.timeout_ms.
[[nodiscard]] std::chrono::milliseconds worst_phase_duration(const config::RigConfig& config);

// storage.root/<YYYYMMDD-HHMMSS>-<sample id>, with the id made safe as a name.
[[nodiscard]] std::filesystem::path default_scan_directory(const config::RigConfig& config,
                                                           const std::string& sample_id);

}  // namespace psrig::rig
