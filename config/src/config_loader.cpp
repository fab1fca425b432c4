#include "psrig/config/config_loader.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <toml++/toml.h>

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {
namespace {

Result<RigConfig> read(const toml::table& root, const fs::path& file,
                       std::vector<std::string>* warnings) {
  RigConfig c;
  c.source = file;
  Section top(&root, "", file, warnings);
  auto geometry = top.sub("geometry");
  if (!geometry) return std::unexpected(geometry.error());
  PSRIG_TRY(read_geometry(*geometry, c));
  auto lights = top.sub("lights");
  if (!lights) return std::unexpected(lights.error());
  PSRIG_TRY(read_lights(*lights, c));
  PSRIG_TRY(check_lights_against_geometry(*lights, *geometry, c));
  auto camera = top.sub("camera");
  if (!camera) return std::unexpected(camera.error());
  PSRIG_TRY(read_camera(*camera, c));
  PSRIG_TRY(read_rig_sections(top, c));
  auto sim = top.sub("sim");
  if (!sim) return std::unexpected(sim.error());
  PSRIG_TRY(read_sim(*sim, c));
  auto daemon = top.sub("daemon");
  if (!daemon) return std::unexpected(daemon.error());
  PSRIG_TRY(read_daemon(*daemon, c));
  auto catalogue = top.sub("catalogue");
  if (!catalogue) return std::unexpected(catalogue.error());
  PSRIG_TRY(read_catalogue(*catalogue, c));
  top.finish();
  return c;
}

}  // namespace

Result<RigConfig> parse_config(std::string_view text, const fs::path& source,
                               std::vector<std::string>* warnings) {
  try {
    const toml::table root = toml::parse(text, source.string());
    return read(root, source, warnings);
  } catch (const toml::parse_error& e) {
    Error error =
        bad_input(source, "", std::string("malformed TOML: ") + std::string(e.description()));
    error.line = static_cast<int>(e.source().begin.line);
    error.column = static_cast<int>(e.source().begin.column);
    return std::unexpected(error);
  } catch (const std::exception& e) {
    return std::unexpected(
        internal_error(source.string() + ": reading the configuration failed: " + e.what()));
  }
}

Result<RigConfig> load_config(const fs::path& file, std::vector<std::string>* warnings) {
  std::ifstream stream(file);
  std::error_code ec;
  if (!fs::exists(file, ec))
    return std::unexpected(
        bad_input(file, "", "no such configuration file (see config/rig.example.toml)"));
  if (!stream) return std::unexpected(bad_input(file, "", "cannot open for reading"));
  std::stringstream text;
  text << stream.rdbuf();
  return parse_config(text.str(), fs::absolute(file, ec), warnings);
}

std::vector<std::array<double, 3>> led_positions_mm(const Geometry& geometry) {
  if (!geometry.led_positions_mm.empty()) return geometry.led_positions_mm;
  if (!geometry.led_distance_mm) return {};
  constexpr double kDeg = 3.14159265358979323846 / 180;
  const double d = *geometry.led_distance_mm;
  const double slant = geometry.slant_deg * kDeg;
  std::vector<std::array<double, 3>> positions;
  for (const double tilt_deg : geometry.tilts_deg) {
    const double tilt = tilt_deg * kDeg;
    positions.push_back({d * std::cos(tilt) * std::sin(slant), d * std::sin(tilt) * std::sin(slant),
                         d * std::cos(slant)});
  }
  return positions;
}

}  // namespace psrig::config
