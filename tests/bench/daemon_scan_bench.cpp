// BM_DaemonScan/12MP: psrigd's memory through a 12 MP scan (4000x3000, the
// simulated rig of config/sim.toml, three LEDs and a dark frame, two frames
// averaged each, the maps processed in the daemon). The daemon runs as its
// own process; its resident set is read from /proc (VmHWM reset before the
// scan, so `peak_MB` is exact). The first scan opens the rig; the one
// measured is the second, from a daemon idle with the rig open.
//
// The simulated camera holds a world the real one does not: the swatch and
// its radiance under each LED, 19 floats a pixel (`world_MB`). So the
// daemon's own figures are `own_peak_MB` (the peak less the world; goal: at
// most 600) and `after_over_idle_MB` (what the scan left resident; goal:
// about 0, the daemon back to its idle size).

#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <httplib.h>
#include <signal.h>
#include <spawn.h>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

constexpr int kScanWidth = 4000, kScanHeight = 3000;
constexpr int kDaemonPort = 18471;

// config/sim.toml at 12 MP into `dir`, with a longer LED limit and camera
// timeout: the simulated sensor takes seconds a frame at this size.
fs::path write_config(const fs::path& dir) {
  std::string text = psrig::test::file_contents(fs::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  const auto replace = [&](const std::string& from, const std::string& to) {
    if (const auto at = text.find(from); at != std::string::npos) text.replace(at, from.size(), to);
  };
  replace("width = 640", "width = " + std::to_string(kScanWidth));
  replace("height = 480", "height = " + std::to_string(kScanHeight));
  replace("max_on_ms = 5000", "max_on_ms = 60000");
  replace("timeout_ms = 2000", "timeout_ms = 30000");
  replace("root = \"../out/scans\"", "root = \"" + (dir / "scans").string() + "\"");
  replace("port = 8470", "port = " + std::to_string(kDaemonPort));
  const fs::path file = dir / "rig.toml";
  std::ofstream(file) << text;
  return file;
}

// Submits a scan and waits for it to end; its final status ("done", "failed").
std::string scan(httplib::Client& client) {
  const auto posted = client.Post("/v1/scans", R"({"sample_id":"bench"})", "application/json");
  if (!posted || posted->status != 202) return "not accepted";
  const auto id = nlohmann::json::parse(posted->body).value("id", std::int64_t{-1});
  for (;;) {
    std::this_thread::sleep_for(100ms);
    const auto got = client.Get("/v1/scans/" + std::to_string(id));
    if (!got) return "daemon gone";
    const std::string status = nlohmann::json::parse(got->body).value("status", "");
    if (status != "queued" && status != "running") return status;
  }
}

void BM_DaemonScan(benchmark::State& state) {
  psrig::test::TempDir temp("psrig-bench-daemon");
  const fs::path config = write_config(temp.path());
  const psrig::test::ProgramCommand command("psrigd", {"--config", config.string()});
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  const std::string log = (temp.path() / "psrigd.log").string();
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT, 0644);
  pid_t pid = -1;
  const int spawned =
      posix_spawn(&pid, command.file().c_str(), &actions, nullptr, command.argv(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    state.SkipWithError(("cannot start " + command.file()).c_str());
    return;
  }
  httplib::Client client("127.0.0.1", kDaemonPort);
  client.set_read_timeout(10s);
  bool ready = false;
  for (int i = 0; i < 300 && !ready; ++i) {
    if (const auto got = client.Get("/v1/status"); got && got->status == 200)
      ready = true;
    else
      std::this_thread::sleep_for(100ms);
  }
  const auto mb = [](long kb) { return static_cast<double>(kb) / 1024; };
  for (auto _ : state) {
    if (!ready || scan(client) != "done") break;  // the rig opened, the world made
    std::this_thread::sleep_for(1s);
    const long idle = psrig::test::process_status_kb(pid, "VmRSS");
    const bool exact = psrig::test::reset_peak_resident(pid);
    const std::string status = scan(client);
    const long peak = psrig::test::process_status_kb(pid, exact ? "VmHWM" : "VmRSS");
    std::this_thread::sleep_for(1s);
    const long after = psrig::test::process_status_kb(pid, "VmRSS");
    if (status != "done") {
      state.SkipWithError(("the scan ended " + status + "; see " + log).c_str());
      break;
    }
    const double world = 19.0 * 4 * kScanWidth * kScanHeight / (1 << 20);
    state.counters["idle_MB"] = mb(idle);
    state.counters["peak_MB"] = mb(peak);
    state.counters["after_MB"] = mb(after);
    state.counters["world_MB"] = world;
    state.counters["own_peak_MB"] = mb(peak) - world;
    state.counters["after_over_idle_MB"] = mb(after - idle);
  }
  if (!ready) state.SkipWithError(("psrigd did not answer; see " + log).c_str());
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
}

}  // namespace

BENCHMARK(BM_DaemonScan)
    ->Name("BM_DaemonScan/12MP")
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);
