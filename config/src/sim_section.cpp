// rig.toml's [sim]: the simulated world, camera and LEDs.

#include <array>
#include <string>
#include <system_error>
#include <vector>

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {

Status read_sim(Section& sim, RigConfig& c) {
  const fs::path& section_file = sim.file();
  auto& s = c.sim;
  PSRIG_TRY(sim.get("target", s.target,
                    {"swatch", "flat", "chrome_sphere", "matte_sphere", "white_card",
                     "charuco_board", "colour_chart"}));
  // "flat", the older name of a grey card: the white card at albedo 0.6.
  if (s.target == "flat") {
    s.target = "white_card";
    s.card_albedo = 0.6;
  }
  PSRIG_TRY(sim.get("card_albedo", s.card_albedo, 0, 1, true));
  PSRIG_TRY(sim.get("sphere_diameter_mm", s.sphere_diameter_mm, 0.1, 1000, true));
  PSRIG_TRY(sim.get("led_angular_diameter_deg", s.led_angular_diameter_deg, 0.01, 20, true));
  {
    std::vector<double> centre;
    PSRIG_TRY(sim.get("sphere_centre_mm", centre, -1e4, 1e4));
    if (sim.find("sphere_centre_mm")) {
      if (centre.size() != 2)
        return std::unexpected(sim.error_at(sim.find("sphere_centre_mm"), "sphere_centre_mm",
                                            "expected [x, y] in millimetres from the camera axis"));
      s.sphere_centre_mm = std::array<double, 2>{centre[0], centre[1]};
    }
  }
  if (const toml::node* places = sim.node("sphere_places_mm")) {
    const toml::array* array = places->as_array();
    if (!array || array->empty())
      return std::unexpected(sim.error_at(places, "sphere_places_mm",
                                          "expected a list of [x, y] places in millimetres "
                                          "from the camera axis, e.g. [[-8, 5], [8, 5], [0, -7]]"));
    for (const auto& element : *array) {
      const toml::array* pair = element.as_array();
      std::optional<double> x, y;
      if (pair && pair->size() == 2) x = (*pair)[0].value<double>(), y = (*pair)[1].value<double>();
      if (!x || !y || std::abs(*x) > 1e4 || std::abs(*y) > 1e4)
        return std::unexpected(sim.error_at(&element, "sphere_places_mm",
                                            "expected [x, y] in millimetres from the camera axis"));
      s.sphere_places_mm.push_back({*x, *y});
    }
  }
  if (sim.find("led_distance_mm")) {
    double distance = 0;
    PSRIG_TRY(sim.get("led_distance_mm", distance, 0, 1e5, true));
    s.led_distance_mm = distance;
  } else {
    sim.node("led_distance_mm");
  }
  {
    std::vector<double> mixing;
    PSRIG_TRY(sim.get("colour_matrix", mixing, -10, 10));
    if (sim.find("colour_matrix")) {
      if (mixing.size() != 9)
        return std::unexpected(sim.error_at(
            sim.find("colour_matrix"), "colour_matrix",
            "expected 9 numbers, the 3x3 matrix from the scene's linear sRGB to the camera's "
            "RGB row by row (e.g. [0.7, 0.25, 0.05, 0.1, 0.8, 0.1, 0.02, 0.28, 0.7])"));
      std::array<double, 9> m{};
      std::copy(mixing.begin(), mixing.end(), m.begin());
      s.colour_matrix = m;
    }
  }
  PSRIG_TRY(sim.get("pattern", s.pattern));
  {
    // A file is found from the rig.toml's folder; a name in patterns_dir,
    // when the simulated world is made (sim/swatch_pattern.h).
    const fs::path given(s.pattern);
    if (s.pattern.empty())
      return std::unexpected(
          sim.error_at(sim.find("pattern"), "pattern",
                       "is empty; give a .chart or .weave file or a shipped pattern's name, e.g. "
                       "\"stockinette\""));
    if (s.pattern.find('/') != std::string::npos || given.extension() == ".chart" ||
        given.extension() == ".weave") {
      s.pattern = relative_to_file(section_file, s.pattern).string();
      std::error_code ec;
      if (!fs::is_regular_file(s.pattern, ec))
        return std::unexpected(sim.error_at(
            sim.find("pattern"), "pattern",
            "\"" + s.pattern +
                "\" is not a file; give a .chart or .weave file (relative to this rig.toml) or a "
                "shipped pattern's name, e.g. \"stockinette\""));
    }
    std::string patterns_dir;
    PSRIG_TRY(sim.get("patterns_dir", patterns_dir));
    if (!patterns_dir.empty()) {
      s.patterns_dir = relative_to_file(section_file, patterns_dir);
      std::error_code ec;
      if (!fs::is_directory(s.patterns_dir, ec))
        return std::unexpected(sim.error_at(
            sim.find("patterns_dir"), "patterns_dir",
            "\"" + s.patterns_dir.string() +
                "\" is not a folder; point it at the shipped patterns (config/patterns) or "
                "leave it out"));
    }
  }
  PSRIG_TRY(sim.get("swatch_rotation_deg", s.swatch_rotation_deg, -45, 45));
  PSRIG_TRY(sim.get("seed", s.seed));
  PSRIG_TRY(sim.get("width", s.width, 8, 16384));
  PSRIG_TRY(sim.get("height", s.height, 8, 16384));
  PSRIG_TRY(sim.get("pixel_size_mm", s.pixel_size_mm, 0, 1, true));
  PSRIG_TRY(sim.get("bit_depth", s.bit_depth, 8, 16));
  PSRIG_TRY(sim.get("full_well", s.full_well, 1, 1e7));
  PSRIG_TRY(sim.get("read_noise", s.read_noise, 0, 1000));
  PSRIG_TRY(sim.get("black_level", s.black_level, 0, 65535));
  PSRIG_TRY(sim.get("ambient", s.ambient, 0, 10));
  PSRIG_TRY(sim.get("vignetting", s.vignetting, 0, 0.9));
  PSRIG_TRY(sim.get("led_irradiance", s.led_irradiance, 0, 100));
  PSRIG_TRY(sim.get("readout_us", s.readout_us, 0, 10000000));
  PSRIG_TRY(sim.get("frame_interval_us", s.frame_interval_us, 0, 60000000));
  sim.finish();
  if (s.black_level >= (1 << s.bit_depth) - 1)
    return std::unexpected(sim.error_at(sim.find("black_level"), "black_level",
                                        "must be below the " + std::to_string(s.bit_depth) +
                                            "-bit full scale (" +
                                            std::to_string((1 << s.bit_depth) - 1) + ")"));
  if (c.camera.backend == "sim" && c.geometry.pixel_size_mm == std::nullopt)
    c.geometry.pixel_size_mm = s.pixel_size_mm;
  return {};
}

}  // namespace psrig::config
