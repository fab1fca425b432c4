// `psrig-preview drape` (issue 19): every scene runs, its frames show cloth
// that moves and then settles, the directory appears whole, bad input is a
// clear error, and each scene leaves a contact sheet in the build tree
// (build/drape-contact-sheets/SCENE.png) for a reviewer to look at. A
// scan's maps drape as the chart read off them, in its colours; the kiosk
// turns about between the scan's swatch and that drape.

#include <cstdio>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

// The share of a frame that is the cloth: its coloured pixels (the
// stockinette's yarn is a red; the background and the props are grey, a
// colour spread of 5 codes at most, where the cloth's is over 30).
double cloth_share(const cv::Mat& frame) {
  std::vector<cv::Mat> channels;
  cv::split(frame, channels);
  cv::Mat low = cv::min(cv::min(channels[0], channels[1]), channels[2]);
  cv::Mat high = cv::max(cv::max(channels[0], channels[1]), channels[2]);
  return cv::countNonZero(high - low > 20) / static_cast<double>(frame.total());
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
    EXPECT_GT(cloth_share(last), 0.05) << scene << ": cloth in the frame (0.10 to 0.28)";
    // Motion of the cloth, not of its stitches' texture: frames compared at
    // an eighth of their size.
    const auto difference = [](const cv::Mat& a, const cv::Mat& b) {
      cv::Mat small_a, small_b;
      cv::resize(a, small_a, {}, 0.125, 0.125, cv::INTER_AREA);
      cv::resize(b, small_b, {}, 0.125, 0.125, cv::INTER_AREA);
      return cv::norm(small_a, small_b, cv::NORM_L1) / static_cast<double>(small_a.total());
    };
    const double moved = difference(first, early), still = difference(late, last);
    std::printf("drape %-6s: moved %.2f, still %.3f, cloth %.3f of the frame\n", scene, moved,
                still, cloth_share(last));
    EXPECT_GT(moved, 1.0) << scene << ": the cloth moves at first";
    if (!arm) {  // the arm keeps swinging
      EXPECT_LT(still, 0.25 * moved) << scene << ": and comes to rest";
    }
    // It failed twice in full runs with other builds beside it (a scene
    // not at rest) and never alone: keep the frames of a failure to look at.
    if (::testing::Test::HasFailure()) {
      const fs::path kept = fs::path(PSRIG_BUILD_DIR) / "drape-failure" / scene;
      fs::create_directories(kept.parent_path());
      fs::remove_all(kept);
      fs::copy(out, kept, fs::copy_options::recursive);
      std::printf("drape %s: frames kept in %s\n", scene, kept.c_str());
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

// A simulated scan of two-colour stripes (or `pattern`), processed: its
// maps directory.
fs::path stripes_scan(const TempDir& temp, const std::string& pattern = "stripes") {
  const auto maps = synth_and_process(temp / pattern, pattern);
  EXPECT_TRUE(maps) << maps.error();
  return maps.value_or(fs::path());
}

// The pixels of `frame` near a colour (sRGB, BGR order), as a share.
double share_near(const cv::Mat& frame, cv::Scalar bgr) {
  cv::Mat near;
  cv::inRange(frame, bgr - cv::Scalar::all(40), bgr + cv::Scalar::all(40), near);
  return cv::countNonZero(near) / static_cast<double>(frame.total());
}

// The kiosk shows the swatch for --swatch-seconds, then the scan's knit
// draping for --drape-seconds (the very frames `psrig-preview drape` makes
// of the maps), then the swatch again; a woven scan keeps the swatch and
// says why.
TEST(PsrigPreviewDrape, TheKioskTurnsAboutBetweenTheSwatchAndItsDrape) {
  TempDir temp;
  const fs::path maps = stripes_scan(temp);
  const std::vector<std::string> cloth = {"--size", "160x120", "--samples", "0"};
  std::vector<std::string> kiosk_args = {
      "kiosk", maps.string(), "--headless", "--frames", "12", "--fps", "20", "--swatch-seconds",
      "0.2", "--drape", "hang", "--drape-seconds", "0.2", "--drape-stitches", "16",
      "--drape-rows", "20", "--out-dir", (temp / "kiosk").string()};
  kiosk_args.insert(kiosk_args.end(), cloth.begin(), cloth.end());
  const auto kiosk = run_program("psrig-preview", kiosk_args);
  ASSERT_EQ(kiosk.exit_code, 0) << kiosk.err;
  EXPECT_NE(kiosk.out.find("draping " + maps.string()), std::string::npos) << kiosk.out;
  std::vector<std::string> drape_args = {"drape", maps.string(), "--scene", "hang", "--out",
                                         (temp / "drape").string(), "--stitches", "16", "--rows",
                                         "20", "--seconds", "0.2", "--fps", "20"};
  drape_args.insert(drape_args.end(), cloth.begin(), cloth.end());
  const auto drape = run_program("psrig-preview", drape_args);
  ASSERT_EQ(drape.exit_code, 0) << drape.err;

  const auto kiosk_frame = [&](int n) {
    return cv::imread((temp / "kiosk" / cv::format("frame_%06d.png", n)).string());
  };
  for (int n = 0; n < 12; ++n) {
    const cv::Mat frame = kiosk_frame(n);
    ASSERT_FALSE(frame.empty()) << "frame " << n;
    const bool draping = n >= 4 && n < 8;
    if (draping) {
      const cv::Mat drawn =
          cv::imread((temp / "drape" / cv::format("frame-%04d.png", n - 4)).string());
      EXPECT_EQ(cv::norm(frame, drawn, cv::NORM_INF), 0) << "kiosk frame " << n;
    }
    // Both stripes' colours (stripes.chart: #E9DDC9 and #303B60), the
    // scan's as read off it, on the swatch and on the drape.
    EXPECT_GT(share_near(frame, {0xC9, 0xDD, 0xE9}), 0.01) << "frame " << n;
    EXPECT_GT(share_near(frame, {0x60, 0x3B, 0x30}), 0.01) << "frame " << n;
  }
  // The swatch's patch and the drape are not alike.
  EXPECT_GT(cv::norm(kiosk_frame(3), kiosk_frame(4), cv::NORM_L1) / (160 * 120 * 3), 10.0);

  const fs::path woven = stripes_scan(temp, "plain");
  kiosk_args[1] = woven.string();
  kiosk_args[kiosk_args.size() - 5] = (temp / "woven-kiosk").string();
  const auto plain = run_program("psrig-preview", kiosk_args);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_NE(plain.out.find("no drape for " + woven.string()), std::string::npos) << plain.out;
  EXPECT_EQ(plain.out.find("draping"), std::string::npos) << plain.out;
}

// A woven scan's maps are not draped: exit 2 naming them, nothing written.
TEST(PsrigPreviewDrape, AWovenScanIsNotDraped) {
  TempDir temp;
  const fs::path woven = stripes_scan(temp, "plain");
  const auto run = run_program("psrig-preview", {"drape", woven.string(), "--out",
                                                 (temp / "out").string(), "--seconds", "0.1"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find(woven.string()), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("drape shows knits"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(temp / "out"));
}

}  // namespace
}  // namespace psrig::test
