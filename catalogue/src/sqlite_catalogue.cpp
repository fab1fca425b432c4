#include "sqlite_catalogue.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include "catalogue_rows.h"
#include "psrig/base/log.h"
#include "scan_leftovers.h"
#include "sqlite_statement.h"

namespace psrig::catalogue {
namespace {

namespace fs = std::filesystem;
using sqlite::Statement;

// Each step takes the schema from version N to N + 1; user_version says
// how many have run. Append, never edit: databases in the field have run
// the old ones.
const char* const kSqliteMigrations[] = {
    R"sql(
CREATE TABLE scans (
  id INTEGER PRIMARY KEY AUTOINCREMENT,  -- never reused: a PLC may still hold an old id
  sample_id TEXT NOT NULL DEFAULT '',
  description TEXT NOT NULL DEFAULT '',
  source TEXT NOT NULL DEFAULT '',
  status TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed', 'aborted')),
  created TEXT NOT NULL,
  started TEXT,
  finished TEXT,
  error_code INTEGER NOT NULL DEFAULT 0,
  error_message TEXT NOT NULL DEFAULT '',
  scan_path TEXT,  -- relative to the storage root
  maps_path TEXT,
  angular_error_deg REAL,  -- report metrics worth searching and sorting on
  residual_mean REAL,
  height_range REAL,
  total_ms REAL,
  report TEXT  -- the maps' report.json
);
CREATE INDEX scans_sample_id ON scans (sample_id);
CREATE INDEX scans_created ON scans (created);
CREATE INDEX scans_status ON scans (status);
CREATE TABLE scan_tags (
  scan_id INTEGER NOT NULL REFERENCES scans (id) ON DELETE CASCADE,
  tag TEXT NOT NULL,
  PRIMARY KEY (scan_id, tag)
);
CREATE INDEX scan_tags_tag ON scan_tags (tag);
)sql",
    // The fabric's measured densities (report.json's fabric section), as
    // columns to search by range; computed from the stored report, so rows
    // written before this step have them too.
    R"sql(
ALTER TABLE scans ADD COLUMN wales_per_cm REAL
  GENERATED ALWAYS AS (json_extract(report, '$.fabric.wales_per_cm')) VIRTUAL;
ALTER TABLE scans ADD COLUMN courses_per_cm REAL
  GENERATED ALWAYS AS (json_extract(report, '$.fabric.courses_per_cm')) VIRTUAL;
ALTER TABLE scans ADD COLUMN ends_per_cm REAL
  GENERATED ALWAYS AS (json_extract(report, '$.fabric.ends_per_cm')) VIRTUAL;
ALTER TABLE scans ADD COLUMN picks_per_cm REAL
  GENERATED ALWAYS AS (json_extract(report, '$.fabric.picks_per_cm')) VIRTUAL;
ALTER TABLE scans ADD COLUMN construction TEXT
  GENERATED ALWAYS AS (json_extract(report, '$.fabric.construction')) VIRTUAL;
)sql",
    // The rig that scanned each row (rows from before this step: the rig
    // that opens it next, set by open()). The fabric
    // columns again, numbers only: a string in the report matched any
    // lower bound (SQLite orders text after numbers), as the shared
    // catalogue's never did.
    R"sql(
ALTER TABLE scans DROP COLUMN wales_per_cm;
ALTER TABLE scans ADD COLUMN wales_per_cm REAL GENERATED ALWAYS AS
  (CASE WHEN json_type(report, '$.fabric.wales_per_cm') IN ('real', 'integer')
        THEN json_extract(report, '$.fabric.wales_per_cm') END) VIRTUAL;
ALTER TABLE scans DROP COLUMN courses_per_cm;
ALTER TABLE scans ADD COLUMN courses_per_cm REAL GENERATED ALWAYS AS
  (CASE WHEN json_type(report, '$.fabric.courses_per_cm') IN ('real', 'integer')
        THEN json_extract(report, '$.fabric.courses_per_cm') END) VIRTUAL;
ALTER TABLE scans DROP COLUMN ends_per_cm;
ALTER TABLE scans ADD COLUMN ends_per_cm REAL GENERATED ALWAYS AS
  (CASE WHEN json_type(report, '$.fabric.ends_per_cm') IN ('real', 'integer')
        THEN json_extract(report, '$.fabric.ends_per_cm') END) VIRTUAL;
ALTER TABLE scans DROP COLUMN picks_per_cm;
ALTER TABLE scans ADD COLUMN picks_per_cm REAL GENERATED ALWAYS AS
  (CASE WHEN json_type(report, '$.fabric.picks_per_cm') IN ('real', 'integer')
        THEN json_extract(report, '$.fabric.picks_per_cm') END) VIRTUAL;
ALTER TABLE scans ADD COLUMN rig TEXT NOT NULL DEFAULT '';
CREATE INDEX scans_rig ON scans (rig);
)sql",
};
static_assert(std::size(kSqliteMigrations) == SqliteCatalogue::kSchemaVersion);

