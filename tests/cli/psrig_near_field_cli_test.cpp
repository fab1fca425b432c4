// Near LEDs measured and used, end to end through the command line as a
// technician runs it: a simulated rig whose LEDs are point sources 250 mm
// away that its rig.toml does not know about (it gives only their slant and
// tilts). Scanned as it is, a flat grey card's normals lean more toward the
// field's edges; `psrig calibrate lights --places 3` finds the LEDs from the
// chrome sphere at three places, and the next scan of the card, processed
// with those positions, is within 0.3° over the whole field.

#include <cmath>
#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "psrig/formats/light_matrix.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/processing/evaluation.h"
#include "psrig/processing/woodham.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// 32 x 24 mm of field at 0.025 mm (room for a 6 mm sphere to move), little
// sensor noise so the light model's error is what is measured.
fs::path near_rig(const TempDir& temp, const std::string& extra_sim = "") {
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << "[geometry]\nslant_deg = 45\ntilts_deg = [0, 120, 240]\n"
                         "[lights]\nbackend = \"sim\"\nchannels = 3\n"
                         "[camera]\nbackend = \"sim\"\nframes_average = 1\nframes_discard = 0\n"
                         "[capture]\nsettle_ms = 1\n"
                         "[storage]\nroot = \"state\"\n"
                         "[sim]\ntarget = \"white_card\"\ncard_albedo = 0.6\nwidth = 1280\n"
                         "height = 960\npixel_size_mm = 0.025\nsphere_diameter_mm = 6\n"
                         "led_distance_mm = 250\nfull_well = 1000000\nreadout_us = 0\n"
                      << extra_sim;
  return file;
}

struct FieldError {
  double centre = 0;
  double edges = 0;
  double all = 0;
};

// The solve's angular error against the card's truth: the central 10 %
// square, the outer 5 % band, the whole field.
FieldError field_error(const fs::path& scan_directory) {
  auto scan = formats::read_scan(scan_directory);
  EXPECT_TRUE(scan) << scan.error().describe();
  auto solved = processing::solve(*scan);
  EXPECT_TRUE(solved);
  const cv::Mat error =
      processing::angular_error_deg(solved->p, solved->q, scan->ground_truth_normal);
  const int w = error.cols, h = error.rows, bw = w / 20, bh = h / 20;
  cv::Mat edge = cv::Mat::ones(error.size(), CV_8U) * 255;
  edge(cv::Rect(bw, bh, w - 2 * bw, h - 2 * bh)) = 0;
  FieldError f;
  f.centre =
      processing::describe(error(cv::Rect(w / 2 - w / 20, h / 2 - h / 20, w / 10, h / 10))).mean;
  f.edges = processing::describe(error, edge).mean;
  f.all = processing::describe(error).mean;
  return f;
}

