#pragma once
// The readers of rig.toml's sections, one per owner; read() in
// config_loader.cpp calls them in order. Each reads its table's keys into
// the configuration, checks them, and finishes the table (warning of
// unknown keys). Private to config/.

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"
#include "toml_section.h"

namespace psrig::config {

[[nodiscard]] Status read_geometry(Section& geometry, RigConfig& c);
[[nodiscard]] Status read_lights(Section& lights, RigConfig& c);
// Tilts, positions and intensities: one per channel.
[[nodiscard]] Status check_lights_against_geometry(const Section& lights, const Section& geometry,
                                                   RigConfig& c);
[[nodiscard]] Status read_camera(Section& camera, RigConfig& c);
// [capture], [processing], [calibration], [storage] from the top table.
[[nodiscard]] Status read_rig_sections(Section& top, RigConfig& c);
[[nodiscard]] Status read_sim(Section& sim, RigConfig& c);
[[nodiscard]] Status read_daemon(Section& daemon, RigConfig& c);
// After [storage] and [daemon]: a shared catalogue moves the rig's storage
// root under its name.
[[nodiscard]] Status read_catalogue(Section& catalogue, RigConfig& c);
// Why `name` cannot name a rig (it becomes a directory under the shared
// storage root), or nothing.
[[nodiscard]] std::optional<std::string> rig_name_problem(const std::string& name);

}  // namespace psrig::config
