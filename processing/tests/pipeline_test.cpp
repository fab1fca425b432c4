// The whole chain, files to files: scan directory in, maps directory out.

#include "psrig/processing/pipeline.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/processing/evaluation.h"
#include "psrig/sim/swatch_model.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "synthetic_scene.h"
#include "test_support.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kMapFiles = {"albedo.exr", "albedo.png", "height.exr",
                                            "height.png", "mask.png",   "normal.png",
                                            "p.exr",      "q.exr",      "report.json"};

// A plane of one orientation, as a scan on disk.
fs::path write_plane_scan(const fs::path& dir, const cv::Vec3f& normal) {
  test::Surface plane{cv::Mat(48, 64, CV_32FC3, cv::Scalar(normal[0], normal[1], normal[2])),
                      cv::Mat(48, 64, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5))};
  const formats::Scan scan = test::render_scan(plane, test::ring_lights(3, 45), CV_16U);
  EXPECT_TRUE(formats::write_scan(scan, dir));
  return dir;
}

TEST(Pipeline, WritesEveryMapAndTheReport) {
  test::TempDir temp;
  auto scan =
      test::render_scan(test::sphere_surface({96, 80}, 30, 3), test::ring_lights(3, 45), CV_16U);
  scan.description.pixel_size_mm = 0.05;
  ASSERT_TRUE(formats::write_scan(scan, temp / "scan"));
  auto summary = process_scan(temp / "scan");
  ASSERT_TRUE(summary) << summary.error().describe();
  EXPECT_EQ(summary->maps_directory, temp / "scan" / "maps");
  EXPECT_EQ(test::list_directory(temp / "scan" / "maps"), kMapFiles);

  const auto& r = summary->report;
  EXPECT_EQ(r["format"], kReportFormat);
  EXPECT_EQ(r["inputs"]["lights"], 3);
  EXPECT_EQ(r["height"]["units"], "mm");
  EXPECT_NEAR(r["light_matrix"]["condition_number"].get<double>(), std::sqrt(2.0),
              1e-6);  // sqrt(2) cot 45
  for (const char* stage :
       {"read", "solve", "evaluate", "integrate", "integrate_and_write", "total"})
    EXPECT_TRUE(r["timings_ms"].contains(stage)) << stage;
  EXPECT_EQ(r["pixels"]["total"], 96 * 80);
  EXPECT_LT(r["ground_truth"]["angular_error_deg"]["mean"].get<double>(), 0.05);
  EXPECT_GT(r["ground_truth"]["angular_error_deg"]["pixels"].get<int>(), 0.8 * 96 * 80);

  // The files hold what the report says: 16-bit normals, float maps.
  const fs::path maps = temp / "scan" / "maps";
  EXPECT_EQ(cv::imread((maps / "normal.png").string(), cv::IMREAD_UNCHANGED).type(), CV_16UC3);
  EXPECT_EQ(cv::imread((maps / "height.png").string(), cv::IMREAD_UNCHANGED).type(), CV_16UC1);
  EXPECT_EQ(cv::imread((maps / "albedo.png").string(), cv::IMREAD_UNCHANGED).type(), CV_8UC3);
  EXPECT_EQ(cv::imread((maps / "albedo.exr").string(), cv::IMREAD_UNCHANGED).type(), CV_32FC3);
  EXPECT_EQ(cv::imread((maps / "p.exr").string(), cv::IMREAD_UNCHANGED).type(), CV_32FC1);
  std::ifstream report_file(maps / "report.json");
  EXPECT_EQ(nlohmann::json::parse(report_file), r);
}