// catalogue_rows.h's columns.
constexpr const char* kSqliteSelectEntry = R"sql(
SELECT s.id, s.rig, s.sample_id, s.description, s.source, s.status, s.created,
       s.started, s.finished, s.error_code, s.error_message, s.scan_path, s.maps_path, s.report,
       (SELECT json_group_array(tag) FROM (SELECT tag FROM scan_tags t WHERE t.scan_id = s.id
                                           ORDER BY t.rowid))
FROM scans s)sql";

bool disk_full(const Error& error) {
  return error.code == ErrorCode::disk_full;
}

CatalogueEntry read_entry(const Statement& row, const fs::path& root) {
  std::vector<std::optional<std::string>> columns;
  for (int i = 0; i < rows::kEntryColumns; ++i)
    columns.push_back(row.is_null(i) ? std::nullopt : std::optional(row.text(i)));
  return rows::entry_from(columns, root);
}

}  // namespace

SqliteCatalogue::SqliteCatalogue(fs::path root, std::string rig, sqlite3* db)
    : root_(std::move(root)), rig_(std::move(rig)), db_(db) {}

template <class Write>
auto SqliteCatalogue::with_room(Write&& write) -> decltype(write()) {
  flush_pending();
  return write_with_room(std::forward<Write>(write));
}

template <class Write>
auto SqliteCatalogue::write_with_room(Write&& write) -> decltype(write()) {
  const auto injected = [&]() -> std::optional<Error> {
    std::lock_guard lock(fault_mutex_);
    if (!write_fault_) return std::nullopt;
    if (writes_before_fault_ > 0) {
      --writes_before_fault_;
      return std::nullopt;
    }
    return write_fault_;
  };
  const auto attempt = [&]() -> decltype(write()) {
    if (auto fault = injected()) return std::unexpected(*fault);
    return write();
  };
  auto result = attempt();
  if (result) {
    hold_reserve();
    return result;
  }
  if (!disk_full(result.error())) return result;
  if (release_reserve()) {
    logger("catalogue")
        ->warn("{}: the disk is full; gave back the catalogue's reserve ({} KiB) to record this",
               root_.string(), kReserveBytes >> 10);
    result = attempt();
    if (result || !disk_full(result.error())) return result;
  }
  std::error_code ec;
  const auto space = fs::space(root_, ec);
  return std::unexpected(
      io_error(root_ / kFileName,
               "the disk is full (" + std::to_string(ec ? 0 : space.available >> 10) +
                   " KiB free), the catalogue cannot record scans; delete or move old "
                   "scans, or point storage.root at a larger disk")
          .with(ErrorCode::disk_full));
}

void SqliteCatalogue::hold_reserve() {
  std::lock_guard lock(reserve_mutex_);
  if (reserve_held_) return;
  // Only with room to spare: allocating it must not take the last bytes a
  // scan being written needs.
  std::error_code ec;
  if (const auto space = fs::space(root_, ec); ec || space.available < 4 * kReserveBytes) return;
  const fs::path file = root_ / kReserveFileName;
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return;
  const int failed = ::posix_fallocate(fd, 0, static_cast<off_t>(kReserveBytes));
  ::close(fd);
  if (failed != 0) {
    ::unlink(file.c_str());
    return;
  }
  reserve_held_ = true;
}

