// Colour: a ColorChecker Classic and a 3x3 matrix to linear sRGB D65.

#include "procedure_steps.h"

namespace psrig::rig {

// ---- colour ----

// A patch is refused when more than this of it reached full scale, and the
// chart when its white patch reads below this of full scale.
constexpr double kColourMaxSaturated = 0.01;
constexpr double kColourMinWhite = 0.02;

namespace {

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

}  // namespace

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
    auto read = calibration::read_linear_colour(
        args.image, args.encoding == "srgb" ? formats::Encoding::srgb : formats::Encoding::linear);
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

}  // namespace psrig::rig
