// Loading a maps directory for the preview: decoded values, the pixel size
// from the report, errors that name the file; and which scan the kiosk
// picks from a catalogue.

#include "psrig/preview/swatch_maps.h"

#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/map_encoding.h"
#include "psrig/preview/newest_scan.h"
#include "test_support.h"

namespace psrig::preview {
namespace {

namespace fs = std::filesystem;

// A small maps directory as `psrig process` writes it: albedo.png,
// normal.png and report.json (gradients p = 0.2, q = -0.1 everywhere).
void write_maps(const fs::path& dir, cv::Size size = {8, 6}) {
  fs::create_directories(dir);
  cv::imwrite((dir / "albedo.png").string(), cv::Mat(size, CV_8UC3, cv::Scalar(188, 188, 188)));
  const cv::Mat p(size, CV_32F, cv::Scalar(0.2)), q(size, CV_32F, cv::Scalar(-0.1));
  cv::imwrite((dir / "normal.png").string(), formats::encode_normal16(p, q));
  std::ofstream(dir / "report.json")
      << R"({"inputs": {"pixel_size_mm": 0.05, "sample": {"id": "J-7"}}, "height": {"units": "mm"}})";
}

TEST(SwatchMaps, LoadsWhatProcessingWrites) {
  const test::TempDir temp;
  write_maps(temp.path());
  auto maps = load_swatch_maps(temp.path());
  ASSERT_TRUE(maps) << maps.error().describe();
  EXPECT_EQ(maps->size(), cv::Size(8, 6));
  EXPECT_NEAR(maps->albedo.at<cv::Vec3f>(2, 3)[0], 0.5, 0.003);  // sRGB 188 is linear 0.5
  const cv::Vec3f expected = cv::normalize(cv::Vec3f(-0.2f, 0.1f, 1.0f));
  const cv::Vec3f normal = maps->normal.at<cv::Vec3f>(1, 1);
  EXPECT_LT(cv::norm(normal - expected), 1e-4) << normal;
  EXPECT_DOUBLE_EQ(maps->pixel_size_mm, 0.05);
  EXPECT_EQ(maps->sample_id, "J-7");
  EXPECT_EQ(maps->height_units, "mm");
  EXPECT_NEAR(maps->extent().width, 0.4, 1e-12);
  EXPECT_TRUE(maps->gloss.empty());
  EXPECT_TRUE(maps->alpha.empty());
}

TEST(SwatchMaps, OptionalGlossAndAlphaMaps) {
  const test::TempDir temp;
  write_maps(temp.path());
  cv::imwrite((temp / "gloss.png").string(), cv::Mat(6, 8, CV_8U, cv::Scalar(51)));
  cv::imwrite((temp / "alpha.png").string(), cv::Mat(6, 8, CV_16U, cv::Scalar(65535)));
  auto maps = load_swatch_maps(temp.path());
  ASSERT_TRUE(maps) << maps.error().describe();
  EXPECT_NEAR(maps->gloss.at<float>(0, 0), 0.2, 1e-6);
  EXPECT_NEAR(maps->alpha.at<float>(5, 7), 1.0, 1e-6);
}

TEST(SwatchMaps, ErrorsNameTheFile) {
  const test::TempDir temp;
  write_maps(temp.path());
  fs::remove(temp / "normal.png");
  auto missing = load_swatch_maps(temp.path());
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().describe().find("normal.png"), std::string::npos)
      << missing.error().describe();

  write_maps(temp.path());
  cv::imwrite((temp / "gloss.png").string(), cv::Mat(3, 4, CV_8U, cv::Scalar(9)));
  auto wrong_size = load_swatch_maps(temp.path());
  ASSERT_FALSE(wrong_size);
  EXPECT_NE(wrong_size.error().describe().find("gloss.png"), std::string::npos);
  EXPECT_NE(wrong_size.error().describe().find("4x3"), std::string::npos);

  cv::imwrite((temp / "gloss.png").string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar(9)));
  auto colour = load_swatch_maps(temp.path());
  ASSERT_FALSE(colour);
  EXPECT_NE(colour.error().describe().find("grey"), std::string::npos);
  fs::remove(temp / "gloss.png");

  std::ofstream(temp / "report.json") << R"({"inputs": {"pixel_size_mm": "small"}})";
  auto bad_report = load_swatch_maps(temp.path());
  ASSERT_FALSE(bad_report);
  EXPECT_NE(bad_report.error().describe().find("inputs.pixel_size_mm"), std::string::npos);

  auto not_a_directory = load_swatch_maps(temp / "nowhere");
  ASSERT_FALSE(not_a_directory);
  EXPECT_EQ(exit_code(not_a_directory.error()), 2);
}

TEST(NewestMaps, PicksTheLatestFinishedScan) {
  const test::TempDir temp;
  EXPECT_FALSE(newest_maps(temp.path()));
  EXPECT_FALSE(newest_maps(temp / "absent"));
  write_maps(temp / "scan-a" / "maps");
  EXPECT_EQ(newest_maps(temp.path()), temp / "scan-a" / "maps");
  // A scan still being processed (no report yet) is not picked.
  fs::create_directories(temp / "scan-c" / "maps");
  write_maps(temp / "scan-b" / "maps");
  fs::last_write_time(
      temp / "scan-b" / "maps" / "report.json",
      fs::last_write_time(temp / "scan-a" / "maps" / "report.json") + std::chrono::seconds(5));
  EXPECT_EQ(newest_maps(temp.path()), temp / "scan-b" / "maps");
  // A maps directory straight in the catalogue counts too.
  write_maps(temp / "loose-maps");
  fs::last_write_time(
      temp / "loose-maps" / "report.json",
      fs::last_write_time(temp / "scan-b" / "maps" / "report.json") + std::chrono::seconds(5));
  EXPECT_EQ(newest_maps(temp.path()), temp / "loose-maps");
}

}  // namespace
}  // namespace psrig::preview
