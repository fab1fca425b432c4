// The fabric measurement against the simulator's gauge: every pattern, as
// laid and turned by a few degrees, within 1 % of its densities and 0.5 deg
// of its skew and rotation.

#include "psrig/analysis/fabric_measure.h"

#include <cmath>
#include <string>
#include <tuple>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "psrig/sim/swatch_model.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::processing {
namespace {

struct FabricCase {
  const char* pattern;
  double rotation_deg;
  cv::Size size{640, 480};
};

sim::Swatch swatch_of(const FabricCase& c, cv::Size size = {640, 480}) {
  sim::SwatchParams params = test::swatch_params(c.pattern, size, 0.025, 3);
  params.rotation_deg = c.rotation_deg;
  return test::made(sim::make_swatch(params));
}

// What scan.json's fabric says of a simulated swatch (sim/fabric_truth.h).
analysis::FabricHints hints_of(const sim::SwatchPattern& pattern) {
  return {pattern.knitted() ? analysis::Construction::knit : analysis::Construction::woven,
          pattern.name, pattern.gauge.across_per_repeat, pattern.gauge.along_per_repeat};
}

class FabricGauge : public ::testing::TestWithParam<FabricCase> {};

TEST_P(FabricGauge, DensitiesWithinOnePercentSkewWithinHalfADegree) {
  const FabricCase c = GetParam();
  const sim::Swatch swatch = swatch_of(c, c.size);
  const sim::SwatchPattern pattern = test::named_pattern(c.pattern);
  const sim::SwatchGauge& truth = pattern.gauge;
  analysis::MeasureOptions options;
  options.pixel_size_mm = 0.025;
  options.hints = hints_of(pattern);
  const auto m = analysis::measure_fabric(swatch.height_mm, swatch.albedo, options);
  ASSERT_TRUE(m) << m.error().describe();
  ASSERT_TRUE(m->periodic) << (m->notes.empty() ? "" : m->notes.back());
  EXPECT_NEAR(m->across_density / truth.across_per_cm, 1.0, 0.01) << analysis::summary_line(*m);
  EXPECT_NEAR(m->along_density / truth.along_per_cm, 1.0, 0.01) << analysis::summary_line(*m);
  EXPECT_NEAR(m->skew_deg, 0.0, 0.5) << analysis::summary_line(*m);
  EXPECT_NEAR(m->rotation_deg, c.rotation_deg, 0.5) << analysis::summary_line(*m);
  EXPECT_NEAR(m->wale_rotation_deg, c.rotation_deg, 0.5) << analysis::summary_line(*m);
  const nlohmann::json j = to_json(*m);
  EXPECT_EQ(j["units"], "per_cm");
  EXPECT_TRUE(j.contains(truth.knitted ? "wales_per_cm" : "ends_per_cm")) << j.dump();
  // The repeat in mm: the densities' threads per repeat over their spacing
  // (the same but for the skew's cosine).
  EXPECT_NEAR(m->repeat_width * m->across_density / (10.0 * m->threads_u), 1.0, 1e-3);
}

INSTANTIATE_TEST_SUITE_P(Patterns, FabricGauge,
                         ::testing::Values(FabricCase{"jersey", 0}, FabricCase{"rib", 0},
                                           FabricCase{"garter", 0}, FabricCase{"plain", 0},
                                           FabricCase{"twill", 0}, FabricCase{"jersey", 3.5},
                                           FabricCase{"rib", -4}, FabricCase{"garter", 2.5},
                                           FabricCase{"plain", -3}, FabricCase{"twill", 4},
                                           FabricCase{"rib-2x2", 0}, FabricCase{"seed", 3},
                                           FabricCase{"stripes", -2}, FabricCase{"satin-5", 2},
                                           // Its repeat is 11 x 7.5 mm: two of them each way.
                                           FabricCase{"basketweave", 3, {1100, 800}}),
                         [](const ::testing::TestParamInfo<FabricCase>& param_info) {
                           const double r = param_info.param.rotation_deg;
                           return test::test_name(param_info.param.pattern) + (r == 0 ? ""
                                                                               : r > 0
                                                                                   ? "_turned_ccw"
                                                                                   : "_turned_cw");
                         });

// A scan larger than the measured centre (1280 pixels a side): the finest
// weave's threads, 15 pixels apart, must stay resolved.
TEST(FabricMeasure, LargeScanIsMeasuredAtFullResolution) {
  const sim::Swatch swatch = swatch_of({"plain", 3}, {1800, 1400});
  const auto m = analysis::measure_fabric(swatch.height_mm, swatch.albedo,
                                          {0.025, {analysis::Construction::woven, "plain"}});
  ASSERT_TRUE(m && m->periodic);
  EXPECT_NEAR(m->across_density / 24.0, 1.0, 0.01) << analysis::summary_line(*m);
  EXPECT_NEAR(m->along_density / 22.0, 1.0, 0.01) << analysis::summary_line(*m);
  EXPECT_NEAR(m->rotation_deg, 3.0, 0.5) << analysis::summary_line(*m);
}

// Maps cut to measured_region measure the same, to the last bit: the
// pipeline keeps only that much of a 12 MP albedo.
TEST(FabricMeasure, MapsCutToTheMeasuredRegionMeasureTheSame) {
  const sim::Swatch swatch = swatch_of({"jersey", 2}, {1500, 1350});
  const cv::Rect region = analysis::measured_region(swatch.height_mm.size());
  EXPECT_EQ(region, cv::Rect(110, 35, 1280, 1280));
  EXPECT_EQ(analysis::measured_region({900, 2000}), cv::Rect(0, 360, 900, 1280));
  const analysis::MeasureOptions options{0.025, {analysis::Construction::knit, "jersey"}};
  const auto whole = analysis::measure_fabric(swatch.height_mm, swatch.albedo, options);
  const auto cut =
      analysis::measure_fabric(swatch.height_mm(region), swatch.albedo(region), options);
  ASSERT_TRUE(whole && cut && whole->periodic);
  EXPECT_EQ(to_json(*whole).dump(), to_json(*cut).dump());
}

// Without metadata the construction comes from the structure: a weave's
// centred or oblique cell of alike threads, a knit's plain rectangle.
TEST(FabricMeasure, TellsKnitFromWovenByStructure) {
  for (const auto& [pattern, knitted] :
       {std::pair{"jersey", true}, std::pair{"plain", false}, std::pair{"twill", false}}) {
    const sim::Swatch swatch = swatch_of({pattern, 2});
    analysis::MeasureOptions options;
    options.pixel_size_mm = 0.025;
    const auto m = analysis::measure_fabric(swatch.height_mm, swatch.albedo, options);
    ASSERT_TRUE(m && m->periodic) << pattern;
    EXPECT_EQ(m->construction,
              knitted ? analysis::Construction::knit : analysis::Construction::woven)
        << pattern;
    EXPECT_FALSE(m->construction_from_metadata);
    EXPECT_GT(m->construction_confidence, 0.5);
    EXPECT_LT(m->construction_confidence, 1.0);
    const sim::SwatchGauge truth = test::named_pattern(pattern).gauge;
    EXPECT_NEAR(m->across_density / truth.across_per_cm, 1.0, 0.01) << pattern;
  }
}

TEST(FabricMeasure, WithoutPixelSizeFiguresArePerPixelAndSaySo) {
  const sim::Swatch swatch = swatch_of({"jersey", 0});
  const auto m = analysis::measure_fabric(swatch.height_mm, swatch.albedo,
                                          {std::nullopt, {analysis::Construction::knit, "jersey"}});
  ASSERT_TRUE(m && m->periodic);
  const sim::SwatchGauge truth = test::named_pattern("jersey").gauge;
  // Per pixel = per cm times the pixel size in cm.
  EXPECT_NEAR(m->across_density / (truth.across_per_cm * 0.0025), 1.0, 0.01);
  const nlohmann::json j = to_json(*m);
  EXPECT_EQ(j["units"], "per_px");
  EXPECT_TRUE(j.contains("wales_per_px"));
  EXPECT_TRUE(j.contains("repeat_px"));
  ASSERT_FALSE(m->notes.empty());
  EXPECT_NE(m->notes.front().find("per pixel"), std::string::npos) << m->notes.front();
}

// Smooth random relief (no repeat): not periodic, and a note says why.
TEST(FabricMeasure, RandomReliefHasNoRepeat) {
  cv::Mat height(480, 640, CV_32F), albedo(480, 640, CV_32FC3);
  cv::RNG rng(7);
  rng.fill(height, cv::RNG::NORMAL, 0, 1);
  cv::GaussianBlur(height, height, {0, 0}, 6);
  rng.fill(albedo, cv::RNG::UNIFORM, 0.2, 0.8);
  cv::GaussianBlur(albedo, albedo, {0, 0}, 4);
  const auto m = analysis::measure_fabric(height, albedo, {0.025, {}});
  ASSERT_TRUE(m);
  EXPECT_FALSE(m->periodic);
  ASSERT_FALSE(m->notes.empty());
  EXPECT_NE(m->notes.back().find("no repeat found"), std::string::npos) << m->notes.back();
  EXPECT_FALSE(to_json(*m).contains("wales_per_cm"));
}

// report.json's fabric read back gives the measurement that wrote it; a
// missing lattice names its key.
TEST(FabricMeasure, ReadsReportJsonBack) {
  const sim::Swatch swatch = swatch_of({"rib", 3});
  const auto m = analysis::measure_fabric(swatch.height_mm, swatch.albedo,
                                          {0.025, {analysis::Construction::knit, "rib"}});
  ASSERT_TRUE(m && m->periodic);
  const auto back = analysis::fabric_from_json(to_json(*m), 0.025);
  ASSERT_TRUE(back) << back.error().describe();
  EXPECT_TRUE(back->periodic);
  EXPECT_EQ(back->construction, analysis::Construction::knit);
  EXPECT_TRUE(back->construction_from_metadata);
  EXPECT_EQ(back->structure, "rib");
  EXPECT_EQ(back->u_px, m->u_px);
  EXPECT_EQ(back->v_px, m->v_px);
  EXPECT_EQ(back->threads_u, m->threads_u);
  EXPECT_DOUBLE_EQ(back->across_density, m->across_density);
  EXPECT_DOUBLE_EQ(back->skew_deg, m->skew_deg);
  EXPECT_EQ(back->notes, m->notes);
  nlohmann::json broken = to_json(*m);
  broken["lattice_px"].erase("v");
  const auto refused = analysis::fabric_from_json(broken, 0.025);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().key, "fabric.lattice_px.v");
}

