// `psrig measure` and `psrig tile` as a technician meets them: the figures
// in report.json and the summary, the tile directory, and bad input.

#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

// synth (turned), process, then the report's fabric section against the
// simulator's truth in scan.json.
void expect_measured_like_truth(const std::string& pattern, const std::string& rotate) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--pattern", pattern, "--size",
                                     "640x480", "--rotate", rotate, "--noise", "0.002", "-q"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const nlohmann::json truth = read_json(temp / "scan" / "scan.json")["ground_truth"]["fabric"];
  auto process = run_program("psrig", {"process", scan, "--threads", "2"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  EXPECT_TRUE(contains(process.out, "fabric: " + pattern)) << process.out;
  const nlohmann::json fabric = read_json(temp / "scan" / "maps" / "report.json")["fabric"];
  ASSERT_TRUE(fabric["periodic"].get<bool>()) << fabric.dump(2);
  EXPECT_EQ(fabric["construction_source"], "metadata");
  const bool knit = truth["construction"] == "knit";
  for (const char* key : knit ? std::array{"wales_per_cm", "courses_per_cm"}
                              : std::array{"ends_per_cm", "picks_per_cm"})
    EXPECT_NEAR(fabric[key].get<double>() / truth[key].get<double>(), 1.0, 0.01)
        << key << ": " << fabric.dump(2);
  EXPECT_NEAR(fabric["rotation_deg"].get<double>(), truth["rotation_deg"].get<double>(), 0.5);
  EXPECT_NEAR(fabric["skew_deg"].get<double>(), 0.0, 0.5);

  auto measure = run_program("psrig", {"measure", scan + "/maps", "--json"});
  ASSERT_EQ(measure.exit_code, 0) << measure.err;
  EXPECT_TRUE(measure.err.empty()) << measure.err;
  const auto printed = nlohmann::json::parse(measure.out);
  EXPECT_EQ(printed["summary"], fabric["summary"]);

  auto tile = run_program("psrig", {"tile", scan + "/maps"});
  ASSERT_EQ(tile.exit_code, 0) << tile.err;
  EXPECT_TRUE(contains(tile.out, "invisible")) << tile.out;
  const fs::path dir = temp / "scan" / "maps" / "tile";
  const nlohmann::json tj = read_json(dir / "tile.json");
  EXPECT_EQ(tj["format"], "psrig-tile/1");
  EXPECT_TRUE(tj["periodic"].get<bool>());
  EXPECT_TRUE(tj["seam"]["passed"].get<bool>()) << tj["seam"].dump();
  for (const char* name : {"albedo.png", "albedo.exr", "normal.png", "p.exr", "q.exr", "height.exr",
                           "height.png", "mask.png"})
    EXPECT_TRUE(fs::exists(dir / name)) << name;
  // The tile is whole repeats of the measured repeat.
  EXPECT_NEAR(tj["width_mm"].get<double>() /
                  (tj["repeats"][0].get<double>() * fabric["repeat_mm"][0].get<double>()),
              1.0, 0.002);
  // Again: the earlier tile is replaced.
  EXPECT_EQ(run_program("psrig", {"tile", scan + "/maps", "-q"}).exit_code, 0);
}

TEST(PsrigMeasureTile, TurnedJerseyMeasuresAsMadeAndTiles) {
  expect_measured_like_truth("jersey", "3");
}
TEST(PsrigMeasureTile, TurnedTwillMeasuresAsMadeAndTiles) {
  expect_measured_like_truth("twill", "-4");
}
TEST(PsrigMeasureTile, TurnedRibMeasuresAsMadeAndTiles) {
  expect_measured_like_truth("rib", "2.5");
}
TEST(PsrigMeasureTile, TurnedGarterMeasuresAsMadeAndTiles) {
  expect_measured_like_truth("garter", "-3");
}

// The simulated rig (sensor noise, vignetting) with its swatch turned:
// scan.json carries the gauge truth, the scan's report the measurement, the
// construction guessed from the structure (no fabric metadata on a rig scan).
TEST(PsrigMeasureTile, TurnedSwatchOnTheSimulatedRigMeasuresAsMade) {
  TempDir temp;
  std::ifstream in(fs::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"pattern = \"jersey\"",
                                            "pattern = \"plain\"\nswatch_rotation_deg = -3"},
        {"root = \"../out/scans\"", "root = \"scans\""}}) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  std::ofstream(temp / "rig.toml") << text;
  const auto scan = (temp / "scan").string();
  auto run =
      run_program("psrig", {"scan", "--config", (temp / "rig.toml").string(), "--out", scan});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "fabric: woven (guessed from the structure)")) << run.out;
  const nlohmann::json truth = read_json(temp / "scan" / "scan.json")["ground_truth"]["fabric"];
  EXPECT_EQ(truth["rotation_deg"], -3.0);
  const nlohmann::json fabric = read_json(temp / "scan" / "maps" / "report.json")["fabric"];
  ASSERT_TRUE(fabric["periodic"].get<bool>()) << fabric.dump(2);
  EXPECT_EQ(fabric["construction"], "woven");
  EXPECT_EQ(fabric["construction_source"], "structure");
  for (const char* key : {"ends_per_cm", "picks_per_cm"})
    EXPECT_NEAR(fabric[key].get<double>() / truth[key].get<double>(), 1.0, 0.01) << key;
  EXPECT_NEAR(fabric["rotation_deg"].get<double>(), -3.0, 0.5);
}

