// The rig's calibration procedures (rig_calibration.h): lights (chrome or
// matte sphere; the chrome sphere at several places for near LEDs' positions),
// flat (a white card under each LED), scale (a ChArUco board), colour (a
// ColorChecker Classic). Each captures on the rig, computes, and stores a
// new version of the calibration.

#include "psrig/rig/rig_calibration.h"

#include <algorithm>

#include "calibration/procedure_steps.h"

namespace psrig::rig {

const std::vector<std::string>& calibration_kinds() {
  static const std::vector<std::string> kinds = {"lights", "flat", "scale", "colour"};
  return kinds;
}

bool calibration_kind_supported(const std::string& kind) {
  const auto& kinds = calibration_kinds();
  return std::find(kinds.begin(), kinds.end(), kind) != kinds.end();
}

Result<CalibrationOutcome> run_calibration(const config::RigConfig& config,
                                           const CalibrationRequest& request) {
  if (request.kind == "lights")
    return request.images.empty() ? lights_on_rig(config, request)
                                  : lights_from_images(config, request);
  if (request.kind == "flat") return flat_on_rig(config, request);
  if (request.kind == "scale") return scale_on_rig(config, request);
  if (request.kind == "colour") return colour_on_rig(config, request);
  return std::unexpected(bad_input({}, "kind",
                                   "\"" + request.kind +
                                       "\" is not a calibration this rig runs (lights, flat, "
                                       "scale, colour)"));
}

}  // namespace psrig::rig
