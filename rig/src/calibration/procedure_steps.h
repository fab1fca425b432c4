#pragma once
// The calibration procedures' shared steps (load and locate a sphere's
// images, stage and commit a store version, capture a target on the rig,
// average captures) and each procedure's entry point, one file each:
// lights.cpp, near_field.cpp, flat.cpp, scale.cpp, colour.cpp. Private to
// rig/.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/calibration/calibration_store.h"
#include "psrig/calibration/colour.h"
#include "psrig/calibration/image_set.h"
#include "psrig/calibration/light_calibration.h"
#include "psrig/calibration/scale.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/processing/linearise.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/rig_calibration.h"
#include "psrig/rig/scan_sequencer.h"

namespace psrig::rig {

namespace fs = std::filesystem;
using calibration::LightFrames;

// The images of one sphere, grouped by light.
struct SphereSet {
  std::string role;  // "chrome" or "matte"
  fs::path source;   // the folder, or the rig's captures
  std::vector<LightFrames> lights;
  cv::Mat mask;
  std::optional<fs::path> mask_file;
  std::vector<fs::path> files;
};

[[nodiscard]] Result<SphereSet> load_folder(const std::string& role, const fs::path& folder,
                                            const std::string& mask_override, int frames_per_light,
                                            formats::Encoding encoding);

// A frame as stored, in linear float (its channels kept).
[[nodiscard]] cv::Mat linearised(const processing::CodeLineariser& lineariser,
                                 const cv::Mat& stored);

// Scans the sequencer wrote, as frames per light: linear, dark subtracted.
[[nodiscard]] Result<SphereSet> load_captures(const std::string& role,
                                              const std::vector<fs::path>& scans);

[[nodiscard]] Result<calibration::Circle> locate(const SphereSet& set);

[[nodiscard]] Result<calibration::LightCalibration> compute(const SphereSet* chrome,
                                                            const SphereSet* matte,
                                                            const calibration::CameraModel& camera,
                                                            double saturation);

[[nodiscard]] nlohmann::json describe_sources(const SphereSet& set, const fs::path& relative_to);

// Copies a set's files into `captures/<role>/` of a store version.
[[nodiscard]] Result<SphereSet> copy_into(const SphereSet& set, const fs::path& version);

// Divides each light's frames by the current calibration's flat for it,
// smoothed and scaled to mean 1 (so relative intensities stay). Returns
// the calibration.json whose flats were used, when they were.
[[nodiscard]] std::optional<std::string> divide_by_current_flats(
    const calibration::CalibrationStore& store, SphereSet& set);

[[nodiscard]] double round_to(double value, double step);

// A new version's calibration.json written and the version committed.
[[nodiscard]] Result<CalibrationOutcome> commit_version(formats::AtomicDirectory staging,
                                                        const std::string& kind,
                                                        const nlohmann::json& document);

[[nodiscard]] Result<CalibrationOutcome> write_to_store(
    const config::RigConfig& config, formats::AtomicDirectory staging,
    calibration::LightCalibration& result, const nlohmann::json& led_positions = nullptr);

void tell(const CalibrationRequest& request, const std::string& step);

// The rig's current calibration, which a flat, a scale or a colour extends
// (each is stored with the lights), and the new version's document with
// its other sections carried over; bad input naming the fix where there
// is no light calibration.
struct Extension {
  fs::path current_file;
  calibration::StoredCalibration current;
  nlohmann::json document;
};

[[nodiscard]] Result<Extension> extend_current(const config::RigConfig& config,
                                               const calibration::CalibrationStore& store,
                                               const std::string& kind);

// The simulated rig puts `target` under its camera in place of the swatch;
// a target named in [sim] target stays.
[[nodiscard]] config::RigConfig with_sim_target(const config::RigConfig& config,
                                                const std::string& target);

// `frames` captures of what lies under the camera (every LED in turn, the
// dark frame), unprocessed, into captures/NAME-I of the staged version.
[[nodiscard]] Result<std::vector<fs::path>> capture_target(
    const config::RigConfig& config, const formats::AtomicDirectory& staging,
    const std::string& name, const std::string& sample_id, const std::string& description,
    int frames, const CalibrationRequest& args);

// The captures' names in the staged version, as a calibration section's
// "sources" gives them.
[[nodiscard]] nlohmann::json captured_sources(const std::vector<fs::path>& scans,
                                              const formats::AtomicDirectory& staging,
                                              const config::RigConfig& config);

// A new version staged for an image already taken (--image), the image
// copied into its captures/KIND/; returns its name there.
[[nodiscard]] Result<std::string> stage_given_image(
    const calibration::CalibrationStore& store, const fs::path& image, const std::string& kind,
    std::optional<formats::AtomicDirectory>& staging);

// Every LED's frame of every capture averaged (the target evenly lit),
// linear, dark subtracted, 0..1 of full scale, its channels kept; each
// light's frame times its gain first when `gains` holds one per light
// (the flat field as scans apply it); and where any frame reached full
// scale.
[[nodiscard]] Result<calibration::LinearColourImage> average_captures(
    const std::vector<fs::path>& scans, const std::vector<cv::Mat>& gains = {});

// ---- near-field LEDs (near_field.cpp)

// What places the sphere's pixels in millimetres, and where each came from.
struct NearFieldScale {
  calibration::PlaneGeometry plane;
  std::string pixel_size_from;
  std::string sphere_from;
};

[[nodiscard]] Result<NearFieldScale> near_field_scale(const CalibrationRequest& args,
                                                      const config::RigConfig& config,
                                                      const calibration::CalibrationStore& store,
                                                      cv::Size image_size);

// Where the simulated rig moves its sphere: [sim] sphere_places_mm, else
// spread round an ellipse inside the field (the sphere whole, a margin
// of half its radius), the first place at the top.
[[nodiscard]] Result<std::vector<std::array<double, 2>>> simulated_places(
    const config::RigConfig& config, int places);

// The chrome sphere at one place: its circle and its lights' estimates.
[[nodiscard]] Result<calibration::SpherePlacement> place_sphere(const SphereSet& set);

[[nodiscard]] Result<nlohmann::json> led_positions_section(const std::vector<SphereSet>& sets,
                                                           const NearFieldScale& scale,
                                                           const fs::path& relative_to,
                                                           const fs::path& rig);

// ---- the procedures, one file each

// The spheres of a lights calibration from images already taken.
struct FolderSpheres {
  std::optional<SphereSet> chrome;
  std::optional<SphereSet> matte;
  int per_light = 1;
  formats::Encoding encoding = formats::Encoding::linear;
};

[[nodiscard]] Result<FolderSpheres> load_spheres(const CalibrationRequest& args);

[[nodiscard]] Result<CalibrationOutcome> lights_from_images(const config::RigConfig& config,
                                                            const CalibrationRequest& args);

[[nodiscard]] Result<CalibrationOutcome> lights_on_rig(const config::RigConfig& rig_config,
                                                       const CalibrationRequest& args);

[[nodiscard]] Result<CalibrationOutcome> flat_on_rig(const config::RigConfig& rig_config,
                                                     const CalibrationRequest& args);

[[nodiscard]] Result<CalibrationOutcome> scale_on_rig(const config::RigConfig& rig_config,
                                                      const CalibrationRequest& args);

[[nodiscard]] Result<CalibrationOutcome> colour_on_rig(const config::RigConfig& rig_config,
                                                       const CalibrationRequest& args);

}  // namespace psrig::rig
