// Image files: psrig's own PNG path must agree with OpenCV's both ways, and
// damaged files must give errors, never crashes or wrong pixels.

#include "psrig/formats/image_io.h"

#include <cstring>
#include <fstream>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_support.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;

cv::Mat random_image(int type, int seed) {
  cv::Mat image(37, 53, type);  // odd sizes: no row is a multiple of anything
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, image.depth() == CV_8U ? 256 : 65536);
  // A smooth part too, so the compressor has something to find.
  image(cv::Rect(0, 0, 20, 20)).setTo(cv::Scalar::all(image.depth() == CV_8U ? 77 : 40000));
  return image;
}

const int kTypes[] = {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3};

TEST(ImageIo, PngRoundTripsEveryTypeAtEveryLevel) {
  test::TempDir temp;
  for (int type : kTypes) {
    const cv::Mat image = random_image(type, type);
    for (int level : {0, 1, 6}) {
      const fs::path file =
          temp / ("t" + std::to_string(type) + "_" + std::to_string(level) + ".png");
      ASSERT_TRUE(formats::write_image(file, image, {cv::IMWRITE_PNG_COMPRESSION, level}));
      auto back = formats::read_image(file, "test");
      ASSERT_TRUE(back) << back.error().describe();
      EXPECT_EQ(back->type(), type);
      EXPECT_EQ(cv::norm(*back, image, cv::NORM_INF), 0) << "type " << type << " level " << level;
      // OpenCV (libpng) reads what psrig wrote, channel order included.
      const cv::Mat by_opencv = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
      EXPECT_EQ(cv::norm(by_opencv, image, cv::NORM_INF), 0)
          << "type " << type << " level " << level;
    }
  }
}

TEST(ImageIo, LargePngsSpanManyChunksBothWays) {
  // Several megabytes of noise: psrig's writer emits many IDAT chunks, its
  // reader and libpng must both put them back together.
  test::TempDir temp;
  cv::Mat image(900, 1300, CV_16UC3);
  cv::RNG(9).fill(image, cv::RNG::UNIFORM, 0, 65536);
  ASSERT_TRUE(formats::write_image(temp / "big.png", image));
  EXPECT_GT(std::filesystem::file_size(temp / "big.png"), 3u << 20);
  auto back = formats::read_image(temp / "big.png", "test");
  ASSERT_TRUE(back);
  EXPECT_EQ(cv::norm(*back, image, cv::NORM_INF), 0);
  EXPECT_EQ(
      cv::norm(cv::imread((temp / "big.png").string(), cv::IMREAD_UNCHANGED), image, cv::NORM_INF),
      0);
}

TEST(ImageIo, ReadsWhatLibpngWroteWithEveryFilter) {
  // At level 9 libpng picks filters per row adaptively (Sub, Up, Average,
  // Paeth): psrig's reader must undo all of them exactly.
  test::TempDir temp;
  for (int type : kTypes) {
    cv::Mat image = random_image(type, 100 + type);
    cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);  // gradients make Paeth and Average win
    const fs::path file = temp / ("lib" + std::to_string(type) + ".png");
    ASSERT_TRUE(cv::imwrite(file.string(), image, {cv::IMWRITE_PNG_COMPRESSION, 9}));
    auto back = formats::read_image(file, "test");
    ASSERT_TRUE(back) << back.error().describe();
    EXPECT_EQ(cv::norm(*back, image, cv::NORM_INF), 0) << "type " << type;
  }
}

