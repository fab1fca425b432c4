// The chart round trip (issue 18, "fed by the scan"): a stitch chart
// knitted by the cloth model, seen head-on under the rig's three lights at
// a known pixel size, written as a scan directory; `psrig process` and
// `psrig measure --chart` on it; the gauge measured within 2 % of the
// knitted one and the chart read off equal to the chart knitted, up to a
// cyclic shift of its repeat (where a repeat starts is where the maps
// start). Then `psrig-preview knit --from-scan` draws the chart read off.
//
// The scan is rendered here (tests/support/knitted_maps.h, Lambertian
// under the default rig's lights) until `psrig synth --pattern` renders
// charts itself.

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

class ChartRoundTrip : public ::testing::TestWithParam<Trip> {};

TEST_P(ChartRoundTrip, MeasuresTheGaugeAndReadsTheChartBack) {
  const Trip trip = GetParam();
  auto truth = cloth::load_stitch_chart(shipped_pattern(trip.chart));
  ASSERT_TRUE(truth) << truth.error().describe();
  const KnittedMaps maps = knit_maps(*truth, trip.size, trip.pixel_size_mm);
  TempDir temp;
  const fs::path scan = temp / "scan";
  const auto written = write_knitted_scan(maps, truth->name, scan);
  ASSERT_TRUE(written) << written.error().describe();

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