bool SqliteCatalogue::release_reserve() {
  std::lock_guard lock(reserve_mutex_);
  reserve_held_ = false;
  return ::unlink((root_ / kReserveFileName).c_str()) == 0;
}

SqliteCatalogue::~SqliteCatalogue() {
  // A last try; what is still pending is marked failed by the next start.
  if (const std::size_t lost = flush_pending(); lost > 0)
    logger("catalogue")
        ->error("{} scan(s) ended but could not be recorded; the next start marks them failed",
                lost);
  sqlite3_close_v2(db_);
}

Result<std::unique_ptr<Catalogue>> SqliteCatalogue::open(const fs::path& storage_root,
                                                         const std::string& rig_name) {
  std::error_code ec;
  fs::create_directories(storage_root, ec);
  if (ec)
    return std::unexpected(
        io_error(storage_root, "cannot create the storage root: " + ec.message()));
  const fs::path root = fs::weakly_canonical(storage_root, ec);
  if (ec) return std::unexpected(io_error(storage_root, "cannot resolve: " + ec.message()));
  const fs::path file = root / kFileName;
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(
      file.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close_v2(db);
    return std::unexpected(io_error(file, "cannot open the catalogue: " + message));
  }
  std::unique_ptr<SqliteCatalogue> catalogue(new SqliteCatalogue(root, rig_name, db));
  // WAL: readers (sqlite3 on the command line, a backup) never block the
  // daemon's writes; busy_timeout: a brief lock held by one waits, not fails.
  sqlite3_busy_timeout(db, 5000);
  for (const char* pragma :
       {"PRAGMA journal_mode = WAL", "PRAGMA synchronous = FULL", "PRAGMA foreign_keys = ON"})
    if (auto ok = catalogue->execute(pragma); !ok) return std::unexpected(ok.error());
  if (auto ok = catalogue->migrate(); !ok) return std::unexpected(ok.error());
  // An embedded catalogue is one rig's: rows from before rows had a rig are its.
  if (auto claim = Statement::prepare(db, "UPDATE scans SET rig = ? WHERE rig = ''"); claim) {
    claim->bind(1, rig_name);
    (void)claim->run();  // a full disk: they stay unnamed until the next start
  }
  catalogue->hold_reserve();
  return std::unique_ptr<Catalogue>(std::move(catalogue));
}

Status SqliteCatalogue::execute(const std::string& sql) const {
  char* message = nullptr;
  const int result = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message);
  if (result != SQLITE_OK) {
    const std::string text = message ? message : "unknown error";
    sqlite3_free(message);
    return std::unexpected(io_error(root_ / kFileName, text).with(sqlite::error_code(result)));
  }
  return {};
}

Status SqliteCatalogue::migrate() {
  auto version = Statement::prepare(db_, "PRAGMA user_version");
  if (!version) return std::unexpected(version.error());
  if (auto row = version->step(); !row) return std::unexpected(row.error());
  const auto current = static_cast<int>(version->integer(0));
  if (current > kSchemaVersion)
    return std::unexpected(
        io_error(root_ / kFileName, "schema version " + std::to_string(current) +
                                        " is newer than this psrigd understands (" +
                                        std::to_string(kSchemaVersion) + "); run a newer psrigd"));
  for (int step = current; step < kSchemaVersion; ++step) {
    const std::string sql = std::string("BEGIN IMMEDIATE;") + kSqliteMigrations[step] +
                            "PRAGMA user_version = " + std::to_string(step + 1) + "; COMMIT;";
    if (auto ok = execute(sql); !ok) {
      (void)execute("ROLLBACK");
      return ok;
    }
  }
  return {};
}

Result<std::int64_t> SqliteCatalogue::add(const ScanSubmission& submission) {
  return with_room([&] { return add_row(submission); });
}

