#include "psrig/processing/pipeline.h"

#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <fstream>
#include <functional>
#include <optional>

#include "psrig/processing/atomic_directory.h"
#include "psrig/processing/evaluation.h"
#include "psrig/processing/image_io.h"
#include "psrig/processing/log.h"
#include "psrig/processing/map_encoding.h"
#include "psrig/processing/parallel.h"
#include "psrig/processing/report.h"
#include "psrig/processing/scan_reader.h"
#include "vector_clones.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Steeper than this (85 degrees) a gradient says more about noise than
// shape; integration gets it clamped so one pixel cannot tilt the surface.
constexpr float kMaxSlope = 11.43f;

PSRIG_VECTOR_CLONES
void clamp_row(const float* __restrict in, float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = std::clamp(in[i], -kMaxSlope, kMaxSlope);
}

cv::Mat clamped_gradient(const cv::Mat& gradient) {
  cv::Mat out(gradient.size(), CV_32F);
  parallel_chunks(gradient.rows, 32, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) clamp_row(gradient.ptr<float>(r), out.ptr<float>(r), gradient.cols);
  });
  return out;
}

// An existing output may only be replaced if it is a maps directory psrig
// wrote (or empty): --out must never swallow a scan or a home directory.
Status check_output(const fs::path& output) {
  std::error_code ec;
  const auto status = fs::symlink_status(output, ec);
  if (!fs::exists(status)) return {};
  if (!fs::is_directory(status))
    return std::unexpected(bad_input(output, "", "exists and is not a directory; choose another --out"));
  if (fs::is_empty(output, ec)) return {};
  std::ifstream report(output / map_files::kReport);
  nlohmann::json doc = nlohmann::json::parse(report, nullptr, false);
  if (report && doc.is_object() && doc.value("format", "") == kReportFormat) return {};
  return std::unexpected(bad_input(output, "",
                                   "exists and is not a psrig maps directory; refusing to replace it "
                                   "(choose another --out, or remove it)"));
}

const std::vector<int> kExrFloat = {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT,
                                    // Float gradients barely compress and ZIP costs ~1 s per
                                    // 12 MP map; the maps are derived data, kept uncompressed.
                                    cv::IMWRITE_EXR_COMPRESSION, cv::IMWRITE_EXR_COMPRESSION_NO};

}  // namespace

Result<ProcessSummary> process_scan(const fs::path& scan_directory, const ProcessOptions& options) {
  auto log = logger("processing");
  const auto start = Clock::now();
  std::vector<std::pair<std::string, double>> stages;

  auto scan = read_scan(scan_directory);
  if (!scan) return std::unexpected(scan.error());
  stages.emplace_back("read", ms_since(start));

  const fs::path output = options.output.empty() ? scan_directory / "maps" : options.output;
  if (auto ok = check_output(output); !ok) return std::unexpected(ok.error());
  auto staging = AtomicDirectory::create(output);
  if (!staging) return std::unexpected(staging.error());
  const fs::path dir = staging->path();

  auto stage_start = Clock::now();
  auto solved = solve(*scan, options.solve);
  if (!solved) return std::unexpected(solved.error());
  const SolveResult& result = *solved;
  stages.emplace_back("solve", ms_since(stage_start));

  stage_start = Clock::now();
  GroundTruthSummary truth;
  const cv::Mat valid = encode_valid_mask(result.flags);
  if (!scan->ground_truth_normal.empty()) {
    const cv::Mat error = angular_error_deg(result.p, result.q, scan->ground_truth_normal);
    truth.angular_error_deg = describe(error, valid);
    cv::Mat solved_pixels;
    cv::compare(result.flags & (kOutsideMask | kLowSignal | kNoSolution), 0, solved_pixels, cv::CMP_EQ);
    truth.mean_angular_error_all_deg = describe(error, solved_pixels).mean;
  }
  stages.emplace_back("evaluate", ms_since(stage_start));

  // Integration runs beside the encoding and writing of the other maps:
  // one task list on the one pool, the longest chain first.
  const double pixel_size = scan->description.pixel_size_mm.value_or(1.0);
  std::optional<HeightSummary> height_summary;
  double integrate_ms = 0;
  std::vector<std::function<Status()>> tasks;
  if (options.integration != IntegrationMethod::none) {
    tasks.emplace_back([&]() -> Status {
      const auto integrate_start = Clock::now();
      auto height = integrate(options.integration, clamped_gradient(result.p), clamped_gradient(result.q));
      if (!height) return std::unexpected(height.error());
      if (scan->description.pixel_size_mm) *height *= pixel_size;
      double low = 0, high = 0;
      cv::minMaxLoc(*height, &low, &high);
      height_summary = HeightSummary{low, high, scan->description.pixel_size_mm ? "mm" : "px"};
      if (!scan->ground_truth_height.empty()) truth.height_rms_error = height_rms_error(*height, scan->ground_truth_height);
      integrate_ms = ms_since(integrate_start);
      if (auto ok = write_image(dir / map_files::kHeightExr, *height, kExrFloat); !ok) return ok;
      return write_image(dir / map_files::kHeightPng, encode_height16(*height, low, high));
    });
  }
  tasks.emplace_back([&] { return write_image(dir / map_files::kNormalPng, encode_normal16(result.p, result.q)); });
  tasks.emplace_back([&] { return write_image(dir / map_files::kAlbedoPng, encode_albedo_srgb8(result.albedo)); });
  tasks.emplace_back([&] { return write_image(dir / map_files::kAlbedoExr, result.albedo, kExrFloat); });
  tasks.emplace_back([&] { return write_image(dir / map_files::kP, result.p, kExrFloat); });
  tasks.emplace_back([&] { return write_image(dir / map_files::kQ, result.q, kExrFloat); });
  tasks.emplace_back([&] { return write_image(dir / map_files::kMask, valid); });

  stage_start = Clock::now();
  std::vector<std::optional<Error>> errors(tasks.size());
  parallel_chunks(static_cast<int>(tasks.size()), 1, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      try {
        if (auto ok = tasks[i](); !ok) errors[i] = ok.error();
      } catch (const cv::Exception& e) {
        errors[i] = internal_error(std::string("OpenCV: ") + e.what());
      }
    }
  });
  for (const auto& error : errors)
    if (error) return std::unexpected(*error);
  if (options.integration != IntegrationMethod::none) stages.emplace_back("integrate", integrate_ms);
  stages.emplace_back("integrate_and_write", ms_since(stage_start));
  stages.emplace_back("total", ms_since(start));

  ReportInputs inputs;
  inputs.scan = &*scan;
  inputs.options = &options;
  inputs.solve = &result;
  inputs.valid = valid;
  inputs.height = height_summary;
  inputs.ground_truth = truth;
  inputs.stage_ms = stages;
  nlohmann::json report = make_report(inputs);
  const fs::path report_path = dir / map_files::kReport;
  std::ofstream out(report_path);
  out << report.dump(2) << '\n';
  out.close();
  if (!out) return std::unexpected(io_error(report_path, "cannot write"));

  if (auto ok = staging->commit(AtomicDirectory::Existing::replace, false); !ok) return std::unexpected(ok.error());
  log->debug("maps of {} written to {}", scan_directory.string(), output.string());
  return ProcessSummary{output, report};
}

}  // namespace psrig::processing
