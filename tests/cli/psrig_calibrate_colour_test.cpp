// `psrig calibrate colour` as a technician runs it: the simulated rig's
// ColorChecker through a camera that mixes its channels (a known answer),
// the matrix carried into scans and applied to their albedo, and every bad
// input ending in exit 2 with nothing written.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "psrig/calibration/colour.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The simulated camera's mixing (rows: camera R, G, B from the scene's
// linear sRGB): a plausible sensor, not white-balanced.
constexpr const char* kMixing = "[0.62, 0.30, 0.08, 0.12, 0.80, 0.08, 0.03, 0.27, 0.55]";
const cv::Matx33d kMixingMatrix(0.62, 0.30, 0.08, 0.12, 0.80, 0.08, 0.03, 0.27, 0.55);

// config/sim.toml with its storage root in the temporary directory, the
// camera's colour mixing, and `target` under the camera.
fs::path colour_rig(const TempDir& temp, const std::string& target = "swatch") {
  std::ifstream in(fs::path(PSRIG_SOURCE_DIR) / "config" / "sim.toml");
  std::stringstream out;
  std::string line;
  while (std::getline(in, line)) {
    const std::string key = line.substr(0, line.find(' '));
    if (key == "root") line = "root = \"" + (temp / "state").string() + "\"";
    if (key == "target") line = "target = \"" + target + "\"";
    out << line << '\n';
    if (line == "[sim]") out << "colour_matrix = " << kMixing << '\n';
  }
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << out.str();
  return file;
}

cv::Matx33d matrix_of(const json& m) {
  cv::Matx33d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      out(r, c) = m[r][c].get<double>();
  return out;
}

