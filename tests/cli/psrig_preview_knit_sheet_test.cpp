// Every shipped pattern (config/patterns/*.chart and *.weave) drawn by
// `psrig-preview knit` from the front, from the back (yaw 180), stretched
// 1.5 and 0.6 along the courses and sheared, close enough to see the yarn
// (plies, twist, the flyaway halo): each frame shows cloth, the back is not
// the front, stretching a knit opens it and squeezing closes it, shearing
// changes it. The frames go into one contact sheet in the build tree
// (build/cloth-contact-sheet.png), labelled, for a reviewer to look at.

#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

struct SheetView {
  const char* label;
  std::vector<std::string> options;
};

const std::vector<SheetView> kViews = {
    {"front", {}},
    {"back", {"--yaw", "180"}},
    {"stretch 1.5", {"--stretch", "1.5"}},
    {"stretch 0.6", {"--stretch", "0.6"}},
    {"shear 0.4", {"--shear", "0.4"}},
};

// The share of the frame's middle (a third either way) that is not background.
double centre_yarn_share(const cv::Mat& frame) {
  cv::Mat grey;
  cv::cvtColor(frame(cv::Rect(frame.cols / 3, frame.rows / 3, frame.cols / 3, frame.rows / 3)),
               grey, cv::COLOR_BGR2GRAY);
  return cv::countNonZero(grey > 50) / static_cast<double>(grey.total());
}

// Of the pixels inside the cloth's bounding box (less a tenth either way,
// its ragged edges), the share that is yarn: stretching opens gaps.
double yarn_cover(const cv::Mat& frame) {
  cv::Mat grey;
  cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
  const cv::Mat yarn = grey > 43;  // the background is 40
  cv::Rect box = cv::boundingRect(yarn);
  box = cv::Rect(box.x + box.width / 10, box.y + box.height / 10, box.width * 8 / 10,
                 box.height * 8 / 10);
  return box.area() == 0 ? 0.0 : cv::countNonZero(yarn(box)) / static_cast<double>(box.area());
}

double mean_difference(const cv::Mat& a, const cv::Mat& b) {
  return cv::norm(a, b, cv::NORM_L1) / static_cast<double>(a.total() * a.channels());
}

TEST(PsrigPreviewKnitSheet, EveryPatternFromEverySideMakesTheContactSheet) {
  TempDir temp;
  std::vector<fs::path> patterns;
  for (const auto& entry : fs::directory_iterator(shipped_pattern("stockinette.chart").parent_path()))
    if (entry.path().extension() == ".chart" || entry.path().extension() == ".weave")
      patterns.push_back(entry.path());
  std::sort(patterns.begin(), patterns.end());
  ASSERT_GE(patterns.size(), 9U);

  const cv::Size cell(360, 270);
  cv::Mat sheet(static_cast<int>(patterns.size()) * cell.height,
                static_cast<int>(kViews.size()) * cell.width, CV_8UC3, cv::Scalar(16, 16, 16));
  for (std::size_t row = 0; row < patterns.size(); ++row) {
    const fs::path& pattern = patterns[row];
    const bool woven = pattern.extension() == ".weave";
    std::vector<cv::Mat> frames;
    for (std::size_t column = 0; column < kViews.size(); ++column) {
      const fs::path out = temp / (pattern.stem().string() + std::to_string(column) + ".png");
      std::vector<std::string> args = {"knit",    pattern.string(), "--out",  out.string(),
                                       "--size",  "360x270",        "--stitches", woven ? "14" : "8",
                                       "--rows",  woven ? "14" : "7", "--light-slant", "40"};
      args.insert(args.end(), kViews[column].options.begin(), kViews[column].options.end());
      const auto run = run_program("psrig-preview", args);
      ASSERT_EQ(run.exit_code, 0) << pattern << " " << kViews[column].label << ": " << run.err;
      cv::Mat frame = cv::imread(out.string());
      ASSERT_EQ(frame.size(), cell);
      frames.push_back(frame.clone());
      const std::string label = pattern.stem().string() + ", " + kViews[column].label;
      cv::putText(frame, label, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(235, 235, 235),
                  1, cv::LINE_AA);
      frame.copyTo(sheet(cv::Rect(static_cast<int>(column) * cell.width,
                                  static_cast<int>(row) * cell.height, cell.width, cell.height)));
    }
    const std::string name = pattern.filename().string();
    for (std::size_t column = 0; column < frames.size(); ++column)
      EXPECT_GT(centre_yarn_share(frames[column]), 0.5) << name << ", " << kViews[column].label;
    EXPECT_GT(mean_difference(frames[0], frames[1]), 2.0) << name << ": the back is not the front";
    if (!woven) {  // woven threads jam when squeezed rather than close up
      EXPECT_LT(yarn_cover(frames[2]), yarn_cover(frames[3]))
          << name << ": stretched open, squeezed closed";
    }
    EXPECT_GT(mean_difference(frames[2], frames[3]), 2.0) << name << ": stretching shows";
    EXPECT_GT(mean_difference(frames[0], frames[4]), 2.0) << name << ": sheared";
  }
  const fs::path written = fs::path(PSRIG_BUILD_DIR) / "cloth-contact-sheet.png";
  ASSERT_TRUE(cv::imwrite(written.string(), sheet)) << written;
  std::cout << "contact sheet: " << written.string() << "\n";
}

}  // namespace
}  // namespace psrig::test
