// V4L2 pixel formats: each conversion against a frame made by hand.

#include "psrig/cameras/v4l2_formats.h"

#include <cstdint>
#include <linux/videodev2.h>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace psrig::cameras {
namespace {

using Bytes = std::vector<std::uint8_t>;

V4l2PixelFormat format(std::uint32_t fourcc) {
  auto f = find_v4l2_format(fourcc);
  EXPECT_TRUE(f.has_value()) << fourcc_to_string(fourcc);
  return f.value_or(V4l2PixelFormat{});
}

cv::Mat convert(const Bytes& data, std::uint32_t fourcc, int width, int height,
                std::size_t stride) {
  auto mat = convert_v4l2_frame(data, format(fourcc), width, height, stride);
  EXPECT_TRUE(mat.has_value()) << (mat ? "" : mat.error().describe());
  return mat.value_or(cv::Mat{});
}

// The colour at (row, col) of a Bayer mosaic whose top-left 2x2 is `order`.
char bayer_colour(const char* order, int row, int col) {
  return order[2 * (row % 2) + col % 2];
}

// A uniform colour sampled through a mosaic: every site holds its colour's value.
std::vector<int> uniform_mosaic(const char* order, int width, int height, int b, int g, int r) {
  std::vector<int> values;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const char c = bayer_colour(order, y, x);
      values.push_back(c == 'B' ? b : c == 'G' ? g : r);
    }
  return values;
}

Bytes pack_raw10(const std::vector<int>& values, int width, int height, std::size_t stride) {
  Bytes out(stride * height, 0xEE);  // padding bytes must not matter
  for (int y = 0; y < height; ++y) {
    std::uint8_t* line = out.data() + y * stride;
    for (int x = 0; x < width; x += 4) {
      std::uint8_t* group = line + x / 4 * 5;
      group[4] = 0;
      for (int k = 0; k < 4; ++k) {
        const int v = x + k < width ? values[y * width + x + k] : 0;
        group[k] = static_cast<std::uint8_t>(v >> 2);
        group[4] |= static_cast<std::uint8_t>((v & 3) << (2 * k));
      }
    }
  }
  return out;
}

Bytes pack_raw12(const std::vector<int>& values, int width, int height, std::size_t stride) {
  Bytes out(stride * height, 0xEE);
  for (int y = 0; y < height; ++y) {
    std::uint8_t* line = out.data() + y * stride;
    for (int x = 0; x < width; x += 2) {
      std::uint8_t* group = line + x / 2 * 3;
      const int a = values[y * width + x];
      const int b = x + 1 < width ? values[y * width + x + 1] : 0;
      group[0] = static_cast<std::uint8_t>(a >> 4);
      group[1] = static_cast<std::uint8_t>(b >> 4);
      group[2] = static_cast<std::uint8_t>((a & 0xf) | ((b & 0xf) << 4));
    }
  }
  return out;
}

Bytes pack16(const std::vector<int>& values, int width, int height, std::size_t stride) {
  Bytes out(stride * height, 0xEE);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const int v = values[y * width + x];
      out[y * stride + 2 * x] = static_cast<std::uint8_t>(v & 0xff);
      out[y * stride + 2 * x + 1] = static_cast<std::uint8_t>(v >> 8);
    }
  return out;
}

void expect_uniform(const cv::Mat& bgr, int b, int g, int r, const std::string& what) {
  ASSERT_EQ(bgr.channels(), 3) << what;
  int wrong = 0;
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) {
      cv::Vec3i v;
      if (bgr.depth() == CV_8U)
        v = bgr.at<cv::Vec3b>(y, x);
      else
        v = bgr.at<cv::Vec<std::uint16_t, 3>>(y, x);
      if (v != cv::Vec3i(b, g, r)) {
        if (wrong++ == 0)
          ADD_FAILURE() << what << ": at (" << x << ", " << y << ") got " << v << ", want "
                        << cv::Vec3i(b, g, r);
      }
    }
  EXPECT_EQ(wrong, 0) << what;
}

