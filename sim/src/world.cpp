#include "psrig/sim/world.h"

#include <cmath>
#include <optional>

#include "psrig/formats/light_matrix.h"
#include "psrig/sim/card_target.h"
#include "psrig/sim/colour_chart_target.h"
#include "psrig/sim/lambertian_render.h"
#include "psrig/sim/simulated_rig.h"
#include "psrig/sim/sphere_target.h"

namespace psrig::sim {
namespace {

std::optional<SphereTarget> sphere_target(const config::SimConfig& sim) {
  if (sim.target != "chrome_sphere" && sim.target != "matte_sphere") return std::nullopt;
  SphereTarget target;
  target.kind = sim.target == "chrome_sphere" ? SphereKind::chrome : SphereKind::matte;
  target.size = {sim.width, sim.height};
  target.pixel_size_mm = sim.pixel_size_mm;
  target.diameter_mm = sim.sphere_diameter_mm;
  target.led_angular_diameter_deg = sim.led_angular_diameter_deg;
  if (sim.sphere_centre_mm)
    target.centre = {(sim.width - 1) / 2.0 + (*sim.sphere_centre_mm)[0] / sim.pixel_size_mm,
                     (sim.height - 1) / 2.0 - (*sim.sphere_centre_mm)[1] / sim.pixel_size_mm};
  return target;
}

Swatch target_scene(const config::SimConfig& sim) {
  if (const auto sphere = sphere_target(sim)) return sphere_scene(*sphere);
  if (sim.target == "white_card")
    return white_card({sim.width, sim.height}, sim.pixel_size_mm,
                      static_cast<float>(sim.card_albedo));
  if (sim.target == "charuco_board")
    return charuco_board({sim.width, sim.height}, sim.pixel_size_mm);
  return colour_chart({sim.width, sim.height}, sim.pixel_size_mm);
}

}  // namespace

Result<World> World::make(const config::RigConfig& config,
                          std::shared_ptr<SimulatedLeds> leds) {
  const config::SimConfig& sim = config.sim;
  if (sim.target != "swatch")
    return World(config, target_scene(sim), std::nullopt, std::move(leds));
  // The pattern names the file it is in, or else the rig.toml that named it.
  const auto naming = [&](Error error) {
    if (error.file.empty()) error.file = config.source;
    return error;
  };
  auto pattern = load_swatch_pattern(
      sim.pattern, sim.patterns_dir,
      config.source.empty() ? std::filesystem::path() : config.source.parent_path(), "sim.pattern");
  if (!pattern) return std::unexpected(naming(std::move(pattern.error())));
  SwatchParams params;
  params.pattern = *pattern;
  params.size = {sim.width, sim.height};
  params.pixel_size_mm = sim.pixel_size_mm;
  params.seed = sim.seed;
  params.rotation_deg = sim.swatch_rotation_deg;
  auto swatch = make_swatch(params);
  if (!swatch) return std::unexpected(naming(std::move(swatch.error())));
  return World(config, std::move(*swatch), std::move(*pattern), std::move(leds));
}

World::World(const config::RigConfig& config, Swatch scene, std::optional<SwatchPattern> pattern,
             std::shared_ptr<SimulatedLeds> leds)
    : swatch_(std::move(scene)),
      pattern_(std::move(pattern)),
      leds_(leds ? std::move(leds) : std::make_shared<SimulatedLeds>(config.lights.channels)) {
  const auto sphere = sphere_target(config.sim);
  // Near LEDs where the geometry places them, else (an unmeasured rig) at
  // [sim] led_distance_mm along the geometry's slant and tilts.
  auto positions = config::led_positions_mm(config.geometry);
  if (positions.empty() && config.sim.led_distance_mm) {
    config::Geometry truth = config.geometry;
    truth.led_distance_mm = config.sim.led_distance_mm;
    positions = config::led_positions_mm(truth);
  }
  for (int k = 0; k < config.lights.channels; ++k) {
    const auto& tilts = config.geometry.tilts_deg;
    const double tilt_deg =
        k < static_cast<int>(tilts.size()) ? tilts[k] : 360.0 * k / config.lights.channels;
    if (k < static_cast<int>(positions.size())) {
      // A near LED: a point source; its direction from the field's centre.
      const cv::Vec3d p(positions[k][0], positions[k][1], positions[k][2]);
      positions_.push_back(p);
      directions_.push_back(p / cv::norm(p));
      radiance_.push_back(sphere ? render_sphere_point(*sphere, p)
                                 : render_point_light(swatch_, {p, {1, 1, 1}}, true));
      continue;
    }
    directions_.push_back(formats::light_direction(tilt_deg, config.geometry.slant_deg));
    radiance_.push_back(sphere ? render_sphere(*sphere, directions_.back())
                               : render_lambertian(swatch_, {directions_.back(), {1, 1, 1}}, true));
  }
  if (sphere) {
    ambient_ = render_sphere_ambient(*sphere);
    return;
  }
  // Room light: a bright overcast sky, so a facet sees (1 + n_z) / 2 of it.
  std::vector<cv::Mat> normal;
  cv::split(swatch_.normal, normal);
  cv::Mat sky = (normal[2] + 1) * 0.5;
  cv::Mat sky3;
  cv::merge(std::vector<cv::Mat>{sky, sky, sky}, sky3);
  ambient_ = swatch_.albedo.mul(sky3);
}

Result<std::shared_ptr<World>> World::attach(const config::RigConfig& config) {
  // Rendering under the registry's lock: a second caller waits for the
  // world rather than rendering another. A world that cannot be made is
  // not registered: the next caller tries again.
  static SimulatedRigRegistry<World> registry;
  std::optional<Error> failed;
  auto world = registry.attach(config, [&]() -> std::shared_ptr<World> {
    auto made = make(config, SimulatedLeds::attach(config));
    if (!made) {
      failed = std::move(made.error());
      return nullptr;
    }
    return std::make_shared<World>(std::move(*made));
  });
  if (!world)
    return std::unexpected(failed.value_or(internal_error("the simulated world is missing")));
  return world;
}

}  // namespace psrig::sim
