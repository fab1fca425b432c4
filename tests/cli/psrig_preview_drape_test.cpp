// `psrig-preview drape` (issue 19): every scene runs, its frames show cloth
// that moves and then settles, the directory appears whole, bad input is a
// clear error, and each scene leaves a contact sheet in the build tree
// (build/drape-contact-sheets/SCENE.png) for a reviewer to look at.

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

// The share of a frame that is not background.
double cloth_share(const cv::Mat& frame) {
  cv::Mat grey;
  cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
  return cv::countNonZero(grey > 20) / static_cast<double>(grey.total());
}

TEST(PsrigPreviewDrape, EverySceneMovesThenSettlesAndLeavesAContactSheet) {
  TempDir temp;
  const fs::path sheets = fs::path(PSRIG_BUILD_DIR) / "drape-contact-sheets";
  fs::create_directories(sheets);
  for (const char* scene : {"hang", "table", "sphere", "arm"}) {
    const fs::path out = temp / scene;
    const auto run = run_program(
        "psrig-preview", {"drape", shipped_pattern("stockinette.chart").string(), "--scene", scene,
                          "--out", out.string(), "--stitches", "24", "--rows", "28", "--seconds",
                          "2.5", "--fps", "8", "--size", "320x240", "--samples", "0"});
    ASSERT_EQ(run.exit_code, 0) << scene << ": " << run.err;
    ASSERT_TRUE(fs::exists(out / "frame-0019.png")) << scene;
    EXPECT_FALSE(fs::exists(out / "frame-0020.png")) << scene;
    // The arm lifts the cloth from 1.5 s on; the others fall at once.
    const bool arm = std::string(scene) == "arm";
    const cv::Mat first = cv::imread((out / (arm ? "frame-0012.png" : "frame-0000.png")).string());
    const cv::Mat early = cv::imread((out / (arm ? "frame-0014.png" : "frame-0008.png")).string());
    const cv::Mat late = cv::imread((out / "frame-0018.png").string());
    const cv::Mat last = cv::imread((out / "frame-0019.png").string());
    EXPECT_GT(cloth_share(last), 0.02) << scene << ": cloth in the frame";
    // Motion of the cloth, not of its stitches' texture: frames compared at
    // an eighth of their size.
    const auto difference = [](const cv::Mat& a, const cv::Mat& b) {
      cv::Mat small_a, small_b;
      cv::resize(a, small_a, {}, 0.125, 0.125, cv::INTER_AREA);
      cv::resize(b, small_b, {}, 0.125, 0.125, cv::INTER_AREA);
      return cv::norm(small_a, small_b, cv::NORM_L1) / static_cast<double>(small_a.total());
    };
    const double moved = difference(first, early), still = difference(late, last);
    EXPECT_GT(moved, 1.0) << scene << ": the cloth moves at first";
    if (!arm) {  // the arm keeps swinging
      EXPECT_LT(still, 0.25 * moved) << scene << ": and comes to rest";
    }
    fs::copy_file(out / "contact-sheet.png", sheets / (std::string(scene) + ".png"),
                  fs::copy_options::overwrite_existing);
  }
}

TEST(PsrigPreviewDrape, BadInputIsAClearErrorAndWritesNothing) {
  TempDir temp;
  const auto scene = run_program("psrig-preview", {"drape", shipped_pattern("seed.chart").string(),
                                                   "--scene", "trampoline", "--out",
                                                   (temp / "out").string()});
  EXPECT_EQ(scene.exit_code, 2);
  EXPECT_NE(scene.err.find("hang, table, sphere or arm"), std::string::npos) << scene.err;
  const auto woven = run_program("psrig-preview", {"drape", shipped_pattern("plain.weave").string(),
                                                   "--out", (temp / "out").string()});
  EXPECT_EQ(woven.exit_code, 2);
  EXPECT_NE(woven.err.find("plain.weave"), std::string::npos) << woven.err;
  EXPECT_FALSE(fs::exists(temp / "out"));
}

}  // namespace
}  // namespace psrig::test
