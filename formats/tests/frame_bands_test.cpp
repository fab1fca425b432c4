// Frames decoded a band at a time are read_scan's frames, pixel for pixel;
// what read_scan refuses is refused the same, only later; frames outside
// the PNG path are read whole at once.

#include "psrig/formats/frame_bands.h"

#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "psrig/formats/scan_writer.h"
#include "synthetic_scene.h"
#include "test_support.h"

namespace psrig::formats {
namespace {

namespace fs = std::filesystem;

// Every band of every frame, `band` rows at a time.
Status decode_all(BandedScan& banded, int band) {
  for (int first = 0; first < banded.scan.size().height; first += band)
    for (std::size_t k = 0; k < banded.scan.frames.size(); ++k)
      if (auto ok =
              banded.frames.decode(k, first, std::min(band, banded.scan.size().height - first));
          !ok)
        return ok;
  return {};
}

fs::path write_sphere_scan(const fs::path& dir, int depth) {
  const auto surface = test::sphere_surface({211, 157}, 60, 3);
  Scan scan = test::render_scan(surface, test::ring_lights(3, 45), depth, 0.01);
  scan.dark = cv::Mat(scan.size(), scan.frames[0].type(), cv::Scalar::all(3));
  EXPECT_TRUE(write_scan(scan, dir));
  return dir;
}

TEST(FrameBands, BandsGiveReadScansFrames) {
  test::TempDir temp;
  for (int depth : {CV_8U, CV_16U}) {
    const fs::path dir = write_sphere_scan(temp / std::to_string(depth), depth);
    auto whole = read_scan(dir);
    auto banded = read_scan_by_band(dir);
    ASSERT_TRUE(whole && banded) << (whole ? banded.error() : whole.error()).describe();
    EXPECT_EQ(banded->scan.size(), whole->size());
    EXPECT_EQ(banded->scan.depth(), whole->depth());
    for (std::size_t k = 0; k < 3; ++k)
      EXPECT_TRUE(banded->frames.pending(k));
    ASSERT_TRUE(decode_all(*banded, 13));
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_FALSE(banded->frames.pending(k));
      EXPECT_EQ(cv::norm(banded->scan.frames[k], whole->frames[k], cv::NORM_INF), 0);
    }
    EXPECT_EQ(cv::norm(banded->scan.dark, whole->dark, cv::NORM_INF), 0);  // whole at once
  }
}

TEST(FrameBands, BandsOutOfOrderAreRefused) {
  test::TempDir temp;
  auto banded = read_scan_by_band(write_sphere_scan(temp / "scan", CV_16U));
  ASSERT_TRUE(banded);
  EXPECT_FALSE(banded->frames.decode(0, 10, 5));
  ASSERT_TRUE(banded->frames.decode(0, 0, 5));
  EXPECT_FALSE(banded->frames.decode(0, 0, 5));
}

// A frame whose image data is cut short reads with read_scan's error, from
// the band where the damage shows.
TEST(FrameBands, DamageShowsAsReadScansError) {
  test::TempDir temp;
  const fs::path dir = write_sphere_scan(temp / "scan", CV_16U);
  std::ifstream in(dir / "led1.png", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), {});
  in.close();
  // Keep the chunks' lengths and CRCs right but zero the middle of the
  // compressed data: the chunk walk passes, the inflater fails.
  const std::size_t idat = bytes.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  const std::size_t length = static_cast<unsigned char>(bytes[idat - 4]) << 24 |
                             static_cast<unsigned char>(bytes[idat - 3]) << 16 |
                             static_cast<unsigned char>(bytes[idat - 2]) << 8 |
                             static_cast<unsigned char>(bytes[idat - 1]);
  ASSERT_GT(length, 4000u);
  // A damaged image data chunk with a right CRC: recompute it.
  for (std::size_t i = idat + 4 + length / 2; i < idat + 4 + length / 2 + 200; ++i)
    bytes[i] = static_cast<char>(0xFF);
  std::uint32_t crc = 0xFFFFFFFFU;
  for (std::size_t i = idat; i < idat + 4 + length; ++i) {
    crc ^= static_cast<unsigned char>(bytes[i]);
    for (int k = 0; k < 8; ++k)
      crc = (crc >> 1) ^ (0xEDB88320U & (0U - (crc & 1U)));
  }
  crc = ~crc;
  for (int k = 0; k < 4; ++k)
    bytes[idat + 4 + length + k] = static_cast<char>(crc >> (24 - 8 * k));
  std::ofstream(dir / "led1.png", std::ios::binary) << bytes;

  auto whole = read_scan(dir);
  ASSERT_FALSE(whole);
  auto banded = read_scan_by_band(dir);
  ASSERT_TRUE(banded) << banded.error().describe();  // the chunks are sound
  const auto decoded = decode_all(*banded, 16);
  ASSERT_FALSE(decoded);
  EXPECT_EQ(decoded.error().kind, whole.error().kind);
  EXPECT_EQ(decoded.error().file, whole.error().file);
  EXPECT_EQ(decoded.error().key, whole.error().key);
  EXPECT_EQ(decoded.error().message, whole.error().message);
}

TEST(FrameBands, FramesOutsideThePngPathAreWholeAtOnce) {
  test::TempDir temp;
  const auto surface = test::sphere_surface({32, 24}, 10, 1);
  const Scan scan = test::render_scan(surface, test::ring_lights(3, 40), CV_32F);
  ASSERT_TRUE(write_scan(scan, temp / "float"));  // EXR frames
  auto banded = read_scan_by_band(temp / "float");
  ASSERT_TRUE(banded) << banded.error().describe();
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_FALSE(banded->frames.pending(k));
    EXPECT_TRUE(banded->frames.decode(k, 0, 24));  // nothing to do
    EXPECT_EQ(cv::norm(banded->scan.frames[k], scan.frames[k], cv::NORM_INF), 0);
  }
}

}  // namespace
}  // namespace psrig::formats
