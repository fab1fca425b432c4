// The headless GLES platform: a surfaceless context and an offscreen frame
// whose pixels read back as drawn, the right way up.

#include "psrig/preview/egl_context.h"

#include <GLES3/gl3.h>

#include <gtest/gtest.h>

#include "psrig/preview/offscreen_target.h"

namespace psrig::preview {
namespace {

TEST(EglContext, SurfacelessGles3ContextOpens) {
  auto context = EglContext::open_surfaceless();
  ASSERT_TRUE(context) << context.error().describe();
  EXPECT_GE((*context)->gles_major(), 3);
  EXPECT_NE((*context)->describe().find("OpenGL ES"), std::string::npos) << (*context)->describe();
  EXPECT_FALSE((*context)->has_extension("GL_PSRIG_no_such_extension"));
  EXPECT_FALSE((*context)->has_extension(""));
}

TEST(OffscreenTarget, ReadsBackWhatWasDrawnTopRowFirst) {
  auto context = EglContext::open_surfaceless();
  ASSERT_TRUE(context) << context.error().describe();
  for (const int samples : {0, 4}) {
    auto target = OffscreenTarget::create({40, 30}, samples);
    ASSERT_TRUE(target) << target.error().describe();
    (*target)->bind();
    glClearColor(0.25f, 0.5f, 0.75f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    // The top ten rows red: GL counts rows from the bottom.
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 20, 40, 10);
    glClearColor(1, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
    const cv::Mat frame = (*target)->read();
    ASSERT_EQ(frame.size(), cv::Size(40, 30));
    ASSERT_EQ(frame.type(), CV_8UC3);
    const cv::Vec3b top = frame.at<cv::Vec3b>(0, 0), bottom = frame.at<cv::Vec3b>(29, 39);
    EXPECT_EQ(top, cv::Vec3b(0, 0, 255)) << "samples " << samples;
    EXPECT_NEAR(bottom[0], 191, 1) << "blue, samples " << samples;
    EXPECT_NEAR(bottom[1], 128, 1) << "green";
    EXPECT_NEAR(bottom[2], 64, 1) << "red";
  }
}

TEST(OffscreenTarget, ImpossibleSizeIsAClearError) {
  auto context = EglContext::open_surfaceless();
  ASSERT_TRUE(context) << context.error().describe();
  auto target = OffscreenTarget::create({0, 10});
  ASSERT_FALSE(target);
  EXPECT_NE(target.error().describe().find("--size"), std::string::npos)
      << target.error().describe();
}

}  // namespace
}  // namespace psrig::preview
