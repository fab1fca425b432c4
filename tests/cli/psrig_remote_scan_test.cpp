// `psrig scan --remote` against a real psrigd on the simulated rig, beside
// `psrig scan --config` on the same rig: the same steps, the same summary,
// the same exit codes.

#include <algorithm>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daemon_process.h"
#include "test_support.h"

namespace psrig::test {
namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    lines.push_back(line);
  return lines;
}

// The steps a scan showed: its "psrig scan: STEP" lines, without the remote
// scan's own (queued, done) and any warning or error.
std::vector<std::string> steps_of(const std::string& err) {
  static const std::regex own(R"(^scan \d+ (queued on .*|done)$)");
  constexpr std::string_view kPrefix = "psrig scan: ";
  std::vector<std::string> steps;
  for (const auto& line : lines_of(err)) {
    if (!line.starts_with(kPrefix)) continue;
    const std::string step = line.substr(kPrefix.size());
    if (std::regex_match(step, own) || step.starts_with("warning:") || step.starts_with("error:"))
      continue;
    steps.push_back(step);
  }
  return steps;
}

// A summary line with its paths and numbers blotted out: what must be the
// same for two scans of one rig.
std::string shape(const std::string& line) {
  static const std::regex path(R"(/\S*)"), number(R"(-?\d+(\.\d+)?)");
  return std::regex_replace(std::regex_replace(line, path, "PATH"), number, "N");
}

std::vector<std::string> shapes(const std::string& out) {
  std::vector<std::string> result;
  for (const auto& line : lines_of(out))
    result.push_back(shape(line));
  return result;
}

// Whether `part` appears in `whole` in order (other lines between allowed).
bool in_order(const std::vector<std::string>& part, const std::vector<std::string>& whole) {
  auto at = whole.begin();
  for (const auto& line : part) {
    at = std::find(at, whole.end(), line);
    if (at == whole.end()) return false;
    ++at;
  }
  return true;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines)
    text += line + '\n';
  return text;
}

TEST(PsrigCliRemote, ShowsEveryStepAndTheSummaryOfALocalScan) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port);
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  auto local = run_program("psrig", {"scan", "--config", config.string(), "--out",
                                     (temp / "local").string(), "--sample-id", "S-1"});
  ASSERT_EQ(local.exit_code, 0) << local.err;
  auto remote = run_program("psrig", {"scan", "--remote", daemon.url(), "--sample-id", "S-1"});
  ASSERT_EQ(remote.exit_code, 0) << remote.err << daemon.log();

  // Every step of the local scan, in its order: the dark frame, each
  // light, writing, processing (psrigd adds "opening the rig").
  const auto local_steps = steps_of(local.err);
  for (const std::string step :
       {"dark frame", "light 1 of 3", "light 2 of 3", "light 3 of 3", "writing", "processing"})
    EXPECT_TRUE(in_order({step}, local_steps)) << step << " missing from\n" << local.err;
  const auto remote_steps = steps_of(remote.err);
  EXPECT_TRUE(in_order(local_steps, remote_steps)) << "local:\n"
                                                   << joined(local_steps) << "remote:\n"
                                                   << joined(remote_steps);
  EXPECT_TRUE(contains(remote.err, "scan 1 queued on " + daemon.url())) << remote.err;
  EXPECT_TRUE(contains(remote.err, "scan 1 done")) << remote.err;

  // The same summary, line for line, but for paths and numbers.
  const auto local_summary = shapes(local.out);
  EXPECT_EQ(shapes(remote.out), local_summary) << "local:\n"
                                               << local.out << "remote:\n"
                                               << remote.out;
  for (const std::string line : {"scan: PATH (N frames kept, N skipped, N ms capturing)",
                                 "maps: PATH", "residual: mean N of full scale", "time: N ms"})
    EXPECT_TRUE(in_order({line}, local_summary)) << line << " missing from\n" << local.out;
  const auto entry = daemon.get("/v1/scans/1");
  EXPECT_TRUE(contains(remote.out, "scan: " + entry["scan_directory"].get<std::string>() + " ("))
      << remote.out;
  EXPECT_TRUE(contains(remote.out, "maps: " + entry["maps_directory"].get<std::string>()))
      << remote.out;
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(PsrigCliRemote, QuietPrintsNothingOnSuccessInEitherPath) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port);
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  auto local = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", (temp / "local").string(), "-q"});
  auto remote = run_program("psrig", {"scan", "--remote", daemon.url(), "-q"});
  for (const auto* run : {&local, &remote}) {
    EXPECT_EQ(run->exit_code, 0) << run->err;
    EXPECT_EQ(run->out, "");
    EXPECT_EQ(run->err, "");
  }
  EXPECT_EQ(daemon.wait_finished(1)["status"], "done");
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// A camera that stops delivering frames (one in 1 s against a 300 ms grab
// timeout): both scans show their steps up to the failure, exit 1, and
// name the key to look at; the remote one names psrigd's error code too.
TEST(PsrigCliRemote, AFailedScanExitsAsALocalOneWithTheDaemonsCodeAndMessage) {
  TempDir temp;
  const int port = free_port();
  const auto config =
      daemon_config(temp, port,
                    {{"timeout_ms = 2000", "timeout_ms = 300"},
                     {"readout_us = 15000", "readout_us = 15000\nframe_interval_us = 1000000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  auto local = run_program(
      "psrig", {"scan", "--config", config.string(), "--out", (temp / "local").string()});
  auto remote = run_program("psrig", {"scan", "--remote", daemon.url()});
  EXPECT_EQ(local.exit_code, 1) << local.err;
  EXPECT_EQ(remote.exit_code, local.exit_code) << remote.err;
  EXPECT_TRUE(contains(local.err, "camera.timeout_ms")) << local.err;
  EXPECT_TRUE(contains(remote.err, "psrig scan: error: scan 1 failed (camera): ")) << remote.err;
  EXPECT_TRUE(contains(remote.err, "camera.timeout_ms")) << remote.err;
  EXPECT_TRUE(in_order(steps_of(local.err), steps_of(remote.err))) << "local:\n"
                                                                   << local.err << "remote:\n"
                                                                   << remote.err;
  EXPECT_EQ(remote.out, "");
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(PsrigCliRemote, NoDaemonThereExitsOneSayingSo) {
  const std::string url = "http://127.0.0.1:" + std::to_string(free_port());
  auto remote = run_program("psrig", {"scan", "--remote", url});
  EXPECT_EQ(remote.exit_code, 1);
  EXPECT_TRUE(contains(remote.err, "cannot reach psrigd")) << remote.err;
  EXPECT_EQ(remote.out, "");
}

}  // namespace
}  // namespace psrig::test