Result<std::int64_t> SqliteCatalogue::add_row(const ScanSubmission& submission) {
  std::lock_guard lock(mutex_);
  if (auto ok = execute("BEGIN IMMEDIATE"); !ok) return std::unexpected(ok.error());
  const auto fail = [&](const Error& e) -> Result<std::int64_t> {
    (void)execute("ROLLBACK");
    return std::unexpected(e);
  };
  auto insert = Statement::prepare(
      db_,
      "INSERT INTO scans (rig, sample_id, description, source, status, created) VALUES (?, ?, ?, "
      "?, 'queued', ?)");
  if (!insert) return fail(insert.error());
  insert->bind(1, rig_);
  insert->bind(2, submission.sample_id);
  insert->bind(3, submission.description);
  insert->bind(4, submission.source);
  insert->bind(5, utc_timestamp_now());
  if (auto ok = insert->run(); !ok) return fail(ok.error());
  const std::int64_t id = sqlite3_last_insert_rowid(db_);
  for (const auto& tag : submission.tags) {
    auto tag_insert =
        Statement::prepare(db_, "INSERT OR IGNORE INTO scan_tags (scan_id, tag) VALUES (?, ?)");
    if (!tag_insert) return fail(tag_insert.error());
    tag_insert->bind(1, id);
    tag_insert->bind(2, tag);
    if (auto ok = tag_insert->run(); !ok) return fail(ok.error());
  }
  if (auto ok = execute("COMMIT"); !ok) return fail(ok.error());
  return id;
}

Status SqliteCatalogue::mark_running(std::int64_t id, const fs::path& scan_directory) {
  const auto inside = rows::inside_root(root_, scan_directory);
  if (!inside)
    return std::unexpected(internal_error("scan directory " + scan_directory.string() +
                                          " is outside the storage root " + root_.string()));
  return with_room([&]() -> Status {
    std::lock_guard lock(mutex_);
    auto update = Statement::prepare(
        db_, "UPDATE scans SET status = 'running', started = ?, scan_path = ? WHERE id = ?");
    if (!update) return std::unexpected(update.error());
    update->bind(1, utc_timestamp_now());
    update->bind(2, inside->lexically_relative(root_).generic_string());
    update->bind(3, id);
    return update->run();
  });
}

Status SqliteCatalogue::mark_done(std::int64_t id, const fs::path& maps_directory,
                            const nlohmann::json& report) {
  std::optional<std::string> maps_path;
  if (!maps_directory.empty()) {
    const auto inside = rows::inside_root(root_, maps_directory);
    if (!inside)
      return std::unexpected(internal_error("maps directory " + maps_directory.string() +
                                            " is outside the storage root"));
    maps_path = inside->lexically_relative(root_).generic_string();
  }
  return with_room([&] { return mark_done_row(id, maps_path, report); });
}

Status SqliteCatalogue::mark_done_row(std::int64_t id, const std::optional<std::string>& maps_path,
                                const nlohmann::json& report) {
  std::lock_guard lock(mutex_);
  auto update = Statement::prepare(db_, R"sql(
UPDATE scans SET status = 'done', finished = ?, maps_path = ?, report = ?,
  angular_error_deg = ?, residual_mean = ?, height_range = ?, total_ms = ?,
  error_code = 0, error_message = ''
WHERE id = ?)sql");
  if (!update) return std::unexpected(update.error());
  const rows::ReportFigures figures = rows::figures_of(report);
  update->bind(1, utc_timestamp_now());
  if (maps_path)
    update->bind(2, *maps_path);
  else
    update->bind_null(2);
  if (report.is_null())
    update->bind_null(3);
  else
    update->bind(3, report.dump());
  update->bind(4, figures.angular_error_deg);
  update->bind(5, figures.residual_mean);
  update->bind(6, figures.height_range);
  update->bind(7, figures.total_ms);
  update->bind(8, id);
  return update->run();
}

Status SqliteCatalogue::mark_failed(std::int64_t id, ScanStatus status, ScanErrorCode code,
                              const std::string& message, bool keep_scan_directory) {
  const Outcome outcome{status, code, message, keep_scan_directory, utc_timestamp_now()};
  // Under the flush's lock, so that no older end of this scan, being
  // flushed, lands after this one.
  std::lock_guard flushing(flush_mutex_);
  (void)flush_pending_locked();
  auto written = write_with_room([&] { return write_outcome(id, outcome); });
  std::lock_guard lock(pending_mutex_);
  if (written) {
    pending_.erase(id);  // an older end still waiting must not overwrite this one
    return written;
  }
  // The scan has ended whatever the disk says: its end waits in memory for
  // the next write rather than leaving the row `queued` or `running`.
  pending_[id] = outcome;
  Error error = written.error();
  error.message += "; scan " + std::to_string(id) + " is recorded " + to_string(status) +
                   " as soon as the catalogue can write";
  return std::unexpected(std::move(error));
}

