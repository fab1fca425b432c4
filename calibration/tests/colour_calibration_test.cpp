// calibration/colour.h: the reference chart and its conversions (lcms2),
// the ColorChecker found and read on the simulated rig's chart through a
// camera that mixes its channels, the fitted matrix against the known
// inverse, and the refusals.

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/calibration/colour.h"
#include "psrig/processing/colour_correction.h"
#include "psrig/sim/world.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::test {
namespace {

using namespace psrig::calibration;

// A plausible camera: channels mixed (rows: camera R, G, B from sRGB) and
// not white-balanced (its green the most sensitive).
const cv::Matx33d kCameraMixing(0.62, 0.30, 0.08,  //
                                0.12, 0.80, 0.08,  //
                                0.03, 0.27, 0.55);

config::RigConfig chart_rig() {
  config::RigConfig c;
  c.sim.target = "colour_chart";
  return c;
}

// The chart under the simulated rig's three LEDs at once, through the
// mixing camera: noisy (0.3 % of full scale), clipped at 1. BGR.
cv::Mat capture_chart(const cv::Matx33d& mixing, double level, cv::RNG& rng,
                      cv::Mat* saturated = nullptr) {
  const sim::World world = test::made(sim::World::make(chart_rig()));
  cv::Mat scene = cv::Mat::zeros(world.radiance(0).size(), CV_32FC3);
  for (int k = 0; k < world.channel_count(); ++k)
    scene += world.radiance(k) * level;
  cv::Matx33f bgr;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      bgr(2 - r, 2 - c) = static_cast<float>(mixing(r, c));
  cv::Mat image;
  cv::transform(scene, image, bgr);
  cv::Mat noise(image.size(), image.type());
  rng.fill(noise, cv::RNG::NORMAL, 0, 0.003);
  image += noise;
  if (saturated) {
    cv::Mat top;
    cv::transform(image, top, cv::Matx13f(1, 0, 0));
    cv::Mat g, r;
    cv::transform(image, g, cv::Matx13f(0, 1, 0));
    cv::transform(image, r, cv::Matx13f(0, 0, 1));
    *saturated = (top >= 1.f) | (g >= 1.f) | (r >= 1.f);
  }
  cv::min(image, cv::Scalar::all(1.0), image);
  cv::max(image, cv::Scalar::all(0.0), image);
  return image;
}

TEST(ColourCalibration, ReferenceWhiteIsSrgbWhiteAndTheConversionsRoundTrip) {
  // D50 white through the relative intent is sRGB's (D65) white.
  const cv::Vec3d white = lab_d50_to_linear_srgb({100, 0, 0});
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(white[c], 1.0, 1e-4);
  for (const auto& patch : colorchecker_classic()) {
    const cv::Vec3d rgb = lab_d50_to_linear_srgb(patch.lab_d50);
    const cv::Vec3d back = linear_srgb_to_lab_d50(rgb);
    EXPECT_LT(delta_e2000(patch.lab_d50, back), 1e-3) << patch.name;
  }
  // The cyan patch lies outside sRGB: kept negative, not clipped.
  EXPECT_LT(lab_d50_to_linear_srgb(colorchecker_classic()[17].lab_d50)[0], 0.0);
  // Sharma, Wu and Dalal (2005), CIEDE2000 test data, pair 1: 2.0425.
  EXPECT_NEAR(delta_e2000({50, 2.6772, -79.7751}, {50, 0, -82.7485}), 2.0425, 1e-4);
}

TEST(ColourCalibration, TheSimulatedChartThroughAMixingCameraIsCorrectedBelowOneDeltaE) {
  cv::RNG rng(15);
  cv::Mat saturated;
  // Exposed so the white patch reads ~0.75 of full scale.
  const cv::Mat image = capture_chart(kCameraMixing, 0.35, rng, &saturated);
  cv::Mat preview;
  cv::pow(cv::max(image, 0.0), 1 / 2.2, preview);
  preview.convertTo(preview, CV_8UC3, 255);
  cv::imwrite(::testing::TempDir() + "colour_chart_sim.png", preview);

  auto reading = read_colour_chart(image, saturated, "sim chart");
  ASSERT_TRUE(reading) << reading.error().message;
  for (int p = 0; p < kChartPatches; ++p) {
    EXPECT_GE(reading->pixels[static_cast<std::size_t>(p)], 400) << p;
    EXPECT_EQ(reading->saturated[static_cast<std::size_t>(p)], 0.0) << p;
  }
  const ColourCorrection fit = fit_colour_correction(reading->rgb);
  std::printf("delta E2000 before: mean %.2f max %.2f; after: mean %.3f max %.3f\n",
              fit.mean_before, fit.max_before, fit.mean_after, fit.max_after);
  for (int p = 0; p < kChartPatches; ++p)
    std::printf("  %-14s %6.2f -> %5.2f\n",
                colorchecker_classic()[static_cast<std::size_t>(p)].name,
                fit.delta_e_before[static_cast<std::size_t>(p)],
                fit.delta_e_after[static_cast<std::size_t>(p)]);
  EXPECT_LE(fit.mean_after, 1.0);
  EXPECT_LE(fit.max_after, 3.0);
  EXPECT_GE(fit.mean_before, 5.0);  // clearly worse without the matrix

  // The matrix is the camera's inverse, up to the exposure it leaves out.
  const cv::Matx33d product = fit.matrix * kCameraMixing;
  const double scale = (product(0, 0) + product(1, 1) + product(2, 2)) / 3;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(product(r, c) / scale, r == c ? 1.0 : 0.0, 0.02) << r << "," << c;

  // Applied to the image (processing's colour_correction), the white
  // patch takes the reference's hue (white 9.5 is slightly yellow: b* 2.9).
  cv::Mat corrected = image.clone();
  processing::apply_colour_matrix(fit.matrix, corrected);
  const auto centre = reading->centre[kFirstNeutralPatch];
  const cv::Scalar white =
      cv::mean(corrected(cv::Rect(cvRound(centre.x) - 5, cvRound(centre.y) - 5, 11, 11)));
  const cv::Vec3d reference =
      lab_d50_to_linear_srgb(colorchecker_classic()[kFirstNeutralPatch].lab_d50);
  EXPECT_NEAR(white[2] / white[1], reference[0] / reference[1], 0.01);  // BGR
  EXPECT_NEAR(white[0] / white[1], reference[2] / reference[1], 0.01);
}

TEST(ColourCalibration, AnIdentityCameraNeedsNoCorrection) {
  cv::RNG rng(16);
  const cv::Mat image = capture_chart(cv::Matx33d::eye(), 0.35, rng);
  auto reading = read_colour_chart(image, {}, "sim chart");
  ASSERT_TRUE(reading) << reading.error().message;
  const ColourCorrection fit = fit_colour_correction(reading->rgb);
  std::printf("identity camera: before %.3f after %.3f\n", fit.mean_before, fit.mean_after);
  EXPECT_LE(fit.mean_before, 1.0);
  EXPECT_LE(fit.mean_after, 1.0);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(fit.matrix(r, c), r == c ? 1.0 : 0.0, 0.03);
}

// The chart laid the other way round (turned 180°): the neutral row still
// decides which patch is which.
TEST(ColourCalibration, AChartUpsideDownIsReadTheRightWayRound) {
  cv::RNG rng(17);
  cv::Mat image = capture_chart(kCameraMixing, 0.35, rng);
  cv::rotate(image, image, cv::ROTATE_180);
  auto reading = read_colour_chart(image, {}, "sim chart");
  ASSERT_TRUE(reading) << reading.error().message;
  // White 9.5 now near the top right.
  EXPECT_GT(reading->centre[kFirstNeutralPatch].x, image.cols / 2.0);
  EXPECT_LT(reading->centre[kFirstNeutralPatch].y, image.rows / 2.0);
  const ColourCorrection fit = fit_colour_correction(reading->rgb);
  std::printf("upside down: mean dE2000 after %.3f\n", fit.mean_after);
  EXPECT_LE(fit.mean_after, 1.0);
}

TEST(ColourCalibration, NoChartIsRefusedNamingTheImageAndTheFix) {
  // A uniform grey card, and the card with noise only.
  cv::Mat card(480, 640, CV_32FC3, cv::Scalar::all(0.4));
  auto none = read_colour_chart(card, {}, "/captures/card.png");
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().file, "/captures/card.png");
  EXPECT_NE(none.error().message.find("is the chart fully in view, lit, not saturated?"),
            std::string::npos)
      << none.error().message;
  cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(10));
  EXPECT_FALSE(read_colour_chart(grey, {}, "grey.png"));
}

