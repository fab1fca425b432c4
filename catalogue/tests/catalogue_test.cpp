// The catalogue on its own, on both backends (the embedded SQLite file and
// a PostgreSQL database, a throwaway server per test program): rows
// through their lives, search, delete, and what start-up makes of an
// interrupted run. What one backend alone does (SQLite's full disk, the
// shared database's outages and rigs) is below and in
// postgres_catalogue_test.cpp.

#include "psrig/catalogue/catalogue.h"

#include <fstream>
#include <functional>
#include <sqlite3.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "catalogue_backends.h"
#include "test_support.h"

namespace psrig::test {
namespace {

namespace fs = std::filesystem;
using catalogue::Catalogue;
using catalogue::CatalogueQuery;
using catalogue::ScanErrorCode;
using catalogue::ScanStatus;
using catalogue::ScanSubmission;

std::int64_t add(Catalogue& catalogue, const std::string& sample,
                 std::vector<std::string> tags = {}) {
  auto id = catalogue.add({sample, "a swatch", std::move(tags), "test"});
  EXPECT_TRUE(id) << id.error().describe();
  return id.value_or(-1);
}

// A scan directory with a maps directory inside, as the service leaves one.
void make_scan(const fs::path& directory) {
  fs::create_directories(directory / "maps");
  std::ofstream(directory / "scan.json") << "{}";
  std::ofstream(directory / "maps" / "report.json") << "{}";
}

std::vector<std::int64_t> ids(const std::vector<catalogue::CatalogueEntry>& entries) {
  std::vector<std::int64_t> out;
  for (const auto& e : entries)
    out.push_back(e.id);
  return out;
}

CatalogueQuery query(const std::function<void(CatalogueQuery&)>& set) {
  CatalogueQuery q;
  set(q);
  return q;
}

std::vector<std::int64_t> search(const Catalogue& catalogue, const CatalogueQuery& query) {
  auto found = catalogue.search(query);
  EXPECT_TRUE(found) << found.error().describe();
  return found ? ids(*found) : std::vector<std::int64_t>{};
}

using CatalogueTest = CatalogueBackendTest;

TEST_P(CatalogueTest, ARowThroughItsLife) {
  auto catalogue = open(temp / "scans");
  ASSERT_TRUE(catalogue);
  const auto id = add(*catalogue, "J-0042", {"knit", "cotton", "knit"});
  auto entry = catalogue->get(id);
  ASSERT_TRUE(entry && *entry);
  EXPECT_EQ((*entry)->status, ScanStatus::queued);
  EXPECT_EQ((*entry)->sample_id, "J-0042");
  EXPECT_EQ((*entry)->rig, kRig);
  EXPECT_EQ((*entry)->tags, (std::vector<std::string>{"knit", "cotton"}));  // duplicates once
  EXPECT_TRUE(catalogue::normalise_timestamp((*entry)->created, false)) << (*entry)->created;
  EXPECT_TRUE((*entry)->started.empty());

  const fs::path scan = catalogue->rig_root() / "20260504-091233-J-0042";
  ASSERT_TRUE(catalogue->mark_running(id, scan));
  make_scan(scan);
  const nlohmann::json report = {{"residual", {{"mean", 0.002}}},
                                 {"ground_truth", {{"angular_error_deg", {{"mean", 0.4}}}}}};
  ASSERT_TRUE(catalogue->mark_done(id, scan / "maps", report));
  entry = catalogue->get(id);
  ASSERT_TRUE(entry && *entry);
  EXPECT_EQ((*entry)->status, ScanStatus::done);
  EXPECT_EQ((*entry)->scan_directory, scan);
  EXPECT_EQ((*entry)->maps_directory, scan / "maps");
  EXPECT_EQ((*entry)->report, report);
  EXPECT_FALSE((*entry)->finished.empty());

  // A directory outside the storage root is refused, not recorded.
  const auto other = add(*catalogue, "X");
  EXPECT_FALSE(catalogue->mark_running(other, temp / "elsewhere"));
  EXPECT_FALSE(catalogue->mark_running(other, catalogue->storage_root() / ".." / "escape"));

  auto missing = catalogue->get(9999);
  ASSERT_TRUE(missing);
  EXPECT_FALSE(*missing);
}

TEST_P(CatalogueTest, IdsAreNeverReusedAndTheRowsOutliveTheProcess) {
  std::int64_t first = 0, second = 0;
  {
    auto catalogue = open(temp.path());
    first = add(*catalogue, "A");
    second = add(*catalogue, "B");
    ASSERT_TRUE(catalogue->remove(second));
  }
  auto catalogue = open(temp.path());
  const auto third = add(*catalogue, "C");
  EXPECT_GT(third, second);  // a PLC may still hold the old id
  auto entry = catalogue->get(first);
  ASSERT_TRUE(entry && *entry);
  EXPECT_EQ((*entry)->sample_id, "A");
}

TEST_P(CatalogueTest, SearchBySampleTagDateAndStatusNewestFirst) {
  auto catalogue = open(temp.path());
  const auto a = add(*catalogue, "J-1", {"knit", "wool"});
  const auto b = add(*catalogue, "J-2", {"knitted"});
  const auto c = add(*catalogue, "J-1", {"woven"});
  const auto d = add(*catalogue, "J-3", {"knit"});
  set_created(a, "2026-05-01T08:00:00Z");
  set_created(b, "2026-05-02T23:59:59Z");
  set_created(c, "2026-05-03T00:00:00Z");
  set_created(d, "2026-05-04T12:00:00Z");
  ASSERT_TRUE(
      catalogue->mark_failed(c, ScanStatus::failed, ScanErrorCode::camera, "timeout", false));

  using Ids = std::vector<std::int64_t>;
  EXPECT_EQ(search(*catalogue, {}), (Ids{d, c, b, a}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.sample_id = "J-1"; })), (Ids{c, a}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.tag = "knit"; })),
            (Ids{d, a}));  // exact: not "knitted"
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.tag = "kni"; })), Ids{});
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.sample_id = "J-1";
              q.tag = "woven";
            })),
            Ids{c});
  // A bare date as `to` means the whole of that day.
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.from = catalogue::normalise_timestamp("2026-05-02", false);
              q.to = catalogue::normalise_timestamp("2026-05-03", true);
            })),
            (Ids{c, b}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.from = catalogue::normalise_timestamp("2026-05-02T12:00:00Z", false);
            })),
            (Ids{d, c, b}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.status = ScanStatus::failed; })),
            Ids{c});
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.status = ScanStatus::queued; })),
            (Ids{d, b, a}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.limit = 2; })), (Ids{d, c}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.limit = 2;
              q.offset = 2;
            })),
            (Ids{b, a}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.limit = 2;
              q.offset = 4;
            })),
            Ids{});
  // Text that looks like SQL is only ever a value.
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.sample_id = "J-1' OR '1'='1"; })),
            Ids{});
  // Any case, in the sample id, the description or a tag.
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.text = "KNIT"; })),
            (Ids{d, b, a}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.text = "100%"; })), Ids{});
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.rig = kRig; })), (Ids{d, c, b, a}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) { q.rig = "rig-b"; })), Ids{});
  auto total = catalogue->count(query([](CatalogueQuery& q) {
    q.status = ScanStatus::queued;
    q.limit = 1;
  }));
  ASSERT_TRUE(total);
  EXPECT_EQ(*total, 3);
}

