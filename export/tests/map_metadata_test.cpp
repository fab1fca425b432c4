// Maps that carry their scale: PNG pHYs, sRGB or gAMA 1.0, text chunks;
// EXR attributes; and the maps psrig process writes carry them.

#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/image_metadata.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/processing/pipeline.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using formats::ImageMetadata;

struct PngChunks {
  std::vector<std::string> order;                          // chunk types as they come
  std::map<std::string, std::vector<unsigned char>> data;  // the last of each type
  std::map<std::string, std::string> text;                 // tEXt and iTXt by keyword
};

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         p[3];
}

PngChunks read_chunks(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  const std::vector<unsigned char> bytes{std::istreambuf_iterator<char>(in), {}};
  PngChunks chunks;
  for (std::size_t at = 8; at + 12 <= bytes.size();) {
    const std::uint32_t length = be32(&bytes[at]);
    const std::string type(bytes.begin() + at + 4, bytes.begin() + at + 8);
    std::vector<unsigned char> data(bytes.begin() + at + 8, bytes.begin() + at + 8 + length);
    if (type == "tEXt" || type == "iTXt") {
      const auto nul = std::find(data.begin(), data.end(), 0);
      const std::string keyword(data.begin(), nul);
      auto value = nul + 1;
      if (type == "iTXt") {  // flag, method, language\0, translated keyword\0
        value += 2;
        value = std::find(value, data.end(), 0) + 1;
        value = std::find(value, data.end(), 0) + 1;
      }
      chunks.text[keyword] = std::string(value, data.end());
    }
    chunks.order.push_back(type);
    chunks.data[type] = std::move(data);
    at += 12 + length;
  }
  return chunks;
}

ImageMetadata sample_metadata(ImageMetadata::ColourSpace space) {
  ImageMetadata m;
  m.pixel_size_mm = 0.025;
  m.colour_space = space;
  m.text = {{"psrig:sample_id", "S-7"},
            {"Creation Time", "2026-11-25T03:00:00Z"},
            {"Comment", "Strickgewebe, grün"}};
  return m;
}

