// calibration/: the sphere's circle, light directions from chrome and matte
// spheres (on the simulated targets, whose answer is known, and on the
// uw-cse455 captures), the image folder and mask rules, the store.

#include "psrig/calibration/light_calibration.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/calibration/calibration_store.h"
#include "psrig/calibration/image_set.h"
#include "psrig/calibration/sphere.h"
#include "psrig/formats/light_matrix.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/processing/evaluation.h"
#include "psrig/processing/woodham.h"
#include "psrig/sim/lambertian_render.h"
#include "psrig/sim/sphere_target.h"
#include "psrig/sim/world.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using namespace psrig::calibration;

cv::Mat grey_of(const cv::Mat& bgr) {
  std::vector<cv::Mat> planes;
  cv::split(bgr, planes);
  return planes[0];
}

// What a camera records of a rendered target: scaled, noisy, clipped at 1.
cv::Mat expose(const cv::Mat& radiance, double scale, cv::RNG& rng, double noise = 0.002) {
  cv::Mat image = grey_of(radiance) * scale;
  cv::Mat n(image.size(), CV_32F);
  rng.fill(n, cv::RNG::NORMAL, 0, noise);
  image += n;
  cv::min(image, 1.0, image);
  cv::max(image, 0.0, image);
  return image;
}

sim::SphereTarget target(sim::SphereKind kind) {
  sim::SphereTarget t;
  t.kind = kind;
  t.size = {640, 480};
  t.pixel_size_mm = 0.025;
  t.diameter_mm = 9.3;
  t.centre = {301.3, 250.7};  // off the pixel grid
  return t;
}

const std::vector<cv::Vec3d>& test_lights() {
  static const std::vector<cv::Vec3d> lights = {
      formats::light_direction(30, 20), formats::light_direction(150, 45),
      formats::light_direction(270, 60), formats::light_direction(200, 35)};
  return lights;
}

TEST(LightCalibration, FitCircleRecoversAnExactCircle) {
  std::vector<cv::Point2d> points;
  for (int k = 0; k < 50; ++k) {
    const double a = 2 * std::numbers::pi * k / 50;
    points.emplace_back(12.25 + 80.5 * std::cos(a), -3.5 + 80.5 * std::sin(a));
  }
  const Circle c = fit_circle(points);
  EXPECT_NEAR(c.centre.x, 12.25, 1e-9);
  EXPECT_NEAR(c.centre.y, -3.5, 1e-9);
  EXPECT_NEAR(c.radius, 80.5, 1e-9);
  EXPECT_LT(c.rms_px, 1e-9);
}

TEST(LightCalibration, FindsARenderedSphereToAQuarterOfAPixel) {
  cv::RNG rng(1);
  for (const auto kind : {sim::SphereKind::matte, sim::SphereKind::chrome}) {
    const auto t = target(kind);
    std::vector<cv::Mat> images;
    for (const auto& l : test_lights())
      images.push_back(
          expose(sim::render_sphere(t, l), kind == sim::SphereKind::matte ? 1.5 : 3, rng));
    auto circle = find_sphere(images, {}, "renders");
    ASSERT_TRUE(circle) << circle.error().describe();
    SCOPED_TRACE(kind == sim::SphereKind::matte ? "matte" : "chrome");
    // The chrome sphere's rim is dim (its faint diffuse layer against the
    // velvet): a little less sharp than the matte's.
    const double tolerance = kind == sim::SphereKind::matte ? 0.15 : 0.25;
    EXPECT_NEAR(circle->centre.x, 301.3, tolerance);
    EXPECT_NEAR(circle->centre.y, 250.7, tolerance);
    EXPECT_NEAR(circle->radius, t.radius_px(), tolerance);
  }
}