// Files to files with more lights than the old limit of 64, glossy, with
// --reject: the report names the method and counts the highlights dropped,
// and the normals are closer to the truth than without rejection.
TEST(Pipeline, SeventyGlossyLightsWithRejection) {
  test::TempDir temp;
  const auto surface = test::sphere_surface({64, 48}, 20, 3);
  const formats::Scan scan = test::render_scan(surface, test::dome_lights(70, 55), CV_16U, 0.002, 3,
                                               {}, {.strength = 0.5, .exponent = 40});
  ASSERT_TRUE(formats::write_scan(scan, temp / "scan"));
  ProcessOptions options;
  options.output = temp / "plain";
  auto plain = process_scan(temp / "scan", options);
  options.output = temp / "rejecting";
  options.solve.reject_outliers = true;
  auto rejecting = process_scan(temp / "scan", options);
  ASSERT_TRUE(plain && rejecting) << (plain ? rejecting : plain).error().describe();
  EXPECT_EQ(plain->report["inputs"]["lights"], 70);
  EXPECT_EQ(plain->report["options"]["reject_method"], "none");
  EXPECT_EQ(rejecting->report["options"]["reject_method"], "lts-reweighted");
  EXPECT_EQ(plain->report["pixels"]["highlights_rejected"], 0);
  EXPECT_GT(rejecting->report["pixels"]["highlights_rejected"].get<int>(), 1000);
  const auto error = [](const ProcessSummary& s) {
    return s.report["ground_truth"]["mean_angular_error_all_solved_deg"].get<double>();
  };
  EXPECT_LT(error(*rejecting), 0.5 * error(*plain));
}

