#include "psrig/processing/pipeline.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <future>
#include <optional>

#include <opencv2/imgcodecs.hpp>

#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/log.h"
#include "psrig/base/parallel.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/image_metadata.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/processing/colour_correction.h"
#include "psrig/processing/evaluation.h"
#include "psrig/processing/flatten.h"
#include "psrig/processing/hole_fill.h"
#include "psrig/processing/report.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Steeper than this (85 degrees) a gradient says more about noise than
// shape; integration clamps it so one pixel cannot tilt the surface.
constexpr float kMaxSlope = 11.43f;
// Unsolved specks up to this area inside a swatch are filled, not holes.
constexpr double kSpeckAreaMm2 = 0.25;

// An existing output may only be replaced if it is a maps directory psrig
// wrote (or empty): --out must never swallow a scan or a home directory.
// Says how the commit must treat the target: replace what was checked, or
// refuse anything that appeared since.
Result<formats::AtomicDirectory::Existing> check_output(const fs::path& output) {
  std::error_code ec;
  const auto status = fs::symlink_status(output, ec);
  if (!fs::exists(status)) return formats::AtomicDirectory::Existing::refuse;
  if (!fs::is_directory(status))
    return std::unexpected(
        bad_input(output, "", "exists and is not a directory; choose another --out"));
  if (fs::is_empty(output, ec) && !ec) return formats::AtomicDirectory::Existing::replace;
  std::ifstream report(output / formats::map_files::kReport);
  const nlohmann::json doc = nlohmann::json::parse(report, nullptr, false);
  if (doc.is_object() && doc.contains("format") && doc["format"].is_string() &&
      doc["format"].get<std::string>() == kReportFormat)
    return formats::AtomicDirectory::Existing::replace;
  return std::unexpected(
      bad_input(output, "",
                "exists and is not a psrig maps directory; refusing to replace it "
                "(choose another --out, or remove it)"));
}

// A number for a text chunk: enough digits to give the double back.
std::string fmt_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

// The options' values, and the scan directory: there, and a directory.
Status check_inputs(const fs::path& scan_directory, const ProcessOptions& options) {
  if (!(options.flatten_cutoff_mm > 0) || !std::isfinite(options.flatten_cutoff_mm))
    return std::unexpected(
        bad_input({}, "--flatten-cutoff", "the bend's cut-off must be a positive length (mm)"));
  if (options.storage.png_level < 0 || options.storage.png_level > 9)
    return std::unexpected(
        bad_input({}, "--png-level", "the PNG compression level must be 0 (stored) to 9"));
  // A scan directory that is not there is the error, not the maps
  // directory inside it that cannot be made.
  std::error_code ec;
  if (!fs::is_directory(scan_directory, ec))
    return std::unexpected(
        bad_input(scan_directory, "",
                  fs::exists(scan_directory, ec) ? "not a directory" : "no such scan directory"));
  return {};
}

// Where the maps go, and the hidden directory they are written to until
// the commit.
struct Destination {
  fs::path output;
  formats::AtomicDirectory::Existing existing;
  formats::AtomicDirectory staging;
};

Result<Destination> prepare_output(const fs::path& scan_directory, const ProcessOptions& options) {
  const fs::path output = options.output.empty()
                              ? scan_directory / formats::scan_files::kMapsDirectory
                              : options.output;
  const auto existing = check_output(output);
  if (!existing) return std::unexpected(existing.error());
  auto staging = formats::AtomicDirectory::create(output);
  if (!staging) return std::unexpected(staging.error());
  return Destination{output, *existing, std::move(*staging)};
}

// What the report says of the scan itself, taken before its frames go.
ReportInputs scan_inputs(const formats::Scan& scan, const ProcessOptions& options) {
  ReportInputs inputs;
  inputs.scan = &scan;
  inputs.options = &options;
  inputs.size = scan.size();
  inputs.channels = scan.channels();
  inputs.depth = scan.depth();
  return inputs;
}