TEST(PsrigNearField, CalibratedLedPositionsCorrectTheWholeField) {
  TempDir temp;
  const auto config = near_rig(temp);

  // Uncorrected: the rig's directions alone.
  auto before = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", (temp / "before").string(), "-q"});
  ASSERT_EQ(before.exit_code, 0) << before.err;
  const FieldError uncorrected = field_error(temp / "before");
  const json before_report = read_json(temp / "before" / "maps" / "report.json");
  EXPECT_FALSE(before_report["light_model"]["near_field"].get<bool>());

  auto calibrate = run_program("psrig", {"calibrate", "lights", "--config", config.string(),
                                         "--places", "3", "--frames", "1"});
  ASSERT_EQ(calibrate.exit_code, 0) << calibrate.err;
  std::printf("%s", calibrate.out.c_str());
  EXPECT_NE(calibrate.out.find("LED 2: ("), std::string::npos) << calibrate.out;
  const json c = read_json(temp / "state" / "calibrations" / "0001" / "calibration.json");
  EXPECT_EQ(c["contains"], json::array({"lights", "led_positions_mm"}));
  const auto& section = c["led_positions_mm"];
  ASSERT_EQ(section["positions"].size(), 3u);
  ASSERT_EQ(section["places"].size(), 3u);
  EXPECT_EQ(section["sphere_diameter_mm"].get<double>(), 6.0);
  for (int k = 0; k < 3; ++k) {
    const cv::Vec3d truth = 250.0 * formats::light_direction(120.0 * k, 45);
    const auto& p = section["per_light"][k];
    const cv::Vec3d found(p["position_mm"][0].get<double>(), p["position_mm"][1].get<double>(),
                          p["position_mm"][2].get<double>());
    const double off = cv::norm(found - truth);
    const double uncertainty = p["uncertainty_mm"].get<double>();
    std::printf("LED %d: %.2f mm off the simulator's, uncertainty %.2f mm\n", k, off, uncertainty);
    EXPECT_LT(off, 10.0) << k;
    EXPECT_GT(uncertainty, 0.0) << k;
    EXPECT_LT(off, 4 * uncertainty + 1.0) << k;  // the stated uncertainty is honest
    // Every place's captures are kept beside it.
    for (const auto& place : section["places"])
      for (const auto& image : place["sources"]["images"])
        EXPECT_TRUE(fs::exists(temp / "state" / "calibrations" / "0001" / image.get<std::string>()))
            << image;
  }

  // The same from images already taken: --images once per place (the
  // captures' LED frames copied out, as a technician's own would be).
  std::vector<std::string> from_images = {"calibrate",     "lights",      "--config",
                                          config.string(), "--sphere-mm", "6"};
  for (int place = 1; place <= 3; ++place) {
    const fs::path folder = temp / ("place" + std::to_string(place));
    fs::create_directories(folder);
    for (int k = 0; k < 3; ++k)
      fs::copy_file(temp / "state" / "calibrations" / "0001" / "captures" /
                        ("chrome-p" + std::to_string(place) + "-0") /
                        ("led" + std::to_string(k) + ".png"),
                    folder / ("led" + std::to_string(k) + ".png"));
    from_images.insert(from_images.end(), {"--images", folder.string()});
  }
  auto imported = run_program("psrig", from_images);
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  const json again = read_json(temp / "state" / "calibrations" / "0002" / "calibration.json");
  ASSERT_EQ(again["led_positions_mm"]["places"].size(), 3u);
  EXPECT_EQ(again["led_positions_mm"]["sphere_diameter_from"], "--sphere-mm");
  for (int k = 0; k < 3; ++k) {
    const auto& p = again["led_positions_mm"]["positions"][k];
    const cv::Vec3d found(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
    EXPECT_LT(cv::norm(found - 250.0 * formats::light_direction(120.0 * k, 45)), 10.0) << k;
  }

  // Corrected: the next scan carries the positions and is processed with them.
  auto after = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", (temp / "after").string(), "-q"});
  ASSERT_EQ(after.exit_code, 0) << after.err;
  const json description = read_json(temp / "after" / "scan.json");
  EXPECT_EQ(description["calibration"]["applied"], json::array({"lights", "led_positions_mm"}));
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(description["lights"][k]["position_mm"], again["led_positions_mm"]["positions"][k])
        << k;
  const json report = read_json(temp / "after" / "maps" / "report.json");
  EXPECT_TRUE(report["light_model"]["near_field"].get<bool>());
  const double mean = report["ground_truth"]["angular_error_deg"]["mean"].get<double>();
  const FieldError corrected = field_error(temp / "after");
  std::printf(
      "near LEDs at 250 mm, flat card, mean angular error (deg): uncorrected centre %.3f, "
      "edges %.3f, whole field %.3f; calibrated positions centre %.3f, edges %.3f, whole field "
      "%.3f (report.json %.3f)\n",
      uncorrected.centre, uncorrected.edges, uncorrected.all, corrected.centre, corrected.edges,
      corrected.all, mean);
  EXPECT_GT(uncorrected.edges, 2 * uncorrected.centre);
  EXPECT_GT(uncorrected.all, 0.5);
  EXPECT_LE(mean, 0.3);
  EXPECT_LE(corrected.all, 0.3);
  EXPECT_LE(corrected.edges, 0.4);
}

// The swatch's height above the reference plane lowers the LEDs relative
// to it in every scan.json.
TEST(PsrigNearField, SwatchHeightLowersThePositionsInTheScan) {
  TempDir temp;
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << "[geometry]\nled_distance_mm = 250\nswatch_height_mm = 4\n"
                         "[camera]\nbackend = \"sim\"\nprincipal_point_px = [300, 250]\n"
                         "[capture]\nprocess = false\n[storage]\nroot = \"state\"\n"
                         "[sim]\ntarget = \"white_card\"\nwidth = 64\nheight = 48\n";
  auto run = run_program(
      "psrig", {"scan", "--config", file.string(), "--out", (temp / "scan").string(), "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json d = read_json(temp / "scan" / "scan.json");
  EXPECT_NEAR(d["lights"][0]["position_mm"][2].get<double>(), 250 * std::sqrt(0.5) - 4, 1e-9);
  EXPECT_EQ(d["principal_point_px"], json::array({300.0, 250.0}));
}

// [processing] reject: psrig scan processes every scan with robust
// rejection, and report.json says so.
TEST(PsrigRigProcessing, RejectFromRigTomlReachesTheReport) {
  TempDir temp;
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << "[lights]\nchannels = 6\n[camera]\nbackend = \"sim\"\n"
                         "[storage]\nroot = \"state\"\n[sim]\nwidth = 160\nheight = 120\n";
  auto plain = run_program(
      "psrig", {"scan", "--config", file.string(), "--out", (temp / "plain").string(), "-q"});
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  const json without = read_json(temp / "plain" / "maps" / "report.json");
  EXPECT_FALSE(without["options"]["reject_outliers"].get<bool>());
  EXPECT_EQ(without["options"]["reject_method"], "none");
  std::ofstream(file, std::ios::app) << "[processing]\nreject = true\n";
  auto robust = run_program(
      "psrig", {"scan", "--config", file.string(), "--out", (temp / "robust").string(), "-q"});
  ASSERT_EQ(robust.exit_code, 0) << robust.err;
  const json with = read_json(temp / "robust" / "maps" / "report.json");
  EXPECT_TRUE(with["options"]["reject_outliers"].get<bool>());
  EXPECT_EQ(with["options"]["reject_method"], "lts-reweighted");
}

TEST(PsrigNearField, PlacesNeedAChromeSphereThatMoves) {
  TempDir temp;
  // The default 10 mm sphere cannot move about a 16 x 12 mm field.
  const fs::path small = temp / "small.toml";
  std::ofstream(small) << "[storage]\nroot = \"state\"\n[sim]\nwidth = 640\nheight = 480\n";
  auto run =
      run_program("psrig", {"calibrate", "lights", "--config", small.string(), "--places", "3"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("sim.sphere_diameter_mm"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("sphere_places_mm"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(temp / "state" / "calibrations" / "0001"));

  // Places listed that are the same spot: the sphere did not move.
  const fs::path same = near_rig(temp, "sphere_places_mm = [[0, 0], [0.01, 0], [8, 0]]\n");
  run = run_program("psrig", {"calibrate", "lights", "--config", same.string(), "--places", "3",
                              "--frames", "1"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("move it"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(temp / "state" / "calibrations" / "0001"));

  // A real rig: the pixel size and the sphere's diameter are asked for
  // before the technician is asked to place the sphere (nothing captured).
  const fs::path real = temp / "real.toml";
  std::ofstream(real) << "[camera]\nbackend = \"v4l2\"\ndevice = \"/dev/psrig-no-camera\"\n"
                         "[storage]\nroot = \"real-state\"\n";
  run = run_program("psrig", {"calibrate", "lights", "--config", real.string(), "--places", "3"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("geometry.pixel_size_mm"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("psrig calibrate scale"), std::string::npos) << run.err;
  std::ofstream(real, std::ios::app) << "[geometry]\npixel_size_mm = 0.02\n";
  run = run_program("psrig", {"calibrate", "lights", "--config", real.string(), "--places", "3"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("calibration.sphere_diameter_mm"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("--sphere-mm"), std::string::npos) << run.err;
  EXPECT_EQ(run.err.find("press Enter"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(temp / "real-state" / "calibrations" / "0001"));

  // A matte sphere cannot place the LEDs.
  run = run_program("psrig", {"calibrate", "lights", "--config", same.string(), "--places", "3",
                              "--target", "matte"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--target chrome"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace psrig::test
