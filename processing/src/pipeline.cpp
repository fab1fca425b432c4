#include "psrig/processing/pipeline.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <optional>

#include "band_maps.h"
#include "map_files.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/log.h"
#include "psrig/base/memory_use.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/frame_bands.h"
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
#include "stage_tasks.h"

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

// How long each stage took, and the most memory it held, sampled while it
// ran (the kernel's exact peak covers the process's whole life: report.json's
// memory_mb.process_peak).
class StageClock {
 public:
  explicit StageClock(spdlog::logger& log)
      : log_(log),
        start_(Clock::now()),
        stage_start_(start_),
        stage_cpu_(cpu_ms()),
        at_start_(resident_bytes()) {}

  // A stage begins; the first began with the clock.
  void begin() {
    stage_start_ = Clock::now();
    stage_cpu_ = cpu_ms();
    (void)sampler_.take_peak();
  }
  // The stage begun last ends. The log has its CPU time too (every thread's).
  double end(const std::string& name) {
    const double ms = ms_since(stage_start_);
    stages_.emplace_back(name, ms);
    peaks_.emplace_back(name, megabytes(sampler_.take_peak()));
    log_.debug("stage {}: {:.0f} ms, {:.0f} ms of CPU, {:.0f} MB at most", name, ms,
               cpu_ms() - stage_cpu_, peaks_.back().second);
    return ms;
  }
  // A time measured elsewhere, inside a stage.
  void add(const std::string& name, double ms) { stages_.emplace_back(name, ms); }
  [[nodiscard]] Clock::time_point start() const { return start_; }

  [[nodiscard]] const std::vector<std::pair<std::string, double>>& stages() const {
    return stages_;
  }
  [[nodiscard]] MemoryFigures memory() const {
    return {megabytes(at_start_), megabytes(peak_resident_bytes()), peaks_};
  }

 private:
  static double megabytes(std::size_t bytes) { return static_cast<double>(bytes) / (1 << 20); }
  static double cpu_ms() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
  }

  spdlog::logger& log_;
  Clock::time_point start_;
  Clock::time_point stage_start_;
  double stage_cpu_;
  std::size_t at_start_;
  ResidentSampler sampler_;
  std::vector<std::pair<std::string, double>> stages_;
  std::vector<std::pair<std::string, double>> peaks_;
};

// What the stages after the solve leave for the report.
struct StageResults {
  GroundTruthSummary truth;
  std::optional<HeightSummary> height;
  std::optional<BendSummary> bend;
  std::optional<Result<analysis::FabricMeasurement>> fabric;
  double measure_ms = 0;
};

// The report's statistics, and the ground truth's when the scan has one
// (read now, and let go once used). The residual goes once described.
Status evaluate(formats::Scan& scan, SolvedPlanes& planes, ReportInputs& inputs,
                StageResults& results) {
  cv::Mat solved_pixels;
  cv::compare(planes.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, solved_pixels,
              cv::CMP_EQ);
  const cv::Mat valid = encode_valid_mask(planes.flags);
  inputs.pixels = count_pixels(planes.flags);
  inputs.residual = describe(planes.residual, solved_pixels);
  planes.residual.release();
  inputs.mean_abs_curl = mean_abs_curl(planes.p, planes.q, valid);
  if (auto ok = formats::read_ground_truth(scan, formats::GroundTruth::normal, planes.flags.size());
      !ok)
    return ok;
  if (!scan.ground_truth_normal.empty()) {
    const cv::Mat error = angular_error_deg(planes.p, planes.q, scan.ground_truth_normal);
    scan.ground_truth_normal.release();
    results.truth.angular_error_deg = describe(error, valid);
    results.truth.mean_angular_error_all_deg = describe_moments(error, solved_pixels).mean;
  }
  return {};
}