// What every map task reads: the solve, the scan's description, and how and
// where the maps are written.
struct MapContext {
  const formats::Scan& scan;
  const SolveResult& result;
  const ProcessOptions& options;
  fs::path dir;
  cv::Mat albedo;  // in sRGB D65 after a colour calibration
  cv::Mat valid;
  double pixel_size = 1.0;
  bool in_mm = false;
  // The fabric measurement runs beside the map writes, from the height on.
  analysis::MeasureOptions measure;
  // Every map losslessly compressed as [storage] says (report.json's
  // options record it).
  std::vector<int> png_out;
  // Half floats hold albedo (linear, about 0..1) to 1 part in 2000, at half
  // the bytes of a float map; p, q and height as [storage] map_precision
  // says (storage_options.h: why half is the default).
  std::vector<int> half_exr;
  std::vector<int> map_exr;
  formats::ImageMetadata gradient_meta;

  // What every map file says about itself (image_metadata.h): its scale,
  // the sample and when it was scanned.
  [[nodiscard]] formats::ImageMetadata metadata(formats::ImageMetadata::ColourSpace space) const {
    formats::ImageMetadata m;
    m.pixel_size_mm = scan.description.pixel_size_mm;
    m.colour_space = space;
    if (!scan.description.sample_id.empty())
      m.text.emplace_back(formats::metadata_keys::kSample, scan.description.sample_id);
    const auto& doc = scan.description.document;
    if (doc.contains("capture") && doc["capture"].is_object() &&
        doc["capture"].contains("started") && doc["capture"]["started"].is_string())
      m.text.emplace_back(formats::metadata_keys::kScanTime,
                          doc["capture"]["started"].get<std::string>());
    if (in_mm) m.text.emplace_back(formats::metadata_keys::kPixelSize, fmt_number(pixel_size));
    m.text.emplace_back(formats::metadata_keys::kSoftware, "psrig");
    return m;
  }
};

MapContext map_context(const formats::Scan& scan, const SolveResult& result,
                       const ProcessOptions& options, const fs::path& dir, cv::Mat albedo) {
  const auto& description = scan.description;
  const auto& storage = options.storage;
  MapContext maps{
      .scan = scan,
      .result = result,
      .options = options,
      .dir = dir,
      .albedo = std::move(albedo),
      .valid = encode_valid_mask(result.flags),
      .pixel_size = description.pixel_size_mm.value_or(1.0),
      .in_mm = description.pixel_size_mm.has_value(),
      .measure = {},
      .png_out = formats::png_params(storage.png_level),
      .half_exr = formats::exr_params(storage.exr_compression, true),
      .map_exr = formats::exr_params(storage.exr_compression,
                                     storage.map_precision == formats::MapPrecision::half),
      .gradient_meta = {},
  };
  maps.measure.pixel_size_mm = description.pixel_size_mm;
  maps.measure.hints = analysis::fabric_hints(description.document);
  maps.gradient_meta = maps.metadata(formats::ImageMetadata::ColourSpace::unspecified);
  maps.gradient_meta.text.emplace_back(formats::metadata_keys::kUnits,
                                       "dz/dx, dz/dy (y up), unitless");
  return maps;
}

// What the map tasks leave for the report, each field written by one task.
struct TaskResults {
  GroundTruthSummary truth;  // the statistics' fields and the integration's
  double evaluate_ms = 0;
  double integrate_ms = 0;
  std::optional<HeightSummary> height;
  std::optional<BendSummary> bend;
  std::future<Result<analysis::FabricMeasurement>> fabric;  // reads the context's measure
};

