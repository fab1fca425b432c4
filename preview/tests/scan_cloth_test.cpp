// The cloth a scan shows, as the preview knits and drapes it: a simulated
// rib-1x1 scan processed into maps gives its chart, its gauge at rest (the
// sizes given on the command line over it) and a knit to drape; maps that
// cannot be read are read_maps's error, the program adding its own hints.

#include "psrig/preview/scan_cloth.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "cloth_pixels.h"
#include "psrig/analysis/chart_inference.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/preview/drape_cloth.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/patch_tile.h"
#include "psrig/preview/swatch_maps.h"
#include "psrig/processing/pipeline.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::preview {
namespace {

std::filesystem::path processed_rib(const test::TempDir& temp) {
  sim::SyntheticScanParams params;
  params.swatch = test::swatch_params("rib-1x1", {400, 320}, 0.03);
  const auto scan = temp / "scan";
  EXPECT_TRUE(formats::write_scan(test::made(sim::make_synthetic_scan(params)), scan));
  return test::made(processing::process_scan(scan)).maps_directory;
}

TEST(ScanCloth, ReadsTheChartAndTheGaugeAtRest) {
  test::TempDir temp;
  const auto maps = processed_rib(temp);
  const auto scan = read_scan_cloth(maps);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(scan->maps, maps);
  EXPECT_TRUE(scan->warnings.empty()) << scan->warnings.front();
  ASSERT_TRUE(scan->knit) << scan->why;
  const auto knitted = cloth::load_stitch_chart(test::shipped_pattern("rib-1x1.chart"));
  ASSERT_TRUE(knitted);
  EXPECT_TRUE(analysis::same_chart_up_to_shift(scan->knit->chart, *knitted));
  // The lattice's spacings at rest are its gauge; a square rib leans little.
  EXPECT_NEAR(10 / scan->wale_mm, scan->knit->wales_per_cm, 0.02 * scan->knit->wales_per_cm);
  EXPECT_NEAR(10 / scan->course_mm, scan->knit->courses_per_cm, 0.02 * scan->knit->courses_per_cm);
  EXPECT_LT(std::abs(scan->shear), 0.05f);
  EXPECT_EQ(scan->stitch_colours(4, 3).size(), 12u);

  // What the command line gives wins over the scan's; the rest is the scan's.
  const ClothSize size = scan->cloth_size({.wales_per_cm = 5}, true);
  EXPECT_EQ(size.wales_per_cm, 5);
  EXPECT_NEAR(size.courses_per_cm, 10 / scan->course_mm, 1e-4);
  EXPECT_EQ(size.yarn_mm, scan->knit->chart.gauge.yarn_diameter_mm);

  const auto fabric = drape_fabric(maps, 6, 5);
  ASSERT_TRUE(fabric) << fabric.error().describe();
}

TEST(ScanCloth, UnreadableMapsGiveReadMapsOwnError) {
  test::TempDir temp;
  const auto maps = processed_rib(temp);
  // The scan directory, not its maps: which one was meant is psrig-preview's to say.
  const auto scan = read_scan_cloth(maps.parent_path());
  ASSERT_FALSE(scan);
  EXPECT_EQ(scan.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(scan.error().file, maps.parent_path() / "albedo.exr");
  EXPECT_EQ(scan.error().message.find("did you mean"), std::string::npos) << scan.error().message;
}

TEST(ScanCloth, DrapeSeenFromAfarIsTheScanAndBuildsNoYarn) {
  test::TempDir temp;
  const auto maps = processed_rib(temp);
  auto context = EglContext::open_surfaceless();
  ASSERT_TRUE(context) << context.error().describe();
  auto fabric = drape_fabric(maps, 24, 28);
  ASSERT_TRUE(fabric) << fabric.error().describe();
  // The same drape twice: one building its yarns every frame (as before
  // issue 30), one only for frames that draw them.
  cloth::DrapeAnimation skipping(*fabric, cloth::DrapeScene::hang);
  cloth::DrapeAnimation building(*fabric, cloth::DrapeScene::hang);
  auto skip = drape_renderers();
  auto build = drape_renderers();
  ASSERT_TRUE(skip && build);
  ASSERT_TRUE(use_scan_maps(*skip, maps));
  ASSERT_TRUE(use_scan_maps(*build, maps));
  build->far_without_yarns = false;
  const cv::Size size(320, 240);
  auto target = OffscreenTarget::create(size, 4, ColourStorage::srgb);
  ASSERT_TRUE(target);
  const auto frame = [&](cloth::DrapeAnimation& animation, DrapeRenderers& renderers,
                         const KnitView& view) {
    (*target)->bind();
    draw_drape(animation, renderers, view, size);
    return (*target)->read();
  };
  // A metre off, the yarns are under a pixel: the scan alone draws them.
  const KnitView far = drape_view(20, 25, 1000);
  for (int step = 0; step < 4; ++step) {
    skipping.advance(1 / 30.0f);
    building.advance(1 / 30.0f);
    const cv::Mat without_yarns = frame(skipping, *skip, far);
    const cv::Mat with_yarns = frame(building, *build, far);
    EXPECT_TRUE(skip->yarns->last_drew_far_cloth());
    EXPECT_FALSE(skip->yarns->last_drew_yarns());
    EXPECT_LT(skip->yarns->last_yarn_width_px(), 1.0f);
    cv::Mat difference;
    cv::absdiff(without_yarns, with_yarns, difference);
    double largest = 0;
    cv::minMaxLoc(difference.reshape(1), nullptr, &largest);
    EXPECT_EQ(largest, 0) << "frame " << step;
  }
  EXPECT_EQ(skip->yarns->yarn_updates(), 0);
  EXPECT_TRUE(skip->curves.curves.empty());
  EXPECT_EQ(build->yarns->yarn_updates(), 4);
  // Close up the yarns are built again.
  skipping.advance(1 / 30.0f);
  frame(skipping, *skip, drape_view(20, 25));
  EXPECT_TRUE(skip->yarns->last_drew_yarns());
  EXPECT_EQ(skip->yarns->yarn_updates(), 1);
}

TEST(ScanCloth, DollyIntoTheScansFarLevelKeepsTheBrightness) {
  // A processed rib scan knitted 40 x 40 stitches (its chart, gauge and
  // colour), the scan its far level: the camera backs away 5 % a frame
  // from yarns 8 px wide to 1.2 px, through the cross-fade. The cloth's
  // brightness (its pixels' mean, linear light, the channels averaged)
  // moves by at most 2 % a frame (measured 1.1 %), a channel by at most
  // 4 % (2.6 %, the blue, a dark 0.045 in linear light: 0.001 a frame):
  // the yarns' colour and sheen are matched to the scan's
  // (FarLevel::match_scan). Without the match the yarns were paler than
  // the scan and the colour deepened through the cross-fade, 7.8 % a frame.
  test::TempDir temp;
  const auto maps = processed_rib(temp);
  auto context = EglContext::open_surfaceless();
  ASSERT_TRUE(context) << context.error().describe();
  auto fabric = drape_fabric(maps, 40, 40);
  ASSERT_TRUE(fabric) << fabric.error().describe();
  cloth::YarnSet yarns;
  fabric->update(fabric->mesh(), yarns);
  auto renderer = YarnRenderer::create();
  ASSERT_TRUE(renderer) << renderer.error().describe();
  auto swatch = load_swatch_maps(maps);
  ASSERT_TRUE(swatch) << swatch.error().describe();
  ASSERT_TRUE((*renderer)->use_scan(patch_tile(*swatch)));
  (*renderer)->update(yarns);
  const cv::Size size(320, 240);
  auto target = OffscreenTarget::create(size, 4, ColourStorage::srgb);
  ASSERT_TRUE(target);
  KnitView view;
  view.light.tilt_deg = 45;
  view.light.slant_deg = 45;
  const double focal_px = size.height / 2 / std::tan(view.fov_y_deg / 2 * 3.14159265358979 / 180);
  const double yarn_mm = 2 * yarns.style.radius_mm;
  cv::Scalar previous;
  double worst_brightness = 0, worst_channel = 0;
  bool far_alone = false;
  for (double distance = yarn_mm * focal_px / 8; distance <= yarn_mm * focal_px / 1.2;
       distance *= 1.05) {
    view.distance_mm = distance;
    (*target)->bind();
    (*renderer)->render(view, size);
    far_alone = far_alone || !(*renderer)->last_drew_yarns();
    const cv::Mat mask = testing::cloth_mask(yarns.bounds(), view, size, 3);
    ASSERT_GT(cv::countNonZero(mask), 400) << distance;
    const cv::Scalar mean = cv::mean(testing::linear_light((*target)->read()), mask);
    if (previous[0] > 0) {
      const double brightness =
          (mean[0] + mean[1] + mean[2]) / (previous[0] + previous[1] + previous[2]);
      worst_brightness = std::max(worst_brightness, std::abs(brightness - 1));
      EXPECT_NEAR(brightness, 1.0, 0.02) << "at " << distance << " mm";
      for (int c = 0; c < 3; ++c) {
        worst_channel = std::max(worst_channel, std::abs(mean[c] / previous[c] - 1));
        EXPECT_NEAR(mean[c] / previous[c], 1.0, 0.04) << "channel " << c << " at " << distance;
      }
    }
    previous = mean;
  }
  std::printf("dolly into the scan: worst step %.3f in brightness, %.3f in a channel\n",
              worst_brightness, worst_channel);
  EXPECT_TRUE(far_alone);
}

}  // namespace
}  // namespace psrig::preview
