// Reading psrig-scan/1 directories, and every way one can be wrong.

#include "psrig/formats/scan_reader.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_writer.h"
#include "synthetic_scene.h"
#include "test_support.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;

class ScanReader : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto surface = test::sphere_surface({64, 48}, 20, 3);
    formats::Scan scan = test::render_scan(surface, test::ring_lights(3, 45), CV_16U);
    scan.description.sample_id = "J-0042";
    scan.description.pixel_size_mm = 0.05;
    ASSERT_TRUE(formats::write_scan(scan, dir_));
  }

  nlohmann::json load_json() const {
    std::ifstream in(dir_ / "scan.json");
    return nlohmann::json::parse(in);
  }
  void save_json(const nlohmann::json& doc) const { save_text(doc.dump(2)); }
  void save_text(const std::string& text) const { std::ofstream(dir_ / "scan.json") << text; }

  // Reads the scan expecting a bad-input error about `key` in `file`.
  Error expect_error(const std::string& file, const std::string& key) const {
    auto scan = formats::read_scan(dir_);
    EXPECT_FALSE(scan) << "read a bad scan without complaint";
    if (scan) return {};
    const Error& e = scan.error();
    EXPECT_EQ(e.kind, ErrorKind::bad_input) << e.describe();
    EXPECT_EQ(e.file.filename().string(), file) << e.describe();
    EXPECT_EQ(e.key, key) << e.describe();
    return e;
  }

  test::TempDir temp_;
  fs::path dir_ = temp_ / "scan";
};

TEST_F(ScanReader, ReadsWhatTheWriterWrote) {
  auto scan = formats::read_scan(dir_);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(scan->frames.size(), 3u);
  EXPECT_EQ(scan->size(), cv::Size(64, 48));
  EXPECT_EQ(scan->channels(), 3);
  EXPECT_EQ(scan->depth(), CV_16U);
  EXPECT_EQ(scan->white_level, 65535);
  EXPECT_EQ(scan->description.sample_id, "J-0042");
  EXPECT_EQ(scan->description.pixel_size_mm, 0.05);
  EXPECT_NEAR(scan->description.lights[1].direction[1], std::sin(2 * CV_PI / 3) * std::sqrt(0.5),
              1e-9);
  ASSERT_FALSE(scan->ground_truth_normal.empty());
  EXPECT_EQ(scan->ground_truth_normal.type(), CV_32FC3);
  // Ground truth comes back in (x, y, z), whatever the file's channel order.
  const cv::Vec3f up = scan->ground_truth_normal.at<cv::Vec3f>(10, 32);
  EXPECT_GT(up[1], 0.3f);
  EXPECT_GT(up[2], 0.3f);
}

// Processing reads the ground truth when it needs it: the same images, and
// the same checks then.
TEST_F(ScanReader, GroundTruthCanBeReadWhenNeeded) {
  auto whole = formats::read_scan(dir_);
  auto later = formats::read_scan(dir_, formats::ScanImages::without_ground_truth);
  ASSERT_TRUE(whole && later);
  EXPECT_TRUE(later->ground_truth_normal.empty());
  ASSERT_TRUE(formats::read_ground_truth(*later, formats::GroundTruth::normal, later->size()));
  EXPECT_EQ(cv::norm(later->ground_truth_normal, whole->ground_truth_normal, cv::NORM_INF), 0);
  // None named: nothing to do.
  EXPECT_TRUE(formats::read_ground_truth(*later, formats::GroundTruth::height, later->size()));
  EXPECT_TRUE(later->ground_truth_height.empty());

  // One of the wrong size: refused by read_scan, and by read_ground_truth.
  ASSERT_TRUE(formats::write_vector_exr(dir_ / "gt_normal.exr",
                                        cv::Mat(10, 10, CV_32FC3, cv::Scalar(0, 0, 1))));
  expect_error("gt_normal.exr", "ground_truth.normal");
  auto lazy = formats::read_scan(dir_, formats::ScanImages::without_ground_truth);
  ASSERT_TRUE(lazy) << lazy.error().describe();
  const auto refused = formats::read_ground_truth(*lazy, formats::GroundTruth::normal, {64, 48});
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(refused.error().key, "ground_truth.normal");
  EXPECT_EQ(refused.error().file.filename(), "gt_normal.exr");
  EXPECT_NE(refused.error().message.find("expected 64x48 32-bit float 3-channel"),
            std::string::npos)
      << refused.error().describe();
}

TEST_F(ScanReader, KeepsUnknownKeys) {
  auto doc = load_json();
  doc["vendor"] = {{"rig_serial", "A17"}, {"temperature_c", 31.5}};
  doc["lights"][0]["wavelength_nm"] = 630;
  save_json(doc);
  auto scan = formats::read_scan(dir_);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(scan->description.document["vendor"]["rig_serial"], "A17");
  EXPECT_EQ(scan->description.document["lights"][0]["wavelength_nm"], 630);
  // ...and writing the scan again keeps them.
  EXPECT_EQ(formats::scan_json(*scan)["vendor"]["temperature_c"], 31.5);
}