// The report's statistics, and the ground truth's when the scan has one.
Status evaluate(const MapContext& maps, ReportInputs& inputs, TaskResults& results) {
  const auto evaluate_start = Clock::now();
  const SolveResult& result = maps.result;
  cv::Mat solved_pixels;
  cv::compare(result.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, solved_pixels,
              cv::CMP_EQ);
  inputs.pixels = count_pixels(result.flags);
  inputs.residual = describe(result.residual, solved_pixels);
  inputs.mean_abs_curl = mean_abs_curl(result.p, result.q, maps.valid);
  if (!maps.scan.ground_truth_normal.empty()) {
    const cv::Mat error = angular_error_deg(result.p, result.q, maps.scan.ground_truth_normal);
    results.truth.angular_error_deg = describe(error, maps.valid);
    results.truth.mean_angular_error_all_deg = describe(error, solved_pixels).mean;
  }
  results.evaluate_ms = ms_since(evaluate_start);
  return {};
}

// The height from the gradients, by the method asked for (or the one
// `automatic` picks), in mm where the pixel size is known.
Result<cv::Mat> integrate_height(const MapContext& maps, HeightSummary& summary) {
  const SolveResult& result = maps.result;
  // Heights for the solved pixels: the masked solver leaves the
  // others out (NaN), the whole-rectangle methods take their
  // gradients as 0.
  cv::Mat domain;
  cv::compare(result.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, domain, cv::CMP_EQ);
  summary.units = maps.in_mm ? "mm" : "px";
  summary.method = maps.options.integration;
  if (summary.method == IntegrationMethod::automatic)
    summary.method = needs_masked_integration(result.p, result.q, domain)
                         ? IntegrationMethod::masked
                         : IntegrationMethod::frankot_chellappa;
  Result<cv::Mat> height = cv::Mat();
  if (summary.method == IntegrationMethod::masked) {
    MaskedIntegrationOptions masked;
    masked.max_slope = kMaxSlope;
    MaskedIntegrationStats stats;
    height = integrate_masked(result.p, result.q, domain, masked, &stats);
    summary.solver = stats;
  } else {
    height = integrate(summary.method, result.p, result.q, kMaxSlope);
  }
  // The solve's own gradients cannot be bad input: a failure is ours.
  if (!height) return std::unexpected(internal_error("integration: " + height.error().describe()));
  if (maps.in_mm) *height *= maps.pixel_size;
  if (summary.method == IntegrationMethod::masked) {
    // Specks inside the swatch (up to 0.25 mm², or 64 pixels where
    // the size is unknown) are filled; the mask's outside and
    // larger unsolved regions stay holes.
    cv::Mat inside;
    cv::compare(result.flags & kOutsideMask, 0, inside, cv::CMP_EQ);
    const int max_area =
        maps.in_mm
            ? std::max(16, static_cast<int>(kSpeckAreaMm2 / (maps.pixel_size * maps.pixel_size)))
            : 64;
    summary.filled_pixels = fill_specks(*height, inside, max_area);
  }
  return height;
}

// The low-frequency bend taken off the height, where the options say so.
Result<BendSummary> flatten_height(const MapContext& maps, cv::Mat& height,
                                   const std::string& units, spdlog::logger& log) {
  const ProcessOptions& options = maps.options;
  const bool flatten =
      options.flatten == Flatten::on || (options.flatten == Flatten::automatic && maps.in_mm);
  BendSummary bend;
  if (flatten) {
    const double cutoff_px =
        maps.in_mm ? options.flatten_cutoff_mm / maps.pixel_size : options.flatten_cutoff_mm;
    auto removed = remove_bend(height, cutoff_px);
    if (!removed) return std::unexpected(internal_error("flatten: " + removed.error().describe()));
    bend = {true, options.flatten_cutoff_mm, maps.in_mm ? "mm" : "px", removed->peak_to_valley,
            removed->rms};
    log.debug("bend removed: {:.4g} {} peak to valley", removed->peak_to_valley, units);
  }
  return bend;
}

