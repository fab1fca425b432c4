// Near-field LEDs: the chrome sphere at several places, each LED's position
// the least-squares point of its highlights' reflected rays.

#include "procedure_steps.h"

namespace psrig::rig {

// ---- near-field LEDs: the chrome sphere at several places -------------

Result<NearFieldScale> near_field_scale(const CalibrationRequest& args,
                                        const config::RigConfig& config,
                                        const calibration::CalibrationStore& store,
                                        cv::Size image_size) {
  NearFieldScale scale;
  scale.plane.image_size = image_size;
  if (const auto file = store.current()) {
    if (auto current = calibration::read_calibration(*file); current && current->pixel_size_mm) {
      scale.plane.pixel_size_mm = *current->pixel_size_mm;
      scale.pixel_size_from = "calibration " + file->parent_path().filename().string() + " (scale)";
    }
  }
  if (!(scale.plane.pixel_size_mm > 0) && config.geometry.pixel_size_mm) {
    scale.plane.pixel_size_mm = *config.geometry.pixel_size_mm;
    scale.pixel_size_from = "rig.toml [geometry] pixel_size_mm";
  }
  if (!(scale.plane.pixel_size_mm > 0))
    return std::unexpected(bad_input(config.source, "geometry.pixel_size_mm",
                                     "is needed to place the LEDs in millimetres: run psrig "
                                     "calibrate scale first, or set [geometry] pixel_size_mm"));
  if (args.sphere_mm) {
    scale.plane.sphere_diameter_mm = *args.sphere_mm;
    scale.sphere_from = "--sphere-mm";
  } else if (config.calibration.sphere_diameter_mm) {
    scale.plane.sphere_diameter_mm = *config.calibration.sphere_diameter_mm;
    scale.sphere_from = "rig.toml [calibration] sphere_diameter_mm";
  } else if (config.camera.backend == "sim") {
    scale.plane.sphere_diameter_mm = config.sim.sphere_diameter_mm;
    scale.sphere_from = "rig.toml [sim] sphere_diameter_mm";
  } else {
    return std::unexpected(bad_input(config.source, "calibration.sphere_diameter_mm",
                                     "is needed to place the LEDs: give the chrome sphere's "
                                     "diameter with --sphere-mm MM, or set [calibration] "
                                     "sphere_diameter_mm"));
  }
  if (config.camera.principal_point_px)
    scale.plane.principal_point_px =
        cv::Point2d((*config.camera.principal_point_px)[0], (*config.camera.principal_point_px)[1]);
  return scale;
}

// Where the simulated rig moves its sphere: [sim] sphere_places_mm, else
// spread round an ellipse inside the field (the sphere whole, a margin
// of half its radius), the first place at the top.
Result<std::vector<std::array<double, 2>>> simulated_places(const config::RigConfig& config,
                                                            int places) {
  const auto& sim = config.sim;
  if (!sim.sphere_places_mm.empty()) {
    if (sim.sphere_places_mm.size() < static_cast<std::size_t>(places))
      return std::unexpected(bad_input(config.source, "sim.sphere_places_mm",
                                       "lists " + std::to_string(sim.sphere_places_mm.size()) +
                                           " places but --places is " + std::to_string(places) +
                                           "; list as many places or give fewer --places"));
    return std::vector<std::array<double, 2>>(sim.sphere_places_mm.begin(),
                                              sim.sphere_places_mm.begin() + places);
  }
  const double radius = sim.sphere_diameter_mm / 2;
  const double rx = sim.width * sim.pixel_size_mm / 2 - 1.5 * radius;
  const double ry = sim.height * sim.pixel_size_mm / 2 - 1.5 * radius;
  if (std::min(rx, ry) < radius)
    return std::unexpected(bad_input(
        config.source, "sim.sphere_diameter_mm",
        "is " + std::to_string(sim.sphere_diameter_mm).substr(0, 5) +
            " mm: too large to move about the simulated field; give a smaller sphere, a larger "
            "field ([sim] width, height), or the places ([sim] sphere_places_mm)"));
  std::vector<std::array<double, 2>> result;
  for (int i = 0; i < places; ++i) {
    const double angle = std::numbers::pi / 2 + 2 * std::numbers::pi * i / places;
    result.push_back({rx * std::cos(angle), ry * std::sin(angle)});
  }
  return result;
}

// The chrome sphere at one place: its circle and its lights' estimates.
Result<calibration::SpherePlacement> place_sphere(const SphereSet& set) {
  auto circle = locate(set);
  if (!circle) return std::unexpected(circle.error());
  auto lights = calibration::calibrate_chrome(set.lights, *circle, {}, 0.95);
  if (!lights) return std::unexpected(lights.error());
  return calibration::SpherePlacement{*circle, *lights};
}

Result<nlohmann::json> led_positions_section(const std::vector<SphereSet>& sets,
                                             const NearFieldScale& scale,
                                             const fs::path& relative_to, const fs::path& rig) {
  std::vector<calibration::SpherePlacement> placements;
  for (const auto& set : sets) {
    auto placement = place_sphere(set);
    if (!placement) return std::unexpected(placement.error());
    placements.push_back(*placement);
  }
  for (std::size_t i = 0; i < placements.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (cv::norm(placements[i].sphere.centre - placements[j].sphere.centre) <
          placements[i].sphere.radius)
        return std::unexpected(bad_input(
            sets[i].source, "--places",
            "shows the sphere where place " + std::to_string(j + 1) +
                " had it: move it by its "
                "diameter or more between places (farther apart, the LEDs are placed better)"));
  auto positions = calibration::triangulate_leds(placements, scale.plane);
  if (!positions) return std::unexpected(positions.error());
  nlohmann::json all = nlohmann::json::array();
  nlohmann::json per_light = nlohmann::json::array();
  for (std::size_t k = 0; k < positions->size(); ++k) {
    const auto& p = (*positions)[k];
    const nlohmann::json xyz = {round_to(p.position_mm[0], 1e-3), round_to(p.position_mm[1], 1e-3),
                                round_to(p.position_mm[2], 1e-3)};
    all.push_back(xyz);
    per_light.push_back({{"index", k},
                         {"position_mm", xyz},
                         {"distance_mm", round_to(cv::norm(p.position_mm), 1e-3)},
                         {"uncertainty_mm", round_to(p.uncertainty_mm, 1e-3)},
                         {"ray_rms_mm", round_to(p.ray_rms_mm, 1e-4)},
                         {"baseline_mm", round_to(p.baseline_mm, 1e-3)}});
  }
  const cv::Point2d axis = scale.plane.principal_point_px.value_or(cv::Point2d(
      (scale.plane.image_size.width - 1) / 2.0, (scale.plane.image_size.height - 1) / 2.0));
  nlohmann::json places = nlohmann::json::array();
  for (std::size_t i = 0; i < placements.size(); ++i) {
    const auto& c = placements[i].sphere;
    places.push_back({{"centre_px", {round_to(c.centre.x, 1e-3), round_to(c.centre.y, 1e-3)}},
                      {"centre_mm",
                       {round_to((c.centre.x - axis.x) * scale.plane.pixel_size_mm, 1e-3),
                        round_to((axis.y - c.centre.y) * scale.plane.pixel_size_mm, 1e-3)}},
                      {"radius_px", round_to(c.radius, 1e-3)},
                      {"fit_rms_px", round_to(c.rms_px, 1e-4)},
                      {"sources", describe_sources(sets[i], relative_to)}});
  }
  return nlohmann::json{
      {"created", calibration::utc_now()},
      {"method", "chrome sphere at " + std::to_string(sets.size()) + " places"},
      {"origin", "the camera axis on the reference plane; x right, y up, z toward the camera"},
      {"positions", all},
      {"per_light", per_light},
      {"pixel_size_mm", scale.plane.pixel_size_mm},
      {"pixel_size_from", scale.pixel_size_from},
      {"sphere_diameter_mm", scale.plane.sphere_diameter_mm},
      {"sphere_diameter_from", scale.sphere_from},
      {"principal_point_px", {axis.x, axis.y}},
      {"places", places},
      {"rig", rig.empty() ? nlohmann::json(nullptr) : nlohmann::json(rig.string())}};
}

}  // namespace psrig::rig