TEST_F(ScanReader, MissingDirectoryAndScanJson) {
  auto missing = formats::read_scan(temp_ / "nowhere");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("no such"), std::string::npos);
  fs::remove(dir_ / "scan.json");
  const Error e = expect_error("scan.json", "");
  EXPECT_NE(e.message.find("missing"), std::string::npos);
}

TEST_F(ScanReader, MalformedJsonGivesLineAndColumn) {
  save_text("{\n  \"format\": \"psrig-scan/1\",\n  \"lights\": [,]\n}\n");
  const Error e = expect_error("scan.json", "");
  EXPECT_EQ(e.line, 3);
  EXPECT_EQ(e.column, 14);
  EXPECT_NE(e.describe().find("scan.json:3:14: malformed JSON"), std::string::npos) << e.describe();
}

TEST_F(ScanReader, WrongFormat) {
  auto doc = load_json();
  doc["format"] = "psrig-scan/2";
  save_json(doc);
  expect_error("scan.json", "format");
}

TEST_F(ScanReader, FewerThanThreeLights) {
  auto doc = load_json();
  doc["lights"].erase(2);
  save_json(doc);
  const Error e = expect_error("scan.json", "lights");
  EXPECT_NE(e.message.find("2 light(s)"), std::string::npos) << e.message;
}

TEST_F(ScanReader, ZeroDirection) {
  auto doc = load_json();
  doc["lights"][1]["direction"] = {0, 0, 0};
  save_json(doc);
  expect_error("scan.json", "lights[1].direction");
}

TEST_F(ScanReader, NonFiniteNumber) {
  // JSON has no NaN or infinity literal; the nearest thing is a number too
  // large for a double, which must be an error, not an exception.
  auto text = load_json().dump(2);
  const auto at = text.find("\"direction\"");
  const auto open = text.find('[', at), close = text.find(']', at);
  text.replace(open, close - open + 1, "[1e400, 0, 1]");
  save_text(text);
  const Error e = expect_error("scan.json", "");
  EXPECT_NE(e.message.find("1e400"), std::string::npos) << e.message;
}

TEST_F(ScanReader, DirectionThatIsNotThreeNumbers) {
  auto doc = load_json();
  doc["lights"][0]["direction"] = {1, "up", 1};
  save_json(doc);
  expect_error("scan.json", "lights[0].direction");
}

TEST_F(ScanReader, DegenerateLightMatrixReportsConditionNumber) {
  auto doc = load_json();
  // Three directions in one plane through the origin: the third is the sum.
  doc["lights"][0]["direction"] = {1, 0, 1};
  doc["lights"][1]["direction"] = {0, 1, 1};
  doc["lights"][2]["direction"] = {1, 1, 2};
  save_json(doc);
  const Error e = expect_error("scan.json", "lights");
  EXPECT_NE(e.message.find("condition number"), std::string::npos) << e.message;
}

TEST_F(ScanReader, LightBelowTheSwatch) {
  auto doc = load_json();
  doc["lights"][2]["direction"] = {0.5, 0.5, -0.7};
  save_json(doc);
  expect_error("scan.json", "lights[2].direction");
}

TEST_F(ScanReader, BadIntensity) {
  auto doc = load_json();
  doc["lights"][0]["intensity"] = -1;
  save_json(doc);
  expect_error("scan.json", "lights[0].intensity");
  doc["lights"][0]["intensity"] = {1, 2};
  save_json(doc);
  expect_error("scan.json", "lights[0].intensity");
}

TEST_F(ScanReader, ImageNamesMustStayInsideTheScan) {
  auto doc = load_json();
  doc["lights"][1]["image"] = "../led1.png";
  save_json(doc);
  expect_error("scan.json", "lights[1].image");
  doc["lights"][1]["image"] = "/etc/passwd";
  save_json(doc);
  expect_error("scan.json", "lights[1].image");
}

TEST_F(ScanReader, MissingFrame) {
  fs::remove(dir_ / "led1.png");
  const Error e = expect_error("led1.png", "lights[1].image");
  EXPECT_NE(e.message.find("no such file"), std::string::npos);
}

TEST_F(ScanReader, CorruptFrame) {
  std::ofstream(dir_ / "led2.png") << "this is not a PNG";
  const Error e = expect_error("led2.png", "lights[2].image");
  EXPECT_NE(e.message.find("cannot read"), std::string::npos);
}