TEST(LightCalibration, ChromeDirectionsWithinThreeTenthsOfADegree) {
  cv::RNG rng(2);
  const auto t = target(sim::SphereKind::chrome);
  std::vector<LightFrames> lights;
  for (const auto& l : test_lights()) {
    LightFrames frames;
    for (int f = 0; f < 3; ++f)
      frames.frames.push_back({expose(sim::render_sphere(t, l), 3, rng, 0.004), "chrome.png"});
    lights.push_back(frames);
  }
  std::vector<cv::Mat> all;
  for (const auto& l : lights)
    all.push_back(l.frames.front().image);
  auto circle = find_sphere(all, {}, "renders");
  ASSERT_TRUE(circle);
  // The highlights alone, with the true circle: a tenth of a degree.
  auto exact = calibrate_chrome(lights, Circle{t.centre_px(), t.radius_px(), 0, 720}, {});
  ASSERT_TRUE(exact);
  for (std::size_t k = 0; k < lights.size(); ++k)
    EXPECT_LT(angle_deg((*exact)[k].direction, test_lights()[k]), 0.15);
  auto estimates = calibrate_chrome(lights, *circle, {});
  ASSERT_TRUE(estimates) << estimates.error().describe();
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const double error = angle_deg((*estimates)[k].direction, test_lights()[k]);
    std::printf("chrome light %zu (slant %.0f): error %.3f deg, uncertainty %.3f deg\n", k,
                slant_deg(test_lights()[k]), error, (*estimates)[k].uncertainty_deg);
    EXPECT_LT(error, 0.3);
    EXPECT_EQ((*estimates)[k].frames, 3);
    ASSERT_TRUE((*estimates)[k].highlight_spread_deg);
  }
}

// Near-field LEDs 250 mm from the field's centre at 45° slant, the chrome
// sphere (6 mm) placed at three places in a 32 x 24 mm field: each LED
// triangulated from the highlights' rays within a few millimetres, and a
// flat card under those LEDs, processed with the calibrated positions,
// within 0.3° over a 16 x 12 mm field.
TEST(LightCalibration, NearLedPositionsFromTheSphereAtThreePlaces) {
  cv::RNG rng(5);
  std::vector<cv::Vec3d> truth;
  for (const double tilt : {0.0, 120.0, 240.0})
    truth.push_back(250 * formats::light_direction(tilt, 45));
  sim::SphereTarget t;
  t.kind = sim::SphereKind::chrome;
  t.size = {1280, 960};
  t.pixel_size_mm = 0.025;
  t.diameter_mm = 6;
  std::vector<SpherePlacement> placements;
  for (const cv::Point2d centre :
       {cv::Point2d(250.3, 200.6), cv::Point2d(1030.2, 260.1), cv::Point2d(620.7, 760.4)}) {
    t.centre = centre;
    std::vector<LightFrames> lights;
    std::vector<cv::Mat> all;
    for (const auto& p : truth) {
      LightFrames frames;
      frames.frames.push_back(
          {expose(sim::render_sphere_point(t, p), 3, rng, 0.004), "chrome.png"});
      all.push_back(frames.frames.front().image);
      lights.push_back(frames);
    }
    auto circle = find_sphere(all, {}, "renders");
    ASSERT_TRUE(circle) << circle.error().describe();
    auto estimates = calibrate_chrome(lights, *circle, {});
    ASSERT_TRUE(estimates) << estimates.error().describe();
    placements.push_back({*circle, *estimates});
  }
  const PlaneGeometry geometry{0.025, 6, t.size, std::nullopt};
  auto positions = triangulate_leds(placements, geometry);
  ASSERT_TRUE(positions) << positions.error().describe();
  ASSERT_EQ(positions->size(), 3U);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const auto& p = (*positions)[k];
    const double off = cv::norm(p.position_mm - truth[k]);
    std::printf(
        "LED %zu at (%.1f, %.1f, %.1f) mm, truth (%.1f, %.1f, %.1f): %.2f mm off, "
        "rays %.3f mm RMS, baseline %.1f mm\n",
        k, p.position_mm[0], p.position_mm[1], p.position_mm[2], truth[k][0], truth[k][1],
        truth[k][2], off, p.ray_rms_mm, p.baseline_mm);
    EXPECT_LT(off, 10.0);
  }
  // Too few placements, or no pixel size: bad input.
  EXPECT_FALSE(triangulate_leds({placements.front()}, geometry));
  EXPECT_FALSE(triangulate_leds(placements, {0, 6, t.size, std::nullopt}));

  // A flat card under the true LEDs, processed with the calibrated positions.
  sim::Swatch card;
  card.pixel_size_mm = 0.025;
  card.height_mm = cv::Mat(480, 640, CV_32F, cv::Scalar(0));
  card.normal = cv::Mat(480, 640, CV_32FC3, cv::Scalar(0, 0, 1));
  card.albedo = cv::Mat(480, 640, CV_32FC3, cv::Scalar::all(0.6));
  formats::Scan scan;
  scan.description.pixel_size_mm = 0.025;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    scan.frames.push_back(grey_of(sim::render_point_light(card, {truth[k], {1, 1, 1}}, false)));
    formats::ScanLight light;
    light.image = "led" + std::to_string(k) + ".exr";
    light.direction = (*positions)[k].position_mm / cv::norm((*positions)[k].position_mm);
    light.position_mm = (*positions)[k].position_mm;
    scan.description.lights.push_back(light);
  }
  scan.white_level = 1.0;
  auto solved = processing::solve(scan);
  ASSERT_TRUE(solved) << solved.error().describe();
  cv::Mat up(480, 640, CV_32FC3, cv::Scalar(0, 0, 1));
  const double error =
      processing::describe(processing::angular_error_deg(solved->p, solved->q, up)).mean;
  std::printf("flat card with the calibrated positions: mean angular error %.3f deg\n", error);
  EXPECT_LE(error, 0.3);
}

