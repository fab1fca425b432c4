// The `psrig` program as a technician meets it: exit codes, messages, and
// nothing half-written.

#include <fstream>
#include <functional>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(PsrigCli, SynthThenProcess) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  auto synth = run_program("psrig", {"synth", "--out", scan, "--pattern", "rib", "--size",
                                     "160x120", "--noise", "0.002"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  auto process = run_program("psrig", {"process", scan, "--threads", "2"});
  ASSERT_EQ(process.exit_code, 0) << process.err;
  EXPECT_TRUE(contains(process.out, "maps: " + scan + "/maps")) << process.out;
  EXPECT_TRUE(contains(process.out, "ground truth: mean angular error")) << process.out;
  EXPECT_TRUE(fs::exists(temp / "scan" / "maps" / "normal.png"));
}

TEST(PsrigCli, UsageErrorsExitTwo) {
  EXPECT_EQ(run_program("psrig", {}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process"}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"process", "x", "--integrate", "magic"}).exit_code, 2);
  TempDir temp;
  auto bad_size = run_program("psrig", {"synth", "--out", (temp / "s").string(), "--size", "big"});
  EXPECT_EQ(bad_size.exit_code, 2);
  EXPECT_TRUE(contains(bad_size.err, "--size")) << bad_size.err;
  EXPECT_FALSE(fs::exists(temp / "s"));
  EXPECT_EQ(run_program("psrig", {"--help"}).exit_code, 0);
}

// One way a scan can be wrong, what the message must name, and the change
// that makes it so.
struct BadScan {
  const char* name;
  const char* must_name;  // in stderr
  std::function<void(const fs::path&)> spoil;
};

void edit_json(const fs::path& scan, const std::function<void(nlohmann::json&)>& edit) {
  std::ifstream in(scan / "scan.json");
  auto doc = nlohmann::json::parse(in);
  edit(doc);
  std::ofstream(scan / "scan.json") << doc.dump(2);
}

const BadScan kBadScans[] = {
    {"zero direction", "lights[1].direction",
     [](const fs::path& s) {
       edit_json(s, [](auto& d) { d["lights"][1]["direction"] = {0, 0, 0}; });
     }},
    {"two lights", "scan.json: lights:",
     [](const fs::path& s) { edit_json(s, [](auto& d) { d["lights"].erase(2); }); }},
    {"coplanar lights", "condition number",
     [](const fs::path& s) {
       edit_json(s, [](auto& d) {
         d["lights"][0]["direction"] = {1, 0, 1};
         d["lights"][1]["direction"] = {0, 1, 1};
         d["lights"][2]["direction"] = {1, 1, 2};
       });
     }},
    {"malformed json",
     "scan.json:1:", [](const fs::path& s) { std::ofstream(s / "scan.json") << "{\"format\": }"; }},
    {"missing frame", "led2.png", [](const fs::path& s) { fs::remove(s / "led2.png"); }},
    {"corrupt frame", "led0.png",
     [](const fs::path& s) { std::ofstream(s / "led0.png") << "not an image"; }},
    {"frame of another size", "led1.png",
     [](const fs::path& s) {
       fs::copy_file(s / "small.png", s / "led1.png", fs::copy_options::overwrite_existing);
     }},
};

TEST(PsrigCli, EveryBadScanExitsTwoNamingTheProblemAndWritesNothing) {
  for (const auto& bad : kBadScans) {
    TempDir temp;
    const auto scan = temp / "scan";
    ASSERT_EQ(run_program("psrig", {"synth", "--out", scan.string(), "--size", "32x24"}).exit_code,
              0);
    ASSERT_EQ(run_program("psrig", {"synth", "--out", (temp / "small").string(), "--size", "16x16"})
                  .exit_code,
              0);
    fs::copy_file(temp / "small" / "led0.png", scan / "small.png");
    bad.spoil(scan);
    auto run = run_program("psrig", {"process", scan.string(), "--out", (temp / "maps").string()});
    EXPECT_EQ(run.exit_code, 2) << bad.name << ": " << run.err;
    EXPECT_TRUE(contains(run.err, bad.must_name)) << bad.name << ": " << run.err;
    EXPECT_EQ(list_directory(temp.path()), (std::vector<std::string>{"scan", "small"})) << bad.name;
  }
}

TEST(PsrigCli, MissingScanDirectory) {
  auto run = run_program("psrig", {"process", "/nonexistent/scan"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "/nonexistent/scan")) << run.err;
}

TEST(PsrigCli, ReadOnlyScanNeedsOut) {
  const auto beethoven = real_dataset("beethoven");
  if (!beethoven) GTEST_SKIP() << "shared/data/beethoven not present";
  if (::access(beethoven->c_str(), W_OK) == 0) GTEST_SKIP() << "dataset is writable here";
  auto run = run_program("psrig", {"process", beethoven->string()});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "cannot write")) << run.err;
  TempDir temp;
  auto with_out =
      run_program("psrig", {"process", beethoven->string(), "--out", (temp / "maps").string()});
  EXPECT_EQ(with_out.exit_code, 0) << with_out.err;
}

TEST(PsrigCli, SynthRefusesToOverwrite) {
  TempDir temp;
  const auto scan = (temp / "scan").string();
  ASSERT_EQ(run_program("psrig", {"synth", "--out", scan, "--size", "32x24"}).exit_code, 0);
  auto again = run_program("psrig", {"synth", "--out", scan, "--size", "32x24"});
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_TRUE(contains(again.err, "already exists")) << again.err;
}

}  // namespace
}  // namespace psrig::test