// height.exr as it is, and height.png spread over [low, high] (which its
// metadata records), 0 where the height is not finite.
Status write_height_maps(const MapContext& maps, const cv::Mat& height, const cv::Mat& finite,
                         double low, double high, const std::string& units) {
  formats::ImageMetadata height_meta = maps.metadata(formats::ImageMetadata::ColourSpace::data);
  height_meta.text.emplace_back(formats::metadata_keys::kUnits, units);
  if (auto ok = formats::write_image(maps.dir / formats::map_files::kHeightExr, height,
                                     maps.map_exr, height_meta);
      !ok)
    return ok;
  cv::Mat png = formats::encode_height16(height, low, high);
  png.setTo(0, ~finite);
  height_meta.text.emplace_back(formats::metadata_keys::kHeightRange,
                                fmt_number(low) + " " + fmt_number(high));
  return formats::write_image(maps.dir / formats::map_files::kHeightPng, png, maps.png_out,
                              height_meta);
}

// The longest task: the height, flattened, its summary and the height
// maps. The fabric measurement starts from it, beside the other writes.
Status integrate_and_write_height(const MapContext& maps, TaskResults& results,
                                  spdlog::logger& log) {
  const auto integrate_start = Clock::now();
  HeightSummary summary;
  auto height = integrate_height(maps, summary);
  if (!height) return std::unexpected(height.error());
  const cv::Mat finite = *height == *height;  // NaN outside what was integrated
  summary.pixels = cv::countNonZero(finite);

  const auto bend = flatten_height(maps, *height, summary.units, log);
  if (!bend) return std::unexpected(bend.error());
  results.bend = *bend;
  results.fabric =
      std::async(std::launch::async, [&measure = maps.measure, &result = maps.result, h = *height] {
        return analysis::measure_fabric(h, result.albedo, measure);
      });

  double low = 0, high = 0;
  if (summary.pixels > 0) cv::minMaxLoc(*height, &low, &high, nullptr, nullptr, finite);
  summary.low = low;
  summary.high = high;
  results.height = summary;
  if (!maps.scan.ground_truth_height.empty())
    results.truth.height_rms_error =
        height_rms_error(*height, maps.scan.ground_truth_height, finite);
  results.integrate_ms = ms_since(integrate_start);
  log.debug("integration ({}): {:.0f} ms", to_string(summary.method), results.integrate_ms);
  return write_height_maps(maps, *height, finite, low, high, summary.units);
}

// normal.png, in OpenGL's convention, and DirectX's beside it when asked.
Status write_normal_maps(const MapContext& maps) {
  const cv::Mat normal = formats::encode_normal16(maps.result.p, maps.result.q);
  formats::ImageMetadata m = maps.metadata(formats::ImageMetadata::ColourSpace::data);
  m.text.emplace_back(formats::metadata_keys::kNormalConvention, "OpenGL (+Y up)");
  if (auto ok =
          formats::write_image(maps.dir / formats::map_files::kNormalPng, normal, maps.png_out, m);
      !ok || !maps.options.directx_normal)
    return ok;
  m.text.back().second = "DirectX (+Y down)";
  return formats::write_image(maps.dir / formats::map_files::kNormalDirectxPng,
                              formats::flip_normal_green(normal), maps.png_out, m);
}

struct Task {
  std::string name;
  std::function<Status()> run;
};