// The same through the simulated rig's world: rig.toml's near LEDs
// (led_distance_mm) and [sim] sphere_centre_mm placing the chrome sphere.
TEST(LightCalibration, NearLedPositionsFromTheSimulatedRigsSphere) {
  cv::RNG rng(6);
  config::RigConfig c;
  c.geometry.led_distance_mm = 250;
  c.sim.target = "chrome_sphere";
  c.sim.sphere_diameter_mm = 6;
  c.sim.width = 1280;
  c.sim.height = 960;
  c.sim.pixel_size_mm = 0.025;
  std::vector<SpherePlacement> placements;
  for (const std::array<double, 2> centre :
       {std::array<double, 2>{-9.7, 6.9}, std::array<double, 2>{9.8, 5.4},
        std::array<double, 2>{0.2, -7.5}}) {
    c.sim.sphere_centre_mm = centre;
    const sim::World world = test::made(sim::World::make(c));
    std::vector<LightFrames> lights;
    std::vector<cv::Mat> all;
    for (int k = 0; k < world.channel_count(); ++k) {
      LightFrames frames;
      frames.frames.push_back({expose(world.radiance(k), 3, rng, 0.004), "chrome.png"});
      all.push_back(frames.frames.front().image);
      lights.push_back(frames);
    }
    auto circle = find_sphere(all, {}, "renders");
    ASSERT_TRUE(circle) << circle.error().describe();
    EXPECT_NEAR(circle->centre.x, 639.5 + centre[0] / 0.025, 0.5);
    auto estimates = calibrate_chrome(lights, *circle, {});
    ASSERT_TRUE(estimates) << estimates.error().describe();
    placements.push_back({*circle, *estimates});
  }
  auto positions = triangulate_leds(placements, {0.025, 6, {1280, 960}, std::nullopt});
  ASSERT_TRUE(positions) << positions.error().describe();
  const auto truth = config::led_positions_mm(c.geometry);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const cv::Vec3d p(truth[k][0], truth[k][1], truth[k][2]);
    const double off = cv::norm((*positions)[k].position_mm - p);
    std::printf("simulated rig, LED %zu: %.2f mm off\n", k, off);
    EXPECT_LT(off, 10.0);
  }
}

TEST(LightCalibration, MatteDirectionsAndRelativeIntensities) {
  cv::RNG rng(3);
  const auto t = target(sim::SphereKind::matte);
  const std::vector<double> intensity = {1.0, 0.8, 0.9, 0.6};
  std::vector<LightFrames> lights;
  for (std::size_t k = 0; k < test_lights().size(); ++k)
    lights.push_back({{{expose(sim::render_sphere(t, test_lights()[k]), 1.5 * intensity[k], rng),
                        "matte.png"}}});
  std::vector<cv::Mat> all;
  for (const auto& l : lights)
    all.push_back(l.frames.front().image);
  auto circle = find_sphere(all, {}, "renders");
  ASSERT_TRUE(circle);
  auto estimates = calibrate_matte(lights, *circle, {});
  ASSERT_TRUE(estimates) << estimates.error().describe();
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const double error = angle_deg((*estimates)[k].direction, test_lights()[k]);
    std::printf("matte light %zu: error %.3f deg, intensity %.4f (true %.2f)\n", k, error,
                (*estimates)[k].intensity, intensity[k]);
    EXPECT_LT(error, 0.3);
    EXPECT_NEAR((*estimates)[k].intensity, intensity[k], 0.01);
  }
}