TEST_F(ScanReader, FramesOfDifferentSizes) {
  cv::imwrite((dir_ / "led1.png").string(), cv::Mat(40, 64, CV_16UC3, cv::Scalar(100, 100, 100)));
  const Error e = expect_error("led1.png", "lights[1].image");
  EXPECT_NE(e.message.find("64x40"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("64x48"), std::string::npos) << e.message;
}

TEST_F(ScanReader, FramesWithDifferentChannels) {
  cv::imwrite((dir_ / "led2.png").string(), cv::Mat(48, 64, CV_16UC1, cv::Scalar(100)));
  const Error e = expect_error("led2.png", "lights[2].image");
  EXPECT_NE(e.message.find("grey"), std::string::npos) << e.message;
}

TEST_F(ScanReader, FramesWithAlpha) {
  cv::imwrite((dir_ / "led0.png").string(), cv::Mat(48, 64, CV_16UC4, cv::Scalar(1, 2, 3, 4)));
  const Error e = expect_error("led0.png", "lights[0].image");
  EXPECT_NE(e.message.find("alpha"), std::string::npos) << e.message;
}

TEST_F(ScanReader, WhiteLevelAboveFullScale) {
  for (int k = 0; k < 3; ++k)
    cv::imwrite((dir_ / ("led" + std::to_string(k) + ".png")).string(),
                cv::Mat(48, 64, CV_8UC3, cv::Scalar(9, 9, 9)));
  expect_error("scan.json", "white_level");  // 65535 on 8-bit frames
}

TEST_F(ScanReader, RgbIntensityOnGreyFrames) {
  for (int k = 0; k < 3; ++k)
    cv::imwrite((dir_ / ("led" + std::to_string(k) + ".png")).string(),
                cv::Mat(48, 64, CV_16UC1, cv::Scalar(9)));
  auto doc = load_json();
  doc["lights"][1]["intensity"] = {1.0, 0.9, 0.8};
  save_json(doc);
  expect_error("scan.json", "lights[1].intensity");
}

TEST_F(ScanReader, MaskOfTheWrongSize) {
  cv::imwrite((dir_ / "mask.png").string(), cv::Mat(10, 10, CV_8U, cv::Scalar(255)));
  auto doc = load_json();
  doc["mask"] = "mask.png";
  save_json(doc);
  expect_error("mask.png", "mask");
}

TEST_F(ScanReader, NullMeansDefault) {
  auto doc = load_json();
  doc["encoding"] = nullptr;
  doc["lights"][0]["intensity"] = nullptr;
  doc["pixel_size_mm"] = nullptr;
  save_json(doc);
  auto scan = formats::read_scan(dir_);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(scan->description.encoding, formats::Encoding::linear);
  EXPECT_EQ(scan->description.lights[0].intensity_bgr, cv::Vec3d(1, 1, 1));
  EXPECT_FALSE(scan->description.pixel_size_mm);
}

// No upper limit: real light stages have 96 lights (DiLiGenT) or more.
TEST_F(ScanReader, NinetySixLightsAreRead) {
  auto doc = load_json();
  while (doc["lights"].size() < 96)
    doc["lights"].push_back(doc["lights"][0]);
  save_json(doc);
  auto scan = formats::read_scan(dir_);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(scan->frames.size(), 96u);
}

TEST_F(ScanReader, AnyNonzeroMaskValueSelects) {
  cv::Mat mask(48, 64, CV_32F, cv::Scalar(0));
  mask.at<float>(1, 1) = 0.001f;  // small, but not zero
  mask.at<float>(2, 2) = -1.0f;
  cv::imwrite((dir_ / "mask.exr").string(), mask);
  auto doc = load_json();
  doc["mask"] = "mask.exr";
  save_json(doc);
  auto scan = formats::read_scan(dir_);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(cv::countNonZero(scan->mask), 2);
  EXPECT_NE(scan->mask.at<std::uint8_t>(1, 1), 0);
}

TEST_F(ScanReader, FlatsMustMatchTheLights) {
  auto doc = load_json();
  doc["flats"] = {"flat0.png"};
  save_json(doc);
  expect_error("scan.json", "flats");
}

TEST_F(ScanReader, MissingDarkFrame) {
  auto doc = load_json();
  doc["dark"] = "dark.png";
  save_json(doc);
  expect_error("dark.png", "dark");
}

TEST_F(ScanReader, FloatExrFramesAndMaskAreRead) {
  const auto surface = test::sphere_surface({32, 24}, 10, 1);
  formats::Scan scan = test::render_scan(surface, test::ring_lights(4, 40), CV_32F);
  scan.mask = cv::Mat(scan.size(), CV_8U, cv::Scalar(255));
  const fs::path dir = temp_ / "float";
  ASSERT_TRUE(formats::write_scan(scan, dir));
  EXPECT_TRUE(fs::exists(dir / "led3.exr"));
  auto read = formats::read_scan(dir);
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_EQ(read->depth(), CV_32F);
  EXPECT_EQ(read->white_level, 1.0);
  EXPECT_EQ(cv::norm(read->frames[3], scan.frames[3], cv::NORM_INF), 0);
  EXPECT_EQ(cv::countNonZero(read->mask), 32 * 24);
}

TEST(ScanWriter, NeverOverwritesAndLeavesNothingHalfWritten) {
  test::TempDir temp;
  const auto surface = test::sphere_surface({16, 16}, 5, 1);
  const formats::Scan scan = test::render_scan(surface, test::ring_lights(3, 45), CV_8U);
  ASSERT_TRUE(formats::write_scan(scan, temp / "a"));
  auto again = formats::write_scan(scan, temp / "a");
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().kind, ErrorKind::bad_input);
  // Only the finished scan is there: no staging directories left behind.
  int entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(temp.path()))
    ++entries;
  EXPECT_EQ(entries, 1);
}

}  // namespace
}  // namespace psrig::processing
