// The maps directory's encodings follow docs/design.md ("Maps directory",
// "Normal-map convention").

#include "psrig/formats/map_encoding.h"

#include <cmath>

#include <gtest/gtest.h>

#include "psrig/processing/woodham.h"

namespace psrig::processing {
namespace {

cv::Vec3w normal_rgb(float p, float q) {
  const cv::Vec3w bgr = formats::encode_normal16(cv::Mat(1, 1, CV_32F, cv::Scalar(p)),
                                                 cv::Mat(1, 1, CV_32F, cv::Scalar(q)))
                            .at<cv::Vec3w>(0, 0);
  return {bgr[2], bgr[1], bgr[0]};
}

TEST(MapEncoding, NormalMapIsOpenGlConvention) {
  // Flat: (0, 0, 1) -> (0.5, 0.5, 1).
  EXPECT_EQ(normal_rgb(0, 0), cv::Vec3w(32768, 32768, 65535));
  // A facet tilted toward +x has dz/dx < 0 and its normal leans to +x: red above mid-grey.
  const cv::Vec3w toward_x = normal_rgb(-1, 0);
  EXPECT_GT(toward_x[0], 32768);
  EXPECT_EQ(toward_x[1], 32768);
  // Tilted toward the image top (+y): green above mid-grey.
  const cv::Vec3w toward_top = normal_rgb(0, -1);
  EXPECT_GT(toward_top[1], 32768);
  EXPECT_EQ(toward_top[0], 32768);
  // 45 degrees: n = (0.7071, 0, 0.7071) -> 0.8536 * 65535.
  EXPECT_NEAR(toward_x[0], 0.85355 * 65535, 1.5);
  EXPECT_NEAR(toward_x[2], 0.85355 * 65535, 1.5);
}

TEST(MapEncoding, AlbedoIsSrgbEncodedAndClamped) {
  cv::Mat albedo = (cv::Mat_<float>(1, 5) << 0.0f, 1.0f, 0.5f, -0.2f, 1.7f);
  const cv::Mat srgb = formats::encode_albedo_srgb8(albedo);
  EXPECT_EQ(srgb.type(), CV_8UC1);
  EXPECT_EQ(srgb.at<std::uint8_t>(0, 0), 0);
  EXPECT_EQ(srgb.at<std::uint8_t>(0, 1), 255);
  EXPECT_EQ(srgb.at<std::uint8_t>(0, 2), 188);  // sRGB(0.5) = 0.7354
  EXPECT_EQ(srgb.at<std::uint8_t>(0, 3), 0);
  EXPECT_EQ(srgb.at<std::uint8_t>(0, 4), 255);
  const cv::Mat colour(2, 2, CV_32FC3, cv::Scalar(0.2, 0.5, 0.8));
  EXPECT_EQ(formats::encode_albedo_srgb8(colour).type(), CV_8UC3);
}

TEST(MapEncoding, HeightSpansTheSixteenBitRange) {
  const cv::Mat height = (cv::Mat_<float>(1, 3) << -0.2f, 0.1f, 0.4f);
  const cv::Mat png = formats::encode_height16(height, -0.2, 0.4);
  EXPECT_EQ(png.at<std::uint16_t>(0, 0), 0);
  EXPECT_EQ(png.at<std::uint16_t>(0, 1), 32768);
  EXPECT_EQ(png.at<std::uint16_t>(0, 2), 65535);
}

TEST(MapEncoding, MaskMarksValidPixels) {
  const cv::Mat flags = (cv::Mat_<std::uint8_t>(1, 5) << 0, kShadowed, kShadowed | kRecovered,
                         kOutsideMask, kLowSignal);
  const cv::Mat mask = encode_valid_mask(flags);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 1), 0);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 2), 255);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 3), 0);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 4), 0);
}

TEST(MapEncoding, DecodingANormalMapGivesTheGradientsBack) {
  cv::Mat p(6, 8, CV_32F);
  cv::Mat q(6, 8, CV_32F);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 8; ++c) {
      p.at<float>(r, c) = 0.3F * (c - 4);
      q.at<float>(r, c) = -0.2F * (r - 3);
    }
  cv::Mat png = formats::encode_normal16(p, q);
  png.at<cv::Vec3w>(0, 0) = cv::Vec3w(0, 0, 0);  // background: no normal
  const formats::DecodedGradients back = formats::decode_normal_map(png);
  ASSERT_EQ(back.p.type(), CV_32FC1);
  EXPECT_TRUE(std::isnan(back.p.at<float>(0, 0)));
  EXPECT_TRUE(std::isnan(back.q.at<float>(0, 0)));
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 8; ++c) {
      if (r == 0 && c == 0) continue;
      EXPECT_NEAR(back.p.at<float>(r, c), p.at<float>(r, c), 1e-3) << r << "," << c;
      EXPECT_NEAR(back.q.at<float>(r, c), q.at<float>(r, c), 1e-3) << r << "," << c;
    }
  // DirectX (green down): q changes sign, p does not.
  const formats::DecodedGradients directx = formats::decode_normal_map(png, true);
  EXPECT_NEAR(directx.q.at<float>(5, 5), -q.at<float>(5, 5), 1e-3);
  EXPECT_NEAR(directx.p.at<float>(5, 5), p.at<float>(5, 5), 1e-3);
  // 8-bit with alpha: alpha 0 has no normal. Floats hold n itself.
  cv::Mat rgba(1, 2, CV_8UC4, cv::Scalar(255, 128, 128, 255));  // B G R A: flat
  rgba.at<cv::Vec4b>(0, 1)[3] = 0;
  const formats::DecodedGradients a = formats::decode_normal_map(rgba);
  EXPECT_NEAR(a.p.at<float>(0, 0), 0.0, 1e-2);
  EXPECT_TRUE(std::isnan(a.p.at<float>(0, 1)));
  cv::Mat floats(1, 1, CV_32FC3, cv::Scalar(0.8, 0.0, 0.6));  // B = z, G = y, R = x
  const formats::DecodedGradients f = formats::decode_normal_map(floats);
  EXPECT_NEAR(f.p.at<float>(0, 0), -0.6 / 0.8, 1e-6);
  EXPECT_TRUE(formats::decode_normal_map(cv::Mat(2, 2, CV_32FC1)).p.empty());
}

}  // namespace
}  // namespace psrig::processing