TEST(LightCalibration, PerspectiveNormalsFaceTheCameraAtTheCentre) {
  Circle sphere{{320, 240}, 100, 0, 0};
  const CameraModel camera{1000.0};
  auto n = sphere_normal(sphere, {320, 240}, camera, {641, 481});
  ASSERT_TRUE(n);
  EXPECT_NEAR((*n)[2], 1.0, 1e-6);
  // Off centre the view ray leans, so the highlight of an overhead light
  // is not where orthographic reflection puts it.
  auto right = sphere_normal(sphere, {380, 240}, camera, {641, 481});
  ASSERT_TRUE(right);
  EXPECT_GT((*right)[0], 0.5);
  EXPECT_FALSE(sphere_normal(sphere, {430, 240}, camera, {641, 481}));
}

TEST(LightCalibration, AMissingHighlightIsBadInputNamingTheFrame) {
  cv::RNG rng(4);
  const auto t = target(sim::SphereKind::chrome);
  std::vector<LightFrames> lights;
  for (std::size_t k = 0; k < 3; ++k) {
    // Light 2 was off: the sphere's faint diffuse glow only.
    const double scale = k == 2 ? 0.0 : 3;
    cv::Mat image = k == 2 ? expose(sim::render_sphere_ambient(t), 0.05, rng)
                           : expose(sim::render_sphere(t, test_lights()[k]), scale, rng);
    lights.push_back({{{image, "chrome." + std::to_string(k) + ".png"}}});
  }
  // Two lights outline only part of the rim: the sphere is known here.
  const Circle circle{t.centre_px(), t.radius_px(), 0, 720};
  auto estimates = calibrate_chrome(lights, circle, {});
  ASSERT_FALSE(estimates);
  EXPECT_EQ(estimates.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(estimates.error().file, "chrome.2.png");
  EXPECT_NE(estimates.error().message.find("no highlight"), std::string::npos);
}

TEST(LightCalibration, NoSphereIsBadInputNamingTheSource) {
  cv::RNG rng(5);
  cv::Mat noise(240, 320, CV_32F);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 0.2);
  auto found = find_sphere({noise}, {}, "folder/of/images");
  ASSERT_FALSE(found);
  EXPECT_EQ(found.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(found.error().file, "folder/of/images");
  EXPECT_NE(found.error().message.find("no sphere found"), std::string::npos);
  EXPECT_NE(found.error().message.find("--mask"), std::string::npos);
}

// Round bright things that are not spheres are refused, not fitted: the
// uw-cse455 objects, and its chrome sphere without a mask (too dim an edge).
TEST(LightCalibration, ObjectsAndADimChromeRimAreNotTakenForASphere) {
  const auto data = real_dataset("uw-cse455");
  if (!data) GTEST_SKIP() << "../shared/data/uw-cse455 is absent";
  for (const std::string object : {"cat", "buddha", "owl", "horse", "rock", "chrome"}) {
    auto listed = list_image_folder(*data / object);
    ASSERT_TRUE(listed);
    std::vector<cv::Mat> images;
    for (const auto& file : listed->images)
      images.push_back(*read_linear_grey(file, formats::Encoding::linear));
    auto found = find_sphere(images, {}, *data / object);
    EXPECT_FALSE(found) << object;
    if (!found) {
      EXPECT_EQ(found.error().kind, ErrorKind::bad_input);
    }
  }
}

TEST(LightCalibration, NaturalOrderPutsTwoBeforeTen) {
  EXPECT_TRUE(natural_less("chrome.2.png", "chrome.10.png"));
  EXPECT_FALSE(natural_less("chrome.10.png", "chrome.2.png"));
  EXPECT_TRUE(natural_less("a.png", "b.png"));
  EXPECT_TRUE(natural_less("led1.png", "led01x.png"));
}

TEST(LightCalibration, MasksMayBeRgbWithEqualChannelsButNotColour) {
  TempDir temp;
  cv::Mat rgb(20, 30, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::circle(rgb, {15, 10}, 5, cv::Scalar(255, 255, 255), -1);
  cv::imwrite((temp / "rgb.png").string(), rgb);
  auto mask = read_mask(temp / "rgb.png");
  ASSERT_TRUE(mask) << mask.error().describe();
  EXPECT_EQ(mask->type(), CV_8U);
  EXPECT_GT(cv::countNonZero(*mask), 50);
  rgb.at<cv::Vec3b>(0, 0) = {0, 0, 255};
  cv::imwrite((temp / "colour.png").string(), rgb);
  auto refused = read_mask(temp / "colour.png");
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().file, temp / "colour.png");
}

// The scan reader takes a dataset's RGB mask (R = G = B) as it stands.
TEST(LightCalibration, ScanReaderTakesAnRgbMaskWithEqualChannels) {
  TempDir temp;
  nlohmann::json lights = nlohmann::json::array();
  for (int k = 0; k < 3; ++k) {
    cv::imwrite((temp / ("led" + std::to_string(k) + ".png")).string(),
                cv::Mat(8, 8, CV_8U, cv::Scalar(100)));
    const cv::Vec3d d = formats::light_direction(120.0 * k, 45);
    lights.push_back(
        {{"image", "led" + std::to_string(k) + ".png"}, {"direction", {d[0], d[1], d[2]}}});
  }
  cv::Mat rgb(8, 8, CV_8UC3, cv::Scalar(0, 0, 0));
  rgb(cv::Rect(0, 0, 4, 8)).setTo(cv::Scalar(255, 255, 255));
  cv::imwrite((temp / "mask.png").string(), rgb);
  std::ofstream(temp / "scan.json") << nlohmann::json{
      {"format", "psrig-scan/1"},
      {"lights", lights},
      {"mask", "mask.png"}}.dump();
  auto scan = formats::read_scan(temp.path());
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(cv::countNonZero(scan->mask), 32);
  rgb.at<cv::Vec3b>(1, 1) = {0, 255, 0};
  cv::imwrite((temp / "mask.png").string(), rgb);
  auto refused = formats::read_scan(temp.path());
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().key, "mask");
}