Status SqliteCatalogue::write_outcome(std::int64_t id, const Outcome& outcome) {
  std::lock_guard lock(mutex_);
  auto update = Statement::prepare(
      db_, std::string("UPDATE scans SET status = ?, finished = ?, error_code = ?, "
                       "error_message = ?") +
               (outcome.keep_scan_directory ? "" : ", scan_path = NULL, maps_path = NULL") +
               " WHERE id = ?");
  if (!update) return std::unexpected(update.error());
  update->bind(1, std::string(to_string(outcome.status)));
  update->bind(2, outcome.finished);
  update->bind(3, static_cast<std::int64_t>(outcome.code));
  update->bind(4, outcome.message);
  update->bind(5, id);
  return update->run();
}

std::size_t SqliteCatalogue::flush_pending() {
  std::lock_guard flushing(flush_mutex_);
  return flush_pending_locked();
}

std::size_t SqliteCatalogue::flush_pending_locked() {
  std::map<std::int64_t, Outcome> pending;
  {
    std::lock_guard lock(pending_mutex_);
    if (pending_.empty()) return 0;
    pending = pending_;
  }
  // In id order, and no further once the disk refuses one: the rest would
  // be refused too.
  for (const auto& [id, outcome] : pending) {
    if (!write_with_room([&] { return write_outcome(id, outcome); })) break;
    logger("catalogue")
        ->info("scan {}: recorded {} now that the catalogue can write", id,
               to_string(outcome.status));
    std::lock_guard lock(pending_mutex_);
    if (const auto it = pending_.find(id); it != pending_.end() && it->second == outcome)
      pending_.erase(it);
  }
  std::lock_guard lock(pending_mutex_);
  return pending_.size();
}

std::size_t SqliteCatalogue::pending_count() const {
  std::lock_guard lock(pending_mutex_);
  return pending_.size();
}

void SqliteCatalogue::inject_write_failure(std::optional<Error> error, int writes_first) {
  std::lock_guard lock(fault_mutex_);
  write_fault_ = std::move(error);
  writes_before_fault_ = writes_first;
}

void SqliteCatalogue::overlay_pending(CatalogueEntry& entry) const {
  std::lock_guard lock(pending_mutex_);
  const auto it = pending_.find(entry.id);
  if (it == pending_.end()) return;
  const Outcome& outcome = it->second;
  entry.status = outcome.status;
  entry.finished = outcome.finished;
  entry.error_code = outcome.code;
  entry.error_message = outcome.message;
  if (!outcome.keep_scan_directory) {
    entry.scan_directory.clear();
    entry.maps_directory.clear();
  }
}

Result<std::optional<CatalogueEntry>> SqliteCatalogue::get(std::int64_t id) const {
  std::optional<CatalogueEntry> entry;
  {
    std::lock_guard lock(mutex_);
    auto select = Statement::prepare(db_, std::string(kSqliteSelectEntry) + " WHERE s.id = ?");
    if (!select) return std::unexpected(select.error());
    select->bind(1, id);
    auto row = select->step();
    if (!row) return std::unexpected(row.error());
    if (!*row) return entry;
    entry = read_entry(*select, root_);
  }
  overlay_pending(*entry);
  return entry;
}

Result<std::int64_t> SqliteCatalogue::count(const CatalogueQuery& query) const {
  const rows::Filter filter = rows::filter_of(query, rows::sqlite_dialect());
  std::lock_guard lock(mutex_);
  auto select = Statement::prepare(db_, "SELECT count(*) FROM scans s" + filter.where);
  if (!select) return std::unexpected(select.error());
  int index = 1;
  for (const auto& text : filter.texts)
    select->bind(index++, text);
  auto row = select->step();
  if (!row) return std::unexpected(row.error());
  return *row ? select->integer(0) : 0;
}