// Integration runs beside the statistics and the encoding and writing of
// the other maps: one task list on the one pool, the longest chain first.
std::vector<Task> map_tasks(const MapContext& maps, ReportInputs& inputs, TaskResults& results,
                            spdlog::logger& log) {
  using ColourSpace = formats::ImageMetadata::ColourSpace;
  const fs::path& dir = maps.dir;
  std::vector<Task> tasks;
  if (maps.options.integration != IntegrationMethod::none)
    tasks.push_back({"integrate + height maps", [&maps, &results, &log] {
                       return integrate_and_write_height(maps, results, log);
                     }});
  tasks.push_back(
      {"statistics", [&maps, &inputs, &results] { return evaluate(maps, inputs, results); }});
  tasks.push_back({formats::map_files::kNormalPng, [&maps] { return write_normal_maps(maps); }});
  tasks.push_back({formats::map_files::kAlbedoPng, [&maps, &dir] {
                     return formats::write_image(dir / formats::map_files::kAlbedoPng,
                                                 formats::encode_albedo_srgb8(maps.albedo),
                                                 maps.png_out, maps.metadata(ColourSpace::colour));
                   }});
  tasks.push_back({formats::map_files::kAlbedoExr, [&maps, &dir] {
                     return formats::write_image(dir / formats::map_files::kAlbedoExr, maps.albedo,
                                                 maps.half_exr,
                                                 maps.metadata(ColourSpace::unspecified));
                   }});
  tasks.push_back({formats::map_files::kP, [&maps, &dir] {
                     return formats::write_image(dir / formats::map_files::kP, maps.result.p,
                                                 maps.map_exr, maps.gradient_meta);
                   }});
  tasks.push_back({formats::map_files::kQ, [&maps, &dir] {
                     return formats::write_image(dir / formats::map_files::kQ, maps.result.q,
                                                 maps.map_exr, maps.gradient_meta);
                   }});
  tasks.push_back({formats::map_files::kMask, [&maps, &dir] {
                     return formats::write_image(dir / formats::map_files::kMask, maps.valid,
                                                 maps.png_out, maps.metadata(ColourSpace::data));
                   }});
  return tasks;
}

// Every task on the pool, each timed in the log; the first failure (in the
// tasks' order) is the error.
Status run_tasks(const std::vector<Task>& tasks, spdlog::logger& log) {
  std::vector<std::optional<Error>> errors(tasks.size());
  parallel_chunks(static_cast<int>(tasks.size()), 1, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const auto task_start = Clock::now();
      try {
        if (auto ok = tasks[i].run(); !ok) errors[i] = ok.error();
      } catch (const std::exception& e) {
        errors[i] = internal_error(tasks[i].name + ": " + e.what());
      }
      log.debug("{}: {:.0f} ms", tasks[i].name, ms_since(task_start));
    }
  });
  for (const auto& error : errors)
    if (error) return std::unexpected(*error);
  return {};
}

// report.json's contents: the statistics and summaries, what the albedo's
// colours mean, and the fabric measured on the maps.
nlohmann::json build_report(ReportInputs& inputs, const TaskResults& results,
                            const std::vector<std::pair<std::string, double>>& stages,
                            const cv::Mat& albedo, const std::optional<ColourCorrection>& colour,
                            const Result<analysis::FabricMeasurement>& fabric) {
  const bool colour_corrected = colour && albedo.channels() == 3;
  inputs.height = results.height;
  inputs.bend = results.bend;
  inputs.ground_truth = results.truth;
  inputs.stage_ms = stages;
  nlohmann::json report = make_report(inputs);
  // What the albedo's colours mean: sRGB D65 after a colour calibration,
  // the camera's own RGB without one (processing/colour_correction.h).
  report["albedo_colour_space"] = colour_corrected         ? kAlbedoColourSpace
                                  : albedo.channels() == 3 ? "camera RGB"
                                                           : "grey";
  report["colour_calibration"] = colour_corrected && !colour->calibration.empty()
                                     ? nlohmann::json(colour->calibration)
                                     : nlohmann::json(nullptr);
  if (fabric) report["fabric"] = to_json(*fabric);
  return report;
}

Status write_report(const nlohmann::json& report, const fs::path& dir) {
  const fs::path report_path = dir / formats::map_files::kReport;
  std::ofstream out(report_path);
  out << report.dump(2) << '\n';
  out.close();
  if (!out) return std::unexpected(io_error(report_path, "cannot write"));
  return {};
}