TEST(Catalogue, TimestampsAreCheckedAndNormalised) {
  using catalogue::normalise_timestamp;
  EXPECT_EQ(normalise_timestamp("2026-05-04", false), "2026-05-04T00:00:00Z");
  EXPECT_EQ(normalise_timestamp("2026-05-04", true), "2026-05-04T23:59:59Z");
  EXPECT_EQ(normalise_timestamp("2026-05-04T09:12:33Z", true), "2026-05-04T09:12:33Z");
  EXPECT_EQ(normalise_timestamp("2026-05-04T09:12:33.250+00:00", false), "2026-05-04T09:12:33Z");
  EXPECT_FALSE(normalise_timestamp("yesterday", false));
  EXPECT_FALSE(normalise_timestamp("2026-13-04", false));
  EXPECT_FALSE(normalise_timestamp("2026-05-04T09:12:33+02:00", false));  // UTC only
  EXPECT_FALSE(normalise_timestamp("2026-05-04'; DROP TABLE scans; --", false));
}

// Real calendar days and times of day only, not whatever has the digits.
TEST(Catalogue, TimestampsAreRealDatesAndTimes) {
  using catalogue::normalise_timestamp;
  for (const char* real : {"2028-02-29", "2000-02-29", "2026-01-31", "2026-04-30", "2026-12-31",
                           "9999-12-31T23:59:59Z", "2026-05-04T00:00:00Z", "2026-05-04 23:59:59"})
    EXPECT_TRUE(normalise_timestamp(real, false)) << real;
  for (const char* unreal :
       {"2026-02-30", "2026-02-29", "1900-02-29", "2026-04-31", "2026-06-31", "2026-01-32",
        "2026-00-10", "2026-05-00", "2026-13-01", "9999-12-31T99:99:99Z", "2026-05-04T24:00:00Z",
        "2026-05-04T23:60:00Z", "2026-05-04T23:59:60Z", "2026-02-30T12:00:00Z",
        "2026-05-04T9:12:33Z", "2026-5-04", "+2026-05-04"})
    EXPECT_FALSE(normalise_timestamp(unreal, false)) << unreal;
}

