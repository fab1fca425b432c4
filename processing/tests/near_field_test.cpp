// Near-field LEDs end to end: the simulated rig with point-source LEDs at a
// realistic distance over a flat matte card. The directional model's error
// grows toward the field's edges; with the LEDs' positions (rig.toml ->
// scan.json -> a per-pixel light matrix) the whole field is within 0.3°.

#include <cmath>
#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>

#include "psrig/base/parallel.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/processing/evaluation.h"
#include "psrig/processing/pipeline.h"
#include "psrig/processing/woodham.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"
#include "test_support.h"

namespace psrig {
namespace {

// LEDs 250 mm from the swatch centre at 45° slant over a 16 x 12 mm field
// (640 x 480 px of 0.025 mm), a flat grey card; little sensor noise, so the
// light model's error is what is measured.
config::RigConfig near_rig() {
  config::RigConfig c;
  c.lights.backend = "sim";
  c.camera.backend = "sim";
  c.camera.frames_average = 2;
  c.camera.frames_discard = 0;
  c.capture.settle_ms = 5;
  c.geometry.slant_deg = 45;
  c.geometry.tilts_deg = {0, 120, 240};
  c.geometry.led_distance_mm = 250;
  c.sim.target = "white_card";
  c.sim.card_albedo = 0.6;
  c.sim.width = 640;
  c.sim.height = 480;
  c.sim.pixel_size_mm = 0.025;
  c.geometry.pixel_size_mm = 0.025;
  c.sim.full_well = 1e6;
  return c;
}

// Mean angular error (degrees) of a solve over the rows and columns in `r`.
double mean_error(const cv::Mat& error, const cv::Rect& r) {
  return processing::describe(error(r)).mean;
}

TEST(NearField, SimulatedRigIsCorrectedOverTheWholeField) {
  test::TempDir dir;
  const auto config = near_rig();
  auto rig = rig::open_rig(config);
  ASSERT_TRUE(rig) << rig.error().describe();
  rig::ScanSequencer sequencer(config, *rig->lights, *rig->camera);
  auto request = rig->request(config);
  request.directory = dir / "scan";
  auto outcome = sequencer.capture(request, {});
  ASSERT_TRUE(outcome) << outcome.error().describe();
  ASSERT_TRUE(outcome->maps);

  // scan.json carries the positions and where the axis meets the image.
  auto scan = formats::read_scan(request.directory);
  ASSERT_TRUE(scan) << scan.error().describe();
  ASSERT_TRUE(scan->description.near_field());
  EXPECT_NEAR((*scan->description.lights[0].position_mm)[0], 250 * std::sqrt(0.5), 1e-9);
  ASSERT_TRUE(scan->description.principal_point_px);
  EXPECT_DOUBLE_EQ(scan->description.principal_point_px->x, 319.5);

  // The pipeline used the near-field model: the whole field within 0.3°.
  const auto& report = outcome->maps->report;
  EXPECT_TRUE(report["light_model"]["near_field"].get<bool>()) << report["light_model"].dump();
  const double corrected = report["ground_truth"]["angular_error_deg"]["mean"].get<double>();
  const double corrected_all =
      report["ground_truth"]["mean_angular_error_all_solved_deg"].get<double>();
  EXPECT_LE(corrected, 0.3);
  EXPECT_LE(corrected_all, 0.3);

  // Per region, corrected and with the directional model (positions dropped).
  auto near_solve = processing::solve(*scan);
  ASSERT_TRUE(near_solve);
  const cv::Mat near_error =
      processing::angular_error_deg(near_solve->p, near_solve->q, scan->ground_truth_normal);
  formats::Scan directional = *scan;
  for (auto& light : directional.description.lights)
    light.position_mm.reset();
  auto far_solve = processing::solve(directional);
  ASSERT_TRUE(far_solve);
  const cv::Mat far_error =
      processing::angular_error_deg(far_solve->p, far_solve->q, scan->ground_truth_normal);

  const cv::Rect centre(320 - 32, 240 - 32, 64, 64);
  const cv::Rect ring_inner(160, 120, 320, 240);  // the middle half of each side
  const cv::Rect left(0, 0, 32, 480), right(608, 0, 32, 480), top(0, 0, 640, 32),
      bottom(0, 448, 640, 32);
  const double far_centre = mean_error(far_error, centre);
  const double far_middle = mean_error(far_error, ring_inner);
  const double far_edges = (mean_error(far_error, left) + mean_error(far_error, right) +
                            mean_error(far_error, top) + mean_error(far_error, bottom)) /
                           4;
  const double far_all = processing::describe(far_error).mean;
  const double near_all = processing::describe(near_error).mean;
  const double near_edges = (mean_error(near_error, left) + mean_error(near_error, right) +
                             mean_error(near_error, top) + mean_error(near_error, bottom)) /
                            4;
  std::printf(
      "near-field figures (deg): directional centre %.3f, middle half %.3f, edges %.3f, "
      "whole field %.3f, max %.3f; near-field whole field %.3f, edges %.3f, max %.3f\n",
      far_centre, far_middle, far_edges, far_all, processing::describe(far_error).max, near_all,
      near_edges, processing::describe(near_error).max);
  // Bit for bit the same whatever the thread count.
  for (const int threads : {1, 3}) {
    psrig::set_thread_count(threads);
    auto again = processing::solve(*scan);
    psrig::set_thread_count(0);
    ASSERT_TRUE(again);
    EXPECT_EQ(cv::norm(again->p, near_solve->p, cv::NORM_INF), 0) << threads;
    EXPECT_EQ(cv::norm(again->q, near_solve->q, cv::NORM_INF), 0) << threads;
    EXPECT_EQ(cv::norm(again->albedo, near_solve->albedo, cv::NORM_INF), 0) << threads;
  }
  // The uncorrected error grows toward the edges.
  EXPECT_GT(far_edges, 2 * far_centre);
  EXPECT_GT(far_edges, far_middle);
  EXPECT_GT(far_all, 2 * near_all);
  // Corrected: flat over the field.
  EXPECT_LE(near_all, 0.3);
  EXPECT_LE(near_edges, 0.3);
}

TEST(NearField, ScanReaderChecksPositions) {
  test::TempDir dir;
  // A small scan written by hand: three flat frames.
  const auto write = [&](const std::string& lights_json, const std::string& extra) {
    const auto path = dir / "s";
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
    for (int k = 0; k < 3; ++k)
      ASSERT_TRUE(formats::write_image(path / ("led" + std::to_string(k) + ".png"),
                                       cv::Mat(8, 8, CV_16U, cv::Scalar(30000))));
    std::ofstream(path / "scan.json")
        << R"({"format": "psrig-scan/1", "lights": )" << lights_json << extra << "}";
  };
  const std::string good =
      R"([{"image": "led0.png", "direction": [0.7071, 0, 0.7071], "position_mm": [176.8, 0, 176.8]},
          {"image": "led1.png", "direction": [-0.3536, 0.6124, 0.7071], "position_mm": [-88.4, 153.1, 176.8]},
          {"image": "led2.png", "direction": [-0.3536, -0.6124, 0.7071], "position_mm": [-88.4, -153.1, 176.8]}])";
  write(good, R"(, "pixel_size_mm": 0.025, "principal_point_px": [3.5, 3.5])");
  auto ok = formats::read_scan(dir / "s");
  ASSERT_TRUE(ok) << ok.error().describe();
  EXPECT_TRUE(ok->description.near_field());
  EXPECT_EQ(ok->description.principal_point_px, cv::Point2d(3.5, 3.5));

  const auto expect_key = [&](const std::string& key) {
    auto bad = formats::read_scan(dir / "s");
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().key, key) << bad.error().describe();
  };
  write(good, "");  // no pixel size
  expect_key("lights[0].position_mm");
  write(good, R"(, "pixel_size_mm": 0.025, "principal_point_px": [3.5])");
  expect_key("principal_point_px");
  std::string some = good;
  some.replace(some.find(R"(, "position_mm": [-88.4, 153.1, 176.8])"),
               std::string(R"(, "position_mm": [-88.4, 153.1, 176.8])").size(), "");
  write(some, R"(, "pixel_size_mm": 0.025)");
  expect_key("lights[1].position_mm");
  std::string below = good;
  below.replace(below.find("[176.8, 0, 176.8]"), 17, "[176.8, 0, -1]");
  write(below, R"(, "pixel_size_mm": 0.025)");
  expect_key("lights[0].position_mm");
  std::string wrong = good;
  wrong.replace(wrong.find("[176.8, 0, 176.8]"), 17, "[176.8, 0]");
  write(wrong, R"(, "pixel_size_mm": 0.025)");
  expect_key("lights[0].position_mm");
}

}  // namespace
}  // namespace psrig