TEST(MapMetadata, ColourPngCarriesSrgbScaleAndText) {
  TempDir dir;
  cv::Mat image(20, 30, CV_8UC3, cv::Scalar(10, 120, 240));
  ASSERT_TRUE(formats::write_image(dir / "a.png", image, {},
                                   sample_metadata(ImageMetadata::ColourSpace::colour)));
  const PngChunks chunks = read_chunks(dir / "a.png");
  ASSERT_TRUE(chunks.data.contains("sRGB"));
  EXPECT_EQ(be32(chunks.data.at("gAMA").data()), 45455u);
  ASSERT_TRUE(chunks.data.contains("cHRM"));
  const auto& phys = chunks.data.at("pHYs");
  EXPECT_EQ(be32(phys.data()), 40000u);  // 1000 mm / 0.025 mm per metre
  EXPECT_EQ(be32(phys.data() + 4), 40000u);
  EXPECT_EQ(phys[8], 1);  // metres
  EXPECT_EQ(chunks.text.at("psrig:sample_id"), "S-7");
  EXPECT_EQ(chunks.text.at("Comment"), "Strickgewebe, grün");  // UTF-8 through iTXt
  // Every ancillary chunk before the image data, as PNG requires of these.
  const auto idat = std::find(chunks.order.begin(), chunks.order.end(), "IDAT");
  for (const char* type : {"sRGB", "gAMA", "cHRM", "pHYs", "tEXt", "iTXt"})
    EXPECT_LT(std::find(chunks.order.begin(), chunks.order.end(), type), idat) << type;
  // libpng (through OpenCV) reads it back unchanged: the CRCs hold.
  const cv::Mat back = cv::imread((dir / "a.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0);
}

TEST(MapMetadata, DataPngIsLinearNotSrgb) {
  TempDir dir;
  cv::Mat image(8, 8, CV_16UC1, cv::Scalar(1234));
  ASSERT_TRUE(formats::write_image(dir / "h.png", image, {cv::IMWRITE_PNG_COMPRESSION, 0},
                                   sample_metadata(ImageMetadata::ColourSpace::data)));
  const PngChunks chunks = read_chunks(dir / "h.png");
  EXPECT_FALSE(chunks.data.contains("sRGB"));
  EXPECT_EQ(be32(chunks.data.at("gAMA").data()), 100000u);  // gamma 1.0
  const cv::Mat back = cv::imread((dir / "h.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0);
}

TEST(MapMetadata, ExrCarriesAttributes) {
  TempDir dir;
  cv::Mat image(6, 9, CV_32F, cv::Scalar(0.125));
  ASSERT_TRUE(formats::write_image(dir / "h.exr", image, {},
                                   sample_metadata(ImageMetadata::ColourSpace::data)));
  Imf::InputFile in((dir / "h.exr").c_str());
  const Imf::Header& header = in.header();
  ASSERT_TRUE(Imf::hasXDensity(header));
  EXPECT_NEAR(Imf::xDensity(header), 25.4 / 0.025, 1e-3);
  const auto* sample = header.findTypedAttribute<Imf::StringAttribute>("psrig:sample_id");
  ASSERT_NE(sample, nullptr);
  EXPECT_EQ(sample->value(), "S-7");
  ASSERT_NE(header.findTypedAttribute<Imf::StringAttribute>("psrig:pixel_size_mm"), nullptr);
  const cv::Mat back = cv::imread((dir / "h.exr").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_32FC1);
  EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0);
  // The caller's compression is kept.
  ASSERT_TRUE(formats::write_image(dir / "z.exr", image,
                                   {cv::IMWRITE_EXR_COMPRESSION, cv::IMWRITE_EXR_COMPRESSION_ZIP},
                                   sample_metadata(ImageMetadata::ColourSpace::data)));
  EXPECT_EQ(Imf::InputFile((dir / "z.exr").c_str()).header().compression(), Imf::ZIP_COMPRESSION);
  EXPECT_EQ(in.header().compression(), Imf::NO_COMPRESSION);
  // Three channels, half: OpenCV reads the colours back in its order.
  cv::Mat colour(4, 5, CV_32FC3, cv::Scalar(0.25, 0.5, 0.75));
  ASSERT_TRUE(formats::write_image(dir / "c.exr", colour,
                                   {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_HALF},
                                   sample_metadata(ImageMetadata::ColourSpace::unspecified)));
  const cv::Mat colour_back = cv::imread((dir / "c.exr").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(colour_back.type(), CV_32FC3);
  EXPECT_EQ(cv::norm(colour_back, colour, cv::NORM_INF), 0.0);
}

TEST(MapMetadata, DirectxNormalFlipsGreenOnly) {
  cv::Mat normal(2, 2, CV_16UC3, cv::Scalar(100, 2000, 30000));  // BGR
  const cv::Mat dx = formats::flip_normal_green(normal);
  EXPECT_EQ(dx.at<cv::Vec3w>(1, 1), cv::Vec3w(100, 65535 - 2000, 30000));
  EXPECT_EQ(cv::norm(formats::flip_normal_green(dx), normal, cv::NORM_INF), 0.0);
}

TEST(MapMetadata, ProcessedMapsCarryScaleSampleAndConvention) {
  TempDir dir;
  sim::SyntheticScanParams params;
  params.swatch.pattern = test::named_pattern("jersey");
  params.swatch.size = {96, 64};
  params.swatch.pixel_size_mm = 0.04;
  auto scan = test::made(sim::make_synthetic_scan(params));
  scan.description.sample_id = "S-9";
  ASSERT_TRUE(formats::write_scan(scan, dir / "scan"));
  processing::ProcessOptions options;
  options.directx_normal = true;
  auto summary = processing::process_scan(dir / "scan", options);
  ASSERT_TRUE(summary) << summary.error().describe();
  const fs::path maps = summary->maps_directory;
  const auto albedo = read_chunks(maps / "albedo.png");
  EXPECT_EQ(albedo.text.at("psrig:sample_id"), "S-9");
  EXPECT_TRUE(albedo.data.contains("sRGB"));
  EXPECT_EQ(be32(albedo.data.at("pHYs").data()), 25000u);  // 0.04 mm
  const auto normal = read_chunks(maps / "normal.png");
  EXPECT_FALSE(normal.data.contains("sRGB"));
  EXPECT_EQ(normal.text.at("psrig:normal_convention"), "OpenGL (+Y up)");
  const auto dx = read_chunks(maps / "normal_directx.png");
  EXPECT_EQ(dx.text.at("psrig:normal_convention"), "DirectX (+Y down)");
  const auto height = read_chunks(maps / "height.png");
  EXPECT_EQ(height.text.at("psrig:units"), "mm");
  const auto& range = summary->report["height"]["png_range"];
  char expected[80];
  std::snprintf(expected, sizeof expected, "%.9g %.9g", range[0].get<double>(),
                range[1].get<double>());
  EXPECT_EQ(height.text.at("psrig:height_range"), expected);
  Imf::InputFile exr((maps / "height.exr").c_str());
  EXPECT_NEAR(Imf::xDensity(exr.header()), 25.4 / 0.04, 1e-3);
  EXPECT_EQ(summary->report["options"]["normal_convention"], "opengl, directx");
}

}  // namespace
}  // namespace psrig::test
