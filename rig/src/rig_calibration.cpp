// The rig's calibration procedures (rig_calibration.h): lights (chrome or
// matte sphere; the chrome sphere at several places for near LEDs' positions),
// flat (a white card under each LED), scale (a ChArUco board), colour (a
// ColorChecker Classic). Each captures on the rig, computes, and stores a
// new version of the calibration.

#include "psrig/rig/rig_calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/calibration/calibration_store.h"
#include "psrig/calibration/colour.h"
#include "psrig/calibration/image_set.h"
#include "psrig/calibration/light_calibration.h"
#include "psrig/calibration/scale.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/processing/linearise.h"
#include "psrig/formats/scan_reader.h"

namespace psrig::rig {
namespace {

namespace fs = std::filesystem;
using calibration::LightFrames;

// The images of one sphere, grouped by light.
struct SphereSet {
  std::string role;  // "chrome" or "matte"
  fs::path source;   // the folder, or the rig's captures
  std::vector<LightFrames> lights;
  cv::Mat mask;
  std::optional<fs::path> mask_file;
  std::vector<fs::path> files;
};

Result<SphereSet> load_folder(const std::string& role, const fs::path& folder,
                              const std::string& mask_override, int frames_per_light,
                              formats::Encoding encoding) {
  SphereSet set;
  set.role = role;
  set.source = folder;
  auto listed = calibration::list_image_folder(folder);
  if (!listed) return std::unexpected(listed.error());
  const std::size_t count = listed->images.size();
  if (count % static_cast<std::size_t>(frames_per_light) != 0)
    return std::unexpected(
        bad_input(folder, "--frames",
                  "holds " + std::to_string(count) + " images, not a whole number of lights at " +
                      std::to_string(frames_per_light) +
                      " frames each; give --frames to match, or remove the extra images"));
  if (count / frames_per_light < 3)
    return std::unexpected(bad_input(folder, "",
                                     "holds images of " + std::to_string(count / frames_per_light) +
                                         " lights; a calibration needs 3 or more"));
  set.files = listed->images;
  for (std::size_t i = 0; i < count; ++i) {
    auto image = calibration::read_linear_grey(listed->images[i], encoding);
    if (!image) return std::unexpected(image.error());
    if (i % static_cast<std::size_t>(frames_per_light) == 0) set.lights.emplace_back();
    set.lights.back().frames.push_back({*image, listed->images[i]});
  }
  if (!mask_override.empty())
    set.mask_file = mask_override;
  else
    set.mask_file = listed->mask;
  if (set.mask_file) {
    auto mask = calibration::read_mask(*set.mask_file, "--mask");
    if (!mask) return std::unexpected(mask.error());
    if (mask->size() != set.lights.front().frames.front().image.size())
      return std::unexpected(bad_input(*set.mask_file, "--mask",
                                       "differs in size from the images; give the sphere's mask "
                                       "for these images"));
    set.mask = *mask;
  }
  return set;
}

// A frame as stored, in linear float (its channels kept).
cv::Mat linearised(const processing::CodeLineariser& lineariser, const cv::Mat& stored) {
  const cv::Mat continuous = stored.isContinuous() ? stored : stored.clone();
  cv::Mat linear(continuous.size(), CV_MAKETYPE(CV_32F, continuous.channels()));
  lineariser.convert(continuous.data, static_cast<int>(continuous.total()) * continuous.channels(),
                     linear.ptr<float>());
  return linear;
}

// Scans the sequencer wrote, as frames per light: linear, dark subtracted.
Result<SphereSet> load_captures(const std::string& role, const std::vector<fs::path>& scans) {
  SphereSet set;
  set.role = role;
  set.source = scans.front().parent_path();
  for (const auto& directory : scans) {
    auto scan = formats::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(formats::Encoding::linear, d.black_level,
                                                scan->white_level, scan->depth());
    const auto linear_grey = [&](const cv::Mat& stored) {
      cv::Mat linear = linearised(lineariser, stored);
      if (linear.channels() == 3)
        cv::transform(linear, linear, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
      return linear;
    };
    const cv::Mat dark = scan->dark.empty() ? cv::Mat() : linear_grey(scan->dark);
    if (set.lights.empty()) set.lights.resize(scan->frames.size());
    for (std::size_t k = 0; k < scan->frames.size(); ++k) {
      cv::Mat image = linear_grey(scan->frames[k]);
      if (!dark.empty()) image -= dark;
      const fs::path file = directory / d.lights[k].image;
      set.lights[k].frames.push_back({image, file});
      set.files.push_back(file);
    }
  }
  return set;
}

Result<calibration::Circle> locate(const SphereSet& set) {
  std::vector<cv::Mat> all;
  for (const auto& light : set.lights)
    for (const auto& frame : light.frames)
      all.push_back(frame.image);
  return calibration::find_sphere(all, set.mask, set.mask_file ? *set.mask_file : set.source);
}

Result<calibration::LightCalibration> compute(const SphereSet* chrome, const SphereSet* matte,
                                              const calibration::CameraModel& camera,
                                              double saturation) {
  calibration::LightCalibration result;
  result.camera = camera;
  result.method = chrome && matte ? "chrome+matte" : chrome ? "chrome" : "matte";
  if (chrome && matte && chrome->lights.size() != matte->lights.size())
    return std::unexpected(bad_input(matte->source, "--matte",
                                     "holds images of " + std::to_string(matte->lights.size()) +
                                         " lights but " + chrome->source.string() + " of " +
                                         std::to_string(chrome->lights.size()) +
                                         "; give both spheres under the same lights"));
  if (chrome) {
    auto sphere = locate(*chrome);
    if (!sphere) return std::unexpected(sphere.error());
    result.chrome_sphere = *sphere;
    auto lights = calibration::calibrate_chrome(chrome->lights, *sphere, camera, saturation);
    if (!lights) return std::unexpected(lights.error());
    result.chrome = *lights;
  }
  if (matte) {
    auto sphere = locate(*matte);
    if (!sphere) return std::unexpected(sphere.error());
    result.matte_sphere = *sphere;
    auto lights = calibration::calibrate_matte(matte->lights, *sphere, camera, saturation);
    if (!lights) return std::unexpected(lights.error());
    result.matte = *lights;
  }
  return result;
}

nlohmann::json describe_sources(const SphereSet& set, const fs::path& relative_to) {
  nlohmann::json files = nlohmann::json::array();
  const auto name = [&](const fs::path& file) {
    return relative_to.empty() ? fs::absolute(file).lexically_normal().string()
                               : file.lexically_relative(relative_to).string();
  };
  for (const auto& file : set.files)
    files.push_back(name(file));
  std::size_t frames = set.lights.empty() ? 0 : set.lights.front().frames.size();
  return {{"images", files},
          {"frames_per_light", frames},
          {"mask", set.mask_file ? nlohmann::json(name(*set.mask_file)) : nlohmann::json(nullptr)}};
}

// Copies a set's files into `captures/<role>/` of a store version.
Result<SphereSet> copy_into(const SphereSet& set, const fs::path& version) {
  SphereSet copied = set;
  const fs::path directory = version / calibration::kCapturesDirectory / set.role;
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) return std::unexpected(io_error(directory, "cannot create: " + ec.message()));
  copied.files.clear();
  for (const auto& file : set.files) {
    const fs::path target = directory / file.filename();
    fs::copy_file(file, target, ec);
    if (ec)
      return std::unexpected(
          io_error(target, "cannot copy " + file.string() + ": " + ec.message()));
    copied.files.push_back(target);
  }
  if (set.mask_file) {
    const fs::path target = directory / set.mask_file->filename();
    fs::copy_file(*set.mask_file, target, ec);
    if (ec) return std::unexpected(io_error(target, "cannot copy: " + ec.message()));
    copied.mask_file = target;
  }
  return copied;
}

// Divides each light's frames by the current calibration's flat for it,
// smoothed and scaled to mean 1 (so relative intensities stay). Returns
// the calibration.json whose flats were used, when they were.
std::optional<std::string> divide_by_current_flats(const calibration::CalibrationStore& store,
                                                   SphereSet& set) {
  const auto file = store.current();
  if (!file) return std::nullopt;
  auto current = calibration::read_calibration(*file);
  if (!current || current->flat_images.size() != set.lights.size()) return std::nullopt;
  std::vector<cv::Mat> gains;
  for (std::size_t k = 0; k < set.lights.size(); ++k) {
    cv::Mat flat = cv::imread(current->flat_images[k].string(), cv::IMREAD_UNCHANGED);
    if (flat.empty() || set.lights[k].frames.empty() ||
        flat.size() != set.lights[k].frames.front().image.size())
      return std::nullopt;
    flat.convertTo(flat, CV_32F);
    if (flat.channels() == 3) cv::transform(flat, flat, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
    cv::GaussianBlur(flat, flat, cv::Size(), 2.0);
    const double mean = cv::mean(flat)[0];
    if (!(mean > 0)) return std::nullopt;
    cv::max(flat / mean, 0.05, flat);
    gains.push_back(flat);
  }
  for (std::size_t k = 0; k < set.lights.size(); ++k)
    for (auto& frame : set.lights[k].frames)
      frame.image = frame.image / gains[k];
  return file->string();
}

// ---- near-field LEDs: the chrome sphere at several places -------------

// What places the sphere's pixels in millimetres, and where each came from.
struct NearFieldScale {
  calibration::PlaneGeometry plane;
  std::string pixel_size_from;
  std::string sphere_from;
};

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

double round_to(double value, double step) {
  return std::round(value / step) * step;
}

// The LEDs' positions from the sphere's places, as calibration.json's
// led_positions_mm section; bad_input when the sphere did not move.
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

// A new version's calibration.json written and the version committed.
Result<CalibrationOutcome> commit_version(formats::AtomicDirectory staging,
                                          const std::string& kind, const nlohmann::json& document) {
  const std::string text = document.dump(2) + "\n";
  if (auto ok = calibration::write_new_file(staging.path() / calibration::kCalibrationFile, text);
      !ok)
    return std::unexpected(ok.error());
  const fs::path target = staging.target();
  if (auto ok = staging.commit(formats::AtomicDirectory::Existing::refuse, true); !ok)
    return std::unexpected(ok.error());
  return CalibrationOutcome{kind, target / calibration::kCalibrationFile, document};
}

Result<CalibrationOutcome> write_to_store(const config::RigConfig& config,
                                          formats::AtomicDirectory staging,
                                          calibration::LightCalibration& result,
                                          const nlohmann::json& led_positions = nullptr) {
  nlohmann::json document = calibration::to_json(result, calibration::utc_now());
  // The sections this does not measure (the flat field, …) carry over from
  // the current version.
  const calibration::CalibrationStore store(config.storage.root);
  if (const auto current_file = store.current()) {
    if (auto current = calibration::read_calibration(*current_file)) {
      if (auto carried = calibration::carry_forward(*current, "lights")) {
        for (const char* section : {"flat", "colour", "scale", "led_positions_mm"})
          document[section] = (*carried)[section];
        document["contains"] = (*carried)["contains"];
      }
    }
  }
  if (!led_positions.is_null()) {
    document["led_positions_mm"] = led_positions;
    nlohmann::json contains = nlohmann::json::array();
    for (const char* section : {"lights", "flat", "colour", "scale", "led_positions_mm"})
      if (document.contains(section) && !document[section].is_null()) contains.push_back(section);
    document["contains"] = contains;
  }
  return commit_version(std::move(staging), "lights", document);
}

void tell(const CalibrationRequest& request, const std::string& step) {
  if (request.progress) request.progress(step);
}

// The spheres of a lights calibration from images already taken.
struct FolderSpheres {
  std::optional<SphereSet> chrome;
  std::optional<SphereSet> matte;
  int per_light = 1;
  formats::Encoding encoding = formats::Encoding::linear;
};

Result<FolderSpheres> load_spheres(const CalibrationRequest& args) {
  FolderSpheres spheres;
  spheres.encoding =
      args.encoding == "srgb" ? formats::Encoding::srgb : formats::Encoding::linear;
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

// ---- flat ----

// A flat frame per light, from the card's captures: linear (0..1 of full
// scale), dark subtracted, all channels, the captures averaged; and the
// fraction of its pixels at full scale.
struct FlatFrames {
  std::vector<cv::Mat> linear;
  std::vector<double> saturated;
};

Result<FlatFrames> load_flats(const std::vector<fs::path>& scans) {
  FlatFrames flats;
  for (const auto& directory : scans) {
    auto scan = formats::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(formats::Encoding::linear, d.black_level,
                                                scan->white_level, scan->depth());
    const auto linear = [&](const cv::Mat& stored) { return linearised(lineariser, stored); };
    const cv::Mat dark = scan->dark.empty() ? cv::Mat() : linear(scan->dark);
    if (flats.linear.empty()) {
      flats.linear.resize(scan->frames.size());
      flats.saturated.assign(scan->frames.size(), 0.0);
    }
    for (std::size_t k = 0; k < scan->frames.size(); ++k) {
      cv::Mat image = linear(scan->frames[k]);
      cv::Mat grey = image.reshape(1, image.rows * image.cols);
      cv::Mat full;
      cv::reduce(grey, full, 1, cv::REDUCE_MAX);
      flats.saturated[k] = std::max(
          flats.saturated[k], static_cast<double>(cv::countNonZero(full >= 0.98f)) / full.total());
      if (!dark.empty()) image -= dark;
      if (flats.linear[k].empty())
        flats.linear[k] = image / static_cast<double>(scans.size());
      else
        flats.linear[k] += image / static_cast<double>(scans.size());
    }
  }
  return flats;
}

// How far a flat frame is from a uniform card: the RMS of its ratio to its
// own smooth version (a card's shading is smooth, a textile's or a
// sphere's is not), its mean level, and its fall-off (smooth minimum over
// maximum) over the field, the rim of a blur's width left out.
struct FlatQuality {
  double roughness = 0;
  double mean = 0;
  double fall_off = 0;
};

FlatQuality flat_quality(const cv::Mat& flat) {
  cv::Mat grey;
  if (flat.channels() == 3)
    cv::transform(flat, grey, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
  else
    grey = flat;
  const double sigma = std::min(flat.cols, flat.rows) / 32.0;
  cv::Mat smooth;
  cv::GaussianBlur(grey, smooth, cv::Size(), sigma, sigma, cv::BORDER_REFLECT);
  const int rim = static_cast<int>(std::ceil(3 * sigma));
  const cv::Rect inside(rim, rim, flat.cols - 2 * rim, flat.rows - 2 * rim);
  FlatQuality q;
  q.mean = cv::mean(grey(inside))[0];
  cv::Mat floor = cv::max(smooth(inside), 1e-6);
  cv::Mat ratio = grey(inside) / floor - 1.0;
  q.roughness = std::sqrt(cv::mean(ratio.mul(ratio))[0]);
  double lo = 0, hi = 0;
  cv::minMaxLoc(smooth(inside), &lo, &hi);
  q.fall_off = hi > 0 ? lo / hi : 0;
  return q;
}

// ---- what flat, scale and colour share ----

// The rig's current calibration, which a flat, a scale or a colour extends
// (each is stored with the lights), and the new version's document with
// its other sections carried over; bad input naming the fix where there
// is no light calibration.
struct Extension {
  fs::path current_file;
  calibration::StoredCalibration current;
  nlohmann::json document;
};

Result<Extension> extend_current(const config::RigConfig& config,
                                 const calibration::CalibrationStore& store,
                                 const std::string& kind) {
  const auto current_file = store.current();
  if (!current_file)
    return std::unexpected(bad_input(config.source, "storage.root",
                                     "has no light calibration (" + store.directory().string() +
                                         "): run psrig calibrate lights first; the " + kind +
                                         " is stored with the lights"));
  auto current = calibration::read_calibration(*current_file);
  if (!current) return std::unexpected(current.error());
  auto document = calibration::carry_forward(*current, kind);
  if (!document) return std::unexpected(document.error());
  return Extension{*current_file, std::move(*current), std::move(*document)};
}

// The simulated rig puts `target` under its camera in place of the swatch;
// a target named in [sim] target stays.
config::RigConfig with_sim_target(const config::RigConfig& config, const std::string& target) {
  config::RigConfig placed = config;
  if (placed.camera.backend == "sim" && placed.sim.target == "swatch") placed.sim.target = target;
  return placed;
}

// `frames` captures of what lies under the camera (every LED in turn, the
// dark frame), unprocessed, into captures/NAME-I of the staged version.
Result<std::vector<fs::path>> capture_target(const config::RigConfig& config,
                                             const formats::AtomicDirectory& staging,
                                             const std::string& name, const std::string& sample_id,
                                             const std::string& description, int frames,
                                             const CalibrationRequest& args) {
  auto rig = open_rig(config);
  if (!rig) return std::unexpected(rig.error());
  ScanSequencer sequencer(config, *rig->lights, *rig->camera);
  std::error_code ec;
  fs::create_directories(staging.path() / calibration::kCapturesDirectory, ec);
  std::vector<fs::path> scans;
  for (int i = 0; i < frames; ++i) {
    const std::string count = "capture " + std::to_string(i + 1) + " of " + std::to_string(frames);
    ScanRequest request;
    request.sample_id = sample_id;
    request.description = description + ", " + count;
    request.directory =
        staging.path() / calibration::kCapturesDirectory / (name + "-" + std::to_string(i));
    request.process = false;
    auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
      tell(args, frames > 1 ? count + ": " + p.step : p.step);
    });
    if (!outcome) return std::unexpected(outcome.error());
    scans.push_back(outcome->directory);
  }
  return scans;
}

// The captures' names in the staged version, as a calibration section's
// "sources" gives them.
nlohmann::json captured_sources(const std::vector<fs::path>& scans,
                                const formats::AtomicDirectory& staging,
                                const config::RigConfig& config) {
  nlohmann::json captures = nlohmann::json::array();
  for (const auto& scan : scans)
    captures.push_back(scan.lexically_relative(staging.path()).string());
  return {{"captures", captures}, {"rig", fs::absolute(config.source).lexically_normal().string()}};
}

// A new version staged for an image already taken (--image), the image
// copied into its captures/KIND/; returns its name there.
Result<std::string> stage_given_image(const calibration::CalibrationStore& store,
                                      const fs::path& image, const std::string& kind,
                                      std::optional<formats::AtomicDirectory>& staging) {
  auto next = store.begin_next();
  if (!next) return std::unexpected(next.error());
  staging.emplace(std::move(*next));
  const fs::path directory = staging->path() / calibration::kCapturesDirectory / kind;
  std::error_code ec;
  fs::create_directories(directory, ec);
  fs::copy_file(image, directory / image.filename(), ec);
  if (ec) return std::unexpected(io_error(directory, "cannot copy the image: " + ec.message()));
  return "captures/" + kind + "/" + image.filename().string();
}

// Every LED's frame of every capture averaged (the target evenly lit),
// linear, dark subtracted, 0..1 of full scale, its channels kept; each
// light's frame times its gain first when `gains` holds one per light
// (the flat field as scans apply it); and where any frame reached full
// scale.
Result<calibration::LinearColourImage> average_captures(const std::vector<fs::path>& scans,
                                                        const std::vector<cv::Mat>& gains = {}) {
  calibration::LinearColourImage out;
  int count = 0;
  for (const auto& directory : scans) {
    auto scan = formats::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(formats::Encoding::linear, d.black_level,
                                                scan->white_level, scan->depth());
    const cv::Mat dark = scan->dark.empty() ? cv::Mat() : linearised(lineariser, scan->dark);
    for (std::size_t k = 0; k < scan->frames.size(); ++k) {
      cv::Mat image = linearised(lineariser, scan->frames[k]);
      cv::Mat brightest;
      cv::reduce(image.reshape(1, static_cast<int>(image.total())), brightest, 1, cv::REDUCE_MAX);
      const cv::Mat full = brightest.reshape(1, image.rows) >= 0.98f;
      out.saturated = out.saturated.empty() ? full : cv::Mat(out.saturated | full);
      if (!dark.empty()) image -= dark;
      if (!gains.empty()) {
        if (gains.size() != scan->frames.size() || gains[k].size() != image.size() ||
            gains[k].channels() != image.channels())
          return std::unexpected(bad_input(directory, "flat",
                                           "does not fit the rig's current flat field (lights "
                                           "or frame size): run psrig calibrate flat again"));
        image = image.mul(gains[k]);
      }
      out.bgr = out.bgr.empty() ? image : cv::Mat(out.bgr + image);
      ++count;
    }
  }
  if (count > 0) out.bgr /= count;
  return out;
}

// ---- flat ----

// A card is refused when it is not flat and uniform (the textile or a
// sphere still under the camera), saturated, or unlit.
constexpr double kFlatMaxRoughness = 0.04;
constexpr double kFlatMaxSaturated = 0.001;
constexpr double kFlatMinMean = 0.02;

Result<CalibrationOutcome> flat_on_rig(const config::RigConfig& rig_config,
                                       const CalibrationRequest& args) {
  const int frames = args.frames > 0 ? args.frames : 3;
  calibration::CalibrationStore store(rig_config.storage.root);
  auto extension = extend_current(rig_config, store, "flat");
  if (!extension) return std::unexpected(extension.error());
  if (extension->current.lights.size() != static_cast<std::size_t>(rig_config.lights.channels))
    return std::unexpected(bad_input(extension->current_file, "lights.per_light",
                                     "has " + std::to_string(extension->current.lights.size()) +
                                         " lights but " + rig_config.source.string() + " " +
                                         std::to_string(rig_config.lights.channels) +
                                         ": run psrig calibrate lights again"));
  // The simulated rig puts the white card under its camera; a sphere named
  // in [sim] target stays (the card forgotten).
  const config::RigConfig config = with_sim_target(rig_config, "white_card");

  auto staging = store.begin_next();
  if (!staging) return std::unexpected(staging.error());
  auto scans =
      capture_target(config, *staging, "flat", "flat-card", "flat field: white card", frames, args);
  if (!scans) return std::unexpected(scans.error());
  auto flats = load_flats(*scans);
  if (!flats) return std::unexpected(flats.error());
  nlohmann::json per_light = nlohmann::json::array();
  std::vector<FlatQuality> quality;
  for (std::size_t k = 0; k < flats->linear.size(); ++k) {
    const FlatQuality q = flat_quality(flats->linear[k]);
    quality.push_back(q);
    const std::string light = "light " + std::to_string(k);
    std::string problem;
    if (flats->saturated[k] > kFlatMaxSaturated)
      problem = "the card as captured under " + light + " is saturated (" +
                std::to_string(flats->saturated[k] * 100).substr(0, 4) +
                " % of its pixels at full scale): lower camera.exposure_us or camera.gain, or "
                "use a grey card";
    else if (q.mean < kFlatMinMean)
      problem = "the card as captured under " + light +
                " is dark: is the LED on, and the card under the camera?";
    else if (q.roughness > kFlatMaxRoughness)
      problem = "the capture under " + light + " is not a uniform card (it varies by " +
                std::to_string(q.roughness * 100).substr(0, 4) +
                " % RMS from pixel to pixel): lay a flat white or grey card over the whole "
                "field, then run psrig calibrate flat again";
    if (!problem.empty()) return std::unexpected(bad_input(config.source, "", problem));
    per_light.push_back({{"index", k},
                         {"image", "captures/flat/flat" + std::to_string(k) + ".png"},
                         {"mean", std::round(q.mean * 1e4) / 1e4},
                         {"fall_off", std::round(q.fall_off * 1e4) / 1e4},
                         {"roughness", std::round(q.roughness * 1e5) / 1e5}});
  }
  // The flats: linear, dark subtracted, 0..1 of full scale as 16 bits.
  const fs::path flat_directory = staging->path() / calibration::kCapturesDirectory / "flat";
  std::error_code ec;
  fs::create_directories(flat_directory, ec);
  if (ec) return std::unexpected(io_error(flat_directory, "cannot create: " + ec.message()));
  nlohmann::json images = nlohmann::json::array();
  for (std::size_t k = 0; k < flats->linear.size(); ++k) {
    cv::Mat stored;
    flats->linear[k].convertTo(stored, CV_16U, 65535.0);
    const std::string name = "captures/flat/flat" + std::to_string(k) + ".png";
    if (!cv::imwrite((staging->path() / name).string(), stored))
      return std::unexpected(io_error(staging->path() / name, "cannot write"));
    images.push_back(name);
  }
  auto& doc = extension->document;
  doc["flat"] = {{"created", doc["created"]},
                 {"images", images},
                 {"encoding", "linear, dark subtracted, 65535 = full scale"},
                 {"sources", captured_sources(*scans, *staging, config)},
                 {"per_light", per_light}};
  return commit_version(std::move(*staging), "flat", doc);
}

// ---- scale ----

Result<CalibrationOutcome> scale_on_rig(const config::RigConfig& rig_config,
                                        const CalibrationRequest& args) {
  calibration::CharucoSpec spec;
  spec.square_mm = args.square_mm;
  spec.marker_mm = args.marker_mm;
  spec.dictionary = args.dictionary;
  if (std::sscanf(args.squares.c_str(), "%dx%d", &spec.squares_x, &spec.squares_y) != 2 ||
      spec.squares_x < 2 || spec.squares_y < 2 || spec.squares_x > 100 || spec.squares_y > 100)
    return std::unexpected(
        bad_input({}, "--squares", "must be COLUMNSxROWS, e.g. 7x5 (2 to 100 each)"));
  if (!(spec.marker_mm > 0 && spec.marker_mm < spec.square_mm))
    return std::unexpected(
        bad_input({}, "--marker-mm", "must be more than 0, less than --square-mm"));
  if (calibration::dictionary_id(spec.dictionary) < 0)
    return std::unexpected(bad_input({}, "--dictionary",
                                     spec.dictionary +
                                         " is not an OpenCV predefined dictionary (DICT_4X4_50, "
                                         "DICT_5X5_100, …, DICT_ARUCO_ORIGINAL)"));
  calibration::CalibrationStore store(rig_config.storage.root);
  auto extension = extend_current(rig_config, store, "scale");
  if (!extension) return std::unexpected(extension.error());

  cv::Mat image;
  fs::path source;
  nlohmann::json sources;
  std::optional<formats::AtomicDirectory> staging;
  if (!args.image.empty()) {
    auto read = calibration::read_linear_grey(args.image, formats::Encoding::linear);
    if (!read) return std::unexpected(read.error());
    image = *read;
    source = args.image;
  } else {
    const config::RigConfig config = with_sim_target(rig_config, "charuco_board");
    auto next = store.begin_next();
    if (!next) return std::unexpected(next.error());
    staging.emplace(std::move(*next));
    auto scans =
        capture_target(config, *staging, "scale", "charuco-board", "scale: ChArUco board", 1, args);
    if (!scans) return std::unexpected(scans.error());
    auto averaged = average_captures(*scans);
    if (!averaged) return std::unexpected(averaged.error());
    image = averaged->bgr;
    if (image.channels() == 3) cv::transform(image, image, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
    source = config.source;
    sources = captured_sources(*scans, *staging, config);
  }
  auto estimate = calibration::measure_scale(image, spec, source);
  if (!estimate) {
    Error error = estimate.error();
    if (args.image.empty()) error.message = "the board as captured " + error.message;
    return std::unexpected(error);
  }
  if (!staging) {
    auto copied = stage_given_image(store, args.image, "scale", staging);
    if (!copied) return std::unexpected(copied.error());
    sources = {{"image", *copied}};
  }
  auto& doc = extension->document;
  doc["scale"] = {{"created", doc["created"]},
                  {"pixel_size_mm", estimate->pixel_size_mm},
                  {"uncertainty_mm", estimate->uncertainty_mm},
                  {"distortion", nullptr},
                  {"rotation_deg", std::round(estimate->rotation_deg * 1e4) / 1e4},
                  {"fit_rms_px", std::round(estimate->fit_rms_px * 1e4) / 1e4},
                  {"corners", estimate->corners},
                  {"markers", estimate->markers},
                  {"board",
                   {{"squares", {spec.squares_x, spec.squares_y}},
                    {"square_mm", spec.square_mm},
                    {"marker_mm", spec.marker_mm},
                    {"dictionary", spec.dictionary}}},
                  {"sources", sources}};
  return commit_version(std::move(*staging), "scale", doc);
}

// ---- colour ----

// A patch is refused when more than this of it reached full scale, and the
// chart when its white patch reads below this of full scale.
constexpr double kColourMaxSaturated = 0.01;
constexpr double kColourMinWhite = 0.02;

// The current flat field as processing applies it to a scan (linearise.cpp):
// per light and channel the flat, smoothed, over the light's incidence,
// and one level for all of them; the gain is the level over it. A matrix
// measured through these gains holds for scans flat-fielded alike.
Result<std::vector<cv::Mat>> colour_flat_gains(const calibration::StoredCalibration& current) {
  std::vector<cv::Mat> flats;
  double level = 0;
  for (std::size_t k = 0; k < current.flat_images.size(); ++k) {
    const fs::path& file = current.flat_images[k];
    cv::Mat flat = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    if (flat.empty() || flat.channels() != 3 || k >= current.lights.size())
      return std::unexpected(bad_input(file, "flat.images",
                                       "cannot be read as a colour flat for light " +
                                           std::to_string(k) +
                                           ": run psrig calibrate flat again, then colour"));
    flat.convertTo(flat, CV_32FC3, 1.0 / 65535.0);
    cv::GaussianBlur(flat, flat, cv::Size(), 2.0);
    flat /= std::max(current.lights[k].direction[2], 0.05);
    const cv::Scalar mean = cv::mean(flat);
    cv::max(flat, cv::Scalar::all(0.01 * (mean[0] + mean[1] + mean[2]) / 3), flat);
    level += (mean[0] + mean[1] + mean[2]) / 3;
    flats.push_back(flat);
  }
  if (!flats.empty()) level /= static_cast<double>(flats.size());
  std::vector<cv::Mat> gains;
  for (const auto& flat : flats) {
    cv::Mat gain;
    cv::divide(cv::Scalar::all(level), flat, gain);
    gains.push_back(gain);
  }
  return gains;
}

nlohmann::json rounded(const cv::Vec3d& v, double step) {
  return {std::round(v[0] / step) * step, std::round(v[1] / step) * step,
          std::round(v[2] / step) * step};
}

Result<CalibrationOutcome> colour_on_rig(const config::RigConfig& rig_config,
                                         const CalibrationRequest& args) {
  const int frames = args.frames > 0 ? args.frames : 1;
  calibration::CalibrationStore store(rig_config.storage.root);
  auto extension = extend_current(rig_config, store, "colour");
  if (!extension) return std::unexpected(extension.error());
  const calibration::StoredCalibration& current = extension->current;

  calibration::LinearColourImage image;
  fs::path source;
  nlohmann::json sources;
  std::optional<formats::AtomicDirectory> staging;
  // Scans divide by the current flat field channel by channel: the chart
  // captured on the rig is read through it too, and the version named.
  nlohmann::json flat_field = nullptr;
  if (!args.image.empty()) {
    if (!current.flat_version.empty() && args.warn)
      args.warn(args.image.string() + " is taken as it is, not through the rig's flat field " +
                current.flat_version +
                ", so scans (which are flat-fielded) will go without this matrix; calibrate on "
                "the rig (without --image) for them");
    auto read = calibration::read_linear_colour(args.image, args.encoding == "srgb"
                                                                ? formats::Encoding::srgb
                                                                : formats::Encoding::linear);
    if (!read) return std::unexpected(read.error());
    image = std::move(*read);
    source = args.image;
  } else {
    std::vector<cv::Mat> flat_gains;
    if (!current.flat_images.empty()) {
      auto gains = colour_flat_gains(current);
      if (!gains) return std::unexpected(gains.error());
      flat_gains = std::move(*gains);
      flat_field = current.flat_version;
    }
    // The simulated rig puts its ColorChecker under the camera.
    const config::RigConfig config = with_sim_target(rig_config, "colour_chart");
    auto next = store.begin_next();
    if (!next) return std::unexpected(next.error());
    staging.emplace(std::move(*next));
    auto scans = capture_target(config, *staging, "colour", "colour-chart",
                                "colour: ColorChecker Classic", frames, args);
    if (!scans) return std::unexpected(scans.error());
    auto averaged = average_captures(*scans, flat_gains);
    if (!averaged) return std::unexpected(averaged.error());
    if (averaged->bgr.channels() != 3)
      return std::unexpected(bad_input(scans->front(), "camera",
                                       "holds grey frames; the colour calibration needs a "
                                       "colour camera (its RGB frames)"));
    image = std::move(*averaged);
    source = config.source;
    sources = captured_sources(*scans, *staging, config);
  }
  // Refusals name the image, or the rig whose capture it was (the capture
  // goes with the refused version).
  const std::string as_captured = args.image.empty() ? "the chart as captured: " : "";
  const auto refuse = [&](const std::string& problem) {
    return std::unexpected(bad_input(source, "", as_captured + problem));
  };
  auto reading = calibration::read_colour_chart(image.bgr, image.saturated, source);
  if (!reading) {
    Error error = reading.error();
    if (args.image.empty()) error.message = "the chart as captured " + error.message;
    return std::unexpected(error);
  }
  const auto& chart = calibration::colorchecker_classic();
  for (int p = 0; p < calibration::kChartPatches; ++p) {
    const auto i = static_cast<std::size_t>(p);
    if (reading->saturated[i] > kColourMaxSaturated)
      return refuse("its patch " + std::to_string(p + 1) + " (" + chart[i].name +
                    ") is saturated (" + std::to_string(std::lround(reading->saturated[i] * 100)) +
                    " % of it at full scale): lower camera.exposure_us or camera.gain, and "
                    "capture again");
  }
  const double white = cv::mean(reading->rgb[calibration::kFirstNeutralPatch])[0] * 4.0 / 3.0;
  if (white < kColourMinWhite)
    return refuse("its white patch reads " + std::to_string(white).substr(0, 5) +
                  " of full scale: is the chart lit? Raise camera.exposure_us or camera.gain");
  const calibration::ColourCorrection fit = calibration::fit_colour_correction(reading->rgb);

  if (!staging) {
    auto copied = stage_given_image(store, args.image, "colour", staging);
    if (!copied) return std::unexpected(copied.error());
    sources = {{"image", *copied}, {"encoding", args.encoding}};
  }
  nlohmann::json patches = nlohmann::json::array();
  for (int p = 0; p < calibration::kChartPatches; ++p) {
    const auto i = static_cast<std::size_t>(p);
    patches.push_back(
        {{"index", p + 1},
         {"name", chart[i].name},
         {"reference_lab", rounded(chart[i].lab_d50, 0.01)},
         {"camera_rgb", rounded(reading->rgb[i], 1e-5)},
         {"centre_px",
          {std::round(reading->centre[i].x * 10) / 10, std::round(reading->centre[i].y * 10) / 10}},
         {"lab_before", rounded(fit.lab_before[i], 0.01)},
         {"lab_after", rounded(fit.lab_after[i], 0.01)},
         {"delta_e2000_before", std::round(fit.delta_e_before[i] * 1000) / 1000},
         {"delta_e2000_after", std::round(fit.delta_e_after[i] * 1000) / 1000}});
  }
  const auto& m = fit.matrix;
  auto& doc = extension->document;
  doc["colour"] = {
      {"created", doc["created"]},
      {"matrix",
       {{m(0, 0), m(0, 1), m(0, 2)}, {m(1, 0), m(1, 1), m(1, 2)}, {m(2, 0), m(2, 1), m(2, 2)}}},
      {"matrix_maps",
       "camera linear RGB to linear sRGB, exposure-free (neutrals keep the camera's "
       "mean level)"},
      {"space", "sRGB D65"},
      {"white_point", "D65"},
      {"reference",
       {{"chart", "X-Rite ColorChecker Classic, 24 patches"},
        {"values", "X-Rite, charts made after November 2014, CIE L*a*b* D50 2 deg"},
        {"delta_e",
         "CIEDE2000 (lcms2), Lab D50: sRGB D65 adapted to D50 (Bradford) as lcms2's "
         "relative colorimetric intent does"}}},
      {"fit",
       "weighted least squares in linear light, weights 1/(Y + 0.05), the neutral patches' "
       "sum mapped exactly"},
      {"exposure", fit.exposure},
      {"flat_field", flat_field},
      {"delta_e2000",
       {{"before",
         {{"mean", std::round(fit.mean_before * 1000) / 1000},
          {"max", std::round(fit.max_before * 1000) / 1000}}},
        {"after",
         {{"mean", std::round(fit.mean_after * 1000) / 1000},
          {"max", std::round(fit.max_after * 1000) / 1000}}}}},
      {"patches", patches},
      {"chart_corners_px", nlohmann::json::array({{reading->corners[0].x, reading->corners[0].y},
                                                  {reading->corners[1].x, reading->corners[1].y},
                                                  {reading->corners[2].x, reading->corners[2].y},
                                                  {reading->corners[3].x, reading->corners[3].y}})},
      {"sources", sources}};
  return commit_version(std::move(*staging), "colour", doc);
}

}  // namespace

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