TEST_P(CatalogueTest, DeleteRemovesTheFilesThenTheRow) {
  auto catalogue = open(temp / "scans");
  const auto id = add(*catalogue, "J-7");
  const fs::path scan = catalogue->rig_root() / "20260504-000000-J-7";
  ASSERT_TRUE(catalogue->mark_running(id, scan));
  make_scan(scan);
  ASSERT_TRUE(catalogue->mark_done(id, scan / "maps", nullptr));
  const auto removed = catalogue->remove(id);
  ASSERT_TRUE(removed);
  EXPECT_TRUE(*removed);
  EXPECT_FALSE(fs::exists(scan));
  auto entry = catalogue->get(id);
  ASSERT_TRUE(entry);
  EXPECT_FALSE(*entry);
  const auto again = catalogue->remove(id);
  ASSERT_TRUE(again);
  EXPECT_FALSE(*again);
  for (const auto& name : list_directory(catalogue->rig_root()))
    EXPECT_TRUE(name.starts_with("catalogue.sqlite")) << name;
}

TEST_P(CatalogueTest, RecoveryCleansAnInterruptedScanAndNothingElse) {
  const fs::path root = temp / "scans";
  const fs::path rig = rig_dir(root);
  const fs::path done_scan = rig / "20260504-000000-done";
  const fs::path running_scan = rig / "20260504-000001-running";
  const fs::path half_scan = rig / "20260504-000003-half";   // never renamed into place whole
  const fs::path by_hand = rig / "20260504-000002-by-hand";  // `psrig scan` put it there
  const fs::path outside = temp / "outside";
  std::int64_t done = 0, running = 0, half = 0, queued = 0, escaped = 0;
  {
    auto catalogue = open(root);
    done = add(*catalogue, "done");
    ASSERT_TRUE(catalogue->mark_running(done, done_scan));
    make_scan(done_scan);
    ASSERT_TRUE(catalogue->mark_done(done, done_scan / "maps", nullptr));
    running = add(*catalogue, "running");
    ASSERT_TRUE(catalogue->mark_running(running, running_scan));
    half = add(*catalogue, "half");
    ASSERT_TRUE(catalogue->mark_running(half, half_scan));
    queued = add(*catalogue, "queued");
    escaped = add(*catalogue, "escaped");
  }
  // What a killed daemon leaves: the scan written, its maps made (not
  // recorded) and half made again, the writer's staging directory of the
  // next one, and one without its scan.json.
  make_scan(running_scan);
  fs::create_directories(running_scan / ".maps.partial-999999-1");
  fs::create_directories(half_scan / "maps");
  fs::create_directories(rig / ".20260504-000001-running.partial-1-2");  // PID 1 is alive
  fs::create_directories(rig / ".other.partial-999999-3");               // a dead writer's
  make_scan(by_hand);
  make_scan(outside);
  // A row pointing outside the storage root (edited by hand, say).
  sql("UPDATE scans SET status = 'running', scan_path = '../outside' WHERE id = " +
      std::to_string(escaped));

  auto catalogue = open(root);
  auto recovery = catalogue->recover();
  ASSERT_TRUE(recovery) << recovery.error().describe();
  EXPECT_EQ(recovery->interrupted, (std::vector<std::int64_t>{running, half, queued, escaped}));
  for (const auto id : {half, queued, escaped}) {
    auto entry = catalogue->get(id);
    ASSERT_TRUE(entry && *entry);
    EXPECT_EQ((*entry)->status, ScanStatus::failed);
    EXPECT_NE((*entry)->error_message.find("interrupted"), std::string::npos);
    EXPECT_TRUE((*entry)->scan_directory.empty());
  }
  // A whole raw scan cannot be taken again: kept, its row naming it, its
  // unrecorded maps gone.
  {
    auto entry = catalogue->get(running);
    ASSERT_TRUE(entry && *entry);
    EXPECT_EQ((*entry)->status, ScanStatus::failed);
    EXPECT_EQ((*entry)->error_message,
              "interrupted during processing; raw frames kept, reprocess with psrig process");
    EXPECT_EQ((*entry)->scan_directory, catalogue->rig_root() / running_scan.filename());
    EXPECT_TRUE((*entry)->maps_directory.empty());
  }
  EXPECT_TRUE(fs::exists(running_scan / "scan.json"));
  EXPECT_FALSE(fs::exists(running_scan / "maps"));
  EXPECT_FALSE(fs::exists(running_scan / ".maps.partial-999999-1"));
  EXPECT_FALSE(fs::exists(half_scan));
  EXPECT_FALSE(fs::exists(rig / ".20260504-000001-running.partial-1-2"));
  EXPECT_FALSE(fs::exists(rig / ".other.partial-999999-3"));
  EXPECT_TRUE(fs::exists(done_scan / "maps" / "report.json"));
  EXPECT_TRUE(fs::exists(by_hand / "scan.json"));
  EXPECT_TRUE(fs::exists(outside / "scan.json"));
  auto entry = catalogue->get(done);
  ASSERT_TRUE(entry && *entry);
  EXPECT_EQ((*entry)->status, ScanStatus::done);

  // A second start finds nothing more to do.
  auto again = catalogue->recover();
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->interrupted.empty());
  EXPECT_TRUE(again->removed_leftovers.empty());
}