// The height from the gradients, by the method asked for (or the one
// `automatic` picks), in mm where the pixel size is known. p and q are
// handed to the masked solver, which lets them go once it has what it
// needs; no later stage reads them.
Result<cv::Mat> integrate_height(const MapFiles& files, SolvedPlanes& planes,
                                 HeightSummary& summary) {
  // Heights for the solved pixels: the masked solver leaves the
  // others out (NaN), the whole-rectangle methods take their
  // gradients as 0.
  cv::Mat domain;
  cv::compare(planes.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, domain, cv::CMP_EQ);
  summary.units = files.in_mm ? "mm" : "px";
  summary.method = files.options.integration;
  if (summary.method == IntegrationMethod::automatic)
    summary.method = needs_masked_integration(planes.p, planes.q, domain)
                         ? IntegrationMethod::masked
                         : IntegrationMethod::frankot_chellappa;
  Result<cv::Mat> height = cv::Mat();
  if (summary.method == IntegrationMethod::masked) {
    MaskedIntegrationOptions masked;
    masked.max_slope = kMaxSlope;
    MaskedIntegrationStats stats;
    height = integrate_masked(std::move(planes.p), std::move(planes.q), domain, masked, &stats);
    summary.solver = stats;
  } else {
    height = integrate(summary.method, planes.p, planes.q, kMaxSlope);
    planes.p.release();
    planes.q.release();
  }
  // The solve's own gradients cannot be bad input: a failure is ours.
  if (!height) return std::unexpected(internal_error("integration: " + height.error().describe()));
  if (files.in_mm) *height *= files.pixel_size;
  if (summary.method == IntegrationMethod::masked) {
    // Specks inside the swatch (up to 0.25 mm², or 64 pixels where
    // the size is unknown) are filled; the mask's outside and
    // larger unsolved regions stay holes.
    cv::Mat inside;
    cv::compare(planes.flags & kOutsideMask, 0, inside, cv::CMP_EQ);
    const int max_area =
        files.in_mm
            ? std::max(16, static_cast<int>(kSpeckAreaMm2 / (files.pixel_size * files.pixel_size)))
            : 64;
    summary.filled_pixels = fill_specks(*height, inside, max_area);
  }
  return height;
}

// The low-frequency bend taken off the height, where the options say so.
Result<BendSummary> flatten_height(const MapFiles& files, cv::Mat& height, const std::string& units,
                                   spdlog::logger& log) {
  const ProcessOptions& options = files.options;
  const bool flatten =
      options.flatten == Flatten::on || (options.flatten == Flatten::automatic && files.in_mm);
  BendSummary bend;
  if (flatten) {
    const double cutoff_px =
        files.in_mm ? options.flatten_cutoff_mm / files.pixel_size : options.flatten_cutoff_mm;
    auto removed = remove_bend(height, cutoff_px, false);
    if (!removed) return std::unexpected(internal_error("flatten: " + removed.error().describe()));
    bend = {true, options.flatten_cutoff_mm, files.in_mm ? "mm" : "px", removed->peak_to_valley,
            removed->rms};
    log.debug("bend removed: {:.4g} {} peak to valley", removed->peak_to_valley, units);
  }
  return bend;
}

// The height, flattened, with its summary and its error against the ground
// truth (read now, let go once used); `finite` where it has a value.
Result<cv::Mat> height_of(formats::Scan& scan, const MapFiles& files, SolvedPlanes& planes,
                          StageResults& results, cv::Mat& finite, spdlog::logger& log) {
  const auto start = Clock::now();
  HeightSummary summary;
  auto height = integrate_height(files, planes, summary);
  if (!height) return std::unexpected(height.error());
  finite = *height == *height;  // NaN outside what was integrated
  summary.pixels = cv::countNonZero(finite);
  const auto bend = flatten_height(files, *height, summary.units, log);
  if (!bend) return std::unexpected(bend.error());
  results.bend = *bend;
  if (summary.pixels > 0)
    cv::minMaxLoc(*height, &summary.low, &summary.high, nullptr, nullptr, finite);
  // What the solve and the flattening freed goes back before the truth is
  // read: kept beside it, it would raise the peak.
  give_back_free_memory();
  if (auto ok = formats::read_ground_truth(scan, formats::GroundTruth::height, height->size()); !ok)
    return std::unexpected(ok.error());
  if (!scan.ground_truth_height.empty()) {
    results.truth.height_rms_error = height_rms_error(*height, scan.ground_truth_height, finite);
    scan.ground_truth_height.release();
  }
  log.debug("integration ({}): {:.0f} ms", to_string(summary.method), ms_since(start));
  results.height = summary;
  return height;
}

