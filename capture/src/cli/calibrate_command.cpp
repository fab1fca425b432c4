// psrig calibrate lights: the lights' directions and relative intensities
// from a chrome or a matte sphere, captured on the rig (--config) and kept
// in its calibration store, or computed from images already taken
// (--images DIR, written to --out FILE or to the rig's store).
// psrig calibrate flat: a white card under each LED, kept in the store and
// applied to every later scan. psrig calibrate scale: millimetres per pixel
// from a ChArUco board, used as every later scan's pixel size.
// psrig calibrate colour: a ColorChecker Classic, a matrix from the
// camera's RGB to linear sRGB D65 applied to every later scan's albedo.

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command.h"
#include "psrig/calibration/calibration_store.h"
#include "psrig/calibration/colour.h"
#include "psrig/calibration/image_set.h"
#include "psrig/calibration/light_calibration.h"
#include "psrig/calibration/scale.h"
#include "psrig/capture/rig.h"
#include "psrig/capture/scan_sequencer.h"
#include "psrig/firmware_host/emergency_stop.h"
#include "psrig/processing/linearise.h"
#include "psrig/processing/scan_reader.h"

namespace psrig::capture::cli {
namespace {

namespace fs = std::filesystem;
using calibration::LightFrames;

struct CalibrateArgs {
  std::string config;
  std::string target = "chrome";
  int frames = 0;  // 0: 3 captures on the rig, 1 image per light from a folder
  std::string images;
  std::string mask;
  std::string matte;
  std::string matte_mask;
  std::string out;
  std::optional<double> focal_px;
  std::string encoding = "linear";
  bool quiet = false;
};

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
                              processing::Encoding encoding) {
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
    auto scan = processing::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(processing::Encoding::linear, d.black_level,
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

void print_calibration(const calibration::LightCalibration& c) {
  const auto lights = calibration::combine(c);
  if (c.chrome_sphere)
    std::printf("chrome sphere: centre (%.2f, %.2f) px, radius %.2f px (fit RMS %.3f px)\n",
                c.chrome_sphere->centre.x, c.chrome_sphere->centre.y, c.chrome_sphere->radius,
                c.chrome_sphere->rms_px);
  if (c.matte_sphere)
    std::printf("matte sphere: centre (%.2f, %.2f) px, radius %.2f px (fit RMS %.3f px)\n",
                c.matte_sphere->centre.x, c.matte_sphere->centre.y, c.matte_sphere->radius,
                c.matte_sphere->rms_px);
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const auto& l = lights[k];
    std::printf("light %zu: tilt %7.2f deg, slant %6.2f deg, intensity %.3f, +/- %.3f deg", k,
                calibration::tilt_deg(l.direction), calibration::slant_deg(l.direction),
                l.intensity, l.uncertainty_deg);
    if (k < c.chrome.size() && c.chrome[k].frames_spread_deg && c.chrome[k].frames > 1)
      std::printf(", frames agree to %.3f deg", *c.chrome[k].frames_spread_deg);
    if (l.chrome_vs_matte_deg) std::printf(", chrome vs matte %.3f deg", *l.chrome_vs_matte_deg);
    std::printf("\n");
  }
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

int write_to_store(const config::RigConfig& config, processing::AtomicDirectory staging,
                   calibration::LightCalibration& result, bool quiet) {
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
  const std::string text = document.dump(2) + "\n";
  if (auto ok = calibration::write_new_file(staging.path() / calibration::kCalibrationFile, text);
      !ok)
    return report_error("calibrate lights", ok.error());
  const fs::path target = staging.target();
  if (auto ok = staging.commit(processing::AtomicDirectory::Existing::refuse, true); !ok)
    return report_error("calibrate lights", ok.error());
  if (!quiet) {
    print_calibration(result);
    std::printf("calibration: %s (current for %s)\n",
                (target / calibration::kCalibrationFile).c_str(), config.source.c_str());
  }
  return 0;
}

int run_from_images(const CalibrateArgs& args) {
  if (args.out.empty() && args.config.empty()) {
    std::fprintf(stderr,
                 "psrig calibrate lights: error: say where the calibration goes: --out FILE "
                 "(a calibration.json) or --config RIG.toml (the rig's calibration store)\n");
    return 2;
  }
  const auto encoding =
      args.encoding == "srgb" ? processing::Encoding::srgb : processing::Encoding::linear;
  const int per_light = args.frames > 0 ? args.frames : 1;
  std::optional<SphereSet> chrome;
  std::optional<SphereSet> matte;
  auto first = load_folder(args.target, args.images, args.mask, per_light, encoding);
  if (!first) return report_error("calibrate lights", first.error());
  (args.target == "chrome" ? chrome : matte) = std::move(*first);
  if (!args.matte.empty()) {
    if (args.target == "matte") {
      std::fprintf(stderr,
                   "psrig calibrate lights: error: --matte DIR is the matte sphere beside a "
                   "chrome one in --images; with --target matte, --images is the matte sphere\n");
      return 2;
    }
    auto second = load_folder("matte", args.matte, args.matte_mask, per_light, encoding);
    if (!second) return report_error("calibrate lights", second.error());
    matte = std::move(*second);
  }
  calibration::CameraModel camera{args.focal_px};
  auto result = compute(chrome ? &*chrome : nullptr, matte ? &*matte : nullptr, camera, 0.98);
  if (!result) return report_error("calibrate lights", result.error());

  if (!args.out.empty()) {
    if (chrome) result->sources["chrome"] = describe_sources(*chrome, {});
    if (matte) result->sources["matte"] = describe_sources(*matte, {});
    const std::string text = calibration::to_json(*result, calibration::utc_now()).dump(2) + "\n";
    if (auto ok = calibration::write_new_file(args.out, text); !ok)
      return report_error("calibrate lights", ok.error());
    if (!args.quiet) {
      print_calibration(*result);
      std::printf("calibration: %s\n", args.out.c_str());
    }
    return 0;
  }
  int exit_code = 0;
  auto config = load_config_or_report("calibrate lights", args.config, exit_code);
  if (!config) return exit_code;
  const std::size_t lights = std::max(result->chrome.size(), result->matte.size());
  if (lights != static_cast<std::size_t>(config->lights.channels))
    return report_error(
        "calibrate lights",
        bad_input(args.images, "",
                  "holds images of " + std::to_string(lights) + " lights but " + args.config +
                      " has " + std::to_string(config->lights.channels) +
                      " (lights.channels); give one image per LED of that rig, or --out FILE"));
  calibration::CalibrationStore store(config->storage.root);
  auto staging = store.begin_next();
  if (!staging) return report_error("calibrate lights", staging.error());
  for (auto* set : {chrome ? &*chrome : nullptr, matte ? &*matte : nullptr}) {
    if (!set) continue;
    auto copied = copy_into(*set, staging->path());
    if (!copied) return report_error("calibrate lights", copied.error());
    result->sources[set->role] = describe_sources(*copied, staging->path());
  }
  return write_to_store(*config, std::move(*staging), *result, args.quiet);
}

int run_on_rig(const CalibrateArgs& args) {
  stop_gracefully_on_signals();
  int exit_code = 0;
  auto config = load_config_or_report("calibrate lights", args.config, exit_code);
  if (!config) return exit_code;
  // The simulated rig puts the sphere under its camera.
  if (config->camera.backend == "sim")
    config->sim.target = args.target == "chrome" ? "chrome_sphere" : "matte_sphere";
  const int captures = args.frames > 0 ? args.frames : 3;
  calibration::CalibrationStore store(config->storage.root);
  auto staging = store.begin_next();
  if (!staging) return report_error("calibrate lights", staging.error());
  std::vector<fs::path> scans;
  std::string result_flat_note;
  {
    auto rig = open_rig(*config);
    if (!rig) return report_error("calibrate lights", rig.error());
    ScanSequencer sequencer(*config, *rig->lights, *rig->camera);
    std::error_code ec;
    fs::create_directories(staging->path() / calibration::kCapturesDirectory, ec);
    for (int i = 0; i < captures; ++i) {
      ScanRequest request;
      request.sample_id = args.target + "-sphere";
      request.description = "light calibration: " + args.target + " sphere, capture " +
                            std::to_string(i + 1) + " of " + std::to_string(captures);
      request.directory = staging->path() / calibration::kCapturesDirectory /
                          (args.target + "-" + std::to_string(i));
      request.process = false;
      auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
        if (!args.quiet)
          std::fprintf(stderr, "psrig calibrate lights: capture %d of %d: %s\n", i + 1, captures,
                       p.step.c_str());
      });
      if (!outcome) {
        const int code = report_error("calibrate lights", outcome.error());
        return firmware_host::stop_requested() ? psrig::cli::exit_interrupted : code;
      }
      scans.push_back(outcome->directory);
    }
  }
  auto set = load_captures(args.target, scans);
  if (!set) return report_error("calibrate lights", set.error());
  // The current flat field, when there is one, evens out the sensor's and
  // the LEDs' fall-off across the field first (a matte sphere's rim would
  // otherwise read dimmer than its centre).
  if (const auto flat_from = divide_by_current_flats(store, *set)) result_flat_note = *flat_from;
  calibration::CameraModel camera{args.focal_px};
  auto result = compute(args.target == "chrome" ? &*set : nullptr,
                        args.target == "matte" ? &*set : nullptr, camera, 0.95);
  if (!result) {
    // Its captures go with the refused calibration: name the rig instead.
    Error error = result.error();
    error.message = "the " + args.target + " sphere as captured: " + error.message;
    error.file = config->source;
    return report_error("calibrate lights", error);
  }
  result->sources[args.target] = describe_sources(*set, staging->path());
  if (!result_flat_note.empty()) result->sources["flat"] = result_flat_note;
  result->sources["rig"] = fs::absolute(config->source).lexically_normal().string();
  return write_to_store(*config, std::move(*staging), *result, args.quiet);
}

// ---- psrig calibrate flat ----------------------------------------------

struct FlatArgs {
  std::string config;
  int frames = 3;
  bool quiet = false;
};

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
    auto scan = processing::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(processing::Encoding::linear, d.black_level,
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

// The rig's current calibration, which a flat or a scale extends (each is
// stored with the lights); bad input naming the fix where there is none.
Result<calibration::StoredCalibration> light_calibration_to_extend(
    const config::RigConfig& config, const calibration::CalibrationStore& store,
    const std::string& what) {
  const auto current_file = store.current();
  if (!current_file)
    return std::unexpected(bad_input(config.source, "storage.root",
                                     "has no light calibration (" + store.directory().string() +
                                         "): run psrig calibrate lights first; the " + what +
                                         " is stored with the lights"));
  return calibration::read_calibration(*current_file);
}

// A card is refused when it is not flat and uniform (the textile or a
// sphere still under the camera), saturated, or unlit.
constexpr double kFlatMaxRoughness = 0.04;
constexpr double kFlatMaxSaturated = 0.001;
constexpr double kFlatMinMean = 0.02;

int run_flat(const FlatArgs& args) {
  stop_gracefully_on_signals();
  const std::string command = "calibrate flat";
  int exit_code = 0;
  auto config = load_config_or_report(command, args.config, exit_code);
  if (!config) return exit_code;
  calibration::CalibrationStore store(config->storage.root);
  const auto current_file = store.current();
  auto current = light_calibration_to_extend(*config, store, "flat");
  if (!current) return report_error(command, current.error());
  if (current->lights.size() != static_cast<std::size_t>(config->lights.channels))
    return report_error(command, bad_input(*current_file, "lights.per_light",
                                           "has " + std::to_string(current->lights.size()) +
                                               " lights but " + config->source.string() + " " +
                                               std::to_string(config->lights.channels) +
                                               ": run psrig calibrate lights again"));
  auto document = calibration::carry_forward(*current, "flat");
  if (!document) return report_error(command, document.error());
  // The simulated rig puts the white card under its camera in place of the
  // swatch; a sphere named in [sim] target stays (the card forgotten).
  if (config->camera.backend == "sim" && config->sim.target == "swatch")
    config->sim.target = "white_card";

  auto staging = store.begin_next();
  if (!staging) return report_error(command, staging.error());
  std::vector<fs::path> scans;
  {
    auto rig = open_rig(*config);
    if (!rig) return report_error(command, rig.error());
    ScanSequencer sequencer(*config, *rig->lights, *rig->camera);
    std::error_code ec;
    fs::create_directories(staging->path() / calibration::kCapturesDirectory, ec);
    for (int i = 0; i < args.frames; ++i) {
      ScanRequest request;
      request.sample_id = "flat-card";
      request.description = "flat field: white card, capture " + std::to_string(i + 1) + " of " +
                            std::to_string(args.frames);
      request.directory =
          staging->path() / calibration::kCapturesDirectory / ("flat-" + std::to_string(i));
      request.process = false;
      auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
        if (!args.quiet)
          std::fprintf(stderr, "psrig calibrate flat: capture %d of %d: %s\n", i + 1, args.frames,
                       p.step.c_str());
      });
      if (!outcome) {
        const int code = report_error(command, outcome.error());
        return firmware_host::stop_requested() ? psrig::cli::exit_interrupted : code;
      }
      scans.push_back(outcome->directory);
    }
  }
  auto flats = load_flats(scans);
  if (!flats) return report_error(command, flats.error());
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
    if (!problem.empty()) {
      Error error = bad_input(config->source, "", problem);
      return report_error(command, error);
    }
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
  if (ec) return report_error(command, io_error(flat_directory, "cannot create: " + ec.message()));
  nlohmann::json images = nlohmann::json::array();
  for (std::size_t k = 0; k < flats->linear.size(); ++k) {
    cv::Mat stored;
    flats->linear[k].convertTo(stored, CV_16U, 65535.0);
    const std::string name = "captures/flat/flat" + std::to_string(k) + ".png";
    if (!cv::imwrite((staging->path() / name).string(), stored))
      return report_error(command, io_error(staging->path() / name, "cannot write"));
    images.push_back(name);
  }
  nlohmann::json sources = nlohmann::json::array();
  for (const auto& scan : scans)
    sources.push_back(scan.lexically_relative(staging->path()).string());
  auto& doc = *document;
  doc["flat"] = {
      {"created", doc["created"]},
      {"images", images},
      {"encoding", "linear, dark subtracted, 65535 = full scale"},
      {"sources",
       {{"captures", sources}, {"rig", fs::absolute(config->source).lexically_normal().string()}}},
      {"per_light", per_light}};
  const std::string text = doc.dump(2) + "\n";
  if (auto ok = calibration::write_new_file(staging->path() / calibration::kCalibrationFile, text);
      !ok)
    return report_error(command, ok.error());
  const fs::path target = staging->target();
  if (auto ok = staging->commit(processing::AtomicDirectory::Existing::refuse, true); !ok)
    return report_error(command, ok.error());
  if (!args.quiet) {
    for (std::size_t k = 0; k < quality.size(); ++k)
      std::printf("light %zu: flat mean %.3f of full scale, fall-off to %.3f, roughness %.4f\n", k,
                  quality[k].mean, quality[k].fall_off, quality[k].roughness);
    std::printf("calibration: %s (current for %s)\n",
                (target / calibration::kCalibrationFile).c_str(), config->source.c_str());
  }
  return 0;
}

