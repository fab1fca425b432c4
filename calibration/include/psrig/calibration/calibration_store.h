#pragma once
// A rig's calibration: the file (psrig-calibration/1, calibration/README.md)
// and the versioned store in the rig's state directory:
//
//   <storage.root>/calibrations/0001/calibration.json
//                                   /captures/...      the images it came from
//   <storage.root>/calibrations/0002/...               the newest is current
//
// Each version appears whole or not at all (processing's AtomicDirectory).

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/calibration/light_calibration.h"
#include "psrig/formats/atomic_directory.h"

namespace psrig::calibration {

inline constexpr const char* kCalibrationFormat = "psrig-calibration/1";
inline constexpr const char* kCalibrationFile = "calibration.json";
inline constexpr const char* kCapturesDirectory = "captures";

// What `psrig calibrate lights` found, ready to be written.
struct LightCalibration {
  std::string method;  // "chrome", "matte" or "chrome+matte"
  CameraModel camera;
  std::optional<Circle> chrome_sphere;
  std::optional<Circle> matte_sphere;
  std::vector<LightEstimate> chrome;                  // per light, when a chrome sphere was given
  std::vector<LightEstimate> matte;                   // per light, when a matte sphere was given
  nlohmann::json sources = nlohmann::json::object();  // the captures, by role
};

// Chrome directions where there are some (more precise), matte's
// otherwise; matte's intensities where there are some, else 1.
struct CalibratedLight {
  cv::Vec3d direction{0, 0, 1};
  double intensity = 1;
  double uncertainty_deg = 0;
  std::optional<double> chrome_vs_matte_deg;
};
[[nodiscard]] std::vector<CalibratedLight> combine(const LightCalibration& calibration);

// The whole file: format, created (UTC ISO-8601), lights, and the sections
// later calibrations fill (flat, colour, scale, led_positions_mm) as null.
[[nodiscard]] nlohmann::json to_json(const LightCalibration& calibration,
                                     const std::string& created);

// A calibration file's lights, checked: bad_input naming the file and key.
// Its flat field, when it has one: one image per light (absolute paths),
// resolved against the version named by the section's "from" when it was
// carried over from an earlier version.
struct StoredCalibration {
  std::filesystem::path file;
  nlohmann::json document;
  std::vector<CalibratedLight> lights;
  std::vector<std::filesystem::path> flat_images;
  std::optional<double> pixel_size_mm;  // its scale section's, when measured
  // Its near LEDs' positions (led_positions_mm.positions), one per light,
  // when measured.
  std::vector<cv::Vec3d> led_positions_mm;
  // Its colour section's matrix (camera RGB to linear sRGB D65), when
  // measured, and the version that measured it ("0003").
  std::optional<cv::Matx33d> colour_matrix;
  std::string colour_version;
  // The flat field's version ("0002"; empty without one) and the one the
  // colour matrix was measured through (its "flat_field"; empty: none).
  // Scans divide their frames by the flats channel by channel, so the
  // matrix holds for the flat field it was measured through only.
  std::string flat_version;
  std::string colour_flat_field;
};
[[nodiscard]] Result<StoredCalibration> read_calibration(const std::filesystem::path& file);

// The calibration a new version starts from: `current`'s document with
// `created` now, and each section it carries over (non-null, other than
// `measured`) marked with "from": the version whose files its paths name
// (kept when already set). bad_input naming the file when it is unusable.
[[nodiscard]] Result<nlohmann::json> carry_forward(const StoredCalibration& current,
                                                   const std::string& measured);

// Now, as UTC ISO-8601 ("2026-01-31T12:00:00Z").
[[nodiscard]] std::string utc_now();

// Writes `text` to `file` through a temporary sibling renamed into place,
// flushed to disk; refuses an existing `file` (bad_input).
[[nodiscard]] Status write_new_file(const std::filesystem::path& file, const std::string& text);

// The store under a rig's state directory (storage.root).
class CalibrationStore {
 public:
  explicit CalibrationStore(std::filesystem::path state_directory)
      : directory_(std::move(state_directory) / "calibrations") {}

  [[nodiscard]] const std::filesystem::path& directory() const { return directory_; }
  // The versions there are, oldest first (0001, 0002, …).
  [[nodiscard]] std::vector<std::filesystem::path> versions() const;
  // The newest version's calibration.json, if any.
  [[nodiscard]] std::optional<std::filesystem::path> current() const;
  // A staging directory for the next version (creating the store's
  // directory when needed): write calibration.json and captures/ into its
  // path(), then commit(Existing::refuse, true).
  [[nodiscard]] Result<formats::AtomicDirectory> begin_next() const;

 private:
  std::filesystem::path directory_;
};

}  // namespace psrig::calibration