// A palette PNG (colour type 3: black and white entries), 32x24, the
// middle 16 columns white, as some tools save masks.
TEST(LightCalibration, ScanReaderTakesAPaletteMask) {
  static const char kPng[] =
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x20\x00\x00\x00"
      "\x18\x08\x03\x00\x00\x00\xac\x8d\x0f\x06\x00\x00\x00\x06\x50\x4c\x54\x45\x00\x00\x00\xff\xff"
      "\xff\xa5\xd9\x9f\xdd\x00\x00\x00\x17\x49\x44\x41\x54\x78\x9c\x63\x60\x80\x02\x46\x34\xc0\x80"
      "\x0e\x46\x15\x8c\x2a\x18\x39\x0a\x00\x55\x36\x01\x81\xdc\x60\x37\xe3\x00\x00\x00\x00\x49\x45"
      "\x4e\x44\xae\x42\x60\x82";
  TempDir temp;
  nlohmann::json lights = nlohmann::json::array();
  for (int k = 0; k < 3; ++k) {
    cv::imwrite((temp / ("led" + std::to_string(k) + ".png")).string(),
                cv::Mat(24, 32, CV_8U, cv::Scalar(100)));
    const cv::Vec3d d = formats::light_direction(120.0 * k, 45);
    lights.push_back(
        {{"image", "led" + std::to_string(k) + ".png"}, {"direction", {d[0], d[1], d[2]}}});
  }
  std::ofstream(temp / "mask.png", std::ios::binary).write(kPng, sizeof kPng - 1);
  std::ofstream(temp / "scan.json") << nlohmann::json{
      {"format", "psrig-scan/1"},
      {"lights", lights},
      {"mask", "mask.png"}}.dump();
  auto scan = formats::read_scan(temp.path());
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(cv::countNonZero(scan->mask), 16 * 24);
  auto mask = read_mask(temp / "mask.png");
  ASSERT_TRUE(mask) << mask.error().describe();
  EXPECT_EQ(cv::countNonZero(*mask), 16 * 24);
}