TEST(FabricMeasure, ReadsTheScansFabricMetadata) {
  const auto hints = analysis::fabric_hints(
      nlohmann::json{{"fabric", {{"construction", "woven"}, {"structure", "twill"}}}});
  EXPECT_EQ(hints.construction, analysis::Construction::woven);
  EXPECT_EQ(hints.structure, "twill");
  EXPECT_EQ(hints.across_per_repeat, 0);
  EXPECT_EQ(analysis::fabric_hints(nlohmann::json{{"fabric", 3}}).construction,
            analysis::Construction::unknown);
  const auto counted = analysis::fabric_hints(nlohmann::json{
      {"fabric", {{"construction", "knit"}, {"stitches_per_repeat", nlohmann::json{4, 1}}}}});
  EXPECT_EQ(counted.across_per_repeat, 4);
  EXPECT_EQ(counted.along_per_repeat, 1);
  // Counts that are no counts are no hint.
  for (const nlohmann::json& bad : {nlohmann::json{4}, nlohmann::json{0, 1}, nlohmann::json{2.5, 1},
                                    nlohmann::json("4x1"), nlohmann::json{4, 1, 1}})
    EXPECT_EQ(analysis::fabric_hints(nlohmann::json{{"fabric", {{"threads_per_repeat", bad}}}})
                  .across_per_repeat,
              0)
        << bad.dump();
}