TEST(PsrigMeasureTile, MapsWithoutReportWorkInPixelsWithAWarning) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan, "--size", "400x300", "-q"}).exit_code, 0);
  ASSERT_EQ(run_program("psrig", {"process", scan, "-q"}).exit_code, 0);
  fs::remove(temp / "scan" / "maps" / "report.json");
  auto measure = run_program("psrig", {"measure", scan + "/maps"});
  EXPECT_EQ(measure.exit_code, 0) << measure.err;
  EXPECT_TRUE(contains(measure.err, "report.json is missing")) << measure.err;
  EXPECT_TRUE(contains(measure.out, "wales/px")) << measure.out;
  auto tile = run_program("psrig", {"tile", scan + "/maps", "--out", (temp / "t").string()});
  EXPECT_EQ(tile.exit_code, 0) << tile.err;
  EXPECT_TRUE(read_json(temp / "t" / "tile.json")["width_mm"].is_null());
  EXPECT_EQ(read_json(temp / "t" / "tile.json")["units"], "px");
}

TEST(PsrigMeasureTile, MissingMapsAndUnwritableOutputAreClearErrors) {
  TempDir temp;
  auto none = run_program("psrig", {"measure", (temp / "nowhere").string()});
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_TRUE(contains(none.err, "not a directory")) << none.err;
  fs::create_directories(temp / "empty");
  auto empty = run_program("psrig", {"tile", (temp / "empty").string()});
  EXPECT_EQ(empty.exit_code, 2);
  EXPECT_TRUE(contains(empty.err, "albedo.exr")) << empty.err;
  EXPECT_FALSE(fs::exists(temp / "empty" / "tile"));

  const auto scan = (temp / "scan").string();
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan, "--size", "320x240", "-q"}).exit_code, 0);
  ASSERT_EQ(run_program("psrig", {"process", scan, "-q"}).exit_code, 0);
  // A file where the tile's parent should be.
  std::ofstream(temp / "file") << "x";
  auto blocked =
      run_program("psrig", {"tile", scan + "/maps", "--out", (temp / "file" / "t").string()});
  EXPECT_NE(blocked.exit_code, 0);
  EXPECT_TRUE(contains(blocked.err, "file")) << blocked.err;
  // Something else already there is never replaced.
  fs::create_directories(temp / "keep");
  std::ofstream(temp / "keep" / "notes.txt") << "mine";
  auto refused = run_program("psrig", {"tile", scan + "/maps", "--out", (temp / "keep").string()});
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_TRUE(contains(refused.err, "not a psrig tile directory")) << refused.err;
  EXPECT_TRUE(fs::exists(temp / "keep" / "notes.txt"));
  EXPECT_FALSE(fs::exists(temp / "keep" / "tile.json"));
  // Nothing half-written: no staging directory (".NAME.partial-PID-N") left beside them.
  for (const auto& entry : fs::directory_iterator(temp / "keep" / ".."))
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
  for (const auto& entry : fs::directory_iterator(temp / "scan" / "maps"))
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
  auto many = run_program("psrig", {"tile", scan + "/maps", "--repeats", "50"});
  EXPECT_EQ(many.exit_code, 2);
  EXPECT_TRUE(contains(many.err, "--repeats")) << many.err;
}

// A plaster bust does not repeat: a clear message, and the whole scan as
// the tile, its border blended.
TEST(PsrigMeasureTile, BeethovenHasNoRepeatAndTilesAsTheWholeScan) {
  const auto data = real_dataset("beethoven");
  if (!data) GTEST_SKIP() << "shared/data/beethoven not present";
  TempDir temp;
  const auto maps = (temp / "maps").string();
  ASSERT_EQ(run_program("psrig", {"process", data->string(), "--out", maps, "-q"}).exit_code, 0);
  EXPECT_FALSE(read_json(temp / "maps" / "report.json")["fabric"]["periodic"].get<bool>());
  auto measure = run_program("psrig", {"measure", maps});
  EXPECT_EQ(measure.exit_code, 0) << measure.err;
  EXPECT_TRUE(contains(measure.err, "no pixel_size_mm")) << measure.err;
  EXPECT_TRUE(contains(measure.err, "no repeat found")) << measure.err;
  auto tile = run_program("psrig", {"tile", maps});
  EXPECT_EQ(tile.exit_code, 0) << tile.err;
  EXPECT_TRUE(contains(tile.err, "whole scan")) << tile.err;
  const nlohmann::json tj = read_json(temp / "maps" / "tile" / "tile.json");
  EXPECT_FALSE(tj["periodic"].get<bool>());
  EXPECT_TRUE(tj["seam"]["passed"].get<bool>()) << tj["seam"].dump();
  EXPECT_GT(tj["seam"]["samples"].get<int>(), 400) << tj["seam"].dump();  // checked, not vacuous
  EXPECT_LT(tj["width_px"].get<int>(), 256);
  EXPECT_GT(tj["width_px"].get<int>(), 200);
}

}  // namespace
}  // namespace psrig::test