// height.exr as it is, and height.png spread over [low, high] (which its
// metadata records), 0 where the height is not finite.
Status write_height_exr(const MapFiles& files, const cv::Mat& height, const std::string& units) {
  formats::ImageMetadata meta = files.metadata(formats::ImageMetadata::ColourSpace::data);
  meta.text.emplace_back(formats::metadata_keys::kUnits, units);
  return formats::write_image(files.dir / formats::map_files::kHeightExr, height, files.map_exr,
                              meta);
}
Status write_height_png(const MapFiles& files, const cv::Mat& height, const cv::Mat& finite,
                        double low, double high, const std::string& units) {
  formats::ImageMetadata meta = files.metadata(formats::ImageMetadata::ColourSpace::data);
  meta.text.emplace_back(formats::metadata_keys::kUnits, units);
  cv::Mat png = formats::encode_height16(height, low, high);
  png.setTo(0, ~finite);
  meta.text.emplace_back(formats::metadata_keys::kHeightRange,
                         metadata_number(low) + " " + metadata_number(high));
  return formats::write_image(files.dir / formats::map_files::kHeightPng, png, files.png_out, meta);
}

// The height maps and the fabric measurement side by side. The fabric is
// measured on the height, or on p without one, with the albedo as solved.
Status write_height_and_measure(const MapFiles& files, const cv::Mat& height, const cv::Mat& finite,
                                SolvedPlanes& planes, StageResults& results,
                                std::vector<std::pair<std::string, double>>& encode_ms,
                                spdlog::logger& log) {
  analysis::MeasureOptions measure;
  measure.pixel_size_mm = files.scan.description.pixel_size_mm;
  measure.hints = analysis::fabric_hints(files.scan.description.document);
  const cv::Mat& relief = height.empty() ? planes.p : height;
  const cv::Mat measured = relief(analysis::measured_region(relief.size()));
  std::vector<StageTask> tasks;
  double exr_ms = 0;
  double png_ms = 0;
  tasks.push_back({"fabric",
                   [&] {
                     results.fabric =
                         analysis::measure_fabric(measured, planes.albedo_centre, measure);
                     return Status{};
                   },
                   &results.measure_ms});
  if (!height.empty()) {
    const HeightSummary& summary = *results.height;
    tasks.push_back({formats::map_files::kHeightExr,
                     [&] { return write_height_exr(files, height, summary.units); }, &exr_ms});
    tasks.push_back({formats::map_files::kHeightPng,
                     [&] {
                       return write_height_png(files, height, finite, summary.low, summary.high,
                                               summary.units);
                     },
                     &png_ms});
  }
  if (auto ok = run_tasks(tasks, log); !ok) return ok;
  if (!height.empty()) {
    encode_ms.emplace_back(formats::map_files::kHeightExr, exr_ms);
    encode_ms.emplace_back(formats::map_files::kHeightPng, png_ms);
    log.debug("{}: {:.0f} ms, {}: {:.0f} ms", formats::map_files::kHeightExr, exr_ms,
              formats::map_files::kHeightPng, png_ms);
  }
  log.debug("fabric: {:.0f} ms", results.measure_ms);
  return {};
}

