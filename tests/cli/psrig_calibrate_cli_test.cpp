// `psrig calibrate lights` and `psrig import` as a technician runs them: on
// the simulated rig (a known answer), on the uw-cse455 captures, and every
// bad input ending in exit 2 with nothing written.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/calibration/image_set.h"
#include "psrig/calibration/light_calibration.h"
#include "psrig/calibration/sphere.h"
#include "psrig/formats/light_matrix.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// config/sim.toml with its storage root in `root` and `extra` lines added
// to the tables they name (replacing keys already there).
fs::path rig_with_state(const TempDir& temp,
                        const std::map<std::string, std::string>& replace = {}) {
  std::ifstream in(fs::path(PSRIG_SOURCE_DIR) / "config" / "sim.toml");
  std::stringstream out;
  std::string line;
  while (std::getline(in, line)) {
    const std::string key = line.substr(0, line.find(' '));
    if (key == "root") line = "root = \"" + (temp / "state").string() + "\"";
    if (const auto it = replace.find(key); it != replace.end()) line = key + " = " + it->second;
    out << line << '\n';
  }
  const fs::path file = temp / "rig.toml";
  std::ofstream(file) << out.str();
  return file;
}

cv::Vec3d direction_of(const json& light) {
  return {light["direction"][0].get<double>(), light["direction"][1].get<double>(),
          light["direction"][2].get<double>()};
}

void expect_sim_answer(const json& calibration, const std::vector<double>& intensities,
                       const char* what) {
  const auto& lights = calibration["lights"]["per_light"];
  ASSERT_EQ(lights.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    const cv::Vec3d truth = formats::light_direction(120.0 * k, 45);
    const double error = calibration::angle_deg(direction_of(lights[k]), truth);
    std::printf("sim %s light %d: error %.3f deg, intensity %.4f\n", what, k, error,
                lights[k]["intensity"].get<double>());
    EXPECT_LT(error, 0.3) << what << " light " << k;
    if (!intensities.empty()) {
      EXPECT_NEAR(lights[k]["intensity"].get<double>(), intensities[k], 0.02) << k;
    }
  }
}

TEST(PsrigCalibrate, ChromeSphereOnTheSimulatedRigGivesTheConfiguredDirections) {
  TempDir temp;
  const auto config = rig_with_state(temp);
  auto run = run_program("psrig", {"calibrate", "lights", "--config", config.string(), "--target",
                                   "chrome", "--frames", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const fs::path version = temp / "state" / "calibrations" / "0001";
  EXPECT_TRUE(contains(run.out, (version / "calibration.json").string())) << run.out;
  EXPECT_TRUE(contains(run.out, "light 2: tilt")) << run.out;
  const json c = read_json(version / "calibration.json");
  EXPECT_EQ(c["format"], "psrig-calibration/1");
  EXPECT_EQ(c["lights"]["method"], "chrome");
  expect_sim_answer(c, {}, "chrome");
  // The captures it came from, beside it.
  EXPECT_TRUE(fs::exists(version / "captures" / "chrome-0" / "scan.json"));
  EXPECT_TRUE(fs::exists(version / "captures" / "chrome-1" / "led2.png"));
  EXPECT_EQ(c["lights"]["sources"]["chrome"]["images"][0], "captures/chrome-0/led0.png");
  // A second run is the next version, and current.
  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "lights", "--config", config.string(), "-q", "--frames", "1"})
                .exit_code,
            0);
  EXPECT_TRUE(fs::exists(temp / "state" / "calibrations" / "0002" / "calibration.json"));

  auto check = run_program("psrig", {"config", "check", config.string()});
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_TRUE(contains(
      check.out, "light calibration: " +
                     (temp / "state" / "calibrations" / "0002" / "calibration.json").string()))
      << check.out;

  // A scan on the rig now uses the current calibration and says so.
  const fs::path scan = temp / "scan";
  auto scanned = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", scan.string(), "--no-process", "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const json description = read_json(scan / "scan.json");
  const fs::path current = temp / "state" / "calibrations" / "0002" / "calibration.json";
  EXPECT_EQ(description["calibration"]["file"], current.string());
  const json calibrated = read_json(current);
  for (int k = 0; k < 3; ++k)
    EXPECT_LT(calibration::angle_deg(direction_of(description["lights"][k]),
                                     direction_of(calibrated["lights"]["per_light"][k])),
              1e-3);
}