// "wales between 6 and 8 per cm": the report's fabric figures as columns.
TEST_P(CatalogueTest, SearchByMeasuredFabricDensity) {
  auto catalogue = open(temp.path());
  ASSERT_TRUE(catalogue);
  const auto done_with = [&](const std::string& sample, const nlohmann::json& fabric) {
    const auto id = add(*catalogue, sample);
    const fs::path scan = catalogue->rig_root() / ("scan-" + sample);
    EXPECT_TRUE(catalogue->mark_running(id, scan));
    make_scan(scan);
    EXPECT_TRUE(catalogue->mark_done(id, scan / "maps", {{"fabric", fabric}}));
    return id;
  };
  const auto jersey = done_with("jersey", {{"wales_per_cm", 6.99}, {"courses_per_cm", 9.0}});
  const auto rib = done_with("rib", {{"wales_per_cm", 11.1}, {"courses_per_cm", 9.0}});
  const auto plain = done_with("plain", {{"ends_per_cm", 24.0}, {"picks_per_cm", 22.0}});
  done_with("odd", {{"wales_per_cm", "n/a"}});  // not a number: matches no range
  using Range = CatalogueQuery::FabricRange;
  using Ids = std::vector<std::int64_t>;
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.fabric = {Range{"wales_per_cm", 6.0, 8.0}};
            })),
            Ids{jersey});
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.fabric = {Range{"wales_per_cm", 6.0, std::nullopt}};
            })),
            (Ids{rib, jersey}));
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.fabric = {Range{"courses_per_cm", 8.5, 9.5}, Range{"wales_per_cm", 10, 12}};
            })),
            Ids{rib});
  EXPECT_EQ(search(*catalogue, query([](CatalogueQuery& q) {
              q.fabric = {Range{"picks_per_cm", std::nullopt, 23.0}};
            })),
            Ids{plain});
}

TEST_P(CatalogueTest, ANewerSchemaIsRefused) {
  { ASSERT_TRUE(open(temp.path())); }
  set_schema_version(99);
  auto catalogue = try_open(temp.path());
  ASSERT_FALSE(catalogue);
  EXPECT_NE(catalogue.error().message.find("newer"), std::string::npos)
      << catalogue.error().describe();
}

// The rigs list: each rig's latest word of itself, with when it came.
TEST_P(CatalogueTest, ARigAnnouncesItselfAndIsListed) {
  auto catalogue = open(temp.path());
  ASSERT_TRUE(catalogue);
  catalogue::RigRecord self;
  self.name = kRig;
  self.api_url = "http://rig-a.lab:8470";
  self.token = "secret-token-0123456789";
  self.status = {{"state", "idle"}, {"queue_length", 0}};
  ASSERT_TRUE(catalogue->announce(self));
  self.status["state"] = "scanning";
  ASSERT_TRUE(catalogue->announce(self));
  auto rigs = catalogue->rigs();
  ASSERT_TRUE(rigs) << rigs.error().describe();
  ASSERT_EQ(rigs->size(), 1U);
  EXPECT_EQ(rigs->front().name, kRig);
  EXPECT_EQ(rigs->front().api_url, "http://rig-a.lab:8470");
  EXPECT_EQ(rigs->front().token, "secret-token-0123456789");
  EXPECT_EQ(rigs->front().status.value("state", ""), "scanning");
  EXPECT_TRUE(catalogue::normalise_timestamp(rigs->front().last_seen, false))
      << rigs->front().last_seen;
  EXPECT_GE(rigs->front().seen_seconds_ago, -1.0);
  EXPECT_LT(rigs->front().seen_seconds_ago, 10.0);
}