TEST(LightCalibration, StoreNumbersVersionsAndTheNewestIsCurrent) {
  TempDir temp;
  CalibrationStore store(temp.path());
  EXPECT_FALSE(store.current());
  LightCalibration c;
  c.method = "chrome";
  for (int k = 0; k < 3; ++k) {
    LightEstimate e;
    e.direction = formats::light_direction(120.0 * k, 40);
    e.uncertainty_deg = 0.1;
    c.chrome.push_back(e);
  }
  for (int version = 1; version <= 2; ++version) {
    auto staging = store.begin_next();
    ASSERT_TRUE(staging) << staging.error().describe();
    ASSERT_TRUE(write_new_file(staging->path() / kCalibrationFile, to_json(c, utc_now()).dump(2)));
    ASSERT_TRUE(staging->commit(formats::AtomicDirectory::Existing::refuse, true));
  }
  ASSERT_EQ(store.versions().size(), 2u);
  ASSERT_TRUE(store.current());
  EXPECT_EQ(*store.current(), temp / "calibrations" / "0002" / kCalibrationFile);
  auto read = read_calibration(*store.current());
  ASSERT_TRUE(read) << read.error().describe();
  ASSERT_EQ(read->lights.size(), 3u);
  EXPECT_LT(angle_deg(read->lights[1].direction, c.chrome[1].direction), 1e-3);
  EXPECT_EQ(read->document["format"], kCalibrationFormat);
  EXPECT_TRUE(read->document["flat"].is_null());  // sections later calibrations fill
  // A file that is not a calibration: bad input naming it and the key.
  std::ofstream(temp / "other.json") << R"({"format": "psrig-scan/1"})";
  auto wrong = read_calibration(temp / "other.json");
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error().key, "format");
  EXPECT_FALSE(write_new_file(*store.current(), "{}"));  // never overwritten
}

// uw-cse455's chrome/: 12 lights, one 8-bit RGB image each, a mask. Each
// colour channel is a separate measurement of the same highlight: the
// directions from R, G and B agree to a few hundredths of a degree; the
// matte gray/ sphere's Lambertian fit agrees within a few degrees (it is
// not quite Lambertian: its fit leaves 2-4 % of full scale).
TEST(LightCalibration, UwCse455ChromeDirectionsAgreeBetweenChannelsAndWithTheGraySphere) {
  const auto data = real_dataset("uw-cse455");
  if (!data) GTEST_SKIP() << "../shared/data/uw-cse455 is absent";
  const auto load = [](const fs::path& folder, bool channels_as_frames) {
    auto listed = list_image_folder(folder);
    EXPECT_TRUE(listed);
    std::vector<LightFrames> lights;
    for (const auto& file : listed->images) {
      cv::Mat stored = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
      cv::Mat linear;
      stored.convertTo(linear, CV_32F, 1.0 / 255);
      LightFrames frames;
      if (channels_as_frames) {
        std::vector<cv::Mat> planes;
        cv::split(linear, planes);
        for (const auto& plane : planes)
          frames.frames.push_back({plane, file});
      } else {
        frames.frames.push_back({*read_linear_grey(file, formats::Encoding::linear), file});
      }
      lights.push_back(frames);
    }
    return std::make_pair(lights, *read_mask(*listed->mask));
  };
  const auto [chrome, chrome_mask] = load(*data / "chrome", true);
  ASSERT_EQ(chrome.size(), 12u);
  auto chrome_sphere = find_sphere({}, chrome_mask, "chrome.mask.png");
  ASSERT_TRUE(chrome_sphere) << chrome_sphere.error().describe();
  auto directions = calibrate_chrome(chrome, *chrome_sphere, {});
  ASSERT_TRUE(directions) << directions.error().describe();
  double worst = 0;
  double sum = 0;
  for (const auto& d : *directions) {
    worst = std::max(worst, *d.frames_spread_deg);
    sum += *d.frames_spread_deg;
  }
  std::printf(
      "uw-cse455 chrome: sphere (%.2f, %.2f) r %.2f px; R/G/B directions agree to %.3f "
      "deg RMS on average, %.3f deg at worst\n",
      chrome_sphere->centre.x, chrome_sphere->centre.y, chrome_sphere->radius, sum / 12, worst);
  EXPECT_LT(worst, 0.5);

  const auto [gray, gray_mask] = load(*data / "gray", false);
  auto gray_sphere = find_sphere({}, gray_mask, "gray.mask.png");
  ASSERT_TRUE(gray_sphere);
  auto matte = calibrate_matte(gray, *gray_sphere, {});
  ASSERT_TRUE(matte) << matte.error().describe();
  double mean = 0;
  double most = 0;
  for (std::size_t k = 0; k < 12; ++k) {
    const double a = angle_deg((*directions)[k].direction, (*matte)[k].direction);
    mean += a / 12;
    most = std::max(most, a);
  }
  std::printf("uw-cse455 chrome vs gray (matte) directions: mean %.2f deg, max %.2f deg\n", mean,
              most);
  EXPECT_LT(mean, 4.0);
}

}  // namespace
}  // namespace psrig::test
