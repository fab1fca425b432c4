// rig.toml's [geometry]: where the LEDs are and what a pixel measures.

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {

Status read_geometry(Section& geometry, RigConfig& c) {
  PSRIG_TRY(geometry.get("slant_deg", c.geometry.slant_deg, 0, 89, true));
  PSRIG_TRY(geometry.get("tilts_deg", c.geometry.tilts_deg, -360, 360));
  PSRIG_TRY(geometry.get("working_distance_mm", c.geometry.working_distance_mm, 0, kNoMax, true));
  double pixel_size = 0;
  if (geometry.find("pixel_size_mm")) {
    PSRIG_TRY(geometry.get("pixel_size_mm", pixel_size, 0, kNoMax, true));
    c.geometry.pixel_size_mm = pixel_size;
  } else {
    geometry.node("pixel_size_mm");
  }
  PSRIG_TRY(geometry.get("led_positions_mm", c.geometry.led_positions_mm, 1e5, 0));
  if (geometry.find("led_distance_mm")) {
    double distance = 0;
    PSRIG_TRY(geometry.get("led_distance_mm", distance, 0, 1e5, true));
    c.geometry.led_distance_mm = distance;
    if (geometry.find("led_positions_mm"))
      return std::unexpected(
          geometry.error_at(geometry.find("led_distance_mm"), "led_distance_mm",
                            "give either led_positions_mm or led_distance_mm, not both"));
  } else {
    geometry.node("led_distance_mm");
  }
  PSRIG_TRY(geometry.get("swatch_height_mm", c.geometry.swatch_height_mm, 0, 1000));
  geometry.finish();
  return {};
}

}  // namespace psrig::config
