#pragma once
// The rig's calibration procedures: capture on the rig, compute, and keep
// the result as a new version of its calibration store
// (calibration/README.md). `psrig calibrate` and psrigd's
// POST /v1/calibrations both run them; the command line only parses and
// prints. Each kind is one procedure; a kind joins by adding a name to
// calibration_kinds() and a branch to run_calibration().

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"

namespace psrig::rig {

// "lights", "flat", "scale", "colour".
[[nodiscard]] const std::vector<std::string>& calibration_kinds();
[[nodiscard]] bool calibration_kind_supported(const std::string& kind);

struct CalibrationRequest {
  std::string kind = "lights";
  // lights
  std::string target = "chrome";  // "chrome" | "matte"
  int frames = 0;                 // 0: 3 captures on the rig, 1 image per light from a folder
  int places = 1;                 // the chrome sphere's places (2+: the LEDs' positions)
  std::optional<double> sphere_mm;
  std::optional<double> focal_px;
  // lights from images already taken: one folder per place (the first
  // also the lights), the first's mask, a matte sphere beside a chrome one
  std::vector<std::filesystem::path> images;
  std::filesystem::path mask;
  std::filesystem::path matte;
  std::filesystem::path matte_mask;
  std::string encoding = "linear";  // how the images (or colour's image) store light:
                                    // "linear" | "srgb"
  // scale, colour: the board or the chart already taken, instead of capturing
  std::filesystem::path image;
  // scale
  std::string squares = "7x5";
  double square_mm = 2.0;
  double marker_mm = 1.4;
  std::string dictionary = "DICT_4X4_50";
  // flat: frames as for lights (0: 3); colour: frames (0: 1), encoding for image

  // What the technician should know that does not stop it (colour: an
  // --image read without the rig's flat field). Unset: not said.
  std::function<void(const std::string& warning)> warn;

  // Each step, for people ("place 2 of 3, capture 1 of 3: light 2 of 3").
  std::function<void(const std::string& step)> progress;
  // A real rig with --places: asks the technician to put the sphere at
  // place `place` (1-based) of `places` and waits; false: give up (the
  // answer never came). Unset: a real rig cannot do several places.
  std::function<bool(int place, int places)> sphere_moved;
};

struct CalibrationOutcome {
  std::string kind;
  std::filesystem::path file;  // the new calibration.json (or the --out file)
  nlohmann::json document;     // what it holds
};

// Runs `request.kind` on the rig `config` describes (the simulated rig puts
// its target under the camera itself), storing a new version in
// config.storage.root/calibrations. Bad input (exit 2 on the command
// line, 400/failed in psrigd) names the file, the key and the fix; nothing
// is stored then. Stopped early (SIGINT/SIGTERM: lights::stop_requested()),
// it fails with the LEDs off.
[[nodiscard]] Result<CalibrationOutcome> run_calibration(const config::RigConfig& config,
                                                         const CalibrationRequest& request);

// Light directions from images already taken, into a new calibration file
// `out` (no rig, no store).
[[nodiscard]] Result<CalibrationOutcome> calibrate_lights_to_file(const CalibrationRequest& request,
                                                                  const std::filesystem::path& out);

}  // namespace psrig::rig