// The PNG at `file` with its image data cut into IDAT chunks of 1 to 13
// bytes; `keep` of the data's bytes kept (all by default).
std::string rechunked_png(const fs::path& file, std::size_t keep = std::string::npos) {
  std::ifstream in(file, std::ios::binary);
  const std::string png((std::istreambuf_iterator<char>(in)), {});
  const auto be32 = [&](std::size_t at) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(png[at])) << 24 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(png[at + 1])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(png[at + 2])) << 8 |
           static_cast<unsigned char>(png[at + 3]);
  };
  const auto crc32 = [](const std::string& bytes) {
    std::uint32_t crc = 0xFFFFFFFFU;
    for (unsigned char b : bytes) {
      crc ^= b;
      for (int k = 0; k < 8; ++k)
        crc = (crc >> 1) ^ (0xEDB88320U & (0U - (crc & 1U)));
    }
    return ~crc;
  };
  const auto chunk = [&](const std::string& type, const std::string& data) {
    std::string out;
    for (std::uint32_t v : {static_cast<std::uint32_t>(data.size())})
      for (int shift : {24, 16, 8, 0})
        out += static_cast<char>(v >> shift);
    const std::uint32_t crc = crc32(type + data);
    out += type + data;
    for (int shift : {24, 16, 8, 0})
      out += static_cast<char>(crc >> shift);
    return out;
  };
  std::string before, data, after;
  for (std::size_t at = 8; at + 12 <= png.size();) {
    const std::uint32_t length = be32(at);
    const std::string type = png.substr(at + 4, 4);
    if (type == "IDAT")
      data += png.substr(at + 8, length);
    else
      (data.empty() ? before : after) += png.substr(at, 12 + length);
    at += 12 + length;
  }
  data = data.substr(0, keep);
  std::string out = png.substr(0, 8) + before;
  for (std::size_t at = 0, size = 1; at < data.size(); at += size, size = size % 13 + 1)
    out += chunk("IDAT", data.substr(at, size));
  return out + after;
}

// Image data cut into thousands of tiny chunks, inflated a batch of rows at
// a time: every boundary falls somewhere inside a chunk, a row or a symbol.
TEST(ImageIo, PngDataInTinyChunksAcrossBatchesOfRows) {
  test::TempDir temp;
  cv::Mat image(700, 900, CV_16UC3);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c)
      image.at<cv::Vec3w>(r, c) =
          cv::Vec3w(static_cast<std::uint16_t>(r * 90 + c), static_cast<std::uint16_t>(c * 70),
                    static_cast<std::uint16_t>((r * c) % 65536));
  ASSERT_TRUE(formats::write_image(temp / "whole.png", image));
  const std::string tiny = rechunked_png(temp / "whole.png");
  std::ofstream(temp / "tiny.png", std::ios::binary) << tiny;
  auto back = formats::read_image(temp / "tiny.png", "test");
  ASSERT_TRUE(back) << back.error().describe();
  EXPECT_EQ(cv::norm(*back, image, cv::NORM_INF), 0);
  // Its data cut short: an error, never a half-read image.
  const std::size_t data_bytes = std::filesystem::file_size(temp / "whole.png");
  std::ofstream(temp / "short.png", std::ios::binary)
      << rechunked_png(temp / "whole.png", data_bytes / 2);
  EXPECT_FALSE(formats::read_image(temp / "short.png", "test"));
}

TEST(ImageIo, PngsOutsideTheFastPathStillRead) {
  test::TempDir temp;
  const cv::Mat rgba(9, 7, CV_16UC4, cv::Scalar(1000, 2000, 3000, 65535));
  ASSERT_TRUE(cv::imwrite((temp / "rgba.png").string(), rgba));
  auto back = formats::read_image(temp / "rgba.png", "test");
  ASSERT_TRUE(back);
  EXPECT_EQ(back->type(), CV_16UC4);  // the scan reader then refuses it, naming the alpha channel
  EXPECT_EQ(cv::norm(*back, rgba, cv::NORM_INF), 0);
}

TEST(ImageIo, DamagedPngsGiveErrors) {
  test::TempDir temp;
  const cv::Mat image = random_image(CV_16UC3, 5);
  const fs::path good = temp / "good.png";
  ASSERT_TRUE(formats::write_image(good, image));
  std::ifstream in(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});

  // Truncated anywhere: an error, not a crash.
  for (std::size_t keep : {std::size_t{10}, std::size_t{40}, bytes.size() / 2, bytes.size() - 5}) {
    const fs::path file = temp / "cut.png";
    std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
    auto read = formats::read_image(file, "lights[0].image");
    ASSERT_FALSE(read) << "kept " << keep;
    EXPECT_EQ(read.error().kind, ErrorKind::bad_input);
    EXPECT_EQ(read.error().key, "lights[0].image");
  }
  // Flipped bytes: the CRC catches them (or the read fails); never a wrong image.
  std::mt19937 random(3);
  for (int trial = 0; trial < 50; ++trial) {
    std::string damaged = bytes;
    const std::size_t at = 33 + random() % (damaged.size() - 45);
    damaged[at] = static_cast<char>(damaged[at] ^ (1 + random() % 255));
    const fs::path file = temp / "flip.png";
    std::ofstream(file, std::ios::binary)
        .write(damaged.data(), static_cast<std::streamsize>(damaged.size()));
    auto read = formats::read_image(file, "x");
    if (read) {
      EXPECT_EQ(cv::norm(*read, image, cv::NORM_INF), 0) << "byte " << at;
    }
  }
}