// ---- psrig calibrate scale ---------------------------------------------

struct ScaleArgs {
  std::string config;
  std::string image;
  std::string squares = "7x5";
  double square_mm = 2.0;
  double marker_mm = 1.4;
  std::string dictionary = "DICT_4X4_50";
  bool quiet = false;
};

int run_scale(const ScaleArgs& args) {
  stop_gracefully_on_signals();
  const std::string command = "calibrate scale";
  calibration::CharucoSpec spec;
  spec.square_mm = args.square_mm;
  spec.marker_mm = args.marker_mm;
  spec.dictionary = args.dictionary;
  if (std::sscanf(args.squares.c_str(), "%dx%d", &spec.squares_x, &spec.squares_y) != 2 ||
      spec.squares_x < 2 || spec.squares_y < 2 || spec.squares_x > 100 || spec.squares_y > 100) {
    std::fprintf(stderr,
                 "psrig calibrate scale: error: --squares must be COLUMNSxROWS, e.g. 7x5\n");
    return 2;
  }
  if (!(spec.marker_mm < spec.square_mm)) {
    std::fprintf(stderr,
                 "psrig calibrate scale: error: --marker-mm must be less than --square-mm\n");
    return 2;
  }
  if (calibration::dictionary_id(spec.dictionary) < 0) {
    std::fprintf(stderr,
                 "psrig calibrate scale: error: --dictionary %s is not an OpenCV predefined "
                 "dictionary (DICT_4X4_50, DICT_5X5_100, …, DICT_ARUCO_ORIGINAL)\n",
                 spec.dictionary.c_str());
    return 2;
  }
  int exit_code = 0;
  auto config = load_config_or_report(command, args.config, exit_code);
  if (!config) return exit_code;
  calibration::CalibrationStore store(config->storage.root);
  auto current = light_calibration_to_extend(*config, store, "scale");
  if (!current) return report_error(command, current.error());
  auto document = calibration::carry_forward(*current, "scale");
  if (!document) return report_error(command, document.error());

  cv::Mat image;
  fs::path source;
  nlohmann::json sources;
  std::optional<processing::AtomicDirectory> staging;
  if (!args.image.empty()) {
    auto read = calibration::read_linear_grey(args.image, processing::Encoding::linear);
    if (!read) return report_error(command, read.error());
    image = *read;
    source = args.image;
  } else {
    if (config->camera.backend == "sim" && config->sim.target == "swatch")
      config->sim.target = "charuco_board";
    auto next = store.begin_next();
    if (!next) return report_error(command, next.error());
    staging.emplace(std::move(*next));
    auto rig = open_rig(*config);
    if (!rig) return report_error(command, rig.error());
    ScanSequencer sequencer(*config, *rig->lights, *rig->camera);
    std::error_code ec;
    fs::create_directories(staging->path() / calibration::kCapturesDirectory, ec);
    ScanRequest request;
    request.sample_id = "charuco-board";
    request.description = "scale: ChArUco board";
    request.directory = staging->path() / calibration::kCapturesDirectory / "scale-0";
    request.process = false;
    auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
      if (!args.quiet) std::fprintf(stderr, "psrig calibrate scale: %s\n", p.step.c_str());
    });
    if (!outcome) {
      const int code = report_error(command, outcome.error());
      return firmware_host::stop_requested() ? psrig::cli::exit_interrupted : code;
    }
    auto set = load_captures("scale", {outcome->directory});
    if (!set) return report_error(command, set.error());
    // Every light's frame, averaged: the board evenly lit.
    for (const auto& light : set->lights)
      for (const auto& frame : light.frames)
        image = image.empty() ? frame.image.clone() : cv::Mat(image + frame.image);
    source = config->source;
    sources = {{"capture", "captures/scale-0"},
               {"rig", fs::absolute(config->source).lexically_normal().string()}};
  }
  auto estimate = calibration::measure_scale(image, spec, source);
  if (!estimate) {
    Error error = estimate.error();
    if (args.image.empty()) error.message = "the board as captured " + error.message;
    return report_error(command, error);
  }
  if (!staging) {
    auto next = store.begin_next();
    if (!next) return report_error(command, next.error());
    staging.emplace(std::move(*next));
    const fs::path directory = staging->path() / calibration::kCapturesDirectory / "scale";
    std::error_code ec;
    fs::create_directories(directory, ec);
    fs::copy_file(args.image, directory / fs::path(args.image).filename(), ec);
    if (ec)
      return report_error(command, io_error(directory, "cannot copy the image: " + ec.message()));
    sources = {{"image", "captures/scale/" + fs::path(args.image).filename().string()}};
  }
  auto& doc = *document;
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
  const std::string text = doc.dump(2) + "\n";
  if (auto ok = calibration::write_new_file(staging->path() / calibration::kCalibrationFile, text);
      !ok)
    return report_error(command, ok.error());
  const fs::path target = staging->target();
  if (auto ok = staging->commit(processing::AtomicDirectory::Existing::refuse, true); !ok)
    return report_error(command, ok.error());
  if (!args.quiet) {
    std::printf(
        "pixel size: %.6f mm +/- %.2g mm (%d corners, %d markers, fit RMS %.3f px, board "
        "rotated %.2f deg)\n",
        estimate->pixel_size_mm, estimate->uncertainty_mm, estimate->corners, estimate->markers,
        estimate->fit_rms_px, estimate->rotation_deg);
    std::printf("calibration: %s (current for %s)\n",
                (target / calibration::kCalibrationFile).c_str(), config->source.c_str());
  }
  return 0;
}

