#pragma once
// The fabric's repeat, measured on its maps: the two lattice vectors of the
// texture (from the autocorrelation of the height and albedo maps, refined
// to a fraction of a pixel over many lattice points), and from them the
// densities a lab counts by hand: wales and courses per cm for a knit (ASTM
// D8007), ends and picks per cm for a woven (ISO 7211-2), the skew and the
// repeat size. Method: analysis/README.md "Fabric measurement".

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::analysis {

enum class Construction { unknown, knit, woven };
[[nodiscard]] std::string_view to_string(Construction construction);
// "knit" | "knitted" | "woven"; anything else is unknown.
[[nodiscard]] Construction parse_construction(std::string_view name);

// What the scan says about its fabric (scan.json's `fabric` object:
// {"construction": "knit"|"woven", "structure": "jersey"|"rib"|...,
// "stitches_per_repeat" (knit) or "threads_per_repeat" (woven): [across, along]}).
struct FabricHints {
  Construction construction = Construction::unknown;
  std::string structure;  // empty: not given
  // Wales (ends) and courses (picks) one repeat of the pattern holds; 0: not given.
  int across_per_repeat = 0;
  int along_per_repeat = 0;
};
// Reads scan.json's `fabric` object (absent or malformed keys: no hint).
[[nodiscard]] FabricHints fabric_hints(const nlohmann::json& scan_document);

struct FabricMeasurement {
  bool periodic = false;
  // Normalised autocorrelation at the lattice vectors (1 = a perfect repeat).
  double confidence = 0;
  // One repeat along the courses (knit) or the weft (woven), roughly the
  // image's x axis, and one along the wales or the warp, roughly its y
  // axis; pixels, x = column (right), y = row (down).
  cv::Point2d u_px;
  cv::Point2d v_px;
  // Wales (ends) in one repeat along u, courses (picks) in one along v.
  int threads_u = 1;
  int threads_v = 1;
  Construction construction = Construction::unknown;
  bool construction_from_metadata = false;
  double construction_confidence = 0;  // 1 when from the metadata
  std::string structure;               // from the metadata, or empty
  std::optional<double> pixel_size_mm;
  // Wales (ends) and courses (picks) per cm, or per pixel without a pixel size.
  double across_density = 0;  // wales or ends: counted along u
  double along_density = 0;   // courses or picks: counted along v
  // 90 deg minus the angle between the two directions (0: square).
  double skew_deg = 0;
  // Course (weft) direction to the image's x axis, counterclockwise as seen.
  double rotation_deg = 0;
  // Wale (warp) direction to the image's vertical, counterclockwise as seen.
  double wale_rotation_deg = 0;
  double repeat_width = 0;         // |u|, mm (or px)
  double repeat_height = 0;        // distance between course lines one repeat apart, mm (or px)
  std::vector<std::string> notes;  // what a user should know: units, guesses
};

struct MeasureOptions {
  std::optional<double> pixel_size_mm;
  FabricHints hints;
};

// The part of the maps measure_fabric reads: the central 1280 pixels a side
// (all of a smaller side). Measuring maps cut to it gives the same result,
// so a caller short of memory keeps only that much (the pipeline's albedo).
[[nodiscard]] cv::Rect measured_region(cv::Size maps);

// height: CV_32F (NaN = no height); albedo: CV_32FC3/CV_32FC1 or 8-bit, or
// empty. Returns a measurement with periodic = false when no repeat is found
// (a note says why); errors only for unusable input.
[[nodiscard]] Result<FabricMeasurement> measure_fabric(const cv::Mat& height, const cv::Mat& albedo,
                                                       const MeasureOptions& options);

// The lattice alone: u and v as above, their confidence; nullopt when the
// texture does not repeat.
struct RepeatLattice {
  cv::Point2d u_px;
  cv::Point2d v_px;
  cv::Point2d a_px;  // the primitive (reduced) basis the two come from
  cv::Point2d b_px;
  double confidence = 0;
};
[[nodiscard]] std::optional<RepeatLattice> find_repeat_lattice(const cv::Mat& height,
                                                               const cv::Mat& albedo,
                                                               std::string* why = nullptr);

// report.json's `fabric` section.
[[nodiscard]] nlohmann::json to_json(const FabricMeasurement& m);
// The measurement back from report.json's `fabric` section (the scan's
// pixel size is the report's inputs.pixel_size_mm); bad input naming the
// key when a key to_json() writes is missing or malformed.
[[nodiscard]] Result<FabricMeasurement> fabric_from_json(const nlohmann::json& fabric,
                                                         std::optional<double> pixel_size_mm);
// One line for the CLI summary, e.g. "jersey knit: 6.99 wales/cm, 9.01 courses/cm, ...".
[[nodiscard]] std::string summary_line(const FabricMeasurement& m);

}  // namespace psrig::analysis
