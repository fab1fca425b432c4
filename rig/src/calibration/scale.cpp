// Millimetres per pixel from a ChArUco board.

#include "procedure_steps.h"

namespace psrig::rig {

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

}  // namespace psrig::rig
