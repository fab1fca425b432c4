// The scan and maps directory names are the on-disk contract users and
// tools depend on: spelled out here on purpose, so a change to
// scan_layout.h that would break existing scans fails a test.

#include "psrig/formats/scan_layout.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace psrig::processing {
namespace {

TEST(ScanLayout, FramesArePngForIntegerPixelsAndExrForFloat) {
  EXPECT_EQ(formats::scan_files::led_frame(0, CV_16U), "led0.png");
  EXPECT_EQ(formats::scan_files::led_frame(12, CV_8U), "led12.png");
  EXPECT_EQ(formats::scan_files::led_frame(2, CV_32F), "led2.exr");
  EXPECT_EQ(formats::scan_files::dark_frame(CV_16U), "dark.png");
  EXPECT_EQ(formats::scan_files::dark_frame(CV_32F), "dark.exr");
  EXPECT_EQ(formats::scan_files::flat_frame(1, CV_16U), "flat1.png");
  EXPECT_EQ(formats::scan_files::flat_frame(1, ".tiff"), "flat1.tiff");
  EXPECT_STREQ(formats::scan_files::kDescription, "scan.json");
  EXPECT_STREQ(formats::scan_files::kMapsDirectory, "maps");
}

TEST(ScanLayout, KnowsEveryFileTheRigWritesAndNothingElse) {
  for (const char* name : {"scan.json", "led0.png", "led15.exr", "dark.png", "dark.exr", "mask.png",
                           "flat0.png", "flat2.tif", "gt_normal.exr", "gt_height.exr"})
    EXPECT_TRUE(formats::scan_files::is_scan_file(name)) << name;
  for (const char* name : {"", "led.png", "led01.png", "led1.jpg", "led1.png.bak", "ledx.png",
                           "darkness.png", "../scan.json", "maps", "report.json", ".scan.json"})
    EXPECT_FALSE(formats::scan_files::is_scan_file(name)) << name;
}

TEST(ScanLayout, KnowsEveryMapsFile) {
  for (const char* name : formats::map_files::kAll)
    EXPECT_TRUE(formats::map_files::is_map_file(name)) << name;
  EXPECT_EQ(std::size(formats::map_files::kAll), 10u);
  for (const char* name : {"albedo.png", "albedo.exr", "normal.png", "p.exr", "q.exr", "height.exr",
                           "height.png", "mask.png", "report.json"})
    EXPECT_TRUE(formats::map_files::is_map_file(name)) << name;
  EXPECT_FALSE(formats::map_files::is_map_file("scan.json"));
  EXPECT_FALSE(formats::map_files::is_map_file("normal.exr"));
}

}  // namespace
}  // namespace psrig::processing
