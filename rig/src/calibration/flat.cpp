// The flat field: a uniform card under every LED.

#include "procedure_steps.h"

namespace psrig::rig {

namespace {

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

}  // namespace

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

}  // namespace psrig::rig