TEST(V4l2Formats, FourccsAndNamesParse) {
  EXPECT_EQ(find_v4l2_format("Y16")->fourcc, V4L2_PIX_FMT_Y16);
  EXPECT_EQ(find_v4l2_format("Y16 ")->fourcc, V4L2_PIX_FMT_Y16);
  EXPECT_EQ(find_v4l2_format("BA81")->fourcc, V4L2_PIX_FMT_SBGGR8);
  EXPECT_EQ(find_v4l2_format("BA10")->fourcc, V4L2_PIX_FMT_SGRBG10);  // not BGGR: V4L2's quirk
  EXPECT_EQ(find_v4l2_format("pgAA")->bayer, BayerOrder::grbg);       // case matters
  EXPECT_EQ(find_v4l2_format("pGAA")->bayer, BayerOrder::gbrg);
  EXPECT_EQ(find_v4l2_format("pBCC")->layout, V4l2Layout::bayer12p);
  EXPECT_EQ(find_v4l2_format("sbggr10p")->fourcc, V4L2_PIX_FMT_SBGGR10P);
  EXPECT_EQ(find_v4l2_format("RGB24")->fourcc, V4L2_PIX_FMT_RGB24);
  EXPECT_EQ(find_v4l2_format("RGB3")->fourcc, V4L2_PIX_FMT_RGB24);
  EXPECT_FALSE(find_v4l2_format("MJPG").has_value());
  EXPECT_FALSE(find_v4l2_format("").has_value());
  EXPECT_EQ(fourcc_to_string(V4L2_PIX_FMT_Y16), "Y16");
  EXPECT_EQ(fourcc_to_string(V4L2_PIX_FMT_Y16_BE), "Y16-BE");
  EXPECT_EQ(fourcc_to_string(V4L2_PIX_FMT_SRGGB10P), "pRAA");
}

TEST(V4l2Formats, WhiteLevelsAndEncodings) {
  EXPECT_EQ(format(V4L2_PIX_FMT_GREY).white_level(), 255);
  EXPECT_EQ(format(V4L2_PIX_FMT_Y10).white_level(), 1023);
  EXPECT_EQ(format(V4L2_PIX_FMT_Y12).white_level(), 4095);
  EXPECT_EQ(format(V4L2_PIX_FMT_Y16).white_level(), 65535);
  EXPECT_EQ(format(V4L2_PIX_FMT_SRGGB10P).white_level(), 1023);
  EXPECT_EQ(format(V4L2_PIX_FMT_SBGGR12).white_level(), 4095);
  EXPECT_EQ(format(V4L2_PIX_FMT_SGRBG8).white_level(), 255);
  EXPECT_EQ(format(V4L2_PIX_FMT_YUYV).white_level(), 255);
  EXPECT_EQ(format(V4L2_PIX_FMT_Y16).encoding(), "linear");
  EXPECT_EQ(format(V4L2_PIX_FMT_SRGGB12P).encoding(), "linear");
  EXPECT_EQ(format(V4L2_PIX_FMT_YUYV).encoding(), "srgb");
  EXPECT_EQ(format(V4L2_PIX_FMT_RGB24).encoding(), "srgb");
}

TEST(V4l2Formats, AutoPrefersLinearDeepFormats) {
  const auto rank = [](std::uint32_t f) { return format(f).photometric_rank; };
  EXPECT_GT(rank(V4L2_PIX_FMT_Y16), rank(V4L2_PIX_FMT_SRGGB12));
  EXPECT_GT(rank(V4L2_PIX_FMT_SRGGB12), rank(V4L2_PIX_FMT_SRGGB10P));
  EXPECT_GT(rank(V4L2_PIX_FMT_SRGGB10P), rank(V4L2_PIX_FMT_SRGGB8));
  EXPECT_GT(rank(V4L2_PIX_FMT_SRGGB8), rank(V4L2_PIX_FMT_GREY));
  EXPECT_GT(rank(V4L2_PIX_FMT_GREY), rank(V4L2_PIX_FMT_RGB24));
  EXPECT_GT(rank(V4L2_PIX_FMT_RGB24), rank(V4L2_PIX_FMT_YUYV));
}

