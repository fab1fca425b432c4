// Linearisation: stored codes to linear measurements, each correction
// checked against a scene whose answer is known.

#include "psrig/processing/linearise.h"

#include <cmath>

#include <gtest/gtest.h>

#include "psrig/formats/map_encoding.h"
#include "psrig/processing/woodham.h"
#include "synthetic_scene.h"

namespace psrig::processing {
namespace {

double srgb_encode(double linear) {
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
}

double angular_error(const formats::Scan& scan) {
  auto result = solve(scan);
  EXPECT_TRUE(result) << (result ? "" : result.error().describe());
  if (!result) return 180;
  return test::mean_angular_error_deg(normals_from_gradients(result->p, result->q),
                                      scan.ground_truth_normal,
                                      encode_valid_mask(result->flags));
}

// A colour sphere under three lights, rendered linear in float.
formats::Scan float_sphere() {
  return test::render_scan(test::sphere_surface({96, 72}, 30, 3), test::ring_lights(3, 45), CV_32F);
}

TEST(CodeLineariser, BlackAndWhiteLevelsMapToZeroAndOne) {
  const CodeLineariser codes(formats::Encoding::linear, 1000, 61000, CV_16U);
  const std::uint16_t stored[] = {1000, 31000, 61000, 0};
  float linear[4];
  codes.convert(stored, 4, linear);
  EXPECT_NEAR(linear[0], 0.0f, 1e-6);
  EXPECT_NEAR(linear[1], 0.5f, 1e-6);
  EXPECT_NEAR(linear[2], 1.0f, 1e-6);
  EXPECT_NEAR(linear[3], -1.0f / 60, 1e-6);  // below black stays below zero: noise is not clipped
}

TEST(CodeLineariser, SrgbCodesAreDecoded) {
  const CodeLineariser codes(formats::Encoding::srgb, 0, 255, CV_8U);
  const std::uint8_t stored[] = {0, 188, 255, 10};
  float linear[4];
  codes.convert(stored, 4, linear);
  EXPECT_FLOAT_EQ(linear[0], 0.0f);
  EXPECT_NEAR(linear[1], std::pow((188 / 255.0 + 0.055) / 1.055, 2.4), 1e-6);
  EXPECT_FLOAT_EQ(linear[2], 1.0f);
  EXPECT_NEAR(linear[3], 10 / 255.0 / 12.92, 1e-7);  // the linear toe
}

TEST(ScanLineariser, SrgbEncodedFramesGiveTheLinearAnswer) {
  formats::Scan scan = float_sphere();
  for (auto& frame : scan.frames) {
    cv::Mat encoded(frame.size(), frame.type());
    for (int i = 0; i < static_cast<int>(frame.total() * 3); ++i)
      encoded.ptr<float>()[i] =
          static_cast<float>(srgb_encode(std::max(0.0f, frame.ptr<float>()[i])));
    encoded.convertTo(frame, CV_16UC3, 65535);
  }
  scan.white_level = 65535;
  scan.description.encoding = formats::Encoding::srgb;
  EXPECT_LT(angular_error(scan), 0.05);
  scan.description.encoding =
      formats::Encoding::linear;  // the same codes taken as linear: wrong shape
  EXPECT_GT(angular_error(scan), 2.0);
}

TEST(ScanLineariser, BlackLevelIsSubtracted) {
  formats::Scan scan = float_sphere();
  for (auto& frame : scan.frames)
    frame = frame * 0.8 + 0.1;  // a sensor with a pedestal
  scan.description.black_level = 0.1;
  scan.white_level = 0.9;
  EXPECT_LT(angular_error(scan), 0.01);
  scan.description.black_level = 0;
  EXPECT_GT(angular_error(scan), 2.0);
}

TEST(ScanLineariser, DarkFrameIsSubtracted) {
  formats::Scan scan = float_sphere();
  cv::Mat ambient(scan.size(), CV_32FC3);
  cv::randu(ambient, 0.02, 0.12);  // uneven room light, the same in every frame
  for (auto& frame : scan.frames)
    frame += ambient;
  scan.dark = ambient;
  EXPECT_LT(angular_error(scan), 0.01);
  scan.dark = cv::Mat();
  EXPECT_GT(angular_error(scan), 2.0);
}

TEST(ScanLineariser, FlatFieldsDivideOutEachLedsPattern) {
  formats::Scan scan = float_sphere();
  const cv::Size size = scan.size();
  const std::vector<cv::Point2d> hot_spots = {{0, 0}, {95, 10}, {40, 71}};
  for (std::size_t k = 0; k < 3; ++k) {
    // A smooth fall-off around a different spot for each LED: both the
    // pattern and the overall brightness differ between LEDs.
    cv::Mat pattern(size, CV_32F);
    for (int r = 0; r < size.height; ++r)
      for (int c = 0; c < size.width; ++c)
        pattern.at<float>(r, c) =
            static_cast<float>(1.4 - 0.8 * cv::norm(cv::Point2d(c, r) - hot_spots[k]) / 120.0);
    cv::Mat pattern3;
    cv::merge(std::vector<cv::Mat>{pattern, pattern, pattern}, pattern3);
    scan.frames[k] = scan.frames[k].mul(pattern3);
    // The white target under the same LED: albedo 1, facing the camera.
    const double facing = scan.description.lights[k].direction[2];
    scan.flats.push_back(pattern3 * facing);
  }
  scan.description.flats = {"flat0.exr", "flat1.exr", "flat2.exr"};
  EXPECT_LT(angular_error(scan), 0.1);
  formats::Scan uncorrected = scan;
  uncorrected.flats.clear();
  uncorrected.description.flats.clear();
  EXPECT_GT(angular_error(uncorrected), 2.0);
}

TEST(ScanLineariser, BlackFlatIsAnError) {
  formats::Scan scan = float_sphere();
  for (int k = 0; k < 3; ++k)
    scan.flats.push_back(cv::Mat(scan.size(), CV_32FC3, cv::Scalar::all(0.5)));
  scan.flats[1].setTo(0);
  scan.description.directory = "/scans/x";
  scan.description.flats = {"flat0.exr", "flat1.exr", "flat2.exr"};
  auto lineariser = ScanLineariser::create(scan);
  ASSERT_FALSE(lineariser);
  EXPECT_EQ(lineariser.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(lineariser.error().key, "flats[1]");
  EXPECT_EQ(lineariser.error().file, std::filesystem::path("/scans/x/flat1.exr"));
}

TEST(ScanLineariser, IntensityIsDividedOutPerLight) {
  formats::Scan scan = float_sphere();
  scan.frames[2] *= 1.7;
  scan.description.lights[2].intensity_bgr = {1.7, 1.7, 1.7};
  auto lineariser = ScanLineariser::create(scan);
  ASSERT_TRUE(lineariser);
  const cv::Mat corrected = lineariser->frame(2);
  EXPECT_LT(cv::norm(corrected, scan.frames[2] / 1.7, cv::NORM_INF), 1e-6);
  EXPECT_LT(angular_error(scan), 0.01);
}

TEST(ScanLineariser, SaturationFollowsTheWhiteLevel) {
  formats::Scan scan =
      test::render_scan(test::sphere_surface({16, 16}, 5, 1), test::ring_lights(3, 45), CV_8U);
  scan.frames[0].at<std::uint8_t>(3, 3) = 200;
  scan.frames[1].at<std::uint8_t>(4, 4) = 199;
  scan.white_level = 200;
  auto result = solve(scan);
  ASSERT_TRUE(result);
  EXPECT_TRUE(result->flags.at<std::uint8_t>(3, 3) & kSaturated);
  EXPECT_FALSE(result->flags.at<std::uint8_t>(4, 4) & kSaturated);
}

}  // namespace
}  // namespace psrig::processing
