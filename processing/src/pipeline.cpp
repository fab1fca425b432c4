#include "psrig/processing/pipeline.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <future>
#include <optional>

#include <opencv2/imgcodecs.hpp>

#include "psrig/base/log.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/processing/colour_correction.h"
#include "psrig/processing/evaluation.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/processing/flatten.h"
#include "psrig/processing/hole_fill.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/image_metadata.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/base/parallel.h"
#include "psrig/processing/report.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scan_reader.h"

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

// `loaded`: the scan already in memory (the rig's, as_stored), else it is
// read from `scan_directory`.
Result<ProcessSummary> process_unguarded(const fs::path& scan_directory,
                                         std::optional<formats::Scan> loaded,
                                         const ProcessOptions& options) {
  auto log = logger("processing");
  const auto start = Clock::now();
  std::vector<std::pair<std::string, double>> stages;

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
  // Where the maps go is checked next: a bad --out should not wait for a
  // 12 MP read. Nothing is visible there until the commit.
  const fs::path output =
      options.output.empty() ? scan_directory / formats::scan_files::kMapsDirectory : options.output;
  const auto existing = check_output(output);
  if (!existing) return std::unexpected(existing.error());
  auto staging = formats::AtomicDirectory::create(output);
  if (!staging) return std::unexpected(staging.error());
  const fs::path dir = staging->path();

  auto scan = loaded ? Result<formats::Scan>(std::move(*loaded)) : formats::read_scan(scan_directory);
  loaded.reset();
  if (!scan) return std::unexpected(scan.error());
  stages.emplace_back("read", ms_since(start));

  auto stage_start = Clock::now();
  auto solved = solve(*scan, options.solve);
  if (!solved) return std::unexpected(solved.error());
  const SolveResult& result = *solved;
  stages.emplace_back("solve", ms_since(stage_start));
  ReportInputs inputs;
  inputs.scan = &*scan;
  inputs.options = &options;
  inputs.size = scan->size();
  inputs.channels = scan->channels();
  inputs.depth = scan->depth();
  scan->frames.clear();  // their memory goes back before the maps are made

  // The rig's colour calibration, when the scan carries one: the albedo
  // in linear light, before it is encoded, becomes linear sRGB D65.
  auto colour = read_colour_correction(scan->description.document, scan_directory / formats::scan_files::kDescription);
  if (!colour) return std::unexpected(colour.error());
  cv::Mat albedo = result.albedo;
  const bool colour_corrected = *colour && albedo.channels() == 3;
  if (colour_corrected) {
    albedo = albedo.clone();
    apply_colour_matrix((*colour)->rgb_matrix, albedo);
  }

  const cv::Mat valid = processing::encode_valid_mask(result.flags);
  GroundTruthSummary truth;
  double evaluate_ms = 0;
  // The report's statistics, and the ground truth's when the scan has one.
  const auto evaluate = [&]() -> Status {
    const auto evaluate_start = Clock::now();
    cv::Mat solved_pixels;
    cv::compare(result.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, solved_pixels,
                cv::CMP_EQ);
    inputs.pixels = count_pixels(result.flags);
    inputs.residual = describe(result.residual, solved_pixels);
    inputs.mean_abs_curl = mean_abs_curl(result.p, result.q, valid);
    if (!scan->ground_truth_normal.empty()) {
      const cv::Mat error = angular_error_deg(result.p, result.q, scan->ground_truth_normal);
      truth.angular_error_deg = describe(error, valid);
      truth.mean_angular_error_all_deg = describe(error, solved_pixels).mean;
    }
    evaluate_ms = ms_since(evaluate_start);
    return {};
  };

  // Integration runs beside the statistics and the encoding and writing of
  // the other maps: one task list on the one pool, the longest chain first.
  const double pixel_size = scan->description.pixel_size_mm.value_or(1.0);
  const bool in_mm = scan->description.pixel_size_mm.has_value();
  // What every map file says about itself (image_metadata.h): its scale,
  // the sample and when it was scanned.
  const auto metadata = [&](formats::ImageMetadata::ColourSpace space) {
    formats::ImageMetadata m;
    m.pixel_size_mm = scan->description.pixel_size_mm;
    m.colour_space = space;
    if (!scan->description.sample_id.empty())
      m.text.emplace_back(formats::metadata_keys::kSample, scan->description.sample_id);
    const auto& doc = scan->description.document;
    if (doc.contains("capture") && doc["capture"].is_object() &&
        doc["capture"].contains("started") && doc["capture"]["started"].is_string())
      m.text.emplace_back(formats::metadata_keys::kScanTime, doc["capture"]["started"].get<std::string>());
    if (in_mm) m.text.emplace_back(formats::metadata_keys::kPixelSize, fmt_number(pixel_size));
    m.text.emplace_back(formats::metadata_keys::kSoftware, "psrig");
    return m;
  };
  std::optional<HeightSummary> height_summary;
  std::optional<BendSummary> bend_summary;
  // The fabric measurement runs beside the map writes, from the height on.
  analysis::MeasureOptions measure;
  measure.pixel_size_mm = scan->description.pixel_size_mm;
  measure.hints = analysis::fabric_hints(scan->description.document);
  std::future<Result<analysis::FabricMeasurement>> fabric_future;
  double integrate_ms = 0;
  struct Task {
    std::string name;
    std::function<Status()> run;
  };
  // Every map losslessly compressed as [storage] says (report.json's
  // options record it).
  const std::vector<int> png_out = formats::png_params(options.storage.png_level);
  // Half floats hold albedo (linear, about 0..1) to 1 part in 2000, at half
  // the bytes of a float map; p, q and height as [storage] map_precision
  // says (storage_options.h: why half is the default).
  const std::vector<int> half_exr = formats::exr_params(options.storage.exr_compression, true);
  const std::vector<int> map_exr = formats::exr_params(options.storage.exr_compression,
                                              options.storage.map_precision == formats::MapPrecision::half);
  std::vector<Task> tasks;
  if (options.integration != IntegrationMethod::none) {
    tasks.push_back(
        {"integrate + height maps", [&]() -> Status {
           const auto integrate_start = Clock::now();
           // Heights for the solved pixels: the masked solver leaves the
           // others out (NaN), the whole-rectangle methods take their
           // gradients as 0.
           cv::Mat domain;
           cv::compare(result.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, domain,
                       cv::CMP_EQ);
           HeightSummary summary;
           summary.units = in_mm ? "mm" : "px";
           summary.method = options.integration;
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
           if (!height)
             return std::unexpected(internal_error("integration: " + height.error().describe()));
           if (in_mm) *height *= pixel_size;
           if (summary.method == IntegrationMethod::masked) {
             // Specks inside the swatch (up to 0.25 mm², or 64 pixels where
             // the size is unknown) are filled; the mask's outside and
             // larger unsolved regions stay holes.
             cv::Mat inside;
             cv::compare(result.flags & kOutsideMask, 0, inside, cv::CMP_EQ);
             const int max_area =
                 in_mm ? std::max(16, static_cast<int>(kSpeckAreaMm2 / (pixel_size * pixel_size)))
                       : 64;
             summary.filled_pixels = fill_specks(*height, inside, max_area);
           }
           const cv::Mat finite = *height == *height;  // NaN outside what was integrated
           summary.pixels = cv::countNonZero(finite);

           const bool flatten =
               options.flatten == Flatten::on || (options.flatten == Flatten::automatic && in_mm);
           BendSummary bend;
           if (flatten) {
             const double cutoff_px =
                 in_mm ? options.flatten_cutoff_mm / pixel_size : options.flatten_cutoff_mm;
             auto removed = remove_bend(*height, cutoff_px);
             if (!removed)
               return std::unexpected(internal_error("flatten: " + removed.error().describe()));
             bend = {true, options.flatten_cutoff_mm, in_mm ? "mm" : "px", removed->peak_to_valley,
                     removed->rms};
             log->debug("bend removed: {:.4g} {} peak to valley", removed->peak_to_valley,
                        summary.units);
           }
           bend_summary = bend;
           fabric_future = std::async(std::launch::async, [&measure, &result, h = *height] {
             return analysis::measure_fabric(h, result.albedo, measure);
           });

           double low = 0, high = 0;
           if (summary.pixels > 0) cv::minMaxLoc(*height, &low, &high, nullptr, nullptr, finite);
           summary.low = low;
           summary.high = high;
           height_summary = summary;
           if (!scan->ground_truth_height.empty())
             truth.height_rms_error = height_rms_error(*height, scan->ground_truth_height, finite);
           integrate_ms = ms_since(integrate_start);
           log->debug("integration ({}): {:.0f} ms", to_string(summary.method), integrate_ms);
           formats::ImageMetadata height_meta = metadata(formats::ImageMetadata::ColourSpace::data);
           height_meta.text.emplace_back(formats::metadata_keys::kUnits, summary.units);
           if (auto ok = formats::write_image(dir / formats::map_files::kHeightExr, *height, map_exr, height_meta);
               !ok)
             return ok;
           cv::Mat png = formats::encode_height16(*height, low, high);
           png.setTo(0, ~finite);
           height_meta.text.emplace_back(formats::metadata_keys::kHeightRange,
                                         fmt_number(low) + " " + fmt_number(high));
           return formats::write_image(dir / formats::map_files::kHeightPng, png, png_out, height_meta);
         }});
  }
  tasks.push_back({"statistics", evaluate});
  tasks.push_back({formats::map_files::kNormalPng, [&] {
                     const cv::Mat normal = formats::encode_normal16(result.p, result.q);
                     formats::ImageMetadata m = metadata(formats::ImageMetadata::ColourSpace::data);
                     m.text.emplace_back(formats::metadata_keys::kNormalConvention, "OpenGL (+Y up)");
                     if (auto ok = formats::write_image(dir / formats::map_files::kNormalPng, normal, png_out, m);
                         !ok || !options.directx_normal)
                       return ok;
                     m.text.back().second = "DirectX (+Y down)";
                     return formats::write_image(dir / formats::map_files::kNormalDirectxPng,
                                        formats::flip_normal_green(normal), png_out, m);
                   }});
  tasks.push_back({formats::map_files::kAlbedoPng, [&] {
                     return formats::write_image(dir / formats::map_files::kAlbedoPng, formats::encode_albedo_srgb8(albedo),
                                        png_out, metadata(formats::ImageMetadata::ColourSpace::colour));
                   }});
  tasks.push_back({formats::map_files::kAlbedoExr, [&] {
                     return formats::write_image(dir / formats::map_files::kAlbedoExr, albedo, half_exr,
                                        metadata(formats::ImageMetadata::ColourSpace::unspecified));
                   }});
  formats::ImageMetadata gradient_meta = metadata(formats::ImageMetadata::ColourSpace::unspecified);
  gradient_meta.text.emplace_back(formats::metadata_keys::kUnits, "dz/dx, dz/dy (y up), unitless");
  tasks.push_back({formats::map_files::kP, [&] {
                     return formats::write_image(dir / formats::map_files::kP, result.p, map_exr, gradient_meta);
                   }});
  tasks.push_back({formats::map_files::kQ, [&] {
                     return formats::write_image(dir / formats::map_files::kQ, result.q, map_exr, gradient_meta);
                   }});
  tasks.push_back({formats::map_files::kMask, [&] {
                     return formats::write_image(dir / formats::map_files::kMask, valid, png_out,
                                        metadata(formats::ImageMetadata::ColourSpace::data));
                   }});

  stage_start = Clock::now();
  std::vector<std::optional<Error>> errors(tasks.size());
  parallel_chunks(static_cast<int>(tasks.size()), 1, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const auto task_start = Clock::now();
      try {
        if (auto ok = tasks[i].run(); !ok) errors[i] = ok.error();
      } catch (const std::exception& e) {
        errors[i] = internal_error(tasks[i].name + ": " + e.what());
      }
      log->debug("{}: {:.0f} ms", tasks[i].name, ms_since(task_start));
    }
  });
  for (const auto& error : errors)
    if (error) return std::unexpected(*error);
  // Statistics and integration ran inside the last stage, beside the writes.
  stages.emplace_back("evaluate", evaluate_ms);
  if (options.integration != IntegrationMethod::none)
    stages.emplace_back("integrate", integrate_ms);
  stages.emplace_back("integrate_and_write", ms_since(stage_start));
  // The fabric's repeat and densities, from the maps just made.
  const auto measure_start = Clock::now();  // what is left of it after the writes
  const auto fabric = fabric_future.valid()
                          ? fabric_future.get()
                          : analysis::measure_fabric(result.p, result.albedo, measure);  // no height
  stages.emplace_back("measure", ms_since(measure_start));
  stages.emplace_back("total", ms_since(start));

  inputs.height = height_summary;
  inputs.bend = bend_summary;
  inputs.ground_truth = truth;
  inputs.stage_ms = stages;
  nlohmann::json report = make_report(inputs);
  // What the albedo's colours mean: sRGB D65 after a colour calibration,
  // the camera's own RGB without one (processing/colour_correction.h).
  report["albedo_colour_space"] = colour_corrected         ? kAlbedoColourSpace
                                  : albedo.channels() == 3 ? "camera RGB"
                                                           : "grey";
  report["colour_calibration"] = colour_corrected && !(*colour)->calibration.empty()
                                     ? nlohmann::json((*colour)->calibration)
                                     : nlohmann::json(nullptr);
  if (fabric) report["fabric"] = to_json(*fabric);
  const fs::path report_path = dir / formats::map_files::kReport;
  std::ofstream out(report_path);
  out << report.dump(2) << '\n';
  out.close();
  if (!out) return std::unexpected(io_error(report_path, "cannot write"));

  if (auto ok = staging->commit(*existing, false); !ok) return std::unexpected(ok.error());
  log->debug("maps of {} written to {}", scan_directory.string(), output.string());
  return ProcessSummary{output, report};
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