// ---- psrig calibrate colour --------------------------------------------

struct ColourArgs {
  std::string config;
  std::string image;
  std::string encoding = "linear";
  int frames = 1;
  bool quiet = false;
};

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

// The chart's captures as one linear colour image: every LED's frame of
// every capture averaged (the chart evenly lit), dark subtracted, through
// the flat field's gains when given (one per light), 0..1 of full scale;
// and where any frame reached full scale.
Result<calibration::LinearColourImage> average_colour_captures(
    const std::vector<fs::path>& scans, const std::vector<cv::Mat>& flat_gains) {
  calibration::LinearColourImage out;
  int count = 0;
  for (const auto& directory : scans) {
    auto scan = processing::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    if (scan->channels() != 3)
      return std::unexpected(bad_input(directory, "camera",
                                       "holds grey frames; the colour calibration needs a colour "
                                       "camera (its RGB frames)"));
    const processing::CodeLineariser lineariser(processing::Encoding::linear, d.black_level,
                                                scan->white_level, scan->depth());
    const cv::Mat dark = scan->dark.empty() ? cv::Mat() : linearised(lineariser, scan->dark);
    for (std::size_t k = 0; k < scan->frames.size(); ++k) {
      cv::Mat image = linearised(lineariser, scan->frames[k]);
      cv::Mat planes[3];
      cv::split(image, planes);
      const cv::Mat full = (planes[0] >= 0.98f) | (planes[1] >= 0.98f) | (planes[2] >= 0.98f);
      out.saturated = out.saturated.empty() ? full : cv::Mat(out.saturated | full);
      if (!dark.empty()) image -= dark;
      if (!flat_gains.empty()) {
        if (flat_gains.size() != scan->frames.size() || flat_gains[k].size() != image.size())
          return std::unexpected(bad_input(directory, "flat",
                                           "does not fit the rig's current flat field (lights "
                                           "or frame size): run psrig calibrate flat again"));
        image = image.mul(flat_gains[k]);
      }
      out.bgr = out.bgr.empty() ? image : cv::Mat(out.bgr + image);
      ++count;
    }
  }
  if (count > 0) out.bgr /= count;
  return out;
}

