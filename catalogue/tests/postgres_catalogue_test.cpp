// What the shared catalogue alone does: several rigs writing one database
// at once, each recovering only its own rows, and the database going away
// and coming back while rows are written (the journal). The suite both
// backends share is catalogue_test.cpp.

#include <chrono>
#include <fstream>
#include <future>
#include <iterator>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "catalogue_backends.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using catalogue::Catalogue;
using catalogue::CatalogueQuery;
using catalogue::ScanErrorCode;
using catalogue::ScanStatus;

using SharedCatalogue = CatalogueBackendTest;

std::int64_t add_shared(Catalogue& catalogue, const std::string& sample) {
  auto id = catalogue.add({sample, "", {"shared"}, "test"});
  EXPECT_TRUE(id) << id.error().describe();
  return id.value_or(-1);
}

void make_bare_scan(const fs::path& directory) {
  fs::create_directories(directory);
  std::ofstream(directory / "scan.json") << "{}";
}

std::vector<catalogue::CatalogueEntry> rows(const Catalogue& catalogue, CatalogueQuery query = {}) {
  query.limit = 1000;
  auto found = catalogue.search(query);
  EXPECT_TRUE(found) << found.error().describe();
  return found ? *found : std::vector<catalogue::CatalogueEntry>{};
}

std::optional<catalogue::CatalogueEntry> row(const Catalogue& catalogue, std::int64_t id) {
  auto entry = catalogue.get(id);
  EXPECT_TRUE(entry) << entry.error().describe();
  return entry ? *entry : std::nullopt;
}

// The journal as it is on disk.
// Every write waiting in the journal reaches the database once it is back
// (the back-off is at most 5 s).
bool wait_flushed(Catalogue& catalogue) {
  const auto deadline = std::chrono::steady_clock::now() + 15s;
  while (catalogue.flush_pending() > 0)
    if (std::chrono::steady_clock::now() > deadline) return false;
    else std::this_thread::sleep_for(50ms);
  return true;
}

TEST_P(SharedCatalogue, TwoRigsWriteOneCatalogueAtOnce) {
  const fs::path root = temp / "shared";
  auto a = open(root, "rig-a");
  auto b = open(root, "rig-b");
  ASSERT_TRUE(a && b);
  constexpr int kEach = 25;
  const auto write = [](Catalogue& catalogue, const std::string& prefix) {
    std::vector<std::int64_t> ids;
    for (int i = 0; i < kEach; ++i) {
      const auto id = add_shared(catalogue, prefix + std::to_string(i));
      EXPECT_TRUE(catalogue.mark_running(id, catalogue.rig_root() / (prefix + std::to_string(i))));
      EXPECT_TRUE(catalogue.mark_done(id, {}, {{"residual", {{"mean", 0.001 * i}}}}));
      ids.push_back(id);
    }
    return ids;
  };
  auto from_a = std::async(std::launch::async, write, std::ref(*a), "A-");
  auto from_b = std::async(std::launch::async, write, std::ref(*b), "B-");
  std::set<std::int64_t> ids;
  for (const auto id : from_a.get())
    ids.insert(id);
  for (const auto id : from_b.get())
    ids.insert(id);
  EXPECT_EQ(ids.size(), 2U * kEach) << "every scan its own id";
  // Either rig sees every row, each once, named for its rig, its scan
  // under that rig's own directory.
  for (const Catalogue* reader : {a.get(), b.get()}) {
    const auto all = rows(*reader);
    EXPECT_EQ(all.size(), 2U * kEach);
    for (const auto& entry : all) {
      EXPECT_EQ(entry.status, ScanStatus::done);
      EXPECT_EQ(entry.rig, entry.sample_id.starts_with("A-") ? "rig-a" : "rig-b");
      EXPECT_EQ(entry.scan_directory.parent_path(), root / entry.rig);
    }
  }
  CatalogueQuery only_b;
  only_b.rig = "rig-b";
  EXPECT_EQ(rows(*a, only_b).size(), static_cast<std::size_t>(kEach));
}

// A rig that starts again fails its own interrupted scans and cleans its
// own directory; another rig's running scan and files are not its to touch.
TEST_P(SharedCatalogue, RecoveryTouchesOnlyThisRigsRowsAndFiles) {
  const fs::path root = temp / "shared";
  auto b = open(root, "rig-b");
  ASSERT_TRUE(b);
  const auto b_running = add_shared(*b, "B");
  const fs::path b_scan = b->rig_root() / "20260504-000000-B";
  ASSERT_TRUE(b->mark_running(b_running, b_scan));
  make_bare_scan(b_scan);
  const fs::path b_staging = b->rig_root() / ".20260504-000001-B2.partial-999999-1";
  fs::create_directories(b_staging);
  std::int64_t a_running = 0;
  fs::path a_half;
  {
    auto a = open(root, "rig-a");
    ASSERT_TRUE(a);
    a_running = add_shared(*a, "A");
    a_half = a->rig_root() / "20260504-000000-A";
    ASSERT_TRUE(a->mark_running(a_running, a_half));
    fs::create_directories(a_half);  // no scan.json: not whole
  }  // rig A dies here
  auto a = open(root, "rig-a");
  auto recovery = a->recover();
  ASSERT_TRUE(recovery) << recovery.error().describe();
  EXPECT_EQ(recovery->interrupted, std::vector<std::int64_t>{a_running});
  EXPECT_EQ(row(*a, a_running)->status, ScanStatus::failed);
  EXPECT_FALSE(fs::exists(a_half));
  EXPECT_EQ(row(*a, b_running)->status, ScanStatus::running);
  EXPECT_TRUE(fs::exists(b_scan / "scan.json"));
  EXPECT_TRUE(fs::exists(b_staging)) << "another rig's staging directory is its own business";
}

