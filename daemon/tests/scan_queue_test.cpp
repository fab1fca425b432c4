// The scan queue on its own: a bounded FIFO whose every scan is exactly one
// of queued, running or finished, cancelled or aborted where it is, and
// refused (not half-queued) when full, stopping or when its row fails.

#include "psrig/daemon/scan_queue.h"

#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

namespace psrig::daemon {
namespace {

using namespace std::chrono_literals;

// Catalogue rows numbered from 1, as the catalogue would give them.
struct Rows {
  std::int64_t next = 1;
  int made = 0;
  Result<std::int64_t> operator()(const catalogue::ScanSubmission&) {
    ++made;
    return next++;
  }
};

catalogue::ScanSubmission sample(const std::string& id) {
  catalogue::ScanSubmission s;
  s.sample_id = id;
  s.source = "test";
  return s;
}

TEST(ScanQueue, RunsScansInTheOrderTheyCame) {
  ScanQueue queue(4, "rig.toml");
  Rows rows;
  for (const char* id : {"A", "B", "C"})
    ASSERT_TRUE(queue.push(sample(id), std::ref(rows)));
  EXPECT_EQ(queue.length(), 3U);
  for (const char* id : {"A", "B", "C"}) {
    auto next = queue.wait_next(0ms);
    ASSERT_TRUE(next.job);
    EXPECT_EQ(next.job->submission.sample_id, id);
    EXPECT_EQ(queue.running(), next.job->id);
    queue.finish_running();
    EXPECT_FALSE(queue.running());
  }
  EXPECT_EQ(queue.length(), 0U);
  EXPECT_FALSE(queue.wait_next(10ms).job);
}

TEST(ScanQueue, AFullQueueRefusesNamingTheLimitAndMakesNoRow) {
  ScanQueue queue(2, "/etc/psrig/rig.toml");
  Rows rows;
  ASSERT_TRUE(queue.push(sample("A"), std::ref(rows)));
  ASSERT_TRUE(queue.push(sample("B"), std::ref(rows)));
  auto refused = queue.push(sample("C"), std::ref(rows));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::queue_full);
  EXPECT_EQ(refused.error().key, "daemon.queue_limit");
  EXPECT_EQ(refused.error().file, "/etc/psrig/rig.toml");
  EXPECT_EQ(rows.made, 2);  // the refused scan has no row
  // The running scan does not count against the limit.
  ASSERT_TRUE(queue.wait_next(0ms).job);
  EXPECT_TRUE(queue.push(sample("C"), std::ref(rows)));
  queue.set_limit(5, "new.toml");
  EXPECT_TRUE(queue.push(sample("D"), std::ref(rows)));
}

TEST(ScanQueue, ARowThatCannotBeMadeQueuesNothing) {
  ScanQueue queue(4, "rig.toml");
  auto failed =
      queue.push(sample("A"), [](const catalogue::ScanSubmission&) -> Result<std::int64_t> {
        return std::unexpected(io_error("catalogue.db", "disk full").with(ErrorCode::disk_full));
      });
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().code, ErrorCode::disk_full);
  EXPECT_EQ(queue.length(), 0U);
}

TEST(ScanQueue, CancelTakesAQueuedScanOutAndStopsTheRunningOne) {
  ScanQueue queue(4, "rig.toml");
  Rows rows;
  const auto a = *queue.push(sample("A"), std::ref(rows));
  const auto b = *queue.push(sample("B"), std::ref(rows));
  const auto c = *queue.push(sample("C"), std::ref(rows));
  ASSERT_EQ(queue.wait_next(0ms).job->id, a);
  int stops = 0;
  queue.set_stopper([&] { ++stops; });
  EXPECT_EQ(queue.cancel(b), ScanQueue::Found::queued);
  EXPECT_EQ(queue.length(), 1U);
  EXPECT_EQ(queue.cancel(b), ScanQueue::Found::neither);
  EXPECT_EQ(queue.cancel(a), ScanQueue::Found::running);
  EXPECT_EQ(stops, 1);
  EXPECT_TRUE(queue.abort_requested());
  queue.finish_running();
  EXPECT_EQ(queue.cancel(a), ScanQueue::Found::neither);
  // The next scan starts with no abort pending.
  auto next = queue.wait_next(0ms);
  ASSERT_TRUE(next.job);
  EXPECT_EQ(next.job->id, c);
  EXPECT_FALSE(queue.abort_requested());
}

TEST(ScanQueue, AStopperSetAfterTheAbortIsCalledAtOnce) {
  ScanQueue queue(4, "rig.toml");
  Rows rows;
  const auto a = *queue.push(sample("A"), std::ref(rows));
  ASSERT_TRUE(queue.wait_next(0ms).job);
  EXPECT_EQ(queue.cancel(a), ScanQueue::Found::running);  // before the scan could be stopped
  bool stopped = false;
  queue.set_stopper([&] { stopped = true; });
  EXPECT_TRUE(stopped);
}

TEST(ScanQueue, AbortAllEmptiesTheQueueAndStopsTheRunningScan) {
  ScanQueue queue(4, "rig.toml");
  Rows rows;
  for (const char* id : {"A", "B", "C"})
    ASSERT_TRUE(queue.push(sample(id), std::ref(rows)));
  ASSERT_TRUE(queue.wait_next(0ms).job);
  bool stopped = false;
  queue.set_stopper([&] { stopped = true; });
  const auto dropped = queue.abort_all();
  ASSERT_EQ(dropped.size(), 2U);
  EXPECT_EQ(dropped[0].submission.sample_id, "B");
  EXPECT_EQ(dropped[1].submission.sample_id, "C");
  EXPECT_TRUE(stopped);
  EXPECT_EQ(queue.length(), 0U);
  EXPECT_TRUE(queue.push(sample("D"), std::ref(rows)));  // still taking scans
}

TEST(ScanQueue, StoppingWakesTheWorkerAndRefusesNewScans) {
  ScanQueue queue(4, "rig.toml");
  Rows rows;
  ASSERT_TRUE(queue.push(sample("A"), std::ref(rows)));
  std::atomic<bool> woke{false};
  std::thread worker([&] {
    ASSERT_TRUE(queue.wait_next(10s).job);
    queue.finish_running();
    const auto next = queue.wait_next(10s);  // nothing queued: only stop() wakes it
    EXPECT_TRUE(next.stopping);
    EXPECT_FALSE(next.job);
    woke = true;
  });
  while (queue.length() != 0)
    std::this_thread::sleep_for(1ms);
  std::this_thread::sleep_for(20ms);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(queue.stop().empty());
  worker.join();
  EXPECT_TRUE(woke);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
  auto refused = queue.push(sample("B"), std::ref(rows));
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("stopping"), std::string::npos);
}

TEST(ScanQueue, APokeWakesTheWorkerWithNothingToRun) {
  ScanQueue queue(4, "rig.toml");
  std::thread poker([&] {
    std::this_thread::sleep_for(20ms);
    queue.poke();
  });
  const auto start = std::chrono::steady_clock::now();
  const auto next = queue.wait_next(10s);
  poker.join();
  EXPECT_FALSE(next.job);
  EXPECT_FALSE(next.stopping);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
}

}  // namespace
}  // namespace psrig::daemon
