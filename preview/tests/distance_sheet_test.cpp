// Every shipped pattern from near to far (issue 30): five distances at which
// its yarn is about 12, 5, 2.5, 1.2 and 0.6 pixels wide, each level of
// detail the renderer chooses on its own, side by side in one contact sheet
// in the build tree (build/cloth-distance-sheet.png) for a reviewer to
// look at as a textile person would: an opaque jersey, the twill's
// diagonal, no moiré. Each frame must show cloth; each cell's label gives
// the yarn's width and the cloth's mean colour (its own pixels, linear
// light) against the nearest frame's.

#include <GLES3/gl3.h>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cloth_pixels.h"
#include "psrig/preview/cloth_model.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/yarn_renderer.h"
#include "test_support.h"

namespace psrig::preview {
namespace {

constexpr float kYarnPx[] = {12, 5, 2.5f, 1.2f, 0.6f};
const cv::Size kCell(256, 192);

// The cloth's mean colour over its own pixels, grey, in linear light.
double cloth_brightness(const cv::Mat& frame, const cv::Mat& mask) {
  const cv::Scalar mean = cv::mean(testing::linear_light(frame), mask);
  return (mean[0] + mean[1] + mean[2]) / 3;
}

TEST(DistanceSheet, EveryPatternFromNearToFarMakesTheSheet) {
  auto context = EglContext::open_surfaceless();
  ASSERT_TRUE(context) << context.error().describe();
  auto target = OffscreenTarget::create(kCell, 4, ColourStorage::srgb);
  ASSERT_TRUE(target) << target.error().describe();
  const auto& names = test::shipped_pattern_names();
  const int label_px = 18;
  cv::Mat sheet(static_cast<int>(names.size()) * (kCell.height + label_px),
                static_cast<int>(std::size(kYarnPx)) * kCell.width, CV_8UC3,
                cv::Scalar(16, 16, 16));
  for (std::size_t row = 0; row < names.size(); ++row) {
    const std::string name = names[row];
    auto file = test::shipped_pattern(name + ".chart");
    if (!std::filesystem::exists(file)) file = test::shipped_pattern(name + ".weave");
    const bool woven = file.extension() == ".weave";
    // Enough cloth to fill the far frames' middle.
    auto cloth = ClothModel::load(file, woven ? 110 : 48, woven ? 110 : 48, std::nullopt);
    ASSERT_TRUE(cloth) << cloth.error().describe();
    cloth::YarnSet yarns;
    cloth->update({}, yarns);
    auto renderer = YarnRenderer::create();
    ASSERT_TRUE(renderer) << renderer.error().describe();
    (*renderer)->update(yarns);
    KnitView view;
    view.light.tilt_deg = 45;
    view.light.slant_deg = 45;
    const float focal_px = knit_frame(yarns.bounds(), view, kCell).focal_px;
    double nearest = 0;
    for (std::size_t column = 0; column < std::size(kYarnPx); ++column) {
      view.distance_mm = 2 * yarns.style.radius_mm * focal_px / kYarnPx[column];
      (*target)->bind();
      (*renderer)->render(view, kCell);
      ASSERT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
      const cv::Mat frame = (*target)->read();
      const cv::Mat mask = testing::cloth_mask(yarns.bounds(), view, kCell, 2);
      ASSERT_GT(cv::countNonZero(mask), 500) << name;
      const double brightness = cloth_brightness(frame, mask);
      if (column == 0) nearest = brightness;
      EXPECT_GT(brightness, 2 * srgb_decode(40.0f / 255.0f))
          << name << " shows cloth at yarn " << kYarnPx[column] << " px";
      const cv::Rect cell(static_cast<int>(column) * kCell.width,
                          static_cast<int>(row) * (kCell.height + label_px), kCell.width,
                          kCell.height);
      frame.copyTo(sheet(cell));
      char label[96];
      std::snprintf(label, sizeof label, "%s yarn %.1f px x%.2f", name.c_str(), kYarnPx[column],
                    brightness / nearest);
      cv::putText(sheet, label, {cell.x + 4, cell.y + kCell.height + 13}, cv::FONT_HERSHEY_SIMPLEX,
                  0.4, cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
    }
  }
  const auto written = std::filesystem::path(PSRIG_BUILD_DIR) / "cloth-distance-sheet.png";
  ASSERT_TRUE(cv::imwrite(written.string(), sheet)) << written;
  std::printf("distance sheet: %s\n", written.c_str());
}

}  // namespace
}  // namespace psrig::preview
