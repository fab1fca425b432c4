// The chart round trip (issue 18, "fed by the scan"): a stitch chart
// knitted by the cloth model, seen head-on under the rig's three lights at
// a known pixel size, written as a scan directory; `psrig process` and
// `psrig measure --chart` on it; the gauge measured within 2 % of the
// knitted one and the chart read off equal to the chart knitted, up to a
// cyclic shift of its repeat (where a repeat starts is where the maps
// start). (`psrig-preview knit --from-scan` draws what is read off:
// psrig_preview_cli_test.cpp.)
//
// The scan is `psrig synth --pattern CHART`'s where the simulator renders
// charts; until it does (it refuses the pattern), it is rendered here
// (tests/support/knitted_scan.h, Lambertian under the default rig's lights).

#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "knitted_scan.h"
#include "psrig/cloth/chart_inference.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

struct Trip {
  const char* chart;
  cv::Size size;
  double pixel_size_mm;
};

// A scan of the chart and the gauge it was knitted at.
struct KnittedScan {
  double wales_per_cm = 0, courses_per_cm = 0;
  std::string by;  // which renderer made it
};

KnittedScan make_scan(const Trip& trip, const cloth::StitchChart& chart, const fs::path& scan) {
  char size[32], pixel[32];
  std::snprintf(size, sizeof size, "%dx%d", trip.size.width, trip.size.height);
  std::snprintf(pixel, sizeof pixel, "%g", trip.pixel_size_mm);
  const auto synth =
      run_program("psrig", {"synth", "--out", scan.string(), "--pattern",
                            shipped_pattern(trip.chart).string(), "--size", size, "--pixel-size",
                            pixel, "--noise", "0.002", "-q"});
  if (synth.exit_code == 0) {
    std::ifstream in(scan / "scan.json");
    const auto truth = nlohmann::json::parse(in)["ground_truth"]["fabric"];
    return {truth["wales_per_cm"].get<double>(), truth["courses_per_cm"].get<double>(),
            "psrig synth"};
  }
  // Only a simulator that does not render charts yet is stood in for.
  EXPECT_NE(synth.err.find("--pattern"), std::string::npos) << synth.err;
  const KnittedMaps maps = knit_maps(chart, trip.size, trip.pixel_size_mm);
  const auto written = write_knitted_scan(maps, chart.name, scan);
  EXPECT_TRUE(written) << written.error().describe();
  return {maps.wales_per_cm, maps.courses_per_cm, "tests/support/knitted_scan"};
}

class ChartRoundTrip : public ::testing::TestWithParam<Trip> {};

TEST_P(ChartRoundTrip, MeasuresTheGaugeAndReadsTheChartBack) {
  const Trip trip = GetParam();
  auto truth = cloth::load_stitch_chart(shipped_pattern(trip.chart));
  ASSERT_TRUE(truth) << truth.error().describe();
  TempDir temp;
  const fs::path scan = temp / "scan";
  const KnittedScan maps = make_scan(trip, *truth, scan);
  ASSERT_GT(maps.wales_per_cm, 0);
  std::printf("round trip: %s, scan by %s\n", trip.chart, maps.by.c_str());

  auto process = run_program("psrig", {"process", scan.string(), "--threads", "2", "-q"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  const fs::path chart_file = temp / "inferred.chart";
  auto measure = run_program("psrig", {"measure", (scan / "maps").string(), "--chart",
                                       chart_file.string(), "--json"});
  ASSERT_EQ(measure.exit_code, 0) << measure.err;
  const auto printed = nlohmann::json::parse(measure.out);
  EXPECT_NEAR(printed["wales_per_cm"].get<double>() / maps.wales_per_cm, 1.0, 0.02)
      << printed.dump(2);
  EXPECT_NEAR(printed["courses_per_cm"].get<double>() / maps.courses_per_cm, 1.0, 0.02)
      << printed.dump(2);
  std::printf("round trip: %s: wales %+.2f %%, courses %+.2f %%\n", trip.chart,
              100 * (printed["wales_per_cm"].get<double>() / maps.wales_per_cm - 1),
              100 * (printed["courses_per_cm"].get<double>() / maps.courses_per_cm - 1));
  EXPECT_GE(printed["chart"]["agreement"].get<double>(), 0.95) << printed.dump(2);

  auto inferred = cloth::load_stitch_chart(chart_file);
  ASSERT_TRUE(inferred) << inferred.error().describe();
  EXPECT_TRUE(cloth::same_chart_up_to_shift(*inferred, *truth))
      << "read off:\n" << cloth::format_stitch_chart(*inferred)
      << "knitted:\n" << cloth::format_stitch_chart(*truth);
  EXPECT_NEAR(inferred->gauge.wales_per_cm, printed["wales_per_cm"].get<double>(), 0.01);
}

INSTANTIATE_TEST_SUITE_P(Charts, ChartRoundTrip,
                         ::testing::Values(Trip{"stockinette.chart", {400, 320}, 0.03},
                                           Trip{"rib-1x1.chart", {400, 320}, 0.03},
                                           Trip{"garter.chart", {400, 320}, 0.03},
                                           Trip{"seed.chart", {400, 320}, 0.03}),
                         [](const ::testing::TestParamInfo<Trip>& param_info) {
                           std::string name = fs::path(param_info.param.chart).stem().string();
                           std::erase(name, '-');
                           return name;
                         });

// A woven scan's maps: --chart refuses and says why.
TEST(ChartRoundTrip, MeasureChartRefusesAWovenScan) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--pattern", "plain", "--size",
                                     "320x240", "-q"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  auto process = run_program("psrig", {"process", scan, "-q"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  auto measure =
      run_program("psrig", {"measure", scan + "/maps", "--chart", (temp / "x.chart").string()});
  EXPECT_EQ(measure.exit_code, 2);
  EXPECT_NE(measure.err.find("woven"), std::string::npos) << measure.err;
  EXPECT_NE(measure.err.find(scan + "/maps"), std::string::npos) << measure.err;
  EXPECT_FALSE(fs::exists(temp / "x.chart"));
}

}  // namespace
}  // namespace psrig::test
