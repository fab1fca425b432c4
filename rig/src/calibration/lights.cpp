// Light directions (chrome sphere) or directions and intensities (matte
// sphere), on the rig or from images already taken.

#include "procedure_steps.h"

namespace psrig::rig {

Result<FolderSpheres> load_spheres(const CalibrationRequest& args) {
  FolderSpheres spheres;
  spheres.encoding = args.encoding == "srgb" ? formats::Encoding::srgb : formats::Encoding::linear;
  spheres.per_light = args.frames > 0 ? args.frames : 1;
  if (args.images.empty())
    return std::unexpected(bad_input({}, "--images", "give the folder of sphere images"));
  auto first = load_folder(args.target, args.images.front(), args.mask.string(), spheres.per_light,
                           spheres.encoding);
  if (!first) return std::unexpected(first.error());
  (args.target == "chrome" ? spheres.chrome : spheres.matte) = std::move(*first);
  if (!args.matte.empty()) {
    if (args.target == "matte")
      return std::unexpected(bad_input(args.matte, "--matte",
                                       "is the matte sphere beside a chrome one in --images; "
                                       "with --target matte, --images is the matte sphere"));
    auto second = load_folder("matte", args.matte, args.matte_mask.string(), spheres.per_light,
                              spheres.encoding);
    if (!second) return std::unexpected(second.error());
    spheres.matte = std::move(*second);
  }
  return spheres;
}

Result<CalibrationOutcome> lights_from_images(const config::RigConfig& config,
                                              const CalibrationRequest& args) {
  if (args.images.size() > 1 && args.target != "chrome")
    return std::unexpected(
        bad_input(args.images[1], "--images",
                  "given " + std::to_string(args.images.size()) +
                      " times is the chrome sphere at as many places (the LEDs' positions): give "
                      "--target chrome"));
  auto spheres = load_spheres(args);
  if (!spheres) return std::unexpected(spheres.error());
  auto& chrome = spheres->chrome;
  auto& matte = spheres->matte;
  calibration::CameraModel camera{args.focal_px};
  auto result = compute(chrome ? &*chrome : nullptr, matte ? &*matte : nullptr, camera, 0.98);
  if (!result) return std::unexpected(result.error());
  const std::size_t lights = std::max(result->chrome.size(), result->matte.size());
  if (lights != static_cast<std::size_t>(config.lights.channels))
    return std::unexpected(
        bad_input(args.images.front(), "",
                  "holds images of " + std::to_string(lights) + " lights but " +
                      config.source.string() + " has " + std::to_string(config.lights.channels) +
                      " (lights.channels); give one image per LED of that rig, or --out FILE"));
  calibration::CalibrationStore store(config.storage.root);
  auto staging = store.begin_next();
  if (!staging) return std::unexpected(staging.error());
  for (auto* set : {chrome ? &*chrome : nullptr, matte ? &*matte : nullptr}) {
    if (!set) continue;
    auto copied = copy_into(*set, staging->path());
    if (!copied) return std::unexpected(copied.error());
    result->sources[set->role] = describe_sources(*copied, staging->path());
  }
  // The sphere at further places (--images once per place): the LEDs' positions.
  nlohmann::json led_positions = nullptr;
  if (args.images.size() > 1) {
    std::vector<SphereSet> places{*chrome};
    for (std::size_t i = 1; i < args.images.size(); ++i) {
      auto set = load_folder("chrome", args.images[i], "", spheres->per_light, spheres->encoding);
      if (!set) return std::unexpected(set.error());
      if (set->lights.size() != chrome->lights.size())
        return std::unexpected(bad_input(
            args.images[i], "--images",
            "holds images of " + std::to_string(set->lights.size()) + " lights but " +
                args.images.front().string() + " of " + std::to_string(chrome->lights.size()) +
                "; give the sphere under the same lights at each place"));
      places.push_back(std::move(*set));
    }
    auto scale =
        near_field_scale(args, config, store, chrome->lights.front().frames.front().image.size());
    if (!scale) return std::unexpected(scale.error());
    auto section = led_positions_section(places, *scale, {}, {});
    if (!section) return std::unexpected(section.error());
    // Kept beside it, as the first place's images are.
    for (std::size_t i = 1; i < places.size(); ++i) {
      places[i].role = "chrome-p" + std::to_string(i + 1);
      auto copied = copy_into(places[i], staging->path());
      if (!copied) return std::unexpected(copied.error());
      (*section)["places"][i]["sources"] = describe_sources(*copied, staging->path());
    }
    (*section)["places"][0]["sources"] = result->sources["chrome"];
    led_positions = *section;
  }
  return write_to_store(config, std::move(*staging), *result, led_positions);
}

Result<CalibrationOutcome> lights_on_rig(const config::RigConfig& rig_config,
                                         const CalibrationRequest& args) {
  config::RigConfig config = rig_config;
  if (args.places > 1 && args.target != "chrome")
    return std::unexpected(bad_input(config.source, "--places",
                                     "places the LEDs from a chrome sphere's highlights: give "
                                     "--target chrome (or leave --places out)"));
  // The simulated rig puts the sphere under its camera, and moves it
  // between places itself.
  const bool simulated = config.camera.backend == "sim";
  if (simulated) config.sim.target = args.target == "chrome" ? "chrome_sphere" : "matte_sphere";
  std::vector<std::array<double, 2>> sim_places;
  if (simulated && args.places > 1) {
    auto places = simulated_places(config, args.places);
    if (!places) return std::unexpected(places.error());
    sim_places = *places;
  } else if (args.places > 1 && !args.sphere_moved) {
    return std::unexpected(bad_input(config.source, "--places",
                                     "needs the technician to move the sphere between places, "
                                     "which this cannot ask for: run psrig calibrate lights "
                                     "--places in a terminal, or give --images DIR per place"));
  }
  const int captures = args.frames > 0 ? args.frames : 3;
  calibration::CalibrationStore store(config.storage.root);
  // What places the sphere in millimetres, known before the LEDs go on.
  std::optional<NearFieldScale> scale;
  if (args.places > 1) {
    auto known = near_field_scale(args, config, store, {});
    if (!known) return std::unexpected(known.error());
    scale = *known;
  }
  auto staging = store.begin_next();
  if (!staging) return std::unexpected(staging.error());
  std::vector<std::vector<fs::path>> scans(static_cast<std::size_t>(args.places));
  std::string result_flat_note;
  for (int place = 0; place < args.places; ++place) {
    config::RigConfig placed = config;
    const std::string where = args.places > 1 ? "place " + std::to_string(place + 1) + " of " +
                                                    std::to_string(args.places)
                                              : "";
    if (!sim_places.empty()) {
      placed.sim.sphere_centre_mm = sim_places[static_cast<std::size_t>(place)];
    } else if (args.places > 1) {
      // A real rig: the technician moves the sphere; the LEDs are off meanwhile.
      if (!args.sphere_moved(place + 1, args.places))
        return std::unexpected(bad_input(config.source, "--places",
                                         "needs the technician to say the sphere is at " + where +
                                             ", and no answer came; run it in a terminal, or "
                                             "capture each place yourself and give --images DIR "
                                             "for each"));
      if (lights::stop_requested())
        return std::unexpected(bad_input(config.source, "", "interrupted"));
    }
    auto rig = open_rig(placed);
    if (!rig) return std::unexpected(rig.error());
    ScanSequencer sequencer(placed, *rig->lights, *rig->camera);
    std::error_code ec;
    fs::create_directories(staging->path() / calibration::kCapturesDirectory, ec);
    for (int i = 0; i < captures; ++i) {
      ScanRequest request;
      request.sample_id = args.target + "-sphere";
      request.description = "light calibration: " + args.target + " sphere" +
                            (where.empty() ? "" : " at " + where) + ", capture " +
                            std::to_string(i + 1) + " of " + std::to_string(captures);
      request.directory = staging->path() / calibration::kCapturesDirectory /
                          (args.target + (args.places > 1 ? "-p" + std::to_string(place + 1) : "") +
                           "-" + std::to_string(i));
      request.process = false;
      auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
        tell(args, where + (where.empty() ? "" : ", ") + "capture " + std::to_string(i + 1) +
                       " of " + std::to_string(captures) + ": " + p.step);
      });
      if (!outcome) return std::unexpected(outcome.error());
      scans[static_cast<std::size_t>(place)].push_back(outcome->directory);
    }
  }
  std::vector<SphereSet> sets;
  for (const auto& place_scans : scans) {
    auto set = load_captures(args.target, place_scans);
    if (!set) return std::unexpected(set.error());
    // The current flat field, when there is one, evens out the sensor's and
    // the LEDs' fall-off across the field first (a matte sphere's rim would
    // otherwise read dimmer than its centre).
    if (const auto flat_from = divide_by_current_flats(store, *set)) result_flat_note = *flat_from;
    sets.push_back(std::move(*set));
  }
  const auto as_captured = [&](Error error) {
    // Its captures go with the refused calibration: name the rig instead.
    error.message = "the " + args.target + " sphere as captured: " + error.message;
    error.file = config.source;
    return std::unexpected(error);
  };
  calibration::CameraModel camera{args.focal_px};
  auto& set = sets.front();
  auto result = compute(args.target == "chrome" ? &set : nullptr,
                        args.target == "matte" ? &set : nullptr, camera, 0.95);
  if (!result) return as_captured(result.error());
  nlohmann::json led_positions = nullptr;
  if (sets.size() > 1 && scale) {
    scale->plane.image_size = set.lights.front().frames.front().image.size();
    auto section = led_positions_section(sets, *scale, staging->path(),
                                         fs::absolute(config.source).lexically_normal());
    if (!section) return as_captured(section.error());
    led_positions = *section;
  }
  result->sources[args.target] = describe_sources(set, staging->path());
  if (!result_flat_note.empty()) result->sources["flat"] = result_flat_note;
  result->sources["rig"] = fs::absolute(config.source).lexically_normal().string();
  return write_to_store(config, std::move(*staging), *result, led_positions);
}

Result<CalibrationOutcome> calibrate_lights_to_file(const CalibrationRequest& request,
                                                    const fs::path& out) {
  if (request.images.size() > 1)
    return std::unexpected(bad_input(out, "--out",
                                     "takes one sphere; the LEDs' positions (--images once per "
                                     "place) go into the rig's store: give --config RIG.toml"));
  auto spheres = load_spheres(request);
  if (!spheres) return std::unexpected(spheres.error());
  calibration::CameraModel camera{request.focal_px};
  auto result = compute(spheres->chrome ? &*spheres->chrome : nullptr,
                        spheres->matte ? &*spheres->matte : nullptr, camera, 0.98);
  if (!result) return std::unexpected(result.error());
  if (spheres->chrome) result->sources["chrome"] = describe_sources(*spheres->chrome, {});
  if (spheres->matte) result->sources["matte"] = describe_sources(*spheres->matte, {});
  const nlohmann::json document = calibration::to_json(*result, calibration::utc_now());
  if (auto ok = calibration::write_new_file(out, document.dump(2) + "\n"); !ok)
    return std::unexpected(ok.error());
  return CalibrationOutcome{"lights", out, document};
}

}  // namespace psrig::rig