// scan.json's colour_correction as processing reads it: none, a matrix,
// and refusals naming the key.
TEST(ColourCalibration, ScanColourCorrectionIsReadAndBadOnesAreRefused) {
  const std::filesystem::path file = "/scans/a/scan.json";
  auto none = processing::read_colour_correction(nlohmann::json::object(), file);
  ASSERT_TRUE(none);
  EXPECT_FALSE(none->has_value());
  const nlohmann::json good = {
      {"colour_correction",
       {{"matrix", {{1.6, -0.5, -0.1}, {-0.25, 1.3, -0.05}, {0.02, -0.6, 1.6}}},
        {"space", "sRGB D65"},
        {"calibration", "0002"}}}};
  auto read = processing::read_colour_correction(good, file);
  ASSERT_TRUE(read && read->has_value());
  EXPECT_DOUBLE_EQ((*read)->rgb_matrix(2, 1), -0.6);
  EXPECT_EQ((*read)->calibration, "0002");
  for (const nlohmann::json& bad :
       {nlohmann::json{{"colour_correction", {{"matrix", {{1, 0}, {0, 1}}}}}},
        nlohmann::json{{"colour_correction", {{"matrix", {{1, 0, 0}, {0, 1, 0}, {1, 0, 0}}}}}},
        nlohmann::json{
            {"colour_correction",
             {{"matrix", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {"space", "Adobe RGB"}}}}}) {
    auto refused = processing::read_colour_correction(bad, file);
    ASSERT_FALSE(refused) << bad.dump();
    EXPECT_EQ(refused.error().file, file);
    EXPECT_EQ(refused.error().key.rfind("colour_correction.", 0), 0u) << refused.error().key;
  }
}

}  // namespace
}  // namespace psrig::test
