// psrig calibrate lights|flat|scale|colour: the command line of the rig's
// calibration procedures (psrig/rig/rig_calibration.h, which psrigd
// runs too): their options parsed, their progress and results printed.
// lights: directions and relative intensities from a chrome or a matte
// sphere, and near LEDs' positions from the chrome sphere at several
// places; flat: a white card under each LED; scale: a ChArUco board;
// colour: a ColorChecker Classic, a matrix to linear sRGB D65.

#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "command.h"
#include "psrig/lights/emergency_stop.h"
#include "psrig/rig/rig_calibration.h"

namespace psrig::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct CalibrateArgs {
  std::string config;
  std::string target = "chrome";
  int frames = 0;                   // 0: 3 captures on the rig, 1 image per light from a folder
  std::vector<std::string> images;  // one folder per place of the sphere
  int places = 1;                   // the chrome sphere's places on the rig (LED positions)
  std::optional<double> sphere_mm;
  std::string mask;
  std::string matte;
  std::string matte_mask;
  std::string out;
  std::optional<double> focal_px;
  std::string encoding = "linear";
  bool quiet = false;
};

struct FlatArgs {
  std::string config;
  int frames = 3;
  bool quiet = false;
};

struct ScaleArgs {
  std::string config;
  std::string image;
  std::string squares = "7x5";
  double square_mm = 2.0;
  double marker_mm = 1.4;
  std::string dictionary = "DICT_4X4_50";
  bool quiet = false;
};

double number(const json& value) {
  return value.is_number() ? value.get<double>() : 0.0;
}

void print_lights(const json& lights) {
  for (const char* role : {"chrome", "matte"})
    if (lights.contains("spheres") && lights["spheres"].contains(role)) {
      const auto& s = lights["spheres"][role];
      std::printf("%s sphere: centre (%.2f, %.2f) px, radius %.2f px (fit RMS %.3f px)\n", role,
                  number(s["centre_px"][0]), number(s["centre_px"][1]), number(s["radius_px"]),
                  number(s["fit_rms_px"]));
    }
  for (const auto& l : lights["per_light"]) {
    std::printf("light %d: tilt %7.2f deg, slant %6.2f deg, intensity %.3f, +/- %.3f deg",
                l["index"].get<int>(), number(l["tilt_deg"]), number(l["slant_deg"]),
                number(l["intensity"]), number(l["uncertainty_deg"]));
    if (l.contains("chrome") && l["chrome"].contains("frames_spread_deg") &&
        l["chrome"].value("frames", 0) > 1)
      std::printf(", frames agree to %.3f deg", number(l["chrome"]["frames_spread_deg"]));
    if (l.contains("chrome_vs_matte_deg"))
      std::printf(", chrome vs matte %.3f deg", number(l["chrome_vs_matte_deg"]));
    std::printf("\n");
  }
}

void print_led_positions(const json& section) {
  std::printf("LED positions (%s; pixel size %.6g mm from %s, sphere %.4g mm from %s):\n",
              section["method"].get<std::string>().c_str(), number(section["pixel_size_mm"]),
              section["pixel_size_from"].get<std::string>().c_str(),
              number(section["sphere_diameter_mm"]),
              section["sphere_diameter_from"].get<std::string>().c_str());
  for (const auto& l : section["per_light"])
    std::printf("LED %d: (%.2f, %.2f, %.2f) mm, %.1f mm away, +/- %.2f mm (rays within %.3f mm)\n",
                l["index"].get<int>(), number(l["position_mm"][0]), number(l["position_mm"][1]),
                number(l["position_mm"][2]), number(l["distance_mm"]), number(l["uncertainty_mm"]),
                number(l["ray_rms_mm"]));
}

void print_flat(const json& flat) {
  for (const auto& l : flat["per_light"])
    std::printf("light %d: flat mean %.3f of full scale, fall-off to %.3f, roughness %.4f\n",
                l["index"].get<int>(), number(l["mean"]), number(l["fall_off"]),
                number(l["roughness"]));
}