// report.json's contents: the statistics and summaries, what the albedo's
// colours mean, and the fabric measured on the maps.
nlohmann::json build_report(ReportInputs& inputs, const StageResults& results, int channels,
                            const std::optional<ColourCorrection>& colour) {
  const bool colour_corrected = colour && channels == 3;
  inputs.height = results.height;
  inputs.bend = results.bend;
  inputs.ground_truth = results.truth;
  nlohmann::json report = make_report(inputs);
  // What the albedo's colours mean: sRGB D65 after a colour calibration,
  // the camera's own RGB without one (processing/colour_correction.h).
  report["albedo_colour_space"] = colour_corrected ? kAlbedoColourSpace
                                  : channels == 3  ? "camera RGB"
                                                   : "grey";
  report["colour_calibration"] = colour_corrected && !colour->calibration.empty()
                                     ? nlohmann::json(colour->calibration)
                                     : nlohmann::json(nullptr);
  if (results.fabric && *results.fabric) report["fabric"] = to_json(**results.fabric);
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
// read from `scan_directory`, all but its ground truth, which is read when
// the statistics need it.
//
// The stages, one after another, each with the whole pool (stage_tasks.h):
// read; solve and encode (band_maps.h: the solve a band at a time, each
// band's albedo, gradient, normal and mask maps written as it is solved);
// evaluate (the statistics); integrate (the height, filled and flattened);
// height maps (height.exr, height.png and the fabric measurement side by
// side). Each stage's memory goes back before the next: the frames after
// the solve, the residual and the ground truth once described, p and q once
// the height's system is assembled.
Result<ProcessSummary> process_unguarded(const fs::path& scan_directory,
                                         std::optional<formats::Scan> loaded,
                                         const ProcessOptions& options) {
  auto log = logger("processing");
  StageClock clock(*log);

  if (auto ok = check_inputs(scan_directory, options); !ok) return std::unexpected(ok.error());
  // Where the maps go is checked next: a bad --out should not wait for a
  // 12 MP read. Nothing is visible there until the commit.
  auto destination = prepare_output(scan_directory, options);
  if (!destination) return std::unexpected(destination.error());

  // Read from the directory, the PNG frames are decoded a band at a time as
  // the solve needs them (formats/frame_bands.h), beside it.
  auto banded = loaded ? Result<formats::BandedScan>(formats::BandedScan{std::move(*loaded), {}})
                       : formats::read_scan_by_band(scan_directory,
                                                    formats::ScanImages::without_ground_truth);
  loaded.reset();
  if (!banded) return std::unexpected(banded.error());
  formats::Scan* const scan = &banded->scan;
  clock.end("read");

  // The rig's colour calibration, when the scan carries one: the albedo
  // in linear light, before it is encoded, becomes linear sRGB D65.
  auto colour = read_colour_correction(scan->description.document,
                                       scan_directory / formats::scan_files::kDescription);
  if (!colour) return std::unexpected(colour.error());
  std::optional<cv::Matx33d> matrix;
  if (*colour) matrix = (*colour)->rgb_matrix;

  ReportInputs inputs = scan_inputs(*scan, options);
  const MapFiles files = map_files(*scan, options, destination->staging.path());
  clock.begin();
  auto band = solve_and_encode(*scan, banded->frames, options.solve, files, matrix, *log);
  if (!band) return std::unexpected(band.error());
  clock.end("solve_and_encode");
  clock.add("solve", band->solve_ms);
  std::vector<std::pair<std::string, double>> encode_ms = std::move(band->encode_ms);
  SolvedPlanes& planes = band->planes;
  // The frames' memory goes back before the maps that follow are made.
  scan->frames.clear();
  scan->frames.shrink_to_fit();
  scan->dark.release();
  scan->mask.release();
  scan->flats.clear();

  const auto after_solve = Clock::now();
  StageResults results;
  clock.begin();
  if (auto ok = evaluate(*scan, planes, inputs, results); !ok) return std::unexpected(ok.error());
  clock.end("evaluate");

  cv::Mat height;
  cv::Mat finite;
  if (options.integration != IntegrationMethod::none) {
    clock.begin();
    // The solver, the hole fill and the flattening take and drop some 600 MB
    // of planes at 12 MP: kept in the heap, they are cleared once instead of
    // page by page for each (base/memory_use.h).
    const HeapForLargeBlocks heap;
    auto made = height_of(*scan, files, planes, results, finite, *log);
    if (!made) return std::unexpected(made.error());
    height = std::move(*made);
    clock.end("integrate");
  }
  clock.begin();
  if (auto ok = write_height_and_measure(files, height, finite, planes, results, encode_ms, *log);
      !ok)
    return std::unexpected(ok.error());
  clock.end("height_maps");
  clock.add("measure", results.measure_ms);
  clock.add("integrate_and_write", ms_since(after_solve));
  clock.add("total", ms_since(clock.start()));

  inputs.stage_ms = clock.stages();
  inputs.encode_ms = encode_ms;
  inputs.memory = clock.memory();
  const nlohmann::json report = build_report(inputs, results, inputs.channels, *colour);
  if (auto ok = write_report(report, files.dir); !ok) return std::unexpected(ok.error());
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

// Every plane of the processing freed, what malloc keeps of them goes back
// too: a daemon returns to its idle size.
Result<ProcessSummary> process_scan(const fs::path& scan_directory, const ProcessOptions& options) {
  Result<ProcessSummary> summary = std::unexpected(internal_error("processing did not run"));
  try {
    summary = process_unguarded(scan_directory, std::nullopt, options);
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    summary = std::unexpected(internal_error(std::string("processing failed: ") + e.what()));
  }
  give_back_free_memory();
  return summary;
}

Result<ProcessSummary> process_scan(formats::Scan scan, const fs::path& scan_directory,
                                    const ProcessOptions& options) {
  Result<ProcessSummary> summary = std::unexpected(internal_error("processing did not run"));
  try {
    summary = process_unguarded(scan_directory, std::move(scan), options);
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    summary = std::unexpected(internal_error(std::string("processing failed: ") + e.what()));
  }
  give_back_free_memory();
  return summary;
}

}  // namespace psrig::processing
