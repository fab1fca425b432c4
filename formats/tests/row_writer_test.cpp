// Maps written a band of rows at a time must be the very files write_image
// writes whole: every PNG type and level, every EXR sample type and
// compression, bands of any height.

#include "psrig/formats/row_writer.h"

#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/image_io.h"
#include "test_support.h"

namespace psrig::formats {
namespace {

namespace fs = std::filesystem;

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Smooth with noise, in the range of `type`: something for the compressors.
cv::Mat test_image(int type) {
  cv::Mat image(301, 173, type);  // more than a PNG batch or an EXR line block; odd sizes
  cv::Mat noise(image.size(), CV_MAKETYPE(CV_32F, image.channels()));
  cv::RNG(type).fill(noise, cv::RNG::NORMAL, 0, 0.05);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols * image.channels(); ++c)
      noise.ptr<float>(r)[c] += 0.5F + 0.3F * std::sin(r * 0.05F + c * 0.03F);
  const double scale = CV_MAT_DEPTH(type) == CV_8U ? 255 : CV_MAT_DEPTH(type) == CV_16U ? 65535 : 1;
  noise.convertTo(image, type, scale);
  return image;
}

// Bands of 1, 7, 32, 100 rows, then the rest.
Status write_in_bands(const fs::path& file, const cv::Mat& image, const std::vector<int>& params,
                      const ImageMetadata& metadata) {
  auto writer = RowWriter::open(file, image.size(), image.type(), params, metadata);
  if (!writer) return std::unexpected(writer.error());
  int row = 0;
  for (int band : {1, 7, 32, 100, image.rows}) {
    const int end = std::min(image.rows, row + band);
    if (auto ok = writer->write(image.rowRange(row, end)); !ok) return ok;
    row = end;
  }
  return writer->finish();
}

ImageMetadata metadata() {
  ImageMetadata m;
  m.pixel_size_mm = 0.025;
  m.colour_space = ImageMetadata::ColourSpace::data;
  m.text.emplace_back("psrig:sample_id", "S-1");
  return m;
}

TEST(RowWriter, PngsAreTheFilesWriteImageWrites) {
  test::TempDir temp;
  for (int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3})
    for (int level : {0, 1, 6}) {
      const cv::Mat image = test_image(type);
      const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, level};
      ASSERT_TRUE(write_image(temp / "whole.png", image, params, metadata()));
      ASSERT_TRUE(write_in_bands(temp / "bands.png", image, params, metadata()));
      EXPECT_EQ(bytes_of(temp / "whole.png"), bytes_of(temp / "bands.png"))
          << "type " << type << " level " << level;
    }
}

TEST(RowWriter, ExrsAreTheFilesWriteImageWrites) {
  test::TempDir temp;
  for (int type : {CV_32FC1, CV_32FC3})
    for (int sample : {cv::IMWRITE_EXR_TYPE_HALF, cv::IMWRITE_EXR_TYPE_FLOAT})
      for (int compression : {cv::IMWRITE_EXR_COMPRESSION_NO, cv::IMWRITE_EXR_COMPRESSION_ZIP,
                              cv::IMWRITE_EXR_COMPRESSION_PIZ}) {
        const cv::Mat image = test_image(type);
        const std::vector<int> params = {cv::IMWRITE_EXR_TYPE, sample, cv::IMWRITE_EXR_COMPRESSION,
                                         compression};
        ASSERT_TRUE(write_image(temp / "whole.exr", image, params, metadata()));
        ASSERT_TRUE(write_in_bands(temp / "bands.exr", image, params, metadata()));
        EXPECT_EQ(bytes_of(temp / "whole.exr"), bytes_of(temp / "bands.exr"))
            << "type " << type << " sample " << sample << " compression " << compression;
      }
}

TEST(RowWriter, RefusesWhatItCannotStreamAndRowsThatDoNotFit) {
  test::TempDir temp;
  EXPECT_FALSE(RowWriter::open(temp / "a.tif", {8, 8}, CV_16UC1, {}, {}));
  EXPECT_FALSE(RowWriter::open(temp / "a.png", {8, 8}, CV_32FC1, {}, {}));
  EXPECT_FALSE(RowWriter::open(temp / "a.exr", {8, 8}, CV_16UC1, {}, {}));
  auto writer = RowWriter::open(temp / "a.png", {8, 8}, CV_8UC1, {}, {});
  ASSERT_TRUE(writer);
  EXPECT_FALSE(writer->write(cv::Mat(2, 9, CV_8UC1, cv::Scalar(1))));   // too wide
  EXPECT_FALSE(writer->write(cv::Mat(2, 8, CV_16UC1, cv::Scalar(1))));  // not its type
  EXPECT_FALSE(writer->write(cv::Mat(9, 8, CV_8UC1, cv::Scalar(1))));   // past the last row
  ASSERT_TRUE(writer->write(cv::Mat(4, 8, CV_8UC1, cv::Scalar(1))));
  EXPECT_FALSE(writer->finish());  // four rows short
}

TEST(RowWriter, AFileThatCannotBeCreatedIsAnErrorNamingIt) {
  for (const char* name : {"/nonexistent-dir/x.png", "/nonexistent-dir/x.exr"}) {
    auto writer = RowWriter::open(
        name, {8, 8}, std::string(name).ends_with("png") ? CV_8UC1 : CV_32FC1, {}, metadata());
    ASSERT_FALSE(writer) << name;
    EXPECT_EQ(writer.error().file, fs::path(name));
  }
}

}  // namespace
}  // namespace psrig::formats