nlohmann::json rounded(const cv::Vec3d& v, double step) {
  return {std::round(v[0] / step) * step, std::round(v[1] / step) * step,
          std::round(v[2] / step) * step};
}

void print_colour(const calibration::ColourCorrection& fit) {
  const auto& chart = calibration::colorchecker_classic();
  std::printf("patch              dE2000 before   after\n");
  for (int p = 0; p < calibration::kChartPatches; ++p) {
    const auto i = static_cast<std::size_t>(p);
    std::printf("%2d %-15s %13.2f %7.2f\n", p + 1, chart[i].name, fit.delta_e_before[i],
                fit.delta_e_after[i]);
  }
  std::printf("mean               %13.2f %7.2f\n", fit.mean_before, fit.mean_after);
  std::printf("max                %13.2f %7.2f\n", fit.max_before, fit.max_after);
  const auto& m = fit.matrix;
  std::printf("matrix (camera RGB to linear sRGB D65):\n");
  for (int r = 0; r < 3; ++r)
    std::printf("  [%8.4f %8.4f %8.4f]\n", m(r, 0), m(r, 1), m(r, 2));
}

int run_colour(const ColourArgs& args) {
  stop_gracefully_on_signals();
  const std::string command = "calibrate colour";
  int exit_code = 0;
  auto config = load_config_or_report(command, args.config, exit_code);
  if (!config) return exit_code;
  calibration::CalibrationStore store(config->storage.root);
  auto current = light_calibration_to_extend(*config, store, "colour");
  if (!current) return report_error(command, current.error());
  auto document = calibration::carry_forward(*current, "colour");
  if (!document) return report_error(command, document.error());

  calibration::LinearColourImage image;
  fs::path source;
  nlohmann::json sources;
  std::optional<processing::AtomicDirectory> staging;
  // Scans divide by the current flat field channel by channel: the chart
  // captured on the rig is read through it too, and the version named.
  std::vector<cv::Mat> flat_gains;
  nlohmann::json flat_field = nullptr;
  if (!args.image.empty()) {
    if (!current->flat_version.empty())
      std::fprintf(stderr,
                   "psrig calibrate colour: warning: %s is taken as it is, not through the "
                   "rig's flat field %s, so scans (which are flat-fielded) will go without this "
                   "matrix; calibrate on the rig (without --image) for them\n",
                   args.image.c_str(), current->flat_version.c_str());
    auto read = calibration::read_linear_colour(args.image, args.encoding == "srgb"
                                                                ? processing::Encoding::srgb
                                                                : processing::Encoding::linear);
    if (!read) return report_error(command, read.error());
    image = std::move(*read);
    source = args.image;
  } else {
    if (!current->flat_images.empty()) {
      auto gains = colour_flat_gains(*current);
      if (!gains) return report_error(command, gains.error());
      flat_gains = std::move(*gains);
      flat_field = current->flat_version;
    }
    // The simulated rig puts its ColorChecker under the camera.
    if (config->camera.backend == "sim" && config->sim.target == "swatch")
      config->sim.target = "colour_chart";
    auto next = store.begin_next();
    if (!next) return report_error(command, next.error());
    staging.emplace(std::move(*next));
    std::vector<fs::path> scans;
    {
      auto rig = open_rig(*config);
      if (!rig) return report_error(command, rig.error());
      ScanSequencer sequencer(*config, *rig->lights, *rig->camera);
      std::error_code ec;
      fs::create_directories(staging->path() / calibration::kCapturesDirectory, ec);
      for (int i = 0; i < args.frames; ++i) {
        ScanRequest request;
        request.sample_id = "colour-chart";
        request.description = "colour: ColorChecker Classic, capture " + std::to_string(i + 1) +
                              " of " + std::to_string(args.frames);
        request.directory =
            staging->path() / calibration::kCapturesDirectory / ("colour-" + std::to_string(i));
        request.process = false;
        auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
          if (!args.quiet) std::fprintf(stderr, "psrig calibrate colour: %s\n", p.step.c_str());
        });
        if (!outcome) {
          const int code = report_error(command, outcome.error());
          return firmware_host::stop_requested() ? psrig::cli::exit_interrupted : code;
        }
        scans.push_back(outcome->directory);
      }
    }
    auto averaged = average_colour_captures(scans, flat_gains);
    if (!averaged) return report_error(command, averaged.error());
    image = std::move(*averaged);
    source = config->source;
    nlohmann::json captures = nlohmann::json::array();
    for (const auto& scan : scans)
      captures.push_back(scan.lexically_relative(staging->path()).string());
    sources = {{"captures", captures},
               {"rig", fs::absolute(config->source).lexically_normal().string()}};
  }
  // Refusals name the image, or the rig whose capture it was (the capture
  // goes with the refused version).
  const auto refuse = [&](const std::string& problem) {
    Error error = bad_input(source, "", problem);
    return report_error(command, error);
  };
  auto reading = calibration::read_colour_chart(image.bgr, image.saturated, source);
  if (!reading) {
    Error error = reading.error();
    if (args.image.empty()) error.message = "the chart as captured " + error.message;
    return report_error(command, error);
  }
  const auto& chart = calibration::colorchecker_classic();
  for (int p = 0; p < calibration::kChartPatches; ++p) {
    const auto i = static_cast<std::size_t>(p);
    if (reading->saturated[i] > kColourMaxSaturated)
      return refuse(std::string(args.image.empty() ? "the chart as captured: " : "") +
                    "its patch " + std::to_string(p + 1) + " (" + chart[i].name +
                    ") is saturated (" + std::to_string(std::lround(reading->saturated[i] * 100)) +
                    " % of it at full scale): lower camera.exposure_us or camera.gain, and "
                    "capture again");
  }
  const double white = cv::mean(reading->rgb[calibration::kFirstNeutralPatch])[0] * 4.0 / 3.0;
  if (white < kColourMinWhite)
    return refuse(std::string(args.image.empty() ? "the chart as captured: " : "") +
                  "its white patch reads " + std::to_string(white).substr(0, 5) +
                  " of full scale: is the chart lit? Raise camera.exposure_us or camera.gain");
  const calibration::ColourCorrection fit = calibration::fit_colour_correction(reading->rgb);

  if (!staging) {
    auto next = store.begin_next();
    if (!next) return report_error(command, next.error());
    staging.emplace(std::move(*next));
    const fs::path directory = staging->path() / calibration::kCapturesDirectory / "colour";
    std::error_code ec;
    fs::create_directories(directory, ec);
    fs::copy_file(args.image, directory / fs::path(args.image).filename(), ec);
    if (ec)
      return report_error(command, io_error(directory, "cannot copy the image: " + ec.message()));
    sources = {{"image", "captures/colour/" + fs::path(args.image).filename().string()},
               {"encoding", args.encoding}};
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
  auto& doc = *document;
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
  const std::string text = doc.dump(2) + "\n";
  if (auto ok = calibration::write_new_file(staging->path() / calibration::kCalibrationFile, text);
      !ok)
    return report_error(command, ok.error());
  const fs::path target = staging->target();
  if (auto ok = staging->commit(processing::AtomicDirectory::Existing::refuse, true); !ok)
    return report_error(command, ok.error());
  if (!args.quiet) {
    print_colour(fit);
    std::printf("calibration: %s (current for %s)\n",
                (target / calibration::kCalibrationFile).c_str(), config->source.c_str());
  }
  return 0;
}