// `loaded`: the scan already in memory (the rig's, as_stored), else it is
// read from `scan_directory`.
Result<ProcessSummary> process_unguarded(const fs::path& scan_directory,
                                         std::optional<formats::Scan> loaded,
                                         const ProcessOptions& options) {
  auto log = logger("processing");
  const auto start = Clock::now();
  std::vector<std::pair<std::string, double>> stages;

  if (auto ok = check_inputs(scan_directory, options); !ok) return std::unexpected(ok.error());
  // Where the maps go is checked next: a bad --out should not wait for a
  // 12 MP read. Nothing is visible there until the commit.
  auto destination = prepare_output(scan_directory, options);
  if (!destination) return std::unexpected(destination.error());

  auto scan =
      loaded ? Result<formats::Scan>(std::move(*loaded)) : formats::read_scan(scan_directory);
  loaded.reset();
  if (!scan) return std::unexpected(scan.error());
  stages.emplace_back("read", ms_since(start));

  auto stage_start = Clock::now();
  auto solved = solve(*scan, options.solve);
  if (!solved) return std::unexpected(solved.error());
  const SolveResult& result = *solved;
  stages.emplace_back("solve", ms_since(stage_start));
  ReportInputs inputs = scan_inputs(*scan, options);
  scan->frames.clear();  // their memory goes back before the maps are made

  // The rig's colour calibration, when the scan carries one: the albedo
  // in linear light, before it is encoded, becomes linear sRGB D65.
  auto colour = read_colour_correction(scan->description.document,
                                       scan_directory / formats::scan_files::kDescription);
  if (!colour) return std::unexpected(colour.error());
  cv::Mat albedo = result.albedo;
  if (*colour && albedo.channels() == 3) {
    albedo = albedo.clone();
    apply_colour_matrix((*colour)->rgb_matrix, albedo);
  }

  const MapContext maps =
      map_context(*scan, result, options, destination->staging.path(), std::move(albedo));
  TaskResults results;  // after the context: the fabric's task reads its measure
  const std::vector<Task> tasks = map_tasks(maps, inputs, results, *log);
  stage_start = Clock::now();
  if (auto ok = run_tasks(tasks, *log); !ok) return std::unexpected(ok.error());
  // Statistics and integration ran inside the last stage, beside the writes.
  stages.emplace_back("evaluate", results.evaluate_ms);
  if (options.integration != IntegrationMethod::none)
    stages.emplace_back("integrate", results.integrate_ms);
  stages.emplace_back("integrate_and_write", ms_since(stage_start));
  // The fabric's repeat and densities, from the maps just made (from p
  // where there is no height).
  const auto measure_start = Clock::now();  // what is left of it after the writes
  const auto fabric = results.fabric.valid()
                          ? results.fabric.get()
                          : analysis::measure_fabric(result.p, result.albedo, maps.measure);
  stages.emplace_back("measure", ms_since(measure_start));
  stages.emplace_back("total", ms_since(start));

  const nlohmann::json report = build_report(inputs, results, stages, maps.albedo, *colour, fabric);
  if (auto ok = write_report(report, maps.dir); !ok) return std::unexpected(ok.error());
  if (auto ok = destination->staging.commit(destination->existing, false); !ok)
    return std::unexpected(ok.error());
  log->debug("maps of {} written to {}", scan_directory.string(), destination->output.string());
  return ProcessSummary{destination->output, report};
}

}  // namespace

std::optional<Flatten> parse_flatten(std::string_view name) {
  if (name == "auto") return Flatten::automatic;
  if (name == "on") return Flatten::on;
  if (name == "off") return Flatten::off;
  return std::nullopt;
}

std::string_view to_string(Flatten flatten) {
  switch (flatten) {
    case Flatten::automatic:
      return "auto";
    case Flatten::on:
      return "on";
    case Flatten::off:
      return "off";
  }
  return "unknown";
}

Result<ProcessSummary> process_scan(const fs::path& scan_directory, const ProcessOptions& options) {
  try {
    return process_unguarded(scan_directory, std::nullopt, options);
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    return std::unexpected(internal_error(std::string("processing failed: ") + e.what()));
  }
}

Result<ProcessSummary> process_scan(formats::Scan scan, const fs::path& scan_directory,
                                    const ProcessOptions& options) {
  try {
    return process_unguarded(scan_directory, std::move(scan), options);
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    return std::unexpected(internal_error(std::string("processing failed: ") + e.what()));
  }
}

}  // namespace psrig::processing