TEST(PsrigCalibrate, AScanWithoutACalibrationSaysSoInScanJson) {
  TempDir temp;
  const auto config = rig_with_state(temp);
  const fs::path scan = temp / "scan";
  auto scanned = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", scan.string(), "--no-process", "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  EXPECT_TRUE(scanned.err.empty()) << scanned.err;  // -q: nothing on success
  auto said = run_program("psrig", {"scan", "--config", config.string(), "--out",
                                    (temp / "said").string(), "--no-process"});
  ASSERT_EQ(said.exit_code, 0) << said.err;
  EXPECT_TRUE(contains(said.err, "psrig scan: warning: the rig has no calibration")) << said.err;
  const json description = read_json(scan / "scan.json");
  ASSERT_TRUE(description.contains("calibration"));
  EXPECT_TRUE(description["calibration"].is_null());
  auto check = run_program("psrig", {"config", "check", config.string()});
  EXPECT_TRUE(contains(check.out, "light calibration: none")) << check.out;
  EXPECT_LT(calibration::angle_deg(direction_of(description["lights"][1]),
                                   formats::light_direction(120, 45)),
            1e-3);
}

// Matte: directions and the relative intensities the configuration sets.
// Vignetting off: the sensor's fall-off toward the corners (0.15) would
// tilt the Lambertian fit by half a degree; the flat field corrects that.
TEST(PsrigCalibrate, MatteSphereOnTheSimulatedRigGivesDirectionsAndIntensities) {
  TempDir temp;
  const auto config = rig_with_state(
      temp, {{"vignetting", "0"}, {"max_on_ms", "5000\nintensity = [1.0, 0.8, 0.9]"}});
  auto run = run_program("psrig", {"calibrate", "lights", "--config", config.string(), "--target",
                                   "matte", "--frames", "1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json c = read_json(temp / "state" / "calibrations" / "0001" / "calibration.json");
  EXPECT_EQ(c["lights"]["method"], "matte");
  expect_sim_answer(c, {1.0, 0.8, 0.9}, "matte");
}

// The albedo map's coefficient of variation (grey, the field's outer
// 8 pixels left out) of a scan processed where it was written.
double albedo_cv(const fs::path& scan) {
  cv::Mat albedo = cv::imread((scan / "maps" / "albedo.exr").string(), cv::IMREAD_UNCHANGED);
  EXPECT_FALSE(albedo.empty()) << scan;
  if (albedo.empty()) return 1e9;
  cv::Mat grey;
  cv::transform(albedo, grey, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
  const cv::Rect inside(8, 8, grey.cols - 16, grey.rows - 16);
  cv::Scalar mean, deviation;
  cv::meanStdDev(grey(inside), mean, deviation);
  return deviation[0] / mean[0];
}

// Vignetting 0.15 at the corners: a white card scanned without flats shows
// the fall-off in its albedo; with the flats calibrated from the card it is
// flat, and the scan says which calibration and that its flat was applied.
TEST(PsrigCalibrateFlat, FlatsFromTheCardEvenOutTheVignetting) {
  TempDir temp;
  const auto config = rig_with_state(temp, {{"target", "\"white_card\""}});
  const fs::path state = temp / "state";

  // No light calibration yet: refused, nothing written.
  auto refused = run_program("psrig", {"calibrate", "flat", "--config", config.string()});
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_TRUE(contains(refused.err, "psrig calibrate lights first")) << refused.err;
  EXPECT_EQ(calibration_versions(state), 0u);

  const fs::path plain = temp / "plain";
  auto scanned =
      run_program("psrig", {"scan", "--config", config.string(), "--out", plain.string(), "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const double cv_plain = albedo_cv(plain);

  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "lights", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  auto run = run_program("psrig", {"calibrate", "flat", "--config", config.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "light 2: flat mean")) << run.out;
  const fs::path version = state / "calibrations" / "0002";
  const json c = read_json(version / "calibration.json");
  EXPECT_EQ(c["contains"], json::array({"lights", "flat"}));
  EXPECT_EQ(c["lights"]["from"], "0001");
  ASSERT_EQ(c["flat"]["images"].size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(fs::exists(version / c["flat"]["images"][k].get<std::string>()));
    // The simulated sensor's fall-off: 0.15 at the corners.
    EXPECT_NEAR(c["flat"]["per_light"][k]["fall_off"].get<double>(), 0.87, 0.05) << k;
  }

  const fs::path flat = temp / "flat";
  scanned =
      run_program("psrig", {"scan", "--config", config.string(), "--out", flat.string(), "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const json description = read_json(flat / "scan.json");
  EXPECT_EQ(description["calibration"]["file"], (version / "calibration.json").string());
  EXPECT_EQ(description["calibration"]["applied"], json::array({"lights", "flat"}));
  ASSERT_EQ(description["flats"].size(), 3u);
  EXPECT_TRUE(fs::exists(flat / description["flats"][0].get<std::string>()));
  const double cv_flat = albedo_cv(flat);
  std::printf("white card albedo CV: %.4f without flats, %.4f with\n", cv_plain, cv_flat);
  EXPECT_GT(cv_plain, 0.02);
  EXPECT_LT(cv_flat, 0.005);

  // A later light calibration carries the flat over.
  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "lights", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  const json next = read_json(state / "calibrations" / "0003" / "calibration.json");
  EXPECT_EQ(next["flat"]["from"], "0002");
  EXPECT_EQ(next["contains"], json::array({"lights", "flat"}));
}

// The matte sphere under vignetting 0.15 reads its slant low; with the
// flats from the card divided out first, it reads the configured slant.
TEST(PsrigCalibrateFlat, TheFlatCorrectsTheMatteSphereUnderVignetting) {
  TempDir temp;
  const auto config = rig_with_state(temp, {{"max_on_ms", "5000\nintensity = [1.0, 0.8, 0.9]"}});
  const fs::path store = temp / "state" / "calibrations";
  const auto worst_error = [&](const fs::path& file) {
    const json c = read_json(file);
    double worst = 0;
    for (int k = 0; k < 3; ++k)
      worst = std::max(worst, calibration::angle_deg(direction_of(c["lights"]["per_light"][k]),
                                                     formats::light_direction(120.0 * k, 45)));
    return worst;
  };
  const std::vector<std::string> matte = {"calibrate",     "lights",   "--config",
                                          config.string(), "--target", "matte",
                                          "--frames",      "1",        "-q"};
  ASSERT_EQ(run_program("psrig", matte).exit_code, 0);
  const double before = worst_error(store / "0001" / "calibration.json");
  auto flat = run_program("psrig", {"calibrate", "flat", "--config", config.string(), "-q"});
  ASSERT_EQ(flat.exit_code, 0) << flat.err;
  ASSERT_EQ(run_program("psrig", matte).exit_code, 0);
  const json after_file = read_json(store / "0003" / "calibration.json");
  EXPECT_EQ(after_file["lights"]["sources"]["flat"],
            (store / "0002" / "calibration.json").string());
  const double after = worst_error(store / "0003" / "calibration.json");
  std::printf(
      "matte sphere, vignetting 0.15: worst direction error %.3f deg without the flat, "
      "%.3f deg with\n",
      before, after);
  EXPECT_GT(before, 0.3);
  EXPECT_LT(after, 0.1);
  expect_sim_answer(after_file, {1.0, 0.8, 0.9}, "matte, flat-fielded");
}

// No card (the swatch still under the camera), a saturated card: exit 2,
// the fix named, no new version.
TEST(PsrigCalibrateFlat, NoCardOrASaturatedCardIsRefused) {
  TempDir temp;
  const fs::path state = temp / "state";
  {
    const auto config = rig_with_state(temp);
    ASSERT_EQ(run_program("psrig", {"calibrate", "lights", "--config", config.string(), "--frames",
                                    "1", "-q"})
                  .exit_code,
              0);
  }
  // The matte sphere left under the camera instead of the card.
  const auto sphere = rig_with_state(temp, {{"target", "\"matte_sphere\""}});
  auto no_card =
      run_program("psrig", {"calibrate", "flat", "--config", sphere.string(), "--frames", "1"});
  EXPECT_EQ(no_card.exit_code, 2) << no_card.err;
  EXPECT_TRUE(contains(no_card.err, "not a uniform card")) << no_card.err;
  EXPECT_TRUE(contains(no_card.err, "lay a flat white or grey card")) << no_card.err;
  EXPECT_TRUE(contains(no_card.err, sphere.string())) << no_card.err;
  EXPECT_EQ(calibration_versions(state), 1u);

  const auto saturated = rig_with_state(temp, {{"led_irradiance", "4"}});
  auto run =
      run_program("psrig", {"calibrate", "flat", "--config", saturated.string(), "--frames", "1"});
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_TRUE(contains(run.err, "saturated")) << run.err;
  EXPECT_TRUE(contains(run.err, "exposure")) << run.err;
  EXPECT_EQ(calibration_versions(state), 1u);
}

// The simulated ChArUco board (7 x 5 squares of 2 mm, the command's
// defaults) at the configuration's 0.025 mm a pixel: measured within
// 0.2 %, stored, and used as every later scan's pixel size.
TEST(PsrigCalibrateScale, TheBoardOnTheSimulatedRigGivesThePixelSize) {
  TempDir temp;
  const auto config = rig_with_state(temp);
  const fs::path store = temp / "state" / "calibrations";
  auto early = run_program("psrig", {"calibrate", "scale", "--config", config.string()});
  EXPECT_EQ(early.exit_code, 2) << early.err;
  EXPECT_TRUE(contains(early.err, "psrig calibrate lights first")) << early.err;
  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "lights", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  auto run = run_program("psrig", {"calibrate", "scale", "--config", config.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::printf("%s", run.out.c_str());
  const json c = read_json(store / "0002" / "calibration.json");
  EXPECT_EQ(c["contains"], json::array({"lights", "scale"}));
  const double measured = c["scale"]["pixel_size_mm"].get<double>();
  const double uncertainty = c["scale"]["uncertainty_mm"].get<double>();
  std::printf("scale: %.7f mm (+/- %.2g), %.4f %% from 0.025\n", measured, uncertainty,
              100 * std::abs(measured / 0.025 - 1));
  EXPECT_NEAR(measured, 0.025, 0.002 * 0.025);
  EXPECT_GT(uncertainty, 0);
  EXPECT_LT(uncertainty, 0.001 * 0.025);

  const fs::path scan = temp / "scan";
  auto scanned = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", scan.string(), "--no-process", "-q"});
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const json description = read_json(scan / "scan.json");
  EXPECT_DOUBLE_EQ(description["pixel_size_mm"].get<double>(), measured);
  EXPECT_EQ(description["calibration"]["applied"], json::array({"lights", "scale"}));

  // From an image already taken: the same board.
  const fs::path frame = store / "0002" / "captures" / "scale-0" / "led1.png";
  auto from_image = run_program("psrig", {"calibrate", "scale", "--config", config.string(),
                                          "--image", frame.string(), "-q"});
  ASSERT_EQ(from_image.exit_code, 0) << from_image.err;
  const json d = read_json(store / "0003" / "calibration.json");
  EXPECT_NEAR(d["scale"]["pixel_size_mm"].get<double>(), 0.025, 0.002 * 0.025);
  EXPECT_TRUE(fs::exists(store / "0003" / d["scale"]["sources"]["image"].get<std::string>()));

  // No board in the image: exit 2 naming the file and the fix, nothing written.
  const fs::path sphere = store / "0001" / "captures" / "chrome-0" / "led0.png";
  auto refused = run_program(
      "psrig", {"calibrate", "scale", "--config", config.string(), "--image", sphere.string()});
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_TRUE(contains(refused.err, sphere.string())) << refused.err;
  EXPECT_TRUE(contains(refused.err, "shows no ChArUco board")) << refused.err;
  EXPECT_TRUE(contains(refused.err, "--square-mm")) << refused.err;
  EXPECT_EQ(calibration_versions(temp / "state"), 3u);
}

// A pixel size that puts the squares' edges between pixels (86.6 px a
// square): still within 0.2 %.
TEST(PsrigCalibrateScale, APixelSizeOffTheGridIsMeasuredToo) {
  TempDir temp;
  const auto config = rig_with_state(temp, {{"pixel_size_mm", "0.0231"}});
  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "lights", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  auto run = run_program("psrig", {"calibrate", "scale", "--config", config.string(), "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json c = read_json(temp / "state" / "calibrations" / "0002" / "calibration.json");
  const double measured = c["scale"]["pixel_size_mm"].get<double>();
  std::printf("scale at 0.0231 mm: %.7f mm (+/- %.2g), %.4f %% off\n", measured,
              c["scale"]["uncertainty_mm"].get<double>(), 100 * std::abs(measured / 0.0231 - 1));
  EXPECT_NEAR(measured, 0.0231, 0.002 * 0.0231);
}

// A folder of images: 3 renders of the simulated chrome sphere, taken from
// a calibration run, then computed again with --images and --out.
TEST(PsrigCalibrate, FromImagesToAFileAndBadInputsWriteNothing) {
  TempDir temp;
  const auto config = rig_with_state(temp);
  ASSERT_EQ(run_program("psrig",
                        {"calibrate", "lights", "--config", config.string(), "--frames", "1", "-q"})
                .exit_code,
            0);
  const fs::path capture = temp / "state" / "calibrations" / "0001" / "captures" / "chrome-0";
  const fs::path images = temp / "images";
  fs::create_directories(images);
  for (int k = 0; k < 3; ++k)
    fs::copy_file(capture / ("led" + std::to_string(k) + ".png"),
                  images / ("led" + std::to_string(k) + ".png"));
  const fs::path out = temp / "cal.json";
  auto run = run_program(
      "psrig", {"calibrate", "lights", "--images", images.string(), "--out", out.string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // The stored frames keep the black level and the room light: still within 0.3 deg.
  expect_sim_answer(read_json(out), {}, "chrome from --images");
  // Never overwritten.
  auto again = run_program(
      "psrig", {"calibrate", "lights", "--images", images.string(), "--out", out.string()});
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_TRUE(contains(again.err, out.string()) && contains(again.err, "exists")) << again.err;

  const auto expect_refused = [&](const std::vector<std::string>& args, const std::string& names,
                                  const std::string& says) {
    const fs::path target = temp / "refused.json";
    std::vector<std::string> all = {"calibrate", "lights"};
    all.insert(all.end(), args.begin(), args.end());
    all.insert(all.end(), {"--out", target.string()});
    auto r = run_program("psrig", all);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_TRUE(contains(r.err, names)) << r.err;
    EXPECT_TRUE(contains(r.err, says)) << r.err;
    EXPECT_FALSE(fs::exists(target));
  };
  // Highlight missing: light 1's frame replaced by the dark frame.
  const fs::path missing = temp / "missing";
  fs::create_directories(missing);
  for (int k = 0; k < 3; ++k)
    fs::copy_file(k == 1 ? capture / "dark.png" : capture / ("led" + std::to_string(k) + ".png"),
                  missing / ("led" + std::to_string(k) + ".png"));
  expect_refused({"--images", missing.string(), "--mask", (temp / "mask.png").string()}, "mask.png",
                 "");  // the mask does not exist yet: unreadable file, named
  cv::Mat mask(480, 640, CV_8U, cv::Scalar(0));
  cv::circle(mask, {320, 240}, 200, cv::Scalar(255), -1);
  cv::imwrite((temp / "mask.png").string(), mask);
  expect_refused({"--images", missing.string(), "--mask", (temp / "mask.png").string()},
                 (missing / "led1.png").string(), "no highlight on the chrome sphere for light 1");
  // No sphere: three blank frames.
  const fs::path blank = temp / "blank";
  fs::create_directories(blank);
  for (int k = 0; k < 3; ++k)
    cv::imwrite((blank / ("f" + std::to_string(k) + ".png")).string(),
                cv::Mat(120, 160, CV_8U, cv::Scalar(10)));
  expect_refused({"--images", blank.string()}, blank.string(), "no sphere found");
  // Into a rig's store instead: no new version.
  auto into_store = run_program(
      "psrig", {"calibrate", "lights", "--images", blank.string(), "--config", config.string()});
  EXPECT_EQ(into_store.exit_code, 2) << into_store.err;
  EXPECT_FALSE(fs::exists(temp / "state" / "calibrations" / "0002"));
  // Wrong image count for --frames.
  expect_refused({"--images", images.string(), "--frames", "2"}, images.string(),
                 "not a whole number of lights");
  // An unreadable image.
  const fs::path broken = temp / "broken";
  fs::create_directories(broken);
  for (int k = 0; k < 3; ++k)
    fs::copy_file(images / ("led" + std::to_string(k) + ".png"),
                  broken / ("led" + std::to_string(k) + ".png"));
  std::ofstream(broken / "led1.png") << "not a png";
  expect_refused({"--images", broken.string()}, (broken / "led1.png").string(), "");
  // No output named.
  auto nowhere = run_program("psrig", {"calibrate", "lights", "--images", images.string()});
  EXPECT_EQ(nowhere.exit_code, 2);
  EXPECT_TRUE(contains(nowhere.err, "--out FILE")) << nowhere.err;
}

TEST(PsrigImport, BadInputsExitTwoAndWriteNothing) {
  TempDir temp;
  const fs::path folder = temp / "images";
  fs::create_directories(folder);
  for (int k = 0; k < 4; ++k)
    cv::imwrite((folder / ("i" + std::to_string(k) + ".png")).string(),
                cv::Mat(16, 16, CV_8U, cv::Scalar(50 + k)));
  std::ofstream(temp / "three.txt") << "0.5 0 0.866\n-0.25 0.433 0.866\n-0.25 -0.433 0.866\n";
  const fs::path out = temp / "scan";
  auto count = run_program("psrig", {"import", folder.string(), "--directions",
                                     (temp / "three.txt").string(), "--out", out.string()});
  EXPECT_EQ(count.exit_code, 2);
  EXPECT_TRUE(contains(count.err, folder.string()) && contains(count.err, "holds 4 images"))
      << count.err;
  EXPECT_FALSE(fs::exists(out));
  std::ofstream(temp / "four.txt")
      << "4\n0.5 0 0.866\n-0.25 0.433 0.866\n-0.25 -0.433 0.866\n0 0 -1\n";
  auto below = run_program("psrig", {"import", folder.string(), "--directions",
                                     (temp / "four.txt").string(), "--out", out.string()});
  EXPECT_EQ(below.exit_code, 2);
  EXPECT_TRUE(contains(below.err, "four.txt:5")) << below.err;
  EXPECT_FALSE(fs::exists(out));
  auto no_lights = run_program("psrig", {"import", folder.string(), "--out", out.string()});
  EXPECT_EQ(no_lights.exit_code, 2);
  EXPECT_TRUE(contains(no_lights.err, "--calibration")) << no_lights.err;
  auto not_cal = run_program("psrig", {"import", folder.string(), "--calibration",
                                       (temp / "three.txt").string(), "--out", out.string()});
  EXPECT_EQ(not_cal.exit_code, 2);
  EXPECT_TRUE(contains(not_cal.err, "three.txt")) << not_cal.err;
  EXPECT_FALSE(fs::exists(out));
}

// A directions file (the count line first, as some datasets write it) and
// an RGB mask with R = G = B: a scan `psrig process` takes.
TEST(PsrigImport, ADirectionsFileAndAnRgbMaskMakeAProcessableScan) {
  TempDir temp;
  const fs::path folder = temp / "images";
  fs::create_directories(folder);
  const std::vector<cv::Vec3d> lights = {formats::light_direction(0, 40),
                                         formats::light_direction(120, 40),
                                         formats::light_direction(240, 40)};
  std::ofstream directions(temp / "lights.txt");
  directions << "3\n";
  for (int k = 0; k < 3; ++k) {
    // A tilted plane, n = (0.1, 0.2, 1) normalised, albedo 0.6.
    const cv::Vec3d n = cv::normalize(cv::Vec3d(0.1, 0.2, 1));
    cv::imwrite(
        (folder / ("obj." + std::to_string(k) + ".png")).string(),
        cv::Mat(24, 32, CV_8UC3, cv::Scalar::all(std::round(255 * 0.6 * n.dot(lights[k])))));
    directions << lights[k][0] << ", " << lights[k][1] << ", " << lights[k][2] << "\n";
  }
  directions.close();
  cv::Mat mask(24, 32, CV_8UC3, cv::Scalar::all(255));
  cv::imwrite((folder / "obj.mask.png").string(), mask);
  const fs::path scan = temp / "nested" / "scan";
  auto import = run_program("psrig", {"import", folder.string(), "--directions",
                                      (temp / "lights.txt").string(), "--out", scan.string()});
  ASSERT_EQ(import.exit_code, 0) << import.err;
  EXPECT_EQ(read_json(scan / "scan.json")["calibration"]["kind"], "directions");
  auto process = run_program("psrig", {"process", scan.string(), "-q"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  const cv::Mat p = cv::imread((scan / "maps" / "p.exr").string(), cv::IMREAD_UNCHANGED);
  EXPECT_NEAR(p.at<float>(12, 16), -0.1, 0.02);
  // Never over an existing scan.
  auto again = run_program("psrig", {"import", folder.string(), "--directions",
                                     (temp / "lights.txt").string(), "--out", scan.string()});
  EXPECT_EQ(again.exit_code, 2) << again.err;
}

// uw-cse455: calibrate from chrome/ (its mask), import an object and the
// gray sphere with it, process each in one command; the gray sphere's
// normals against the sphere fitted to its mask.
TEST(PsrigImport, UwCse455ObjectsImportAndProcessWithTheChromeCalibration) {
  const auto data = real_dataset("uw-cse455");
  if (!data) GTEST_SKIP() << "../shared/data/uw-cse455 is absent";
  TempDir temp;
  const fs::path cal = temp / "calibration.json";
  auto calibrate =
      run_program("psrig", {"calibrate", "lights", "--images", (*data / "chrome").string(),
                            "--matte", (*data / "gray").string(), "--out", cal.string()});
  ASSERT_EQ(calibrate.exit_code, 0) << calibrate.err;
  std::printf("%s", calibrate.out.c_str());
  for (const std::string object : {"gray", "cat"}) {
    const fs::path scan = temp / object;
    auto import = run_program("psrig", {"import", (*data / object).string(), "--calibration",
                                        cal.string(), "--out", scan.string()});
    ASSERT_EQ(import.exit_code, 0) << import.err;
    EXPECT_TRUE(contains(import.out, "12 lights, masked")) << import.out;
    const json description = read_json(scan / "scan.json");
    EXPECT_EQ(description["lights"].size(), 12u);
    EXPECT_EQ(description["mask"], "mask.png");
    auto process = run_program("psrig", {"process", scan.string(), "-q"});
    ASSERT_EQ(process.exit_code, 0) << process.err;
    EXPECT_TRUE(fs::exists(scan / "maps" / "normal.png"));
  }
  // The gray sphere's normals against the sphere its mask outlines.
  auto mask = calibration::read_mask(*data / "gray" / "gray.mask.png");
  ASSERT_TRUE(mask);
  auto sphere = calibration::find_sphere({}, *mask, "gray.mask.png");
  ASSERT_TRUE(sphere);
  const cv::Mat p = cv::imread((temp / "gray" / "maps" / "p.exr").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat q = cv::imread((temp / "gray" / "maps" / "q.exr").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat valid =
      cv::imread((temp / "gray" / "maps" / "mask.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(p.empty() || q.empty() || valid.empty());
  double sum = 0;
  int count = 0;
  std::vector<double> errors;
  for (int row = 0; row < p.rows; ++row)
    for (int col = 0; col < p.cols; ++col) {
      if (!valid.at<std::uint8_t>(row, col)) continue;
      const auto truth = calibration::sphere_normal(*sphere, cv::Point2d(col, row), {}, p.size());
      // The rim, where the mask's edge and the fit blur: left out.
      if (!truth || (*truth)[2] < 0.2) continue;
      cv::Vec3d n(-p.at<float>(row, col), -q.at<float>(row, col), 1);
      const double e = calibration::angle_deg(n, *truth);
      sum += e;
      errors.push_back(e);
      ++count;
    }
  ASSERT_GT(count, 10000);
  std::sort(errors.begin(), errors.end());
  const double mean = sum / count;
  std::printf(
      "uw-cse455 gray sphere with the chrome calibration: mean angular error %.2f deg, "
      "median %.2f deg over %d pixels\n",
      mean, errors[errors.size() / 2], count);
  EXPECT_LT(mean, 8.0);
}

}  // namespace
}  // namespace psrig::test