void print_scale(const json& s) {
  std::printf(
      "pixel size: %.6f mm +/- %.2g mm (%d corners, %d markers, fit RMS %.3f px, board "
      "rotated %.2f deg)\n",
      number(s["pixel_size_mm"]), number(s["uncertainty_mm"]), s["corners"].get<int>(),
      s["markers"].get<int>(), number(s["fit_rms_px"]), number(s["rotation_deg"]));
}

struct ColourArgs {
  std::string config;
  std::string image;
  std::string encoding = "linear";
  int frames = 1;
  bool quiet = false;
};

// The colour section: ΔE2000 per patch before and after, mean, max, and
// the matrix.
void print_colour(const json& colour) {
  std::printf("patch              dE2000 before   after\n");
  for (const auto& p : colour["patches"])
    std::printf("%2d %-15s %13.2f %7.2f\n", p["index"].get<int>(),
                p["name"].get<std::string>().c_str(), number(p["delta_e2000_before"]),
                number(p["delta_e2000_after"]));
  const json& e = colour["delta_e2000"];
  std::printf("mean               %13.2f %7.2f\n", number(e["before"]["mean"]),
              number(e["after"]["mean"]));
  std::printf("max                %13.2f %7.2f\n", number(e["before"]["max"]),
              number(e["after"]["max"]));
  std::printf("matrix (camera RGB to linear sRGB D65):\n");
  for (const auto& row : colour["matrix"])
    std::printf("  [%8.4f %8.4f %8.4f]\n", number(row[0]), number(row[1]), number(row[2]));
}

void print_outcome(const rig::CalibrationOutcome& outcome, const std::string& rig) {
  const json& d = outcome.document;
  if (outcome.kind == "lights") {
    print_lights(d["lights"]);
    if (d.contains("led_positions_mm") && d["led_positions_mm"].is_object() &&
        !d["led_positions_mm"].contains("from"))
      print_led_positions(d["led_positions_mm"]);
  } else if (outcome.kind == "flat") {
    print_flat(d["flat"]);
  } else if (outcome.kind == "scale") {
    print_scale(d["scale"]);
  } else if (outcome.kind == "colour") {
    print_colour(d["colour"]);
  }
  if (rig.empty())
    std::printf("calibration: %s\n", outcome.file.c_str());
  else
    std::printf("calibration: %s (current for %s)\n", outcome.file.c_str(), rig.c_str());
}

// Runs a procedure on the rig and prints what it found; exit 2 for bad
// input, 130 when interrupted (the LEDs off either way).
int run(const std::string& command, const std::string& config_file, rig::CalibrationRequest request,
        bool quiet) {
  stop_gracefully_on_signals();
  int exit_code = 0;
  auto config = load_config_or_report(command, config_file, exit_code);
  if (!config) return exit_code;
  if (!quiet)
    request.progress = [command](const std::string& step) {
      std::fprintf(stderr, "psrig %s: %s\n", command.c_str(), step.c_str());
    };
  request.warn = [command](const std::string& warning) {
    std::fprintf(stderr, "psrig %s: warning: %s\n", command.c_str(), warning.c_str());
  };
  auto outcome = rig::run_calibration(*config, request);
  if (!outcome) {
    const int code = report_error(command, outcome.error());
    return lights::stop_requested() ? psrig::cli::exit_interrupted : code;
  }
  if (!quiet) print_outcome(*outcome, config->source.string());
  return 0;
}

