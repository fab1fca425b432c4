#include "psrig/processing/report.h"


#include "psrig/processing/light_matrix.h"
#include "psrig/processing/parallel.h"

namespace psrig::processing {
namespace {

using nlohmann::json;

json distribution_json(const Distribution& d) {
  return {{"pixels", d.count}, {"mean", d.mean}, {"median", d.median}, {"p95", d.p95}, {"max", d.max}, {"rms", d.rms}};
}

const char* depth_name(int depth) { return depth == CV_8U ? "8" : depth == CV_16U ? "16" : "32f"; }

json pixel_counts(const cv::Mat& flags) {
  std::size_t valid = 0, outside = 0, saturated = 0, shadowed = 0, low = 0, unsolved = 0, recovered = 0;
  for (int r = 0; r < flags.rows; ++r) {
    const std::uint8_t* f = flags.ptr<std::uint8_t>(r);
    for (int c = 0; c < flags.cols; ++c) {
      valid += is_valid(f[c]);
      outside += (f[c] & kOutsideMask) != 0;
      saturated += (f[c] & kSaturated) != 0;
      shadowed += (f[c] & kShadowed) != 0;
      low += (f[c] & kLowSignal) != 0;
      unsolved += (f[c] & kNoSolution) != 0;
      recovered += (f[c] & kRecovered) != 0;
    }
  }
  return {{"total", flags.total()},          {"valid", valid},         {"masked", flags.total() - valid},
          {"outside_mask", outside},         {"saturated", saturated}, {"shadowed", shadowed},
          {"low_signal", low},               {"no_solution", unsolved}, {"recovered_by_rejection", recovered}};
}

}  // namespace

json make_report(const ReportInputs& in) {
  const Scan& scan = *in.scan;
  const auto& d = scan.description;
  json report;
  report["format"] = kReportFormat;

  json inputs = {{"scan", std::filesystem::absolute(d.directory).lexically_normal().string()},
                 {"sample", {{"id", d.sample_id}, {"description", d.sample_description}}},
                 {"size", {scan.size().width, scan.size().height}},
                 {"channels", scan.channels()},
                 {"bit_depth", depth_name(scan.depth())},
                 {"encoding", d.encoding == Encoding::srgb ? "srgb" : "linear"},
                 {"black_level", d.black_level},
                 {"white_level", scan.white_level},
                 {"lights", d.lights.size()},
                 {"dark", d.dark ? json(*d.dark) : json()},
                 {"mask", d.mask ? json(*d.mask) : json()},
                 {"flats", !d.flats.empty()},
                 {"pixel_size_mm", d.pixel_size_mm ? json(*d.pixel_size_mm) : json()}};
  if (d.document.contains("capture")) inputs["capture"] = d.document["capture"];
  report["inputs"] = inputs;

  const auto& options = *in.options;
  report["options"] = {{"integration", to_string(options.integration)},
                       {"threads", thread_count()},
                       {"reject_outliers", options.solve.reject_outliers},
                       {"shadow_ratio", options.solve.shadow_ratio},
                       {"low_signal", options.solve.low_signal}};

  json times = json::object();
  for (const auto& [stage, ms] : in.stage_ms) times[stage] = ms;
  report["timings_ms"] = times;

  std::vector<cv::Vec3d> directions;
  for (const auto& light : d.lights) directions.push_back(light.direction);
  const LightMatrix matrix = make_light_matrix(directions);
  json rows = json::array();
  for (const auto& l : matrix.directions) rows.push_back({l[0], l[1], l[2]});
  report["light_matrix"] = {{"directions", rows}, {"condition_number", matrix.condition_number}};

  report["pixels"] = pixel_counts(in.solve->flags);

  cv::Mat solved;
  cv::compare(in.solve->flags & (kOutsideMask | kLowSignal | kNoSolution), 0, solved, cv::CMP_EQ);
  const Distribution residual = describe(in.solve->residual, solved);
  report["residual"] = {{"mean", residual.mean}, {"p95", residual.p95}, {"units", "fraction of full scale"}};
  report["integrability"] = {{"mean_abs_curl", mean_abs_curl(in.solve->p, in.solve->q, in.valid)}};

  if (in.height)
    report["height"] = {{"min", in.height->low},
                        {"max", in.height->high},
                        {"range", in.height->high - in.height->low},
                        {"units", in.height->units},
                        {"png_range", {in.height->low, in.height->high}}};

  const auto& truth = in.ground_truth;
  if (truth.angular_error_deg || truth.height_rms_error) {
    json gt = json::object();
    if (truth.angular_error_deg) gt["angular_error_deg"] = distribution_json(*truth.angular_error_deg);
    if (truth.mean_angular_error_all_deg) gt["mean_angular_error_all_solved_deg"] = *truth.mean_angular_error_all_deg;
    if (truth.height_rms_error) gt["height_rms_error"] = *truth.height_rms_error;
    report["ground_truth"] = gt;
  }
  return report;
}

}  // namespace psrig::processing
