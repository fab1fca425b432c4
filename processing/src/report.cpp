#include "psrig/processing/report.h"

#include <algorithm>

#include "psrig/base/parallel.h"
#include "psrig/formats/light_matrix.h"

namespace psrig::processing {
namespace {

using nlohmann::json;

json distribution_json(const Distribution& d) {
  return {{"pixels", d.count}, {"mean", d.mean}, {"median", d.median},
          {"p95", d.p95},      {"max", d.max},   {"rms", d.rms}};
}

json pixel_counts(const PixelCounts& n) {
  return {{"total", n.total},
          {"valid", n.valid},
          {"masked", n.total - n.valid},
          {"outside_mask", n.outside_mask},
          {"saturated", n.saturated},
          {"shadowed", n.shadowed},
          {"low_signal", n.low_signal},
          {"no_solution", n.no_solution},
          {"recovered_by_rejection", n.recovered},
          {"highlights_rejected", n.highlight}};
}

}  // namespace

json make_report(const ReportInputs& in) {
  const formats::Scan& scan = *in.scan;
  const auto& d = scan.description;
  json report;
  report["format"] = kReportFormat;

  json inputs = {{"scan", std::filesystem::absolute(d.directory).lexically_normal().string()},
                 {"sample", {{"id", d.sample_id}, {"description", d.sample_description}}},
                 {"size", {in.size.width, in.size.height}},
                 {"channels", in.channels},
                 {"bit_depth", formats::depth_name(in.depth)},
                 {"encoding", d.encoding == formats::Encoding::srgb ? "srgb" : "linear"},
                 {"black_level", d.black_level},
                 {"white_level", scan.white_level},
                 {"lights", d.lights.size()},
                 {"dark", d.dark ? json(*d.dark) : json()},
                 {"mask", d.mask ? json(*d.mask) : json()},
                 {"flats", !d.flats.empty()},
                 {"pixel_size_mm", d.pixel_size_mm ? json(*d.pixel_size_mm) : json()}};
  if (d.document.contains("capture")) inputs["capture"] = d.document["capture"];
  // Which of the rig's calibrations the scan applied (scan.json), so the
  // maps say it too: the catalogue and the web page show it.
  if (d.document.contains("calibration")) inputs["calibration"] = d.document["calibration"];
  report["inputs"] = inputs;

  const auto& options = *in.options;
  report["options"] = {
      {"integration", to_string(options.integration)},
      {"flatten", to_string(options.flatten)},
      {"flatten_cutoff_mm", options.flatten_cutoff_mm},
      {"threads", thread_count()},
      {"reject_outliers", options.solve.reject_outliers},
      {"reject_method", reject_method(options.solve, static_cast<int>(d.lights.size()))},
      {"shadow_ratio", options.solve.shadow_ratio},
      {"low_signal", options.solve.low_signal},
      {"normal_convention", options.directx_normal ? "opengl, directx" : "opengl"},
      {"exr_compression", to_string(options.storage.exr_compression)},
      {"png_level", options.storage.png_level},
      {"map_precision", to_string(options.storage.map_precision)}};

  json times = json::object();
  for (const auto& [stage, ms] : in.stage_ms)
    times[stage] = ms;
  report["timings_ms"] = times;
  if (!in.encode_ms.empty()) {
    json encode = json::object();
    for (const auto& [file, ms] : in.encode_ms)
      encode[file] = ms;
    report["encode_ms"] = encode;
  }
  if (in.memory) {
    double peak = in.memory->at_start_mb;
    json stages = json::object();
    for (const auto& [stage, mb] : in.memory->stage_peak_mb) {
      stages[stage] = mb;
      peak = std::max(peak, mb);
    }
    report["memory_mb"] = {{"at_start", in.memory->at_start_mb},
                           {"peak", peak},
                           {"growth", peak - in.memory->at_start_mb},
                           {"stage_peaks", stages},
                           {"process_peak", in.memory->process_peak_mb}};
  }

  const formats::LightMatrix matrix = formats::make_light_matrix(d);
  json rows = json::array();
  for (const auto& l : matrix.directions)
    rows.push_back({l[0], l[1], l[2]});
  report["light_matrix"] = {{"directions", rows}, {"condition_number", matrix.condition_number}};
  // Near-field LEDs: a per-pixel direction and 1/r² falloff from each position.
  json light_model = {{"near_field", d.near_field()}};
  if (d.near_field()) {
    json positions = json::array();
    for (const auto& light : d.lights)
      positions.push_back(
          {(*light.position_mm)[0], (*light.position_mm)[1], (*light.position_mm)[2]});
    light_model["positions_mm"] = positions;
    if (d.principal_point_px)
      light_model["principal_point_px"] = {d.principal_point_px->x, d.principal_point_px->y};
  }
  report["light_model"] = light_model;

  report["pixels"] = pixel_counts(in.pixels);
  report["residual"] = {
      {"mean", in.residual.mean}, {"p95", in.residual.p95}, {"units", "fraction of full scale"}};
  report["integrability"] = {{"mean_abs_curl", in.mean_abs_curl}};

  if (in.height) {
    report["height"] = {{"min", in.height->low},
                        {"max", in.height->high},
                        {"range", in.height->high - in.height->low},
                        {"units", in.height->units},
                        {"png_range", {in.height->low, in.height->high}},
                        {"method", to_string(in.height->method)},
                        {"pixels", in.height->pixels},
                        {"filled_pixels", in.height->filled_pixels}};
    if (in.height->solver)
      report["height"]["solver"] = {{"iterations", in.height->solver->iterations},
                                    {"relative_residual", in.height->solver->relative_residual}};
  }
  if (in.bend) {
    json bend = {{"removed", in.bend->removed}};
    if (in.bend->removed) {
      bend["cutoff"] = in.bend->cutoff;
      bend["cutoff_units"] = in.bend->cutoff_units;
      bend["peak_to_valley"] = in.bend->peak_to_valley;
      bend["rms"] = in.bend->rms;
      bend["units"] = in.height ? in.height->units : "";
    }
    report["bend"] = bend;
  }

  const auto& truth = in.ground_truth;
  if (truth.angular_error_deg || truth.height_rms_error) {
    json gt = json::object();
    if (truth.angular_error_deg)
      gt["angular_error_deg"] = distribution_json(*truth.angular_error_deg);
    if (truth.mean_angular_error_all_deg)
      gt["mean_angular_error_all_solved_deg"] = *truth.mean_angular_error_all_deg;
    if (truth.height_rms_error) gt["height_rms_error"] = *truth.height_rms_error;
    report["ground_truth"] = gt;
  }
  return report;
}

}  // namespace psrig::processing