int run_lights(const CalibrateArgs& args) {
  rig::CalibrationRequest request;
  request.kind = "lights";
  request.target = args.target;
  request.frames = args.frames;
  request.places = args.places;
  request.sphere_mm = args.sphere_mm;
  request.focal_px = args.focal_px;
  for (const auto& folder : args.images)
    request.images.emplace_back(folder);
  request.mask = args.mask;
  request.matte = args.matte;
  request.matte_mask = args.matte_mask;
  request.encoding = args.encoding;
  // A real rig's technician moves the sphere and says so.
  request.sphere_moved = [](int place, int places) {
    std::fprintf(stderr,
                 "psrig calibrate lights: put the chrome sphere at place %d of %d (a new spot in "
                 "the field, a sphere's width or more from the others, the whole sphere in "
                 "view), then press Enter\n",
                 place, places);
    std::string line;
    return static_cast<bool>(std::getline(std::cin, line));
  };
  if (!args.out.empty()) {
    auto outcome = rig::calibrate_lights_to_file(request, args.out);
    if (!outcome) return report_error("calibrate lights", outcome.error());
    if (!args.quiet) print_outcome(*outcome, "");
    return 0;
  }
  if (args.config.empty()) {
    std::fprintf(stderr, args.images.empty()
                             ? "psrig calibrate lights: error: give --config RIG.toml (capture on "
                               "the rig) or --images DIR (images already taken)\n"
                             : "psrig calibrate lights: error: say where the calibration goes: "
                               "--out FILE (a calibration.json) or --config RIG.toml (the rig's "
                               "calibration store)\n");
    return 2;
  }
  return run("calibrate lights", args.config, request, args.quiet);
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
  auto* images =
      lights
          ->add_option(
              "--images", args->images,
              "Folder of sphere images, one per light in name order, instead of capturing; given "
              "again for each further place of a chrome sphere, the LEDs' positions too")
          ->expected(1)
          ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  lights->add_option("--target", args->target, "The sphere: chrome or matte")
      ->check(CLI::IsMember({"chrome", "matte"}))
      ->capture_default_str();
  lights
      ->add_option("--places", args->places,
                   "Chrome sphere places on the rig (2 or more: each LED's position in mm, for "
                   "near LEDs; the simulated rig moves the sphere itself, a real one asks you "
                   "to move it and press Enter)")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  lights
      ->add_option("--sphere-mm", args->sphere_mm,
                   "The chrome sphere's diameter, mm, for --places or several --images "
                   "(default: [calibration] sphere_diameter_mm)")
      ->check(CLI::PositiveNumber);
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
  CLI::App* colour = app->add_subcommand(
      "colour",
      "Colour: a ColorChecker Classic, a matrix to sRGB D65 applied to every later albedo");
  colour
      ->add_option("--config", colour_args->config,
                   "Rig configuration: capture the chart on this rig (unless --image) and keep "
                   "the matrix in its calibration store")
      ->required();
  colour->add_option("--image", colour_args->image,
                     "An image of the chart already taken (RGB), instead of capturing");
  colour
      ->add_option("--encoding", colour_args->encoding, "How --image stores light: linear or srgb")
      ->check(CLI::IsMember({"linear", "srgb"}))
      ->capture_default_str();
  colour->add_option("--frames", colour_args->frames, "Captures of the chart on the rig, averaged")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  colour->add_flag("-q,--quiet", colour_args->quiet, "Print nothing on success");

  return {app, [args, flat_args, flat, scale_args, scale, colour_args, colour] {
            if (colour->parsed()) {
              rig::CalibrationRequest request;
              request.kind = "colour";
              request.image = colour_args->image;
              request.encoding = colour_args->encoding;
              request.frames = colour_args->frames;
              return run("calibrate colour", colour_args->config, request, colour_args->quiet);
            }
            if (flat->parsed()) {
              rig::CalibrationRequest request;
              request.kind = "flat";
              request.frames = flat_args->frames;
              return run("calibrate flat", flat_args->config, request, flat_args->quiet);
            }
            if (scale->parsed()) {
              rig::CalibrationRequest request;
              request.kind = "scale";
              request.image = scale_args->image;
              request.squares = scale_args->squares;
              request.square_mm = scale_args->square_mm;
              request.marker_mm = scale_args->marker_mm;
              request.dictionary = scale_args->dictionary;
              return run("calibrate scale", scale_args->config, request, scale_args->quiet);
            }
            return run_lights(*args);
          }};
}

}  // namespace psrig::cli
