// Chart inference on charts knitted by the cloth model and seen head-on at
// a known pixel size (tests/support/knitted_maps.h): the fabric measurement
// then the inference, which must find the chart (up to a cyclic shift of
// its repeat), read 95 % or more of the stitches right on their own, and
// measure the gauge within 2 %.

#include "psrig/analysis/chart_inference.h"

#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "knitted_maps.h"
#include "psrig/analysis/colour_palette.h"
#include "psrig/cloth/srgb.h"
#include "test_support.h"

namespace psrig::cloth {
namespace {

StitchChart shipped(const std::string& name) {
  auto chart = load_stitch_chart(test::shipped_pattern(name));
  EXPECT_TRUE(chart) << chart.error().describe();
  return *chart;
}

analysis::FabricMeasurement measured(const test::KnittedMaps& maps) {
  analysis::MeasureOptions options;
  options.pixel_size_mm = maps.pixel_size_mm;
  options.hints.construction = analysis::Construction::knit;
  auto m = analysis::measure_fabric(maps.height, maps.albedo, options);
  EXPECT_TRUE(m && m->periodic);
  return *m;
}

std::string text_of(const StitchChart& chart) {
  return format_stitch_chart(chart);
}

// The figures, printed for the record (cloth/README.md quotes them).
void print_figures(const std::string& name, const analysis::InferredKnit& knit,
                   const StitchChart& truth, const test::KnittedMaps& maps) {
  std::printf(
      "chart inference: %s: chart %s, %.1f %% of %d stitches right, wales %+.2f %%, "
      "courses %+.2f %%, yarn %.2f mm (chart's %.2f), fit %.3f\n",
      name.c_str(), analysis::same_chart_up_to_shift(knit.chart, truth) ? "equal" : "DIFFERENT",
      100 * analysis::agreement_with_chart(knit.stitches, knit.columns, knit.rows, truth),
      knit.columns * knit.rows, 100 * (knit.wales_per_cm / maps.wales_per_cm - 1),
      100 * (knit.courses_per_cm / maps.courses_per_cm - 1), knit.chart.gauge.yarn_diameter_mm,
      truth.gauge.yarn_diameter_mm, knit.fit);
}

struct ChartCase {
  const char* chart;
  cv::Size size;
  double pixel_size_mm;
  ClothDeformation deformation;
};

class ChartInference : public ::testing::TestWithParam<ChartCase> {};

TEST_P(ChartInference, FindsTheChartTheStitchesAndTheGauge) {
  const ChartCase c = GetParam();
  const StitchChart truth = shipped(c.chart);
  const test::KnittedMaps maps = test::knit_maps(truth, c.size, c.pixel_size_mm, c.deformation);
  const auto inferred = analysis::infer_knit_chart(maps.height, maps.albedo, measured(maps));
  ASSERT_TRUE(inferred) << inferred.error().describe();
  print_figures(c.chart, *inferred, truth, maps);
  EXPECT_TRUE(analysis::same_chart_up_to_shift(inferred->chart, truth))
      << "inferred:\n"
      << text_of(inferred->chart) << "truth:\n"
      << text_of(truth);
  EXPECT_GE(
      analysis::agreement_with_chart(inferred->stitches, inferred->columns, inferred->rows, truth),
      0.95)
      << inferred->notes.front();
  EXPECT_NEAR(inferred->wales_per_cm / maps.wales_per_cm, 1.0, 0.02);
  EXPECT_NEAR(inferred->courses_per_cm / maps.courses_per_cm, 1.0, 0.02);
  EXPECT_NEAR(inferred->chart.gauge.wales_per_cm, inferred->wales_per_cm, 1e-3);
  // The yarn the knitted chart matched best with, where the chart says its
  // own: right to the tightness factor's steps.
  if (truth.gauge.yarn_diameter_mm > 0) {
    EXPECT_NEAR(inferred->chart.gauge.yarn_diameter_mm / truth.gauge.yarn_diameter_mm, 1.0, 0.15);
  }
  EXPECT_GE(inferred->columns * inferred->rows, 30);  // most of the maps read
}

INSTANTIATE_TEST_SUITE_P(
    ShippedCharts, ChartInference,
    ::testing::Values(ChartCase{"stockinette.chart", {400, 320}, 0.03, {}},
                      ChartCase{"rib-1x1.chart", {400, 320}, 0.03, {}},
                      ChartCase{"rib-2x2.chart", {440, 320}, 0.04, {}},
                      ChartCase{"garter.chart", {400, 320}, 0.03, {}},
                      ChartCase{"seed.chart", {400, 320}, 0.03, {}},
                      // Leaning wales (skew 5.7 deg): the lattice is sheared, the
                      // stitches still found. (At 8.5 deg fabric_measure takes a
                      // longer lattice vector, three wales and a course, for u.)
                      ChartCase{"seed.chart", {400, 320}, 0.03, {1.0f, 0.1f}}),
    [](const ::testing::TestParamInfo<ChartCase>& param_info) {
      std::string name = std::filesystem::path(param_info.param.chart).stem().string();
      std::erase(name, '-');
      return name + (param_info.param.deformation.shear != 0 ? "Sheared" : "");
    });

// A 64-stitch repeat whose blocks' rows look unlike lone stitches: found by
// improving a knitted draft stitch by stitch. One stitch of the 64 may come
// out wrong where the cloth model's yarn (from the gauge and a tightness)
// differs from the one knitted; the stitches are read right all the same.
TEST(ChartInference, Basketweave) {
  const StitchChart truth = shipped("basketweave.chart");
  const test::KnittedMaps maps = test::knit_maps(truth, {560, 400}, 0.04);
  const auto inferred = analysis::infer_knit_chart(maps.height, maps.albedo, measured(maps));
  ASSERT_TRUE(inferred) << inferred.error().describe();
  print_figures("basketweave.chart", *inferred, truth, maps);
  EXPECT_EQ(inferred->chart.columns, 8);
  EXPECT_EQ(inferred->chart.rows, 8);
  EXPECT_GE(
      analysis::agreement_with_chart(inferred->stitches, inferred->columns, inferred->rows, truth),
      0.95)
      << "inferred:\n"
      << text_of(inferred->chart) << inferred->notes.front();
  EXPECT_NEAR(inferred->wales_per_cm / maps.wales_per_cm, 1.0, 0.02);
  EXPECT_NEAR(inferred->courses_per_cm / maps.courses_per_cm, 1.0, 0.02);
}

// Stripes come through: two palette entries, two courses of each.
TEST(ChartInference, StripesGiveAPaletteAndColourRows) {
  const StitchChart truth = shipped("stripes.chart");
  const test::KnittedMaps maps = test::knit_maps(truth, {400, 400}, 0.03);
  const auto inferred = analysis::infer_knit_chart(maps.height, maps.albedo, measured(maps));
  ASSERT_TRUE(inferred) << inferred.error().describe();
  const StitchChart& chart = inferred->chart;
  ASSERT_EQ(chart.palette.size(), 2u) << text_of(chart);
  ASSERT_EQ(chart.rows, 4) << text_of(chart);
  for (int row = 0; row < 4; ++row)
    EXPECT_EQ(chart.colour_at(0, row), chart.colour_at(0, row + 2) == 0 ? 1 : 0) << text_of(chart);
  for (const Eigen::Vector3f& colour : chart.palette) {
    const float nearest = std::min(analysis::delta_e(colour, truth.palette[0]),
                                   analysis::delta_e(colour, truth.palette[1]));
    EXPECT_LT(nearest, 3.0f) << format_srgb_hex(colour);
  }
  // Written out and read back, the same chart.
  auto again = parse_stitch_chart(text_of(chart), "inferred.chart");
  ASSERT_TRUE(again) << again.error().describe() << "\n" << text_of(chart);
  EXPECT_TRUE(analysis::same_chart_up_to_shift(*again, chart));
  EXPECT_EQ(again->colour_index, chart.colour_index);
  EXPECT_NEAR(again->gauge.wales_per_cm, chart.gauge.wales_per_cm, 0.01);
}

TEST(ChartInference, RefusesAWovenScan) {
  analysis::FabricMeasurement woven;
  woven.periodic = true;
  woven.construction = analysis::Construction::woven;
  woven.construction_from_metadata = true;
  woven.u_px = {20, 0};
  woven.v_px = {0, 20};
  const auto inferred = analysis::infer_knit_chart(cv::Mat::zeros(200, 200, CV_32F), {}, woven);
  ASSERT_FALSE(inferred);
  EXPECT_EQ(inferred.error().kind, ErrorKind::bad_input);
  EXPECT_NE(inferred.error().message.find("woven"), std::string::npos) << inferred.error().message;
}

TEST(ChartInference, SaysWhenNoRepeatWasMeasured) {
  analysis::FabricMeasurement none;
  none.notes = {"no repeat found: the autocorrelation's highest peak off zero is 0.05"};
  const auto inferred = analysis::infer_knit_chart(cv::Mat::zeros(200, 200, CV_32F), {}, none);
  ASSERT_FALSE(inferred);
  EXPECT_EQ(inferred.error().kind, ErrorKind::bad_input);
  EXPECT_NE(inferred.error().message.find("no repeat"), std::string::npos);
}

// A texture that repeats but is no knit: a grid of round bumps.
TEST(ChartInference, SaysWhenTheStitchesLookLikeNoKnit) {
  cv::Mat height(300, 300, CV_32F);
  for (int r = 0; r < height.rows; ++r)
    for (int c = 0; c < height.cols; ++c)
      height.at<float>(r, c) = static_cast<float>(std::sin(c * 0.2) * std::sin(r * 0.2));
  analysis::MeasureOptions options;
  options.pixel_size_mm = 0.03;
  options.hints.construction = analysis::Construction::knit;
  const auto m = analysis::measure_fabric(height, {}, options);
  ASSERT_TRUE(m && m->periodic);
  const auto inferred = analysis::infer_knit_chart(height, {}, *m);
  ASSERT_FALSE(inferred) << format_stitch_chart(inferred->chart) << inferred->notes.front();
  EXPECT_NE(inferred.error().message.find("no knitted chart"), std::string::npos)
      << inferred.error().message;
}

TEST(ColourPalette, QuantisesToTheYarnsAndDropsStrays) {
  std::vector<Eigen::Vector3f> colours;
  const Eigen::Vector3f cream = *parse_srgb_hex("#E8DCC8"), navy = *parse_srgb_hex("#1F3A5F");
  for (int i = 0; i < 60; ++i)  // dye lots and shading: a percent or two
    colours.push_back((i % 3 == 0 ? navy : cream) * (1.0f + 0.02f * static_cast<float>(i % 5 - 2)));
  colours.push_back(*parse_srgb_hex("#FF0000"));  // one stray stitch
  const analysis::ColourPalette palette = analysis::quantise_colours(colours);
  ASSERT_EQ(palette.colours.size(), 2u);
  EXPECT_LT(analysis::delta_e(palette.colours[0], cream), 2.0f);  // the most used first
  EXPECT_LT(analysis::delta_e(palette.colours[1], navy), 2.0f);
  EXPECT_EQ(palette.index[0], 1);
  EXPECT_EQ(palette.index[1], 0);
}

TEST(StitchChartText, FormatsWhatItParses) {
  const StitchChart seed = shipped("seed.chart");
  auto again = parse_stitch_chart(format_stitch_chart(seed, "read off a scan\nsecond line"), "x");
  ASSERT_TRUE(again) << again.error().describe();
  EXPECT_EQ(again->cells, seed.cells);
  EXPECT_EQ(again->name, seed.name);
  EXPECT_EQ(format_srgb_hex(*parse_srgb_hex("#1F3A5F")), "#1F3A5F");
}

TEST(StitchChartText, SameUpToShift) {
  const StitchChart rib = shipped("rib-2x2.chart");  // K K P P
  StitchChart shifted = rib;
  shifted.cells = {Stitch::purl, Stitch::knit, Stitch::knit, Stitch::purl};
  EXPECT_TRUE(analysis::same_chart_up_to_shift(shifted, rib));
  shifted.cells = {Stitch::purl, Stitch::knit, Stitch::purl, Stitch::knit};
  EXPECT_FALSE(analysis::same_chart_up_to_shift(shifted, rib));
}

}  // namespace
}  // namespace psrig::cloth