// The database goes away while a scan is written and another queued: each
// write waits in the journal, in order, and reaches the database once, when
// it is back.
TEST_P(SharedCatalogue, AnOutageIsRiddenOutAndEveryRowWrittenOnce) {
  auto catalogue = open(temp / "shared");
  ASSERT_TRUE(catalogue);
  const auto before = add_shared(*catalogue, "BEFORE");
  const fs::path scan = catalogue->rig_root() / "20260504-000000-BEFORE";
  ASSERT_TRUE(catalogue->mark_running(before, scan));
  make_bare_scan(scan);

  ASSERT_TRUE(server().stop()) << server().log();
  const nlohmann::json report = {{"residual", {{"mean", 0.002}}}};
  EXPECT_TRUE(catalogue->mark_done(before, scan / "maps", report));
  auto during = catalogue->add({"DURING", "", {"outage"}, "test"});  // an id from the reserve
  ASSERT_TRUE(during) << during.error().describe();
  EXPECT_TRUE(catalogue->mark_failed(*during, ScanStatus::aborted, ScanErrorCode::aborted,
                                     "cancelled before it started", false));
  EXPECT_EQ(catalogue->pending_count(), 3U);
  auto away = catalogue->get(before);
  ASSERT_FALSE(away);
  EXPECT_EQ(away.error().code, ErrorCode::unavailable) << away.error().describe();
  EXPECT_EQ(catalogue->flush_pending(), 3U);

  ASSERT_TRUE(server().start_again()) << server().log();
  ASSERT_TRUE(wait_flushed(*catalogue));
  const auto done = row(*catalogue, before);
  ASSERT_TRUE(done);
  EXPECT_EQ(done->status, ScanStatus::done);
  EXPECT_EQ(done->report, report);
  const auto aborted = row(*catalogue, *during);
  ASSERT_TRUE(aborted);
  EXPECT_EQ(aborted->status, ScanStatus::aborted);
  EXPECT_EQ(aborted->tags, std::vector<std::string>{"outage"});
  EXPECT_EQ(rows(*catalogue).size(), 2U) << "each row once";
}

// psrigd ends while the database is away: what it could not write stays in
// the journal on disk, and the next start writes it before recovering.
TEST_P(SharedCatalogue, TheJournalOutlivesThePsrigd) {
  const fs::path root = temp / "shared";
  std::int64_t id = 0;
  fs::path journal;
  {
    auto catalogue = open(root);
    ASSERT_TRUE(catalogue);
    id = add_shared(*catalogue, "J");
    const fs::path scan = catalogue->rig_root() / "20260504-000000-J";
    ASSERT_TRUE(catalogue->mark_running(id, scan));
    make_bare_scan(scan);
    ASSERT_TRUE(server().stop()) << server().log();
    EXPECT_TRUE(catalogue->mark_done(id, scan / "maps", nullptr));
    journal = options(root).journal;
  }
  const std::string kept = file_contents(journal);
  EXPECT_NE(kept.find("\"done\""), std::string::npos) << kept;
  ASSERT_TRUE(server().start_again()) << server().log();
  auto catalogue = open(root);
  ASSERT_TRUE(catalogue);
  EXPECT_EQ(catalogue->pending_count(), 0U);
  auto recovery = catalogue->recover();
  ASSERT_TRUE(recovery);
  EXPECT_TRUE(recovery->interrupted.empty()) << "its end was written first";
  EXPECT_EQ(row(*catalogue, id)->status, ScanStatus::done);
}

TEST_P(SharedCatalogue, TwoDaemonsCannotBeOneRig) {
  auto first = open(temp / "shared");
  ASSERT_TRUE(first);
  auto second = try_open(temp / "shared");
  ASSERT_FALSE(second);
  EXPECT_NE(second.error().message.find("another psrigd"), std::string::npos)
      << second.error().describe();
  EXPECT_NE(second.error().message.find("rig_name"), std::string::npos);
}

// Rigs starting together on a new database: one migrates, the others wait
// for it and find the schema made.
TEST_P(SharedCatalogue, RigsStartingTogetherMigrateOnce) {
  std::vector<std::future<bool>> starts;
  for (int i = 0; i < 4; ++i)
    starts.push_back(std::async(std::launch::async, [this, i] {
      auto catalogue =
          catalogue::open_catalogue(options(temp / "shared", "rig-" + std::to_string(i)));
      EXPECT_TRUE(catalogue) << catalogue.error().describe();
      return catalogue && add_shared(**catalogue, "S") > 0;
    }));
  for (auto& start : starts)
    EXPECT_TRUE(start.get());
}

TEST_P(SharedCatalogue, ADatabaseThatIsNotThereIsNamed) {
  auto missing = options(temp / "shared");
  missing.url = "postgresql://psrig@%2Fnonexistent%2Fsocket/psrig";
  missing.start_patience = 1s;
  auto catalogue = catalogue::open_catalogue(missing);
  ASSERT_FALSE(catalogue);
  EXPECT_EQ(catalogue.error().key, "catalogue.url");
  EXPECT_NE(catalogue.error().describe().find("/nonexistent/socket"), std::string::npos)
      << catalogue.error().describe();
}

INSTANTIATE_TEST_SUITE_P(Backends, SharedCatalogue, ::testing::Values(Backend::postgresql),
                         backend_name);

}  // namespace
}  // namespace psrig::test
