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

using catalogue::ScanStatus;
using daemon::ScanCancel;
using daemon::ScanService;

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

catalogue::CatalogueEntry wait_finished(ScanService& service, std::int64_t id) {
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  catalogue::CatalogueEntry entry;
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

// The issue 14 stuck row: a scan accepted just before the catalogue's disk
// filled (its row added, nothing written after) fails with the storage
// code; the status says so at once, and the row says so as soon as the
// catalogue can write again, with no new scan needed to get it there.
TEST(PsrigdScanService, AScanAcceptedAsTheCatalogueStopsWritingEndsFailedNotQueued) {
  TempDir temp;
  auto service = start_service(temp);
  ASSERT_TRUE(service);
  // The row is added; every write after it fails, as on a full disk.
  service->catalogue().inject_write_failure(
      io_error("catalogue.sqlite", "database or disk is full").with(ErrorCode::disk_full), 1);
  const auto id = submit(*service, "STUCK");
  ASSERT_GT(id, 0);
  ASSERT_TRUE(wait_for([&] { return service->status().state == daemon::DaemonState::error; }));
  const auto status = service->status();
  EXPECT_EQ(status.last_error_code, catalogue::ScanErrorCode::storage);
  EXPECT_NE(status.last_error.find("disk is full"), std::string::npos) << status.last_error;
  EXPECT_EQ(service->catalogue().pending_count(), 1U);
  // The row as the database file has it, through a second connection.
  const auto on_disk = [&] {
    catalogue::CatalogueEntry row;
    auto reader = catalogue::Catalogue::open(temp / "scans");
    EXPECT_TRUE(reader) << reader.error().describe();
    if (!reader) return row;
    auto entry = (*reader)->get(id);
    EXPECT_TRUE(entry && *entry);
    if (entry && *entry) row = **entry;
    return row;
  };
  EXPECT_EQ(on_disk().status, ScanStatus::queued) << "written while the disk refuses writes?";

  service->catalogue().inject_write_failure(std::nullopt);
  ASSERT_TRUE(wait_for([&] { return service->catalogue().pending_count() == 0; }));
  const auto row = on_disk();
  EXPECT_EQ(row.status, ScanStatus::failed);
  EXPECT_EQ(row.error_code, catalogue::ScanErrorCode::storage);
  EXPECT_EQ(row.error_message, status.last_error);
  EXPECT_TRUE(row.scan_directory.empty());
  for (const auto unfinished : {ScanStatus::queued, ScanStatus::running}) {
    catalogue::CatalogueQuery query;
    query.status = unfinished;
    auto rows = service->catalogue().search(query);
    ASSERT_TRUE(rows);
    EXPECT_TRUE(rows->empty()) << rows->size() << " rows " << catalogue::to_string(unfinished);
  }
  // And the daemon scans on.
  EXPECT_EQ(wait_finished(*service, submit(*service, "NEXT")).status, ScanStatus::done);
}

// A run that ended with rows unfinished (killed, or stopped with the disk
// still full): the next start marks them failed, saying the daemon stopped.
TEST(PsrigdScanService, RowsLeftUnfinishedByTheLastRunFailAtStartUp) {
  TempDir temp;
  std::int64_t queued = 0, running = 0;
  {
    auto config = config::load_config(daemon_config(temp, free_port()));
    ASSERT_TRUE(config) << config.error().describe();
    auto catalogue = catalogue::Catalogue::open(config->storage.root);
    ASSERT_TRUE(catalogue) << catalogue.error().describe();
    queued = (*catalogue)->add({"Q", "", {}, "test"}).value_or(-1);
    running = (*catalogue)->add({"R", "", {}, "test"}).value_or(-1);
    ASSERT_TRUE((*catalogue)->mark_running(running, config->storage.root / "20260504-000000-R"));
  }
  auto service = start_service(temp);
  ASSERT_TRUE(service);
  for (const auto id : {queued, running}) {
    auto entry = service->catalogue().get(id);
    ASSERT_TRUE(entry && *entry);
    EXPECT_EQ((*entry)->status, ScanStatus::failed) << id;
    EXPECT_EQ((*entry)->error_message, "interrupted: psrigd stopped before this scan finished");
  }
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
