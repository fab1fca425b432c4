// Many rigs on one shared catalogue: N simulated rigs (each a ScanService
// with its own simulated world, scanning at the rate its camera allows,
// its queue kept fed) writing their rows to one PostgreSQL database for a
// bounded time, then left to finish what they queued. Counters: scans per
// second over all rigs, each rig's share of that, the row writes'
// latency (median and p99, each add, running, done or end a rig makes),
// and rows_lost: scans accepted whose row is not in the database, done,
// exactly once (anything but 0 fails the run). The baselines, measured in
// the same run: one rig on the same database (rigs:1) and one rig on the
// embedded SQLite catalogue (BM_EmbeddedCatalogueRig).
//
//   build/bin/psrig_bench --benchmark_filter='Catalogue(Rigs|Rig)' --benchmark_format=json

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>

#include <benchmark/benchmark.h>

#include "bench_config.h"
#include "postgres_server.h"
#include "psrig/base/log.h"
#include "psrig/catalogue/catalogue.h"
#include "psrig/config/config_loader.h"
#include "psrig/daemon/scan_service.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// How long the rigs are fed scans; then they finish what they queued.
constexpr auto kFeeding = std::chrono::seconds(6);
constexpr auto kDrainLimit = std::chrono::seconds(60);

// Every row write's duration, in ms, from every rig.
class WriteTimes {
 public:
  void add(double ms) {
    std::lock_guard lock(mutex_);
    times_.push_back(ms);
  }
  [[nodiscard]] double percentile(double p) {
    std::lock_guard lock(mutex_);
    if (times_.empty()) return 0;
    std::sort(times_.begin(), times_.end());
    return times_[std::min(times_.size() - 1, static_cast<std::size_t>(p * times_.size()))];
  }
  [[nodiscard]] std::size_t count() {
    std::lock_guard lock(mutex_);
    return times_.size();
  }

 private:
  std::mutex mutex_;
  std::vector<double> times_;
};

// A catalogue that times each row write it passes on.
class TimedCatalogue final : public catalogue::Catalogue {
 public:
  TimedCatalogue(std::unique_ptr<catalogue::Catalogue> inner, WriteTimes& times)
      : inner_(std::move(inner)), times_(times) {}

  const char* backend() const override { return inner_->backend(); }
  const fs::path& storage_root() const override { return inner_->storage_root(); }
  const fs::path& rig_root() const override { return inner_->rig_root(); }
  const std::string& rig_name() const override { return inner_->rig_name(); }
  Result<std::int64_t> add(const catalogue::ScanSubmission& submission) override {
    return timed([&] { return inner_->add(submission); });
  }
  Status mark_running(std::int64_t id, const fs::path& scan_directory) override {
    return timed([&] { return inner_->mark_running(id, scan_directory); });
  }
  Status mark_done(std::int64_t id, const fs::path& maps, const nlohmann::json& report) override {
    return timed([&] { return inner_->mark_done(id, maps, report); });
  }
  Status mark_failed(std::int64_t id, catalogue::ScanStatus status, catalogue::ScanErrorCode code,
                     const std::string& message, bool keep) override {
    return timed([&] { return inner_->mark_failed(id, status, code, message, keep); });
  }
  std::size_t flush_pending() override { return inner_->flush_pending(); }
  std::size_t pending_count() const override { return inner_->pending_count(); }
  void inject_write_failure(std::optional<Error> error, int writes_first) override {
    inner_->inject_write_failure(std::move(error), writes_first);
  }
  Result<std::optional<catalogue::CatalogueEntry>> get(std::int64_t id) const override {
    return inner_->get(id);
  }
  Result<std::vector<catalogue::CatalogueEntry>> search(
      const catalogue::CatalogueQuery& query) const override {
    return inner_->search(query);
  }
  Result<std::int64_t> count(const catalogue::CatalogueQuery& query) const override {
    return inner_->count(query);
  }
  Result<bool> remove(std::int64_t id) override { return inner_->remove(id); }
  Result<catalogue::CatalogueRecovery> recover() override { return inner_->recover(); }
  Status announce(const catalogue::RigRecord& rig) override { return inner_->announce(rig); }
  Result<std::vector<catalogue::RigRecord>> rigs() const override { return inner_->rigs(); }