// Older scans name a 1x1 rib's or garter's structure without counting its
// stitches; a scan that counts them is measured by its count, whatever its
// structure is called.
TEST(FabricMeasure, StitchesPerRepeatFromTheCountOrElseTheOlderNames) {
  const sim::Swatch swatch = swatch_of({"rib-2x2", 0});
  const double truth = test::named_pattern("rib-2x2").gauge.across_per_cm;
  analysis::MeasureOptions options;
  options.pixel_size_mm = 0.025;
  options.hints = {analysis::Construction::knit, "my rib", 4, 1};
  const auto counted = analysis::measure_fabric(swatch.height_mm, swatch.albedo, options);
  ASSERT_TRUE(counted && counted->periodic);
  EXPECT_NEAR(counted->across_density / truth, 1.0, 0.01) << analysis::summary_line(*counted);
  EXPECT_EQ(counted->threads_u, 4);
  options.hints = {analysis::Construction::knit, "my rib"};
  const auto uncounted = analysis::measure_fabric(swatch.height_mm, swatch.albedo, options);
  ASSERT_TRUE(uncounted && uncounted->periodic);
  EXPECT_NEAR(uncounted->across_density / (truth / 4), 1.0, 0.01);
  EXPECT_NE(to_json(*uncounted)["notes"].dump().find("stitches_per_repeat"), std::string::npos);

  const sim::Swatch rib = swatch_of({"rib-1x1", 0});
  options.hints = {analysis::Construction::knit, "rib"};  // an older scan's name
  const auto named = analysis::measure_fabric(rib.height_mm, rib.albedo, options);
  ASSERT_TRUE(named && named->periodic);
  EXPECT_NEAR(named->across_density / test::named_pattern("rib").gauge.across_per_cm, 1.0, 0.01);
}

}  // namespace
}  // namespace psrig::processing