INSTANTIATE_TEST_SUITE_P(Backends, CatalogueTest, kBothBackends, backend_name);

// What the embedded catalogue alone does: a full disk, and its own
// migrations.

std::unique_ptr<Catalogue> open_sqlite(const fs::path& root) {
  auto catalogue = Catalogue::open(root);
  EXPECT_TRUE(catalogue) << catalogue.error().describe();
  return catalogue ? std::move(*catalogue) : nullptr;
}

// The disk as SQLite sees it when full.
Error disk_full() {
  return io_error("catalogue.sqlite", "database or disk is full").with(ErrorCode::disk_full);
}

// What the database file says, read by a second connection: what the
// process would leave behind if it died now.
std::optional<catalogue::CatalogueEntry> on_disk(const fs::path& root, std::int64_t id) {
  auto reader = open_sqlite(root);
  if (!reader) return std::nullopt;
  auto entry = reader->get(id);
  EXPECT_TRUE(entry) << entry.error().describe();
  return entry ? *entry : std::nullopt;
}

// A scan's end the disk refuses is kept and shown at once, then written at
// the next write (or flush) once the disk has room: no row stays `queued`.
TEST(SqliteCatalogue, AnEndTheDiskRefusesIsKeptThenWrittenWhenItCan) {
  TempDir temp;
  auto catalogue = open_sqlite(temp.path());
  ASSERT_TRUE(catalogue);
  const auto first = add(*catalogue, "FULL-1");
  const auto second = add(*catalogue, "FULL-2");
  catalogue->inject_write_failure(disk_full());

  auto refused = catalogue->mark_failed(first, ScanStatus::failed, ScanErrorCode::storage,
                                        "not enough free space for a scan", false);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("disk is full"), std::string::npos)
      << refused.error().describe();
  EXPECT_NE(refused.error().message.find("as soon as the catalogue can write"), std::string::npos)
      << refused.error().describe();
  EXPECT_EQ(catalogue->pending_count(), 1U);
  // The daemon tells the truth meanwhile; the file still says queued.
  auto shown = catalogue->get(first);
  ASSERT_TRUE(shown && *shown);
  EXPECT_EQ((*shown)->status, ScanStatus::failed);
  EXPECT_EQ((*shown)->error_code, ScanErrorCode::storage);
  EXPECT_FALSE((*shown)->finished.empty());
  EXPECT_EQ(search(*catalogue, query([](auto& q) { q.status = ScanStatus::queued; })),
            std::vector<std::int64_t>{second});
  EXPECT_EQ(on_disk(temp.path(), first)->status, ScanStatus::queued);
  // Still full: a flush changes nothing, and a cancel is kept too.
  EXPECT_EQ(catalogue->flush_pending(), 1U);
  EXPECT_FALSE(catalogue->mark_failed(second, ScanStatus::aborted, ScanErrorCode::aborted,
                                      "cancelled before it started", false));
  EXPECT_EQ(catalogue->pending_count(), 2U);

  // Room again: the next write writes them first.
  catalogue->inject_write_failure(std::nullopt);
  const auto third = add(*catalogue, "AFTER");
  EXPECT_EQ(catalogue->pending_count(), 0U);
  const auto written = on_disk(temp.path(), first);
  ASSERT_TRUE(written);
  EXPECT_EQ(written->status, ScanStatus::failed);
  EXPECT_EQ(written->error_code, ScanErrorCode::storage);
  EXPECT_EQ(written->error_message, "not enough free space for a scan");
  EXPECT_EQ(written->finished, (*shown)->finished) << "the time it ended, not when it was written";
  EXPECT_EQ(on_disk(temp.path(), second)->status, ScanStatus::aborted);
  EXPECT_EQ(search(*catalogue, query([](auto& q) { q.status = ScanStatus::queued; })),
            std::vector<std::int64_t>{third});
}