 private:
  template <class Write>
  auto timed(Write&& write) -> decltype(write()) {
    const auto start = Clock::now();
    auto result = write();
    times_.add(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    return result;
  }
  std::unique_ptr<catalogue::Catalogue> inner_;
  WriteTimes& times_;
};

// One server for every case of the run, durable as a real one (fsync on).
PostgresServer* bench_server(std::string& why_not) {
  static std::string reason;
  static std::unique_ptr<PostgresServer> server = PostgresServer::start({.fsync = true}, reason);
  why_not = reason;
  return server.get();
}

// `rigs` simulated rigs on the catalogue `url` (empty: each its embedded
// one), fed scans for kFeeding, then drained; the counters.
void run_rigs(benchmark::State& state, int rigs, const std::string& url) {
  psrig::set_log_level(spdlog::level::warn);  // hundreds of scans' info lines otherwise
  TempDir temp("psrig-shared-bench");
  WriteTimes times;
  std::vector<std::unique_ptr<daemon::ScanService>> services;
  for (int i = 0; i < rigs; ++i) {
    // A world of its own per rig (its seed), tiny frames: the catalogue is
    // what is measured, not the processing.
    const std::string name = "rig-" + std::to_string(i);
    std::vector<std::pair<std::string, std::string>> edits = {
        {"width = 160", "width = 64"},
        {"height = 120", "height = 48"},
        {"seed = 1", "seed = " + std::to_string(i + 1)},
        {"root = \"scans\"", "root = \"" + (temp / "shared").string() + "\""},
        {"modbus_port = 0", "modbus_port = 0\nrig_name = \"" + name + "\"\n" +
                                (url.empty() ? "" : "\n[catalogue]\nurl = \"" + url + "\"\n")}};
    auto config = config::load_config(bench_config(temp, edits, name + ".toml"));
    if (!config) return state.SkipWithError(config.error().describe().c_str());
    auto catalogue = catalogue::open_catalogue(catalogue::catalogue_options(*config));
    if (!catalogue) return state.SkipWithError(catalogue.error().describe().c_str());
    auto service = daemon::ScanService::start(
        *config, std::make_unique<TimedCatalogue>(std::move(*catalogue), times));
    if (!service) return state.SkipWithError(service.error().describe().c_str());
    services.push_back(std::move(*service));
  }
  std::map<std::int64_t, int> accepted;  // id -> times returned
  const auto start = Clock::now();
  for (auto _ : state) {
    while (Clock::now() - start < kFeeding) {
      for (auto& service : services)
        if (service->status().queue_length < 2) {
          auto id = service->submit({"LOAD", "", {}, "bench"});
          if (!id) return state.SkipWithError(id.error().describe().c_str());
          ++accepted[*id];
        }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    const auto drained = [&] {
      return std::all_of(services.begin(), services.end(), [](const auto& s) {
        const auto status = s->status();
        return status.queue_length == 0 && !status.current_scan;
      });
    };
    while (!drained() && Clock::now() - start < kFeeding + kDrainLimit)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  // Every accepted scan, once, done: read back from the catalogue itself.
  std::size_t done = 0, found = 0, rows_written = 0;
  catalogue::CatalogueQuery everything;
  everything.limit = 1000;
  for (auto& service : services) {
    everything.rig = service->catalogue().rig_name();
    for (everything.offset = 0;; everything.offset += everything.limit) {
      auto rows = service->catalogue().search(everything);
      if (!rows) return state.SkipWithError(rows.error().describe().c_str());
      for (const auto& row : *rows) {
        ++rows_written;
        found += accepted.count(row.id);
        done += row.status == catalogue::ScanStatus::done && accepted.count(row.id) ? 1 : 0;
      }
      if (rows->size() < static_cast<std::size_t>(everything.limit)) break;
    }
  }
  std::size_t twice = 0;
  for (const auto& [id, n] : accepted)
    twice += n > 1 ? 1 : 0;
  // Accepted but not done, rows no accepted scan explains, ids given twice.
  const auto lost = static_cast<double>(accepted.size() - done + (rows_written - found) + twice);
  for (auto& service : services)
    service->stop();
  state.counters["scans"] = static_cast<double>(done);
  state.counters["scans_per_s"] = static_cast<double>(done) / seconds;
  state.counters["scans_per_s_per_rig"] = static_cast<double>(done) / seconds / rigs;
  state.counters["row_writes"] = static_cast<double>(times.count());
  state.counters["p50_row_write_ms"] = times.percentile(0.50);
  state.counters["p99_row_write_ms"] = times.percentile(0.99);
  state.counters["rows_lost"] = lost;
  if (lost != 0) state.SkipWithError("rows lost or written twice: see rows_lost");
}

void BM_SharedCatalogueRigs(benchmark::State& state) {
  std::string why_not;
  PostgresServer* server = bench_server(why_not);
  if (!server) return state.SkipWithError(why_not.c_str());
  run_rigs(state, static_cast<int>(state.range(0)), server->create_database());
}
BENCHMARK(BM_SharedCatalogueRigs)
    ->ArgName("rigs")
    ->Arg(1)
    ->Arg(10)
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

// The baseline: one rig on its embedded catalogue, the same load.
void BM_EmbeddedCatalogueRig(benchmark::State& state) {
  run_rigs(state, 1, "");
}
BENCHMARK(BM_EmbeddedCatalogueRig)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace
}  // namespace psrig::test