void calibrate_lights(const fs::path& config) {
  auto run = run_program(
      "psrig", {"calibrate", "lights", "--config", config.string(), "--frames", "1", "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
}

TEST(PsrigCalibrateColour, TheSimulatedChartGivesTheCamerasInverseAndScansUseIt) {
  TempDir temp;
  const auto config = colour_rig(temp);
  const fs::path state = temp / "state";
  const fs::path store = state / "calibrations";
  auto early = run_program("psrig", {"calibrate", "colour", "--config", config.string()});
  EXPECT_EQ(early.exit_code, 2) << early.err;
  EXPECT_TRUE(contains(early.err, "psrig calibrate lights first")) << early.err;
  calibrate_lights(config);

  auto run = run_program("psrig", {"calibrate", "colour", "--config", config.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::printf("%s", run.out.c_str());
  EXPECT_TRUE(contains(run.out, "dE2000")) << run.out;
  const json c = read_json(store / "0002" / "calibration.json");
  EXPECT_EQ(c["contains"], json::array({"lights", "colour"}));
  const json& colour = c["colour"];
  EXPECT_EQ(colour["space"], "sRGB D65");
  const double before = colour["delta_e2000"]["before"]["mean"].get<double>();
  const double after = colour["delta_e2000"]["after"]["mean"].get<double>();
  std::printf("sim rig: mean dE2000 %.2f before, %.3f after (max %.3f)\n", before, after,
              colour["delta_e2000"]["after"]["max"].get<double>());
  EXPECT_LE(after, 1.0);
  EXPECT_GE(before, 5.0);
  ASSERT_EQ(colour["patches"].size(), 24u);
  EXPECT_EQ(colour["patches"][18]["name"], "white 9.5");
  EXPECT_TRUE(fs::exists(store / "0002" / colour["sources"]["captures"][0].get<std::string>() /
                         "scan.json"));
  // The matrix undoes the camera's mixing, up to the exposure it leaves out.
  const cv::Matx33d product = matrix_of(colour["matrix"]) * kMixingMatrix;
  const double scale = (product(0, 0) + product(1, 1) + product(2, 2)) / 3;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(product(r, k) / scale, r == k ? 1.0 : 0.0, 0.02) << r << "," << k;

  // A scan takes the matrix; its albedo is sRGB D65 and its report says so.
  const fs::path scan = temp / "scan";
  auto scanned =
      run_program("psrig", {"scan", "--config", config.string(), "--out", scan.string(), "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const json description = read_json(scan / "scan.json");
  EXPECT_EQ(description["calibration"]["applied"], json::array({"lights", "colour"}));
  EXPECT_EQ(description["colour_correction"]["calibration"], "0002");
  EXPECT_EQ(description["colour_correction"]["space"], "sRGB D65");
  const json report = read_json(scan / "maps" / "report.json");
  EXPECT_EQ(report["albedo_colour_space"], "sRGB D65");
  EXPECT_EQ(report["colour_calibration"], "0002");

  // A later calibration of the lights carries the colour over.
  calibrate_lights(config);
  const json later = read_json(store / "0003" / "calibration.json");
  EXPECT_EQ(later["colour"]["from"], "0002");
}

// The chart scanned as a swatch after the calibration: its albedo, read at
// the patches, matches the published chart (the matrix applied by
// processing, in linear light).
TEST(PsrigCalibrateColour, TheCorrectedAlbedoOfTheChartMatchesTheReference) {
  TempDir temp;
  const auto config = colour_rig(temp, "colour_chart");
  calibrate_lights(config);
  auto run = run_program("psrig", {"calibrate", "colour", "--config", config.string(), "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json colour =
      read_json(temp / "state" / "calibrations" / "0002" / "calibration.json")["colour"];
  const fs::path scan = temp / "scan";
  auto scanned =
      run_program("psrig", {"scan", "--config", config.string(), "--out", scan.string(), "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const cv::Mat albedo = cv::imread((scan / "maps" / "albedo.exr").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(albedo.type(), CV_32FC3);
  const auto& chart = calibration::colorchecker_classic();
  // The albedo's level is the lights' (not the chart's): scaled so the
  // neutrals' mean matches the reference's, as the calibration does.
  std::array<cv::Vec3d, 24> rgb;
  double level = 0, reference = 0;
  for (int p = 0; p < 24; ++p) {
    const auto& centre = colour["patches"][p]["centre_px"];
    const cv::Rect around(static_cast<int>(centre[0].get<double>()) - 5,
                          static_cast<int>(centre[1].get<double>()) - 5, 11, 11);
    const cv::Scalar mean = cv::mean(albedo(around));
    rgb[static_cast<std::size_t>(p)] = {mean[2], mean[1], mean[0]};
    if (p >= 18) {
      level += mean[0] + mean[1] + mean[2];
      const cv::Vec3d t =
          calibration::lab_d50_to_linear_srgb(chart[static_cast<std::size_t>(p)].lab_d50);
      reference += t[0] + t[1] + t[2];
    }
  }
  double sum = 0, worst = 0;
  for (int p = 0; p < 24; ++p) {
    const auto i = static_cast<std::size_t>(p);
    const double e = calibration::delta_e2000(
        chart[i].lab_d50, calibration::linear_srgb_to_lab_d50(rgb[i] * (reference / level)));
    sum += e / 24;
    worst = std::max(worst, e);
  }
  std::printf("chart scanned after the colour calibration: albedo dE2000 mean %.3f, max %.3f\n",
              sum, worst);
  EXPECT_LE(sum, 1.5);
}

// Scans divide by the flat field channel by channel: the chart is read
// through the current flats (the vignetting gone, the fit closer), the
// version recorded; a flat field measured later leaves scans without the
// matrix (and says so) until the colour is calibrated again.
TEST(PsrigCalibrateColour, ThroughTheFlatFieldAndNotAfterANewOne) {
  TempDir temp;
  const auto config = colour_rig(temp);
  const fs::path store = temp / "state" / "calibrations";
  calibrate_lights(config);
  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "flat", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  auto run = run_program("psrig", {"calibrate", "colour", "--config", config.string(), "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json colour = read_json(store / "0003" / "calibration.json")["colour"];
  EXPECT_EQ(colour["flat_field"], "0002");
  const double after = colour["delta_e2000"]["after"]["mean"].get<double>();
  std::printf("through the flat field: mean dE2000 %.3f before, %.3f after\n",
              colour["delta_e2000"]["before"]["mean"].get<double>(), after);
  EXPECT_LE(after, 0.2);

  const fs::path scan = temp / "scan";
  auto scanned = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", scan.string(), "--no-process", "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  EXPECT_EQ(read_json(scan / "scan.json")["calibration"]["applied"],
            json::array({"lights", "flat", "colour"}));

  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "flat", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  const fs::path later = temp / "later";
  auto stale = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", later.string(), "--no-process"});
  ASSERT_EQ(stale.exit_code, 0) << stale.err;
  EXPECT_EQ(read_json(later / "scan.json")["calibration"]["applied"],
            json::array({"lights", "flat"}));
  EXPECT_FALSE(read_json(later / "scan.json").contains("colour_correction"));
  EXPECT_TRUE(contains(stale.err + stale.out, "run psrig calibrate colour again")) << stale.err;
}

TEST(PsrigCalibrateColour, NoChartIsRefusedNamingTheImageAndTheFixAndWritesNothing) {
  TempDir temp;
  const auto config = colour_rig(temp, "white_card");
  const fs::path state = temp / "state";
  calibrate_lights(config);
  ASSERT_EQ(calibration_versions(state), 1u);

  // Captured on the rig with a white card where the chart should be.
  auto card = run_program("psrig", {"calibrate", "colour", "--config", config.string()});
  EXPECT_EQ(card.exit_code, 2) << card.err;
  EXPECT_TRUE(contains(card.err, config.string())) << card.err;
  EXPECT_TRUE(contains(card.err, "is the chart fully in view, lit, not saturated?")) << card.err;
  EXPECT_EQ(calibration_versions(state), 1u);

  // A uniform colour image given with --image.
  const fs::path uniform = temp / "uniform.png";
  cv::imwrite(uniform.string(), cv::Mat(480, 640, CV_16UC3, cv::Scalar(30000, 32000, 28000)));
  auto flat = run_program(
      "psrig", {"calibrate", "colour", "--config", config.string(), "--image", uniform.string()});
  EXPECT_EQ(flat.exit_code, 2) << flat.err;
  EXPECT_TRUE(contains(flat.err, uniform.string())) << flat.err;
  EXPECT_TRUE(contains(flat.err, "shows no ColorChecker Classic")) << flat.err;

  // A grey image: the calibration needs colour.
  const fs::path grey = temp / "grey.png";
  cv::imwrite(grey.string(), cv::Mat(480, 640, CV_16UC1, cv::Scalar(30000)));
  auto mono = run_program(
      "psrig", {"calibrate", "colour", "--config", config.string(), "--image", grey.string()});
  EXPECT_EQ(mono.exit_code, 2) << mono.err;
  EXPECT_TRUE(contains(mono.err, grey.string()) && contains(mono.err, "grey image")) << mono.err;

  // A simulated camera's colour response that is not 3x3: the key named.
  {
    std::ifstream in(config);
    std::stringstream text;
    text << in.rdbuf();
    std::string bad = text.str();
    bad.replace(bad.find("colour_matrix = "), std::string("colour_matrix = ").size(),
                "colour_matrix = [1, 0, 0, 0, 1, 0, 0, 0] # ");
    const fs::path bad_config = temp / "bad.toml";
    std::ofstream(bad_config) << bad;
    auto r = run_program("psrig", {"calibrate", "colour", "--config", bad_config.string()});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "colour_matrix") && contains(r.err, "9 numbers")) << r.err;
  }

  // No such file.
  auto missing = run_program("psrig", {"calibrate", "colour", "--config", config.string(),
                                       "--image", (temp / "none.png").string()});
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
  EXPECT_TRUE(contains(missing.err, "none.png")) << missing.err;
  EXPECT_EQ(calibration_versions(state), 1u);
}

// An image of the chart already taken (the rig's own capture, one LED's
// frame): the same answer, the image kept beside the calibration; and the
// same chart overexposed is refused as saturated.
TEST(PsrigCalibrateColour, FromAnImageAlreadyTakenAndRefusedWhenSaturated) {
  TempDir temp;
  const auto config = colour_rig(temp);
  const fs::path store = temp / "state" / "calibrations";
  calibrate_lights(config);
  ASSERT_EQ(
      run_program("psrig", {"calibrate", "colour", "--config", config.string(), "-q"}).exit_code,
      0);
  // One LED's stored frame less the dark frame: a linear image of the chart.
  const fs::path capture = store / "0002" / "captures" / "colour-0";
  cv::Mat linear = cv::imread((capture / "led0.png").string(), cv::IMREAD_UNCHANGED) -
                   cv::imread((capture / "dark.png").string(), cv::IMREAD_UNCHANGED);
  const fs::path frame = temp / "chart.png";
  ASSERT_TRUE(cv::imwrite(frame.string(), linear));
  auto from_image = run_program(
      "psrig", {"calibrate", "colour", "--config", config.string(), "--image", frame.string()});
  ASSERT_EQ(from_image.exit_code, 0) << from_image.err;
  const json d = read_json(store / "0003" / "calibration.json");
  std::printf("from one stored frame: mean dE2000 after %.3f\n",
              d["colour"]["delta_e2000"]["after"]["mean"].get<double>());
  EXPECT_LE(d["colour"]["delta_e2000"]["after"]["mean"].get<double>(), 1.5);
  EXPECT_TRUE(fs::exists(store / "0003" / d["colour"]["sources"]["image"].get<std::string>()));

  // Overexposed: the white patch clipped.
  cv::Mat bright = cv::imread(frame.string(), cv::IMREAD_UNCHANGED);
  bright.convertTo(bright, CV_16UC3, 2.0);
  const fs::path over = temp / "over.png";
  cv::imwrite(over.string(), bright);
  auto saturated = run_program(
      "psrig", {"calibrate", "colour", "--config", config.string(), "--image", over.string()});
  EXPECT_EQ(saturated.exit_code, 2) << saturated.err;
  EXPECT_TRUE(contains(saturated.err, "saturated")) << saturated.err;
  EXPECT_TRUE(contains(saturated.err, over.string())) << saturated.err;
  EXPECT_EQ(calibration_versions(temp / "state"), 3u);
}

}  // namespace
}  // namespace psrig::test