CLI::App* add_colour_subcommand(CLI::App& app, ColourArgs& args) {
  CLI::App* colour = app.add_subcommand(
      "colour",
      "Colour: a ColorChecker Classic, a matrix to sRGB D65 applied to every later albedo");
  colour
      ->add_option("--config", args.config,
                   "Rig configuration: capture the chart on this rig (unless --image) and keep "
                   "the matrix in its calibration store")
      ->required();
  colour->add_option("--image", args.image,
                     "An image of the chart already taken (RGB), instead of capturing");
  colour->add_option("--encoding", args.encoding, "How --image stores light: linear or srgb")
      ->check(CLI::IsMember({"linear", "srgb"}))
      ->capture_default_str();
  colour->add_option("--frames", args.frames, "Captures of the chart on the rig, averaged")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  colour->add_flag("-q,--quiet", args.quiet, "Print nothing on success");
  return colour;
}

}  // namespace

Command add_calibrate_command(CLI::App& parent) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* app =
      parent.add_subcommand("calibrate", "Measure the rig: light directions and intensities");
  CLI::App* lights = app->add_subcommand(
      "lights", "Light directions (chrome sphere) and relative intensities (matte sphere)");
  app->require_subcommand(1);
  lights->add_option("--config", args->config,
                     "Rig configuration: capture the sphere on this rig and keep the result in "
                     "its calibration store (storage.root/calibrations)");
  auto* images = lights->add_option(
      "--images", args->images,
      "Folder of sphere images, one per light in name order, instead of capturing");
  lights->add_option("--target", args->target, "The sphere: chrome or matte")
      ->check(CLI::IsMember({"chrome", "matte"}))
      ->capture_default_str();
  lights
      ->add_option("--frames", args->frames,
                   "Captures per light on the rig (default 3), or consecutive images per light "
                   "in --images (default 1); their directions are averaged")
      ->check(CLI::Range(1, 64));
  lights
      ->add_option("--mask", args->mask,
                   "Mask of the sphere in --images (nonzero on it; default: the folder's file "
                   "whose name ends in \"mask\", else the sphere is found in the images)")
      ->needs(images);
  auto* matte = lights
                    ->add_option("--matte", args->matte,
                                 "Folder of matte-sphere images under the same lights: "
                                 "intensities, and chrome vs matte agreement")
                    ->needs(images);
  lights->add_option("--matte-mask", args->matte_mask, "Mask of the sphere in --matte")
      ->needs(matte);
  lights->add_option("--out", args->out, "calibration.json to write (must not exist)")
      ->needs(images);
  lights
      ->add_option("--focal-px", args->focal_px,
                   "Camera focal length in pixels: perspective view rays (default: orthographic)")
      ->check(CLI::PositiveNumber);
  lights->add_option("--encoding", args->encoding, "How --images store light: linear or srgb")
      ->check(CLI::IsMember({"linear", "srgb"}))
      ->capture_default_str();
  lights->add_flag("-q,--quiet", args->quiet, "Print nothing on success");

  auto flat_args = std::make_shared<FlatArgs>();
  CLI::App* flat = app->add_subcommand(
      "flat", "Flat field: a white or grey card under each LED, applied to every later scan");
  flat->add_option("--config", flat_args->config,
                   "Rig configuration: capture the card on this rig and keep the flats in its "
                   "calibration store")
      ->required();
  flat->add_option("--frames", flat_args->frames, "Captures of the card, averaged")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  flat->add_flag("-q,--quiet", flat_args->quiet, "Print nothing on success");

  auto scale_args = std::make_shared<ScaleArgs>();
  CLI::App* scale = app->add_subcommand(
      "scale", "Millimetres per pixel from a printed ChArUco board, used by every later scan");
  scale
      ->add_option("--config", scale_args->config,
                   "Rig configuration: capture the board on this rig (unless --image) and keep "
                   "the result in its calibration store")
      ->required();
  scale->add_option("--image", scale_args->image,
                    "An image of the board already taken (linear), instead of capturing");
  scale->add_option("--squares", scale_args->squares, "The board's squares, COLUMNSxROWS")
      ->capture_default_str();
  scale->add_option("--square-mm", scale_args->square_mm, "A square's side as printed, mm")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  scale->add_option("--marker-mm", scale_args->marker_mm, "A marker's side as printed, mm")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  scale->add_option("--dictionary", scale_args->dictionary, "The markers' ArUco dictionary")
      ->capture_default_str();
  scale->add_flag("-q,--quiet", scale_args->quiet, "Print nothing on success");

  auto colour_args = std::make_shared<ColourArgs>();
  CLI::App* colour = add_colour_subcommand(*app, *colour_args);

  return {app, [args, flat_args, flat, scale_args, scale, colour_args, colour] {
            if (colour->parsed()) return run_colour(*colour_args);
            if (flat->parsed()) return run_flat(*flat_args);
            if (scale->parsed()) return run_scale(*scale_args);
            if (!args->images.empty()) return run_from_images(*args);
            if (args->config.empty()) {
              std::fprintf(stderr,
                           "psrig calibrate lights: error: give --config RIG.toml (capture on the "
                           "rig) or --images DIR (images already taken)\n");
              return 2;
            }
            return run_on_rig(*args);
          }};
}

}  // namespace psrig::capture::cli