Result<std::vector<CatalogueEntry>> SqliteCatalogue::search(const CatalogueQuery& query) const {
  const rows::Filter filter = rows::filter_of(query, rows::sqlite_dialect());
  const std::string& where = filter.where;
  const std::vector<std::string>& texts = filter.texts;

  std::vector<CatalogueEntry> entries;
  {
    std::lock_guard lock(mutex_);
    auto select = Statement::prepare(
        db_, std::string(kSqliteSelectEntry) + where + " ORDER BY s.id DESC LIMIT ? OFFSET ?");
    if (!select) return std::unexpected(select.error());
    int index = 1;
    for (const auto& text : texts)
      select->bind(index++, text);
    select->bind(index++, static_cast<std::int64_t>(query.limit));
    select->bind(index, static_cast<std::int64_t>(query.offset));
    for (;;) {
      auto row = select->step();
      if (!row) return std::unexpected(row.error());
      if (!*row) break;
      entries.push_back(read_entry(*select, root_));
    }
  }
  // Rows as their pending ends say. A status search matches what is
  // written, less the rows whose pending end no longer matches (a page may
  // come up short while the disk is full; simpler than merging in SQL).
  for (auto& entry : entries)
    overlay_pending(entry);
  if (query.status)
    std::erase_if(entries, [&](const CatalogueEntry& e) { return e.status != *query.status; });
  return entries;
}

Result<bool> SqliteCatalogue::remove(std::int64_t id) {
  auto entry = get(id);
  if (!entry) return std::unexpected(entry.error());
  if (!*entry) return false;
  // Files first: a row without files is a lie, files without a row are
  // what recover() and a technician can see and clean.
  if (auto ok = remove_scan_files(root_, {(*entry)->maps_directory, (*entry)->scan_directory}); !ok)
    return std::unexpected(ok.error());
  auto erased = with_room([&]() -> Status {
    std::lock_guard lock(mutex_);
    auto erase = Statement::prepare(db_, "DELETE FROM scans WHERE id = ?");
    if (!erase) return std::unexpected(erase.error());
    erase->bind(1, id);
    return erase->run();
  });
  if (!erased) return std::unexpected(erased.error());
  return true;
}

Result<CatalogueRecovery> SqliteCatalogue::recover() {
  auto log = logger("catalogue");
  std::vector<UnfinishedScan> unfinished;
  {
    std::lock_guard lock(mutex_);
    auto select = Statement::prepare(db_,
                                     "SELECT id, coalesce(scan_path, '') FROM scans WHERE status "
                                     "IN ('queued', 'running') ORDER BY id");
    if (!select) return std::unexpected(select.error());
    for (;;) {
      auto row = select->step();
      if (!row) return std::unexpected(row.error());
      if (!*row) break;
      unfinished.push_back({select->integer(0), select->text(1)});
    }
  }
  CatalogueRecovery recovery;
  for (const auto& scan :
       clean_interrupted_scans(root_, root_, unfinished, recovery.removed_leftovers)) {
    // A disk still full keeps the end pending (written at the next write)
    // rather than keeping the daemon from starting.
    if (auto ok = mark_failed(scan.id, ScanStatus::failed, ScanErrorCode::internal, scan.message,
                              scan.kept);
        !ok)
      log->error("scan {}: {}", scan.id, ok.error().describe());
    recovery.interrupted.push_back(scan.id);
    log->warn("scan {} was interrupted by the last shutdown; marked failed{}", scan.id,
              scan.kept ? ", its raw frames kept" : "");
  }
  return recovery;
}

Status SqliteCatalogue::announce(const RigRecord& rig) {
  std::lock_guard lock(rig_mutex_);
  announced_ = rig;
  announced_->last_seen = utc_timestamp_now();
  announced_at_ = std::chrono::steady_clock::now();
  return {};
}

Result<std::vector<RigRecord>> SqliteCatalogue::rigs() const {
  std::lock_guard lock(rig_mutex_);
  if (!announced_) return std::vector<RigRecord>{};
  RigRecord rig = *announced_;
  rig.seen_seconds_ago =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - announced_at_).count();
  return std::vector<RigRecord>{rig};
}

}  // namespace psrig::catalogue