TEST(Pipeline, NormalMapConventionsOnRealFiles) {
  test::TempDir temp;
  const float s = 0.5f, c = 0.8660254f;  // 30 degrees
  auto toward_x = process_scan(write_plane_scan(temp / "x", {s, 0, c}));
  auto toward_top = process_scan(write_plane_scan(temp / "top", {0, s, c}));
  ASSERT_TRUE(toward_x && toward_top);
  const cv::Mat x = cv::imread((temp / "x" / "maps" / "normal.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat top =
      cv::imread((temp / "top" / "maps" / "normal.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Vec3w x_bgr = x.at<cv::Vec3w>(24, 32), top_bgr = top.at<cv::Vec3w>(24, 32);
  EXPECT_GT(x_bgr[2], 32768 + 10000);  // red above mid-grey
  EXPECT_NEAR(x_bgr[1], 32768, 30);
  EXPECT_GT(top_bgr[1], 32768 + 10000);  // green above mid-grey
  EXPECT_NEAR(top_bgr[2], 32768, 30);
  // And p.exr holds dz/dx = -nx/nz = -tan 30.
  const cv::Mat p = cv::imread((temp / "x" / "maps" / "p.exr").string(), cv::IMREAD_UNCHANGED);
  EXPECT_NEAR(p.at<float>(24, 32), -0.57735f, 1e-3);
}

class SyntheticSwatch : public ::testing::TestWithParam<const char*> {};

TEST_P(SyntheticSwatch, NoiseFreeNormalsAreExact) {
  test::TempDir temp;
  sim::SyntheticScanParams params;
  params.swatch.pattern = test::named_pattern(GetParam());
  params.swatch.size = {240, 180};
  ASSERT_TRUE(formats::write_scan(test::made(sim::make_synthetic_scan(params)), temp / "scan"));
  auto summary = process_scan(temp / "scan");
  ASSERT_TRUE(summary) << summary.error().describe();
  const auto& truth = summary->report["ground_truth"];
  EXPECT_LT(truth["angular_error_deg"]["mean"].get<double>(), 0.05);
  EXPECT_GT(summary->report["pixels"]["valid"].get<double>(), 0.5 * 240 * 180);
  EXPECT_TRUE(truth.contains("height_rms_error"));
}

// The noise bound of woodham_test.cpp on a real-looking surface: per pixel
// E[theta^2] = sigma^2 / (3 rho^2) tr(P (L^T L)^-1 P) for noise sigma per
// channel, and the measured mean lies between sqrt(2/pi) and 1 times the
// mean predicted RMS.
TEST_P(SyntheticSwatch, NoisyNormalsMatchTheDerivedBound) {
  const double sigma = 0.004;
  sim::SyntheticScanParams params;
  params.swatch.pattern = test::named_pattern(GetParam());
  params.swatch.size = {240, 180};
  params.noise = sigma;
  const formats::Scan scan = test::made(sim::make_synthetic_scan(params));
  const auto swatch = test::made(sim::make_swatch(params.swatch));
  auto result = solve(scan);
  ASSERT_TRUE(result);
  const cv::Mat valid = encode_valid_mask(result->flags);

  std::vector<cv::Vec3d> lights;
  for (const auto& light : scan.description.lights)
    lights.push_back(light.direction);
  double measured = 0, predicted = 0;
  int count = 0;
  for (int r = 0; r < valid.rows; ++r) {
    for (int c = 0; c < valid.cols; ++c) {
      if (!valid.at<std::uint8_t>(r, c)) continue;
      const cv::Vec3d n = swatch.normal.at<cv::Vec3f>(r, c);
      const cv::Vec3f a = swatch.albedo.at<cv::Vec3f>(r, c);
      predicted += test::predicted_rms_angle(lights, n, (a[0] + a[1] + a[2]) / 3, sigma, 3);
      const cv::Vec3d estimate(-result->p.at<float>(r, c), -result->q.at<float>(r, c), 1);
      measured += std::acos(std::clamp(estimate.dot(n) / cv::norm(estimate), -1.0, 1.0));
      ++count;
    }
  }
  ASSERT_GT(count, 0.5 * valid.total());
  EXPECT_LE(measured / count, 1.05 * predicted / count);
  EXPECT_GE(measured / count, 0.75 * predicted / count);
}

// Every shipped pattern (config/patterns).
INSTANTIATE_TEST_SUITE_P(Patterns, SyntheticSwatch,
                         ::testing::ValuesIn(test::shipped_pattern_names()),
                         [](const ::testing::TestParamInfo<const char*>& param_info) {
                           return test::test_name(param_info.param);
                         });

TEST(Pipeline, AMaskedScanIsIntegratedOverItsMaskAndTheReportSaysHow) {
  // A sphere cap inside a disk mask: `auto` picks the masked solver, the
  // heights outside the mask are NaN (0 in height.png), and the cap's true
  // depth comes back to a small fraction of its range.
  test::TempDir temp;
  const int w = 96;
  const int h = 80;
  const double radius = 60;  // the cap of a sphere, so the disk sees no silhouette
  auto scan =
      test::render_scan(test::sphere_surface({w, h}, radius, 1), test::ring_lights(3, 45), CV_16U);
  scan.mask = cv::Mat(h, w, CV_8U, cv::Scalar(0));
  cv::circle(scan.mask, cv::Point(w / 2, h / 2), 34, cv::Scalar(255), cv::FILLED);
  ASSERT_TRUE(formats::write_scan(scan, temp / "scan"));
  ProcessOptions options;
  options.flatten = Flatten::off;
  auto summary = process_scan(temp / "scan", options);
  ASSERT_TRUE(summary) << summary.error().describe();
  const auto& r = summary->report;
  EXPECT_EQ(r["options"]["integration"], "auto");
  EXPECT_EQ(r["height"]["method"], "masked");
  EXPECT_EQ(r["height"]["pixels"].get<int>(), cv::countNonZero(scan.mask));
  EXPECT_GT(r["height"]["solver"]["iterations"].get<int>(), 0);
  EXPECT_LT(r["height"]["solver"]["relative_residual"].get<double>(), 1e-4);
  EXPECT_EQ(r["bend"]["removed"], false);
  EXPECT_EQ(r["options"]["flatten"], "off");

  const fs::path maps = temp / "scan" / "maps";
  const cv::Mat height = cv::imread((maps / "height.exr").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat png = cv::imread((maps / "height.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(height.type(), CV_32FC1);
  EXPECT_TRUE(std::isnan(height.at<float>(0, 0)));
  EXPECT_EQ(png.at<std::uint16_t>(0, 0), 0);
  // The cap: z = sqrt(R^2 - x^2 - y^2) in pixels (no pixel size here).
  cv::Mat truth(h, w, CV_32F);
  const double cx = (w - 1) / 2.0;
  const double cy = (h - 1) / 2.0;
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col)
      truth.at<float>(row, col) = static_cast<float>(
          std::sqrt(radius * radius - (col - cx) * (col - cx) - (row - cy) * (row - cy)));
  const double error = height_rms_error(height, truth, scan.mask);
  double low = 0;
  double high = 0;
  cv::minMaxLoc(truth, &low, &high, nullptr, nullptr, scan.mask);
  std::printf("  [measured] masked sphere cap: height rms error %.3g px of a %.3g px range\n",
              error, high - low);
  EXPECT_LT(error, 0.01 * (high - low));
}

TEST(Pipeline, SwatchScansAreFlattenedAndTheBendIsReported) {
  test::TempDir temp;
  sim::SyntheticScanParams params;
  params.swatch.pattern = test::named_pattern("jersey");
  params.swatch.size = {240, 180};
  ASSERT_TRUE(formats::write_scan(test::made(sim::make_synthetic_scan(params)), temp / "scan"));
  auto summary = process_scan(temp / "scan");
  ASSERT_TRUE(summary) << summary.error().describe();
  const auto& r = summary->report;
  EXPECT_EQ(r["options"]["flatten"], "auto");
  EXPECT_EQ(r["bend"]["removed"], true);
  EXPECT_EQ(r["bend"]["cutoff"], kDefaultFlattenCutoffMm);
  EXPECT_EQ(r["bend"]["cutoff_units"], "mm");
  EXPECT_EQ(r["bend"]["units"], "mm");
  EXPECT_GE(r["bend"]["peak_to_valley"].get<double>(), 0.0);
  // Off: no bend removed, and the report says so.
  ProcessOptions off;
  off.flatten = Flatten::off;
  auto unflattened = process_scan(temp / "scan", off);
  ASSERT_TRUE(unflattened);
  EXPECT_EQ(unflattened->report["bend"]["removed"], false);
  // A cut-off that is not a length is refused before anything is read.
  ProcessOptions bad;
  bad.flatten_cutoff_mm = 0;
  auto refused = process_scan(temp / "scan", bad);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, ErrorKind::bad_input);
}

TEST(Pipeline, ReprocessingReplacesTheMaps) {
  test::TempDir temp;
  write_plane_scan(temp / "scan", {0, 0, 1});
  ProcessOptions options;
  options.integration = IntegrationMethod::none;
  ASSERT_TRUE(process_scan(temp / "scan", options));
  EXPECT_FALSE(fs::exists(temp / "scan" / "maps" / "height.exr"));
  options.integration = IntegrationMethod::poisson;
  auto again = process_scan(temp / "scan", options);
  ASSERT_TRUE(again) << again.error().describe();
  EXPECT_TRUE(fs::exists(temp / "scan" / "maps" / "height.exr"));
  EXPECT_EQ(test::list_directory(temp / "scan"),
            (std::vector<std::string>{"gt_normal.exr", "led0.png", "led1.png", "led2.png", "maps",
                                      "scan.json"}));
}

TEST(Pipeline, AMissingScanDirectoryIsTheErrorNotItsMaps) {
  test::TempDir temp;
  auto missing = process_scan(temp / "nowhere");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(missing.error().file, temp / "nowhere");
  EXPECT_EQ(missing.error().message, "no such scan directory");
  EXPECT_TRUE(test::list_directory(temp.path()).empty());
}

TEST(Pipeline, RefusesToReplaceWhatIsNotAMapsDirectory) {
  test::TempDir temp;
  write_plane_scan(temp / "scan", {0, 0, 1});
  fs::create_directory(temp / "precious");
  std::ofstream(temp / "precious" / "thesis.tex") << "chapter 1";
  ProcessOptions options;
  options.output = temp / "precious";
  auto refused = process_scan(temp / "scan", options);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(test::list_directory(temp / "precious"), std::vector<std::string>{"thesis.tex"});
  // Nor the scan itself.
  options.output = temp / "scan";
  EXPECT_FALSE(process_scan(temp / "scan", options));
  EXPECT_TRUE(fs::exists(temp / "scan" / "scan.json"));
}

// A small scan whose flat for light 1 is black: an error found only while
// solving.
void write_scan_with_black_flat(const fs::path& dir) {
  auto scan =
      test::render_scan(test::sphere_surface({32, 24}, 8, 1), test::ring_lights(3, 45), CV_16U);
  for (int k = 0; k < 3; ++k)
    scan.flats.push_back(cv::Mat(scan.size(), CV_16U, cv::Scalar(k == 1 ? 0 : 30000)));
  ASSERT_TRUE(formats::write_scan(scan, dir));
}

TEST(Pipeline, AFailureAfterStagingLeavesNothingBehind) {
  // A black flat is found only while solving, after the staging directory
  // exists: it must go, and no maps appear.
  test::TempDir temp;
  write_scan_with_black_flat(temp / "scan");
  ProcessOptions options;
  options.output = temp / "maps";
  auto failed = process_scan(temp / "scan", options);
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().key, "flats[1]");
  EXPECT_EQ(test::list_directory(temp.path()), std::vector<std::string>{"scan"});
}

TEST(Pipeline, FlatsAreFoundByTheirDesignNames) {
  // docs/design.md "Scan directory" lists flat0.png ... without a key in scan.json.
  test::TempDir temp;
  write_scan_with_black_flat(temp / "scan");
  std::ifstream in(temp / "scan" / "scan.json");
  auto doc = nlohmann::json::parse(in);
  doc.erase("flats");
  std::ofstream(temp / "scan" / "scan.json") << doc.dump();
  ProcessOptions options;
  options.output = temp / "maps";
  auto failed = process_scan(temp / "scan", options);  // the black flat1.png is found, and refused
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().key, "flats[1]");
}

TEST(Pipeline, OutputWithATrailingSlash) {
  test::TempDir temp;
  write_plane_scan(temp / "scan", {0, 0, 1});
  ProcessOptions options;
  options.output = (temp / "maps").string() + "/";
  auto summary = process_scan(temp / "scan", options);
  ASSERT_TRUE(summary) << summary.error().describe();
  EXPECT_TRUE(fs::exists(temp / "maps" / "report.json"));
}

TEST(Pipeline, BadInputWritesNothing) {
  test::TempDir temp;
  write_plane_scan(temp / "scan", {0, 0, 1});
  fs::remove(temp / "scan" / "led2.png");
  ProcessOptions options;
  options.output = temp / "maps";
  auto failed = process_scan(temp / "scan", options);
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(test::list_directory(temp.path()), std::vector<std::string>{"scan"});
  EXPECT_FALSE(fs::exists(temp / "scan" / "maps"));
}

// Every compression [storage] offers is lossless: the maps read back the
// same pixels, bit for bit, as the uncompressed ones, and compressing does
// make the smooth sphere's EXRs and PNGs smaller. report.json records it.
TEST(Pipeline, StorageCompressionIsLosslessAndRecorded) {
  test::TempDir temp;
  auto scan =
      test::render_scan(test::sphere_surface({96, 80}, 30, 3), test::ring_lights(3, 45), CV_16U);
  ASSERT_TRUE(formats::write_scan(scan, temp / "scan"));
  const auto process_with = [&](formats::ExrCompression exr, int png_level) {
    ProcessOptions options;
    options.storage = {exr, png_level};
    options.output = temp / (std::string(to_string(exr)) + std::to_string(png_level));
    auto summary = process_scan(temp / "scan", options);
    EXPECT_TRUE(summary) << summary.error().describe();
    if (summary) {
      EXPECT_EQ(summary->report["options"]["exr_compression"], to_string(exr));
      EXPECT_EQ(summary->report["options"]["png_level"], png_level);
    }
    return options.output;
  };
  const fs::path plain = process_with(formats::ExrCompression::none, 0);
  for (const auto& [exr, level] : {std::pair{formats::ExrCompression::zip, 1},
                                   {formats::ExrCompression::piz, 9},
                                   {formats::ExrCompression::automatic, 1}}) {
    const fs::path packed = process_with(exr, level);
    for (const char* name : {"albedo.exr", "p.exr", "q.exr", "height.exr", "normal.png",
                             "height.png", "albedo.png", "mask.png"}) {
      SCOPED_TRACE(packed / name);
      auto a = formats::read_image(plain / name, name);
      auto b = formats::read_image(packed / name, name);
      ASSERT_TRUE(a && b);
      ASSERT_EQ(a->type(), b->type());
      ASSERT_EQ(a->size(), b->size());
      cv::Mat differs;
      cv::compare(a->reshape(1), b->reshape(1), differs, cv::CMP_NE);
      // NaN heights (none here) would differ from themselves.
      EXPECT_EQ(cv::countNonZero(differs), 0);
    }
    EXPECT_LT(fs::file_size(packed / "albedo.exr"), fs::file_size(plain / "albedo.exr"));
    EXPECT_LT(fs::file_size(packed / "normal.png"), fs::file_size(plain / "normal.png"));
    // Half-float p.exr (the default precision) compresses under every choice.
    EXPECT_LT(fs::file_size(packed / "p.exr"), fs::file_size(plain / "p.exr"));
  }
  ProcessOptions bad;
  bad.storage.png_level = 10;
  bad.output = temp / "bad";
  auto refused = process_scan(temp / "scan", bad);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().describe().find("--png-level"), std::string::npos);
  EXPECT_FALSE(fs::exists(temp / "bad"));
}

// Half-precision p, q and height (the default [storage] map_precision)
// round each value to 1 part in 2048 at worst: the normals they give
// differ from the 32-bit maps' by at most 1/2048 rad (0.028 degrees; the
// gradient turned across itself), far below the solve's noise, and the
// maps take fewer bytes. report.json says which.
TEST(Pipeline, HalfPrecisionMapsStayWithinTheirRoundingAndTakeLessSpace) {
  test::TempDir temp;
  sim::SyntheticScanParams params;
  params.swatch.pattern = test::named_pattern("jersey");
  params.swatch.size = {160, 120};
  params.noise = 0.002;
  ASSERT_TRUE(formats::write_scan(test::made(sim::make_synthetic_scan(params)), temp / "scan"));
  const auto process_with = [&](formats::MapPrecision precision) {
    ProcessOptions options;
    options.storage.map_precision = precision;
    options.output = temp / to_string(precision);
    auto summary = process_scan(temp / "scan", options);
    EXPECT_TRUE(summary) << summary.error().describe();
    if (summary) {
      EXPECT_EQ(summary->report["options"]["map_precision"], to_string(precision));
    }
    return options.output;
  };
  const fs::path full = process_with(formats::MapPrecision::full);
  const fs::path half = process_with(formats::MapPrecision::half);
  std::uintmax_t full_bytes = 0, half_bytes = 0;
  for (const char* name : {"p.exr", "q.exr", "height.exr"}) {
    SCOPED_TRACE(name);
    auto a = formats::read_image(full / name, name);
    auto b = formats::read_image(half / name, name);
    ASSERT_TRUE(a && b);
    ASSERT_EQ(b->type(), CV_32FC1);  // read back as floats, as every reader wants
    for (int r = 0; r < a->rows; ++r)
      for (int c = 0; c < a->cols; ++c) {
        const float x = a->at<float>(r, c), y = b->at<float>(r, c);
        if (std::isnan(x)) {
          EXPECT_TRUE(std::isnan(y));
          continue;
        }
        // Half's 11 significant bits; below 2^-14 its fixed subnormal step.
        ASSERT_LE(std::abs(x - y), std::max(std::abs(x) / 2048.0f, 6.0e-8f)) << r << "," << c;
      }
    full_bytes += fs::file_size(full / name);
    half_bytes += fs::file_size(half / name);
  }
  EXPECT_LT(half_bytes, full_bytes * 6 / 10);
  // The surface angle between the two maps' normals.
  auto p32 = formats::read_image(full / "p.exr", "p"),
       q32 = formats::read_image(full / "q.exr", "q");
  auto p16 = formats::read_image(half / "p.exr", "p"),
       q16 = formats::read_image(half / "q.exr", "q");
  ASSERT_TRUE(p32 && q32 && p16 && q16);
  double worst_deg = 0;
  for (int r = 0; r < p32->rows; ++r)
    for (int c = 0; c < p32->cols; ++c) {
      const cv::Vec3d a(-p32->at<float>(r, c), -q32->at<float>(r, c), 1);
      const cv::Vec3d b(-p16->at<float>(r, c), -q16->at<float>(r, c), 1);
      const double cosine = a.dot(b) / (cv::norm(a) * cv::norm(b));
      worst_deg = std::max(worst_deg, std::acos(std::min(1.0, cosine)) * 180 / CV_PI);
    }
  EXPECT_LE(worst_deg, 180 / CV_PI / 2048);
  // The 16-bit normal.png is the same from either.
  auto n32 = formats::read_image(full / "normal.png", "n"),
       n16 = formats::read_image(half / "normal.png", "n");
  ASSERT_TRUE(n32 && n16);
  EXPECT_EQ(cv::norm(*n32, *n16, cv::NORM_INF), 0);
}

}  // namespace
}  // namespace psrig::processing
