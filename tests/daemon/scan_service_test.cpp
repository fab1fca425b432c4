// ScanService in-process, with the simulated rig at a small size: what the
// HTTP API and the PLC ask of it, decided where the queue is.

#include "psrig/daemon/scan_service.h"

#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "daemon_process.h"
#include "psrig/config/config_loader.h"

namespace psrig::test {
namespace {

using daemon::ScanCancel;
using daemon::ScanService;
using daemon::ScanStatus;

// A service over config/sim.toml at 160x120, scans in `temp`/scans.
std::unique_ptr<ScanService> start_service(const TempDir& temp, const Edits& edits = {}) {
  auto config = config::load_config(daemon_config(temp, free_port(), edits));
  EXPECT_TRUE(config) << config.error().describe();
  if (!config) return nullptr;
  auto service = ScanService::start(*config);
  EXPECT_TRUE(service) << service.error().describe();
  return service ? std::move(*service) : nullptr;
}

std::int64_t submit(ScanService& service, const std::string& sample_id) {
  auto id = service.submit({sample_id, "", {}, "test"});
  EXPECT_TRUE(id) << id.error().describe();
  return id ? *id : -1;
}

daemon::CatalogueEntry wait_finished(ScanService& service, std::int64_t id) {
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  daemon::CatalogueEntry entry;
  while (std::chrono::steady_clock::now() < deadline) {
    auto got = service.catalogue().get(id);
    EXPECT_TRUE(got && *got);
    if (!got || !*got) return entry;
    entry = **got;
    if (entry.status != ScanStatus::queued && entry.status != ScanStatus::running) return entry;
    std::this_thread::sleep_for(10ms);
  }
  ADD_FAILURE() << "scan " << id << " did not finish";
  return entry;
}

template <class Predicate>
bool wait_for(Predicate predicate) {
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < deadline) {
    if (predicate()) return true;
    std::this_thread::sleep_for(2ms);
  }
  return false;
}

TEST(PsrigdScanService, CancelStopsAQueuedOrRunningScanAndNeverTouchesAFinishedOne) {
  TempDir temp;
  auto service = start_service(temp);
  ASSERT_TRUE(service);
  const auto done = submit(*service, "D");
  const auto finished = wait_finished(*service, done);
  ASSERT_EQ(finished.status, ScanStatus::done) << finished.error_message;

  // A finished scan (a client's Ctrl-C just after it finished) stays whole.
  auto late = service->cancel(done);
  ASSERT_TRUE(late) << late.error().describe();
  EXPECT_EQ(*late, ScanCancel::already_finished);
  auto entry = service->catalogue().get(done);
  ASSERT_TRUE(entry && *entry);
  EXPECT_EQ((*entry)->status, ScanStatus::done);
  EXPECT_TRUE(fs::exists(finished.scan_directory / "scan.json"));

  auto unknown = service->cancel(done + 1000);
  ASSERT_TRUE(unknown);
  EXPECT_EQ(*unknown, ScanCancel::not_found);
}

TEST(PsrigdScanService, CancelAbortsTheRunningScanAndCancelsAQueuedOne) {
  TempDir temp;
  auto service = start_service(temp, {{"exposure_us = 20000", "exposure_us = 150000"}});
  ASSERT_TRUE(service);
  const auto running = submit(*service, "R");
  const auto queued = submit(*service, "Q");
  ASSERT_TRUE(wait_for([&] { return service->status().current_scan == running; }));

  auto cancelled = service->cancel(queued);
  ASSERT_TRUE(cancelled) << cancelled.error().describe();
  EXPECT_EQ(*cancelled, ScanCancel::cancelled);
  auto aborting = service->cancel(running);
  ASSERT_TRUE(aborting) << aborting.error().describe();
  EXPECT_EQ(*aborting, ScanCancel::aborting);
  EXPECT_EQ(wait_finished(*service, running).status, ScanStatus::aborted);
  const auto entry = wait_finished(*service, queued);
  EXPECT_EQ(entry.status, ScanStatus::aborted);
  EXPECT_EQ(entry.error_message, "cancelled before it started");
  // Once finished, asking again changes nothing.
  auto again = service->cancel(running);
  ASSERT_TRUE(again);
  EXPECT_EQ(*again, ScanCancel::already_finished);
  auto row = service->catalogue().get(running);
  ASSERT_TRUE(row && *row);
  EXPECT_EQ((*row)->status, ScanStatus::aborted);
}

// The worker shows it lives while it waits and while it scans, for the
// systemd watchdog.
TEST(PsrigdScanService, TheWorkerHeartbeatGoesOnWhileIdleAndScanning) {
  TempDir temp;
  auto service = start_service(temp);
  ASSERT_TRUE(service);
  for (int second = 0; second < 3; ++second) {
    std::this_thread::sleep_for(1s);
    EXPECT_TRUE(service->healthy(1500ms)) << "idle, second " << second;
  }
  const auto id = submit(*service, "H");
  const auto finished = [&] {
    auto entry = service->catalogue().get(id);
    return entry && *entry && !(*entry)->finished.empty();
  };
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (!finished() && std::chrono::steady_clock::now() < deadline) {
    EXPECT_TRUE(service->healthy(1500ms));
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_EQ(wait_finished(*service, id).status, ScanStatus::done);
  EXPECT_TRUE(service->healthy(1500ms));
  auto config = service->config();
  // sim.toml: 64 stale + 2 averaged + 1 grabs of 2 s, and 5 ms settling.
  EXPECT_EQ(ScanService::heartbeat_limit(config), std::chrono::milliseconds(134005));
  config.camera.timeout_ms = 100;
  EXPECT_EQ(ScanService::heartbeat_limit(config), std::chrono::seconds(60));
}

}  // namespace
}  // namespace psrig::test
