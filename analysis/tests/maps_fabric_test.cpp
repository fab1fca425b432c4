// The fabric and chart of a maps directory as psrig measure and the
// preview take them: a simulated rib-1x1 scan processed into maps (the
// pipeline writes report.json's fabric), read back. The report's fabric is
// reused as it is and agrees with the maps measured anew; an unusable one
// is said and measured around; the chart read off is the chart knitted.

#include "psrig/analysis/maps_fabric.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "psrig/formats/scan_writer.h"
#include "psrig/processing/pipeline.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::analysis {
namespace {

constexpr double kPixelSizeMm = 0.03;

formats::Maps processed_knit(const test::TempDir& temp) {
  sim::SyntheticScanParams params;
  params.swatch = test::swatch_params("rib-1x1", {400, 320}, kPixelSizeMm);
  const auto scan = temp / "scan";
  EXPECT_TRUE(formats::write_scan(test::made(sim::make_synthetic_scan(params)), scan));
  const auto processed = test::made(processing::process_scan(scan));
  std::vector<std::string> warnings;
  return test::made(formats::read_maps(processed.maps_directory, warnings));
}

TEST(MapsFabric, ReusesTheReportsFabricWhichAgreesWithTheMapsMeasuredAnew) {
  test::TempDir temp;
  const formats::Maps maps = processed_knit(temp);
  ASSERT_TRUE(maps.report.contains("fabric"));
  std::vector<std::string> warnings;
  const auto reused = fabric_of_maps(maps, warnings);
  ASSERT_TRUE(reused) << reused.error().describe();
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  const auto reported = fabric_from_json(maps.report["fabric"], maps.pixel_size_mm);
  ASSERT_TRUE(reported);
  EXPECT_EQ(reused->u_px, reported->u_px);
  EXPECT_EQ(reused->v_px, reported->v_px);
  EXPECT_DOUBLE_EQ(reused->across_density, reported->across_density);

  const auto measured = measure_maps(maps);
  ASSERT_TRUE(measured) << measured.error().describe();
  ASSERT_TRUE(measured->periodic) << summary_line(*measured);
  EXPECT_EQ(measured->construction, Construction::knit);
  EXPECT_EQ(measured->structure, reused->structure);  // the scan's hints
  ASSERT_TRUE(measured->pixel_size_mm);
  EXPECT_NEAR(*measured->pixel_size_mm, kPixelSizeMm, 1e-9);
  EXPECT_NEAR(measured->across_density / reused->across_density, 1.0, 0.01)
      << summary_line(*measured) << " / " << summary_line(*reused);
  EXPECT_NEAR(measured->along_density / reused->along_density, 1.0, 0.01)
      << summary_line(*measured) << " / " << summary_line(*reused);
}

TEST(MapsFabric, AnUnusableReportFabricIsSaidAndTheMapsMeasured) {
  test::TempDir temp;
  formats::Maps maps = processed_knit(temp);
  maps.report["fabric"]["lattice_px"].erase("v");
  std::vector<std::string> warnings;
  const auto fabric = fabric_of_maps(maps, warnings);
  ASSERT_TRUE(fabric) << fabric.error().describe();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("fabric.lattice_px.v"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("measuring the maps instead"), std::string::npos) << warnings[0];
  const auto measured = measure_maps(maps);
  ASSERT_TRUE(measured);
  EXPECT_EQ(fabric->u_px, measured->u_px);
  EXPECT_DOUBLE_EQ(fabric->across_density, measured->across_density);
  EXPECT_DOUBLE_EQ(fabric->along_density, measured->along_density);

  // Without a fabric in the report there is nothing to warn of.
  maps.report.erase("fabric");
  warnings.clear();
  const auto unreported = fabric_of_maps(maps, warnings);
  ASSERT_TRUE(unreported);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  EXPECT_DOUBLE_EQ(unreported->across_density, measured->across_density);
}

TEST(MapsFabric, ReadsTheChartKnittedOffTheMaps) {
  test::TempDir temp;
  const formats::Maps maps = processed_knit(temp);
  std::vector<std::string> warnings;
  const auto fabric = fabric_of_maps(maps, warnings);
  ASSERT_TRUE(fabric);
  const auto knit = infer_knit_chart(maps, *fabric);
  ASSERT_TRUE(knit) << knit.error().describe();
  const auto knitted = cloth::load_stitch_chart(test::shipped_pattern("rib-1x1.chart"));
  ASSERT_TRUE(knitted);
  EXPECT_TRUE(same_chart_up_to_shift(knit->chart, *knitted))
      << cloth::format_stitch_chart(knit->chart);
  // The scan's count of stitches in its repeat is taken, not counted again.
  EXPECT_TRUE(knit->split_from_scan);
}

}  // namespace
}  // namespace psrig::analysis
