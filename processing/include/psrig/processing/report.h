#pragma once
// report.json of a maps directory (docs/design.md "Maps directory"): inputs,
// per-stage times and memory, each map's encoding time, the light matrix and its condition number,
// mask counts, residual, height range, and errors against ground truth when there is one.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/formats/scan.h"
#include "psrig/processing/evaluation.h"
#include "psrig/processing/pipeline.h"
#include "psrig/processing/woodham.h"

namespace psrig::processing {

struct HeightSummary {
  double low = 0;
  double high = 0;
  std::string units;                                                // "mm" or "px"
  IntegrationMethod method = IntegrationMethod::frankot_chellappa;  // the one used
  long long pixels = 0;                          // with a height (the rest are NaN in height.exr)
  long long filled_pixels = 0;                   // specks filled from around them (hole_fill.h)
  std::optional<MaskedIntegrationStats> solver;  // the masked solver's
};

struct BendSummary {
  bool removed = false;
  double cutoff = 0;          // in cutoff_units
  std::string cutoff_units;   // "mm" or "px"
  double peak_to_valley = 0;  // of the bend removed, in the height's units
  double rms = 0;
};

struct GroundTruthSummary {
  std::optional<Distribution> angular_error_deg;  // over valid pixels
  std::optional<double>
      mean_angular_error_all_deg;          // over every solved pixel, shadowed ones included
  std::optional<double> height_rms_error;  // in the height's units
};

// Resident memory while processing (base/memory_use.h), in MB: at the
// start, the process's peak (its whole life: a daemon's earlier work too),
// and each stage's peak as sampled while it ran.
struct MemoryFigures {
  double at_start_mb = 0;
  double process_peak_mb = 0;
  std::vector<std::pair<std::string, double>> stage_peak_mb;  // in the order they ran
};

struct ReportInputs {
  const formats::Scan* scan = nullptr;  // its frames may already be released
  cv::Size size;               // of the frames
  int channels = 0;
  int depth = -1;
  const ProcessOptions* options = nullptr;
  PixelCounts pixels;
  Distribution residual;     // over solved pixels
  double mean_abs_curl = 0;  // over valid pixels
  std::optional<HeightSummary> height;
  std::optional<BendSummary> bend;  // with a height
  GroundTruthSummary ground_truth;
  std::vector<std::pair<std::string, double>> stage_ms;  // in the order they ran
  std::vector<std::pair<std::string, double>> encode_ms;  // each map file's encoder
  std::optional<MemoryFigures> memory;
};

[[nodiscard]] nlohmann::json make_report(const ReportInputs& inputs);

}  // namespace psrig::processing