// A chunk whose length runs past the end of the file (found by fuzzing: a
// 127-byte file made libpng allocate 976 MB before finding it short) is
// refused from its length, naming the chunk.
TEST(ImageIo, AChunkLongerThanTheFileIsRefusedBeforeAnyoneAllocatesIt) {
  test::TempDir temp;
  const fs::path good = temp / "good.png";
  ASSERT_TRUE(formats::write_image(good, random_image(CV_8UC1, 3)));
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), {});
  // After IHDR (8 + 25 bytes): a tEXt chunk declaring 0x3A2F0019 bytes.
  bytes.insert(33, std::string("\x3a\x2f\x00\x19tEXtComment\0short", 22));
  const fs::path file = temp / "text.png";
  std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  auto read = formats::read_image(file, "mask");
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().kind, ErrorKind::bad_input);
  EXPECT_NE(read.error().message.find("damaged PNG: chunk 'tEXt' at byte 33 declares 976158745 bytes"),
            std::string::npos)
      << read.error().describe();
}

// psrig's EXR path reads what OpenCV reads, bit for bit (NaN and
// infinities too), for every file it takes: Y or R, G, B, half or float,
// written by OpenEXR with attributes or by OpenCV, any compression; files
// with other channels go to OpenCV's reader as before.
TEST(ImageIo, ExrsReadAsOpenCvReadsThem) {
  test::TempDir temp;
  const auto same_bits = [](const cv::Mat& a, const cv::Mat& b) {
    if (a.type() != b.type() || a.size() != b.size()) return false;
    for (int r = 0; r < a.rows; ++r)
      if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
    return true;
  };
  formats::ImageMetadata metadata;
  metadata.text.emplace_back("psrig:test", "yes");
  int written = 0;
  for (int channels : {1, 3}) {
    cv::Mat image(37, 53, CV_32FC(channels));
    cv::RNG(channels).fill(image, cv::RNG::UNIFORM, -4, 4);
    image.at<float>(3, 5) = std::numeric_limits<float>::quiet_NaN();
    image.at<float>(7, 2) = std::numeric_limits<float>::infinity();
    for (int type : {cv::IMWRITE_EXR_TYPE_FLOAT, cv::IMWRITE_EXR_TYPE_HALF})
      for (int compression : {cv::IMWRITE_EXR_COMPRESSION_NO, cv::IMWRITE_EXR_COMPRESSION_ZIP,
                              cv::IMWRITE_EXR_COMPRESSION_PIZ})
        for (bool with_metadata : {false, true}) {
          const fs::path file = temp / ("e" + std::to_string(written++) + ".exr");
          const std::vector<int> params = {cv::IMWRITE_EXR_TYPE, type, cv::IMWRITE_EXR_COMPRESSION,
                                           compression};
          ASSERT_TRUE(with_metadata ? formats::write_image(file, image, params, metadata)
                                    : formats::write_image(file, image, params));
          auto read = formats::read_image(file, "test");
          ASSERT_TRUE(read) << read.error().describe();
          EXPECT_TRUE(same_bits(*read, cv::imread(file.string(), cv::IMREAD_UNCHANGED)))
              << file << " channels " << channels << " type " << type << " compression "
              << compression;
        }
  }
  // Grey and alpha: not the fast path's, read by OpenCV.
  cv::Mat grey_alpha(20, 30, CV_32FC4, cv::Scalar(0.25, 0.5, 0.75, 1.0));
  ASSERT_TRUE(formats::write_image(temp / "alpha.exr", grey_alpha));
  auto read = formats::read_image(temp / "alpha.exr", "test");
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_TRUE(same_bits(*read, cv::imread((temp / "alpha.exr").string(), cv::IMREAD_UNCHANGED)));
  // A damaged EXR is OpenCV's to refuse, as before.
  std::ofstream(temp / "damaged.exr", std::ios::binary) << "v/1\x01not an exr";
  EXPECT_FALSE(formats::read_image(temp / "damaged.exr", "test"));
}

TEST(ImageIo, WriteErrorsNameTheFile) {
  auto failed = formats::write_image("/nonexistent-dir/x.png", cv::Mat(4, 4, CV_8U, cv::Scalar(1)));
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().file, fs::path("/nonexistent-dir/x.png"));
}

}  // namespace
}  // namespace psrig::processing
