// The kiosk's GBM/KMS display: clear errors wherever there is no display to
// drive, and frames on screen where there is one (PSRIG_KMS_TEST=1 and a
// connected /dev/dri/card*, since it takes the screen over).

#include "psrig/preview/kms_display.h"

#include <GLES3/gl3.h>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

bool has_card_nodes() {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator("/dev/dri", error))
    if (entry.path().filename().string().starts_with("card")) return true;
  return false;
}

TEST(KmsDisplay, MissingDeviceIsAnErrorNamingIt) {
  KmsDisplay::Options options;
  options.device = "/nonexistent/card9";
  auto display = KmsDisplay::open(options);
  ASSERT_FALSE(display);
  const std::string text = display.error().describe();
  EXPECT_NE(text.find("/nonexistent/card9"), std::string::npos) << text;
  EXPECT_NE(text.find("No such file or directory"), std::string::npos) << text;
}

TEST(KmsDisplay, DeviceThatIsNotDrmIsAClearError) {
  KmsDisplay::Options options;
  options.device = "/dev/null";
  auto display = KmsDisplay::open(options);
  ASSERT_FALSE(display);
  const std::string text = display.error().describe();
  EXPECT_NE(text.find("/dev/null"), std::string::npos) << text;
  EXPECT_NE(text.find("not a DRM device"), std::string::npos) << text;
}

TEST(KmsDisplay, NoDrmDeviceOnTheMachineIsAClearError) {
  if (has_card_nodes()) GTEST_SKIP() << "this machine has /dev/dri/card*";
  auto display = KmsDisplay::open({});
  ASSERT_FALSE(display);
  const std::string text = display.error().describe();
  EXPECT_NE(text.find("no DRM device found"), std::string::npos) << text;
}

// Takes the screen over for a moment, so only when asked.
TEST(KmsDisplay, PresentsFramesOnARealDisplay) {
  const char* wanted = std::getenv("PSRIG_KMS_TEST");
  if (wanted == nullptr || std::string(wanted) != "1")
    GTEST_SKIP() << "set PSRIG_KMS_TEST=1 to light up a real display through DRM/KMS";
  if (!has_card_nodes()) GTEST_SKIP() << "no /dev/dri/card* on this machine";
  auto display = KmsDisplay::open({});
  if (!display) {
    const std::string text = display.error().describe();
    // No display plugged in skips; anything else (permissions, another DRM
    // master, EGL) is what this test is for.
    const bool unplugged = text.find("no connector is connected") != std::string::npos ||
                           text.find("has no connectors") != std::string::npos;
    if (unplugged && text.find("DRM master") == std::string::npos)
      GTEST_SKIP() << "no card with a connected display: " << text;
    FAIL() << text;
  }
  KmsDisplay& kms = **display;
  std::cout << kms.describe() << (kms.srgb_surface() ? ", sRGB surface" : "") << "\n";
  EXPECT_GT(kms.size().width, 0);
  EXPECT_GT(kms.size().height, 0);
  EXPECT_FALSE(kms.has_extension("GL_PSRIG_no_such_extension"));
  const float colours[3][3] = {{0.8f, 0.2f, 0.2f}, {0.2f, 0.8f, 0.2f}, {0.2f, 0.2f, 0.8f}};
  for (const auto& colour : colours) {
    glViewport(0, 0, kms.size().width, kms.size().height);
    glClearColor(colour[0], colour[1], colour[2], 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    auto presented = kms.present();
    ASSERT_TRUE(presented) << presented.error().describe();
  }
}

}  // namespace
}  // namespace psrig::preview
