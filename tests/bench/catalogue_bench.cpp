// The web catalogue's first page: GET /v1/scans?limit=48 (and a text
// search) from a real HTTP API over a catalogue of N finished scans, each
// with a report like a real one. Issue 17's goal: the first page of a
// 10,000-scan catalogue in under 1 s; the 100-scan catalogue is the
// baseline measured in the same run.
#include <httplib.h>
#include <string>

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include "bench_config.h"
#include "psrig/catalogue/catalogue.h"
#include "psrig/config/config_loader.h"
#include "psrig/daemon/http_api.h"
#include "psrig/daemon/scan_service.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;

// N done rows, each with a three-kilobyte report, as a day's scans leave them.
void fill(const fs::path& storage_root, int scans) {
  auto catalogue = catalogue::Catalogue::open(storage_root);
  if (!catalogue) throw std::runtime_error(catalogue.error().describe());
  nlohmann::json report = {
      {"pixels", {{"total", 12'000'000}, {"valid", 11'800'000}}},
      {"residual", {{"mean", 0.0013}, {"p95", 0.0024}}},
      {"light_matrix",
       {{"condition_number", 1.41},
        {"directions", {{0.7, 0, 0.7}, {-0.35, 0.61, 0.7}, {-0.35, -0.61, 0.7}}}}},
      {"height", {{"min", -0.3}, {"max", 0.2}, {"units", "mm"}}},
      {"padding", std::string(2500, 'x')}};
  for (int i = 0; i < scans; ++i) {
    auto id = (*catalogue)
                  ->add({"SW-" + std::to_string(100000 + i),
                         "cotton jersey, lot " + std::to_string(i % 97),
                         {"knit", i % 3 == 0 ? "wool" : "cotton"},
                         "bench"});
    if (!id) throw std::runtime_error(id.error().describe());
    if (auto ok = (*catalogue)->mark_done(*id, {}, report); !ok)
      throw std::runtime_error(ok.error().describe());
  }
}

void BM_CatalogueFirstPage(benchmark::State& state) {
  TempDir temp("psrig-catalogue-bench");
  const fs::path config_file = bench_config(temp);
  fill(temp / "scans", static_cast<int>(state.range(0)));
  auto config = config::load_config(config_file);
  if (!config) return state.SkipWithError(config.error().describe().c_str());
  auto service = daemon::ScanService::start(*config);
  if (!service) return state.SkipWithError(service.error().describe().c_str());
  auto options = daemon::http_api_options(config->daemon);
  options.port = 0;
  auto api = daemon::HttpApi::start(**service, options);
  if (!api) return state.SkipWithError(api.error().describe().c_str());
  httplib::Client client("127.0.0.1", (*api)->port());
  const std::string path = state.range(1) ? "/v1/scans?limit=48&q=lot%2042" : "/v1/scans?limit=48";
  for (auto _ : state) {
    auto answer = client.Get(path);
    if (!answer || answer->status != 200) return state.SkipWithError("GET /v1/scans failed");
    benchmark::DoNotOptimize(answer->body.data());
  }
  (*api)->stop();
}
BENCHMARK(BM_CatalogueFirstPage)
    ->ArgNames({"scans", "text_search"})
    ->Args({100, 0})
    ->Args({10'000, 0})
    ->Args({10'000, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace psrig::test
