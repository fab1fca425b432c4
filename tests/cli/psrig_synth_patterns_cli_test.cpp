// `psrig synth --pattern` and rig.toml's `[sim] pattern`: every shipped
// chart and weave, a file of one's own and the older names, as a user runs
// them; each synthesised scan processes to its ground truth, and scan.json
// says what it is made of.

#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

class ShippedPattern : public ::testing::TestWithParam<const char*> {};

// Small, noisy, turned a little: the solve still finds the true normals to
// well under a degree on every pattern.
TEST_P(ShippedPattern, SynthesisedAndProcessedToUnderADegree) {
  TempDir temp;
  const std::string scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--pattern", GetParam(), "--size",
                                     "240x180", "--noise", "0.002", "--rotate", "2", "-q"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  auto process = run_program("psrig", {"process", scan, "--threads", "2", "-q"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  const nlohmann::json report = read_json(temp / "scan" / "maps" / "report.json");
  const double mean = report["ground_truth"]["angular_error_deg"]["mean"].get<double>();
  EXPECT_LT(mean, 1.0) << GetParam();
  EXPECT_GT(report["pixels"]["valid"].get<double>(), 0.5 * 240 * 180) << GetParam();
  // What it is made of, for the measurement and the lab.
  const nlohmann::json doc = read_json(temp / "scan" / "scan.json");
  EXPECT_EQ(doc["fabric"]["structure"], GetParam());
  EXPECT_EQ(doc["ground_truth"]["fabric"]["structure"], GetParam());
  const bool knit = doc["fabric"]["construction"] == "knit";
  EXPECT_TRUE(doc["fabric"].contains(knit ? "stitches_per_repeat" : "threads_per_repeat"))
      << doc["fabric"].dump();
  EXPECT_GT(doc["ground_truth"]["fabric"][knit ? "wales_per_cm" : "ends_per_cm"].get<double>(), 3);
}

INSTANTIATE_TEST_SUITE_P(Patterns, ShippedPattern, ::testing::ValuesIn(shipped_pattern_names()),
                         [](const ::testing::TestParamInfo<const char*>& param_info) {
                           return test_name(param_info.param);
                         });

// A chart of one's own, by path: its stitches, gauge and colours.
TEST(PsrigSynthPatterns, AChartFileByPath) {
  TempDir temp;
  std::ofstream(temp / "moss.chart") << "name: moss\nwales_per_cm: 6\ncourses_per_cm: 8\n"
                                        "colour A #2E6B3A\nK P\nP K\n";
  const std::string scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--pattern",
                                     (temp / "moss.chart").string(), "--size", "160x120"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  EXPECT_TRUE(contains(synth.out, "(moss,")) << synth.out;
  const nlohmann::json doc = read_json(temp / "scan" / "scan.json");
  EXPECT_EQ(doc["fabric"]["structure"], "moss");
  EXPECT_EQ(doc["fabric"]["stitches_per_repeat"], nlohmann::json({2, 2}));
  EXPECT_NEAR(doc["ground_truth"]["fabric"]["wales_per_cm"].get<double>(), 6, 1e-4);
  EXPECT_NEAR(doc["ground_truth"]["fabric"]["courses_per_cm"].get<double>(), 8, 1e-4);
}

// The simulator's older names still work and keep their name.
TEST(PsrigSynthPatterns, OlderNamesStillWork) {
  TempDir temp;
  for (const char* older : {"jersey", "rib", "garter", "plain", "twill"}) {
    const std::string scan = (temp / older).string();
    auto synth =
        run_program("psrig", {"synth", "--out", scan, "--pattern", older, "--size", "64x48", "-q"});
    ASSERT_EQ(synth.exit_code, 0) << older << ": " << synth.err;
    EXPECT_EQ(read_json(temp / older / "scan.json")["fabric"]["structure"], older);
  }
}

TEST(PsrigSynthPatterns, WhatIsNoPatternIsBadInputNamingTheOptionAndTheFix) {
  TempDir temp;
  auto unknown = run_program(
      "psrig", {"synth", "--out", (temp / "a").string(), "--pattern", "argyle", "--size", "64x48"});
  EXPECT_EQ(unknown.exit_code, 2);
  for (const char* part : {"--pattern", "argyle", "stockinette", ".chart"})
    EXPECT_TRUE(contains(unknown.err, part)) << unknown.err;
  EXPECT_FALSE(fs::exists(temp / "a"));

  std::ofstream(temp / "typo.chart") << "K P\nK Q\n";
  auto typo = run_program("psrig", {"synth", "--out", (temp / "b").string(), "--pattern",
                                    (temp / "typo.chart").string(), "--size", "64x48"});
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_TRUE(contains(typo.err, (temp / "typo.chart").string() + ":2:")) << typo.err;
  EXPECT_FALSE(fs::exists(temp / "b"));
}

// The simulated rig's swatch from a chart beside its rig.toml, and a
// chart with a mistake: bad input (exit 2) at the chart's line, no scan.
TEST(PsrigSynthPatterns, TheSimulatedRigScansTheChartItsRigTomlNames) {
  TempDir temp;
  std::ifstream in(fs::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"pattern = \"jersey\"", "pattern = \"moss.chart\""},
        {"root = \"../out/scans\"", "root = \"scans\""}}) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  std::ofstream(temp / "rig.toml") << text;
  std::ofstream(temp / "moss.chart") << "name: moss\nK P\nP K\n";
  auto run = run_program("psrig", {"scan", "--config", (temp / "rig.toml").string(), "--out",
                                   (temp / "scan").string(), "--no-process"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json truth = read_json(temp / "scan" / "scan.json")["ground_truth"]["fabric"];
  EXPECT_EQ(truth["structure"], "moss");
  EXPECT_EQ(truth["stitches_per_repeat"], nlohmann::json({2, 2}));

  std::ofstream(temp / "moss.chart") << "K P\nP Q\n";
  auto broken = run_program("psrig", {"scan", "--config", (temp / "rig.toml").string(), "--out",
                                      (temp / "again").string()});
  EXPECT_EQ(broken.exit_code, 2) << broken.err;
  EXPECT_TRUE(contains(broken.err, (temp / "moss.chart").string() + ":2:")) << broken.err;
  EXPECT_FALSE(fs::exists(temp / "again"));
}

}  // namespace
}  // namespace psrig::test