// The process ends before the disk has room: its pending ends die with it,
// and the next start marks those rows failed, saying why. A disk still full
// at that start does not keep the daemon from starting.
TEST(SqliteCatalogue, RowsLeftQueuedOrRunningByADeadRunFailAtTheNextStart) {
  TempDir temp;
  std::int64_t queued = 0, running = 0;
  {
    auto catalogue = open_sqlite(temp.path());
    ASSERT_TRUE(catalogue);
    queued = add(*catalogue, "Q");
    running = add(*catalogue, "R");
    ASSERT_TRUE(catalogue->mark_running(running, temp / "20260504-000000-R"));
    catalogue->inject_write_failure(disk_full());
    EXPECT_FALSE(catalogue->mark_failed(queued, ScanStatus::failed, ScanErrorCode::storage,
                                        "the disk is full", false));
  }  // the last flush is refused too: as if psrigd died here
  EXPECT_EQ(on_disk(temp.path(), queued)->status, ScanStatus::queued);
  EXPECT_EQ(on_disk(temp.path(), running)->status, ScanStatus::running);

  auto catalogue = open_sqlite(temp.path());
  ASSERT_TRUE(catalogue);
  catalogue->inject_write_failure(disk_full());
  auto recovery = catalogue->recover();
  ASSERT_TRUE(recovery) << recovery.error().describe();
  EXPECT_EQ(recovery->interrupted, (std::vector<std::int64_t>{queued, running}));
  EXPECT_EQ(catalogue->pending_count(), 2U);
  catalogue->inject_write_failure(std::nullopt);
  EXPECT_EQ(catalogue->flush_pending(), 0U);
  for (const auto id : {queued, running}) {
    const auto entry = on_disk(temp.path(), id);
    ASSERT_TRUE(entry);
    EXPECT_EQ(entry->status, ScanStatus::failed) << id;
    EXPECT_EQ(entry->error_message, "interrupted: psrigd stopped before this scan finished");
  }
  EXPECT_TRUE(search(*catalogue, query([](auto& q) { q.status = ScanStatus::queued; })).empty());
  EXPECT_TRUE(search(*catalogue, query([](auto& q) { q.status = ScanStatus::running; })).empty());
}


// A version-1 catalogue's rows get the fabric columns (schema 2, computed
// from the stored report) and their rig (schema 3: the rig that opens it).
TEST(SqliteCatalogue, AnOlderCatalogueIsBroughtUpToDate) {
  TempDir temp;
  std::int64_t jersey = 0;
  {
    auto catalogue = open_sqlite(temp.path());
    ASSERT_TRUE(catalogue);
    jersey = add(*catalogue, "jersey");
    const fs::path scan = catalogue->rig_root() / "scan-jersey";
    ASSERT_TRUE(catalogue->mark_running(jersey, scan));
    make_scan(scan);
    ASSERT_TRUE(catalogue->mark_done(jersey, scan / "maps",
                                     {{"fabric", {{"wales_per_cm", 6.99}, {"courses_per_cm", 9.0}}}}));
  }
  // Back to version 1 with the row it wrote: the migrations must add the columns.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((temp / "catalogue.sqlite").c_str(), &db), SQLITE_OK);
  for (const char* sql :
       {"DROP INDEX scans_rig", "ALTER TABLE scans DROP COLUMN rig",
        "ALTER TABLE scans DROP COLUMN wales_per_cm", "ALTER TABLE scans DROP COLUMN courses_per_cm",
        "ALTER TABLE scans DROP COLUMN ends_per_cm", "ALTER TABLE scans DROP COLUMN picks_per_cm",
        "ALTER TABLE scans DROP COLUMN construction", "PRAGMA user_version = 1"})
    EXPECT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK)
        << sql << ": " << sqlite3_errmsg(db);
  sqlite3_close(db);
  catalogue::CatalogueOptions options;
  options.storage_root = temp.path();
  options.rig_name = "bench-3";
  auto catalogue = catalogue::open_catalogue(options);
  ASSERT_TRUE(catalogue) << catalogue.error().describe();
  using Range = CatalogueQuery::FabricRange;
  EXPECT_EQ(search(**catalogue, query([](CatalogueQuery& q) {
              q.fabric = {Range{"wales_per_cm", 6.0, 8.0}};
            })),
            std::vector<std::int64_t>{jersey});
  auto entry = (*catalogue)->get(jersey);
  ASSERT_TRUE(entry && *entry);
  EXPECT_EQ((*entry)->rig, "bench-3");
}

}  // namespace
}  // namespace psrig::test