TEST(V4l2Formats, GreyHonoursLinePadding) {
  const Bytes data = {1, 2, 3, 0xEE, 4, 5, 6, 0xEE};  // 3x2, 4 bytes per line
  const cv::Mat m = convert(data, V4L2_PIX_FMT_GREY, 3, 2, 4);
  ASSERT_EQ(m.type(), CV_8UC1);
  EXPECT_EQ(m.at<std::uint8_t>(0, 2), 3);
  EXPECT_EQ(m.at<std::uint8_t>(1, 0), 4);
  EXPECT_EQ(m.at<std::uint8_t>(1, 2), 6);
}

TEST(V4l2Formats, Y16IsLittleEndianAndY16BeIsNot) {
  const Bytes le = {0x34, 0x12, 0xff, 0x00};
  const cv::Mat a = convert(le, V4L2_PIX_FMT_Y16, 2, 1, 4);
  ASSERT_EQ(a.type(), CV_16UC1);
  EXPECT_EQ(a.at<std::uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(a.at<std::uint16_t>(0, 1), 0x00ff);
  const Bytes be = {0x12, 0x34, 0x00, 0xff};
  const cv::Mat b = convert(be, V4L2_PIX_FMT_Y16_BE, 2, 1, 4);
  EXPECT_EQ(b.at<std::uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(b.at<std::uint16_t>(0, 1), 0x00ff);
}

TEST(V4l2Formats, Y10AndY12KeepTheValueInTheLowBits) {
  const Bytes data = {0xff, 0x03, 0xff, 0x0f};
  EXPECT_EQ(convert(data, V4L2_PIX_FMT_Y10, 1, 1, 2).at<std::uint16_t>(0, 0), 1023);
  EXPECT_EQ(convert(data, V4L2_PIX_FMT_Y12, 2, 1, 4).at<std::uint16_t>(0, 1), 4095);
}

TEST(V4l2Formats, PackedRaw10UnpacksExactly) {
  // The worked example: 0x3ff 0x000 0x155 0x2aa -> ff 00 55 aa, then 2-bit tails 11 00 01 10.
  const Bytes one = {0xff, 0x00, 0x55, 0xaa, 0b10'01'00'11};
  const cv::Mat m = convert(one, V4L2_PIX_FMT_Y10P, 4, 1, 5);
  ASSERT_EQ(m.type(), CV_16UC1);
  EXPECT_EQ(m.at<std::uint16_t>(0, 0), 0x3ff);
  EXPECT_EQ(m.at<std::uint16_t>(0, 1), 0x000);
  EXPECT_EQ(m.at<std::uint16_t>(0, 2), 0x155);
  EXPECT_EQ(m.at<std::uint16_t>(0, 3), 0x2aa);

  // Every value, a width that leaves a partial group, and padded lines.
  const int width = 37, height = 5;
  const std::size_t stride = v4l2_min_bytes_per_line(format(V4L2_PIX_FMT_Y10P), width) + 7;
  EXPECT_EQ(v4l2_min_bytes_per_line(format(V4L2_PIX_FMT_Y10P), width), 50u);
  std::mt19937 random(7);
  std::vector<int> values(width * height);
  for (auto& v : values)
    v = static_cast<int>(random() % 1024);
  const cv::Mat all =
      convert(pack_raw10(values, width, height, stride), V4L2_PIX_FMT_Y10P, width, height, stride);
  for (int i = 0; i < width * height; ++i)
    ASSERT_EQ(all.at<std::uint16_t>(i / width, i % width), values[i]) << "pixel " << i;
}

TEST(V4l2Formats, BayerOrdersDemosaicAUniformColourToThatColour) {
  struct Case {
    std::uint32_t raw8, raw16_10, packed10, packed12;
    const char* order;
  };
  const Case cases[] = {
      {V4L2_PIX_FMT_SBGGR8, V4L2_PIX_FMT_SBGGR10, V4L2_PIX_FMT_SBGGR10P, V4L2_PIX_FMT_SBGGR12P,
       "BGGR"},
      {V4L2_PIX_FMT_SGBRG8, V4L2_PIX_FMT_SGBRG10, V4L2_PIX_FMT_SGBRG10P, V4L2_PIX_FMT_SGBRG12P,
       "GBRG"},
      {V4L2_PIX_FMT_SGRBG8, V4L2_PIX_FMT_SGRBG10, V4L2_PIX_FMT_SGRBG10P, V4L2_PIX_FMT_SGRBG12P,
       "GRBG"},
      {V4L2_PIX_FMT_SRGGB8, V4L2_PIX_FMT_SRGGB10, V4L2_PIX_FMT_SRGGB10P, V4L2_PIX_FMT_SRGGB12P,
       "RGGB"},
  };
  const int width = 12, height = 8;
  for (const auto& c : cases) {
    {  // RAW8: blue 30, green 140, red 220
      const auto values = uniform_mosaic(c.order, width, height, 30, 140, 220);
      Bytes data(values.begin(), values.end());
      const cv::Mat bgr = convert(data, c.raw8, width, height, width);
      EXPECT_EQ(bgr.type(), CV_8UC3);
      expect_uniform(bgr, 30, 140, 220, std::string("RAW8 ") + c.order);
    }
    {  // RAW10 in 16-bit containers
      const auto values = uniform_mosaic(c.order, width, height, 101, 517, 1000);
      const std::size_t stride = 2 * width + 4;
      const cv::Mat bgr =
          convert(pack16(values, width, height, stride), c.raw16_10, width, height, stride);
      EXPECT_EQ(bgr.type(), CV_16UC3);
      expect_uniform(bgr, 101, 517, 1000, std::string("RAW10 ") + c.order);
    }
    {  // RAW10 packed
      const auto values = uniform_mosaic(c.order, width, height, 3, 514, 1021);
      const std::size_t stride = width / 4 * 5;
      const cv::Mat bgr =
          convert(pack_raw10(values, width, height, stride), c.packed10, width, height, stride);
      expect_uniform(bgr, 3, 514, 1021, std::string("RAW10P ") + c.order);
    }
    {  // RAW12 packed: distinct nibbles catch a swapped low byte
      const auto values = uniform_mosaic(c.order, width, height, 0xfed, 0x123, 0xabc);
      const std::size_t stride = width / 2 * 3 + 2;
      const cv::Mat bgr =
          convert(pack_raw12(values, width, height, stride), c.packed12, width, height, stride);
      expect_uniform(bgr, 0xfed, 0x123, 0xabc, std::string("RAW12P ") + c.order);
    }
  }
}

TEST(V4l2Formats, Raw12PackedUnpacksExtremeValues) {
  // A grey image (every site equal) demosaics to itself, so each value
  // checks the unpacking on every site of the mosaic.
  const int width = 10, height = 6;
  for (const int v : {0, 1, 0x800, 0xfff, 0x5a5, 0xa5a}) {
    const std::vector<int> values(width * height, v);
    const std::size_t stride = width / 2 * 3;
    const cv::Mat bgr = convert(pack_raw12(values, width, height, stride), V4L2_PIX_FMT_SRGGB12P,
                                width, height, stride);
    expect_uniform(bgr, v, v, v, "RAW12P value " + std::to_string(v));
  }
}

TEST(V4l2Formats, PackedBayerKeepsEverySitesOwnSampleExactly) {
  // Bilinear demosaicing leaves each site's own colour as it was read, so
  // random samples check the unpacking at every position of every group,
  // a partial last group included (14 pixels: 3 groups of 4 and a half).
  const int width = 14, height = 6;
  std::mt19937 random(11);
  for (const auto& [fourcc, bits] :
       {std::pair{V4L2_PIX_FMT_SGRBG10P, 10}, std::pair{V4L2_PIX_FMT_SGRBG12P, 12}}) {
    std::vector<int> values(width * height);
    for (auto& v : values)
      v = static_cast<int>(random() % (1u << bits));
    const std::size_t stride = v4l2_min_bytes_per_line(format(fourcc), width) + 3;
    const Bytes data = bits == 10 ? pack_raw10(values, width, height, stride)
                                  : pack_raw12(values, width, height, stride);
    const cv::Mat bgr = convert(data, fourcc, width, height, stride);
    ASSERT_EQ(bgr.type(), CV_16UC3);
    for (int y = 1; y < height - 1; ++y)
      for (int x = 1; x < width - 1; ++x) {
        const char c = bayer_colour("GRBG", y, x);
        const int channel = c == 'B' ? 0 : c == 'G' ? 1 : 2;
        const int got = bgr.at<cv::Vec<std::uint16_t, 3>>(y, x)[channel];
        ASSERT_EQ(got, values[y * width + x])
            << fourcc_to_string(fourcc) << " at (" << x << ", " << y << ")";
      }
  }
}

TEST(V4l2Formats, YuyvDecodesBt601LimitedRangeToBgr) {
  // Y U Y V for two pixels each: black, white, then a saturated red
  // (R'=255: Y=81 U=90 V=240) and a mid grey (Y=126).
  const Bytes data = {16, 128, 235, 128, 81, 90, 81, 240, 126, 128, 126, 128};
  const cv::Mat m = convert(data, V4L2_PIX_FMT_YUYV, 2, 3, 4);
  ASSERT_EQ(m.type(), CV_8UC3);
  const auto near = [](cv::Vec3b got, cv::Vec3i want) {
    for (int k = 0; k < 3; ++k)
      if (std::abs(got[k] - want[k]) > 3) return false;
    return true;
  };
  EXPECT_PRED2(near, m.at<cv::Vec3b>(0, 0), cv::Vec3i(0, 0, 0));
  EXPECT_PRED2(near, m.at<cv::Vec3b>(0, 1), cv::Vec3i(255, 255, 255));
  EXPECT_PRED2(near, m.at<cv::Vec3b>(1, 0), cv::Vec3i(0, 0, 255));
  EXPECT_PRED2(near, m.at<cv::Vec3b>(2, 1), cv::Vec3i(128, 128, 128));
}

TEST(V4l2Formats, Rgb24SwapsToBgrAndBgr24StaysAsItIs) {
  const Bytes data = {10, 20, 30, 40, 50, 60};
  const cv::Mat rgb = convert(data, V4L2_PIX_FMT_RGB24, 2, 1, 6);
  EXPECT_EQ(rgb.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  EXPECT_EQ(rgb.at<cv::Vec3b>(0, 1), cv::Vec3b(60, 50, 40));
  const cv::Mat bgr = convert(data, V4L2_PIX_FMT_BGR24, 2, 1, 6);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
}

TEST(V4l2Formats, ShortBuffersAndNarrowLinesAreErrorsNotCrashes) {
  const Bytes data(10, 0);
  auto shortbuf = convert_v4l2_frame(data, format(V4L2_PIX_FMT_Y16), 4, 2, 8);
  ASSERT_FALSE(shortbuf.has_value());
  EXPECT_NE(shortbuf.error().message.find("short"), std::string::npos);
  EXPECT_FALSE(convert_v4l2_frame(data, format(V4L2_PIX_FMT_Y16), 4, 1, 6).has_value());
  EXPECT_FALSE(convert_v4l2_frame(data, format(V4L2_PIX_FMT_GREY), 0, 1, 6).has_value());
  EXPECT_FALSE(convert_v4l2_frame(data, format(V4L2_PIX_FMT_YUYV), 3, 1, 6).has_value());
}

}  // namespace
}  // namespace psrig::cameras
