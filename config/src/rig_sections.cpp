// rig.toml's small sections of the rig itself: [capture], [processing],
// [calibration] and [storage].

#include <string>

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {

Status read_rig_sections(Section& top, RigConfig& c) {
  const fs::path& section_file = top.file();
  auto capture = top.sub("capture");
  if (!capture) return std::unexpected(capture.error());
  PSRIG_TRY(capture->get("dark_frame", c.capture.dark_frame));
  PSRIG_TRY(capture->get("settle_ms", c.capture.settle_ms, 0, 60000));
  PSRIG_TRY(capture->get("process", c.capture.process));
  capture->finish();

  auto processing = top.sub("processing");
  if (!processing) return std::unexpected(processing.error());
  PSRIG_TRY(processing->get("reject", c.processing.reject));
  processing->finish();

  auto calibration = top.sub("calibration");
  if (!calibration) return std::unexpected(calibration.error());
  PSRIG_TRY(calibration->get("max_age_days", c.calibration.max_age_days, 0, 36500));
  if (calibration->find("sphere_diameter_mm")) {
    double diameter = 0;
    PSRIG_TRY(calibration->get("sphere_diameter_mm", diameter, 0, 1000, true));
    c.calibration.sphere_diameter_mm = diameter;
  } else {
    calibration->node("sphere_diameter_mm");
  }
  calibration->finish();

  auto storage = top.sub("storage");
  if (!storage) return std::unexpected(storage.error());
  std::string storage_root = c.storage.root.string();
  PSRIG_TRY(storage->get("root", storage_root));
  PSRIG_TRY(
      storage->get("exr_compression", c.storage.exr_compression, {"auto", "zip", "piz", "none"}));
  PSRIG_TRY(storage->get("png_level", c.storage.png_level, 0, 9));
  PSRIG_TRY(storage->get("map_precision", c.storage.map_precision, {"half", "float"}));
  // Relative to the configuration file, not to wherever psrig was started.
  c.storage.root = relative_to_file(section_file, storage_root);
  storage->finish();
  return {};
}

}  // namespace psrig::config
