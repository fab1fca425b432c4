#include "psrig/daemon/catalogue.h"

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <fcntl.h>
#include <regex>
#include <signal.h>
#include <sqlite3.h>
#include <unistd.h>

#include "psrig/base/log.h"
#include "psrig/processing/atomic_directory.h"
#include "psrig/processing/scan_layout.h"
#include "sqlite_statement.h"

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;
using processing::AtomicDirectory;
using sqlite::Statement;

// Each step takes the schema from version N to N + 1; user_version says
// how many have run. Append, never edit: databases in the field have run
// the old ones.
const char* const kMigrations[] = {
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
};
static_assert(std::size(kMigrations) == Catalogue::kSchemaVersion);

constexpr const char* kSelectEntry = R"sql(
SELECT s.id, s.sample_id, s.description, s.source, s.status, s.created,
       coalesce(s.started, ''), coalesce(s.finished, ''), s.error_code, s.error_message,
       coalesce(s.scan_path, ''), coalesce(s.maps_path, ''), coalesce(s.report, 'null'),
       (SELECT json_group_array(tag) FROM (SELECT tag FROM scan_tags t WHERE t.scan_id = s.id
                                           ORDER BY t.rowid))
FROM scans s)sql";

std::optional<double> number_at(const nlohmann::json& report,
                                const nlohmann::json::json_pointer& at) {
  if (!report.contains(at)) return std::nullopt;
  const auto& value = report.at(at);
  if (!value.is_number()) return std::nullopt;
  return value.get<double>();
}

bool process_alive(pid_t pid) {
  return ::kill(pid, 0) == 0 || errno != ESRCH;
}

bool disk_full(const Error& error) {
  return error.code == ErrorCode::disk_full;
}

}  // namespace

const char* to_string(ScanStatus status) {
  switch (status) {
    case ScanStatus::queued:
      return "queued";
    case ScanStatus::running:
      return "running";
    case ScanStatus::done:
      return "done";
    case ScanStatus::failed:
      return "failed";
    case ScanStatus::aborted:
      return "aborted";
  }
  return "unknown";
}

std::optional<ScanStatus> parse_scan_status(const std::string& text) {
  for (auto status : {ScanStatus::queued, ScanStatus::running, ScanStatus::done, ScanStatus::failed,
                      ScanStatus::aborted})
    if (text == to_string(status)) return status;
  return std::nullopt;
}

std::string utc_timestamp_now() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::optional<std::string> normalise_timestamp(const std::string& text, bool end_of_day) {
  static const std::regex form(
      R"((\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2}):(\d{2})(\.\d+)?(Z|\+00:00|\+0000)?)?)");
  std::smatch match;
  if (!std::regex_match(text, match, form)) return std::nullopt;
  const auto number = [&](int i) { return static_cast<unsigned>(std::stoul(match[i].str())); };
  // A day of the calendar (the month's length, leap years), not just digits.
  const std::chrono::year_month_day day{std::chrono::year{static_cast<int>(number(1))},
                                        std::chrono::month{number(2)}, std::chrono::day{number(3)}};
  if (!day.ok()) return std::nullopt;
  const std::string date = match[1].str() + "-" + match[2].str() + "-" + match[3].str();
  if (!match[4].matched) return date + (end_of_day ? "T23:59:59Z" : "T00:00:00Z");
  // A time of day: the catalogue writes no leap second (:60), nor takes one.
  if (number(4) > 23 || number(5) > 59 || number(6) > 59) return std::nullopt;
  return date + "T" + match[4].str() + ":" + match[5].str() + ":" + match[6].str() + "Z";
}

Catalogue::Catalogue(fs::path root, sqlite3* db) : root_(std::move(root)), db_(db) {}

template <class Write>
auto Catalogue::with_room(Write&& write) -> decltype(write()) {
  flush_pending();
  return write_with_room(std::forward<Write>(write));
}

template <class Write>
auto Catalogue::write_with_room(Write&& write) -> decltype(write()) {
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

void Catalogue::hold_reserve() {
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

bool Catalogue::release_reserve() {
  std::lock_guard lock(reserve_mutex_);
  reserve_held_ = false;
  return ::unlink((root_ / kReserveFileName).c_str()) == 0;
}

Catalogue::~Catalogue() {
  // A last try; what is still pending is marked failed by the next start.
  if (const std::size_t lost = flush_pending(); lost > 0)
    logger("catalogue")
        ->error("{} scan(s) ended but could not be recorded; the next start marks them failed",
                lost);
  sqlite3_close_v2(db_);
}

Result<std::unique_ptr<Catalogue>> Catalogue::open(const fs::path& storage_root) {
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
  std::unique_ptr<Catalogue> catalogue(new Catalogue(root, db));
  // WAL: readers (sqlite3 on the command line, a backup) never block the
  // daemon's writes; busy_timeout: a brief lock held by one waits, not fails.
  sqlite3_busy_timeout(db, 5000);
  for (const char* pragma :
       {"PRAGMA journal_mode = WAL", "PRAGMA synchronous = FULL", "PRAGMA foreign_keys = ON"})
    if (auto ok = catalogue->execute(pragma); !ok) return std::unexpected(ok.error());
  if (auto ok = catalogue->migrate(); !ok) return std::unexpected(ok.error());
  catalogue->hold_reserve();
  return catalogue;
}

Status Catalogue::execute(const std::string& sql) const {
  char* message = nullptr;
  const int result = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message);
  if (result != SQLITE_OK) {
    const std::string text = message ? message : "unknown error";
    sqlite3_free(message);
    return std::unexpected(io_error(root_ / kFileName, text).with(sqlite::error_code(result)));
  }
  return {};
}

Status Catalogue::migrate() {
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
    const std::string sql = std::string("BEGIN IMMEDIATE;") + kMigrations[step] +
                            "PRAGMA user_version = " + std::to_string(step + 1) + "; COMMIT;";
    if (auto ok = execute(sql); !ok) {
      (void)execute("ROLLBACK");
      return ok;
    }
  }
  return {};
}

std::optional<fs::path> Catalogue::inside_root(const fs::path& path) const {
  if (path.empty()) return std::nullopt;
  const fs::path absolute = (path.is_absolute() ? path : root_ / path).lexically_normal();
  const fs::path relative = absolute.lexically_relative(root_);
  if (relative.empty() || relative == "." || *relative.begin() == "..") return std::nullopt;
  return absolute;
}

Result<std::int64_t> Catalogue::add(const ScanSubmission& submission) {
  return with_room([&] { return add_row(submission); });
}

Result<std::int64_t> Catalogue::add_row(const ScanSubmission& submission) {
  std::lock_guard lock(mutex_);
  if (auto ok = execute("BEGIN IMMEDIATE"); !ok) return std::unexpected(ok.error());
  const auto fail = [&](const Error& e) -> Result<std::int64_t> {
    (void)execute("ROLLBACK");
    return std::unexpected(e);
  };
  auto insert = Statement::prepare(
      db_,
      "INSERT INTO scans (sample_id, description, source, status, created) VALUES (?, ?, ?, "
      "'queued', ?)");
  if (!insert) return fail(insert.error());
  insert->bind(1, submission.sample_id);
  insert->bind(2, submission.description);
  insert->bind(3, submission.source);
  insert->bind(4, utc_timestamp_now());
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

Status Catalogue::mark_running(std::int64_t id, const fs::path& scan_directory) {
  const auto inside = inside_root(scan_directory);
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

Status Catalogue::mark_done(std::int64_t id, const fs::path& maps_directory,
                            const nlohmann::json& report) {
  std::optional<std::string> maps_path;
  if (!maps_directory.empty()) {
    const auto inside = inside_root(maps_directory);
    if (!inside)
      return std::unexpected(internal_error("maps directory " + maps_directory.string() +
                                            " is outside the storage root"));
    maps_path = inside->lexically_relative(root_).generic_string();
  }
  return with_room([&] { return mark_done_row(id, maps_path, report); });
}

Status Catalogue::mark_done_row(std::int64_t id, const std::optional<std::string>& maps_path,
                                const nlohmann::json& report) {
  std::lock_guard lock(mutex_);
  auto update = Statement::prepare(db_, R"sql(
UPDATE scans SET status = 'done', finished = ?, maps_path = ?, report = ?,
  angular_error_deg = ?, residual_mean = ?, height_range = ?, total_ms = ?,
  error_code = 0, error_message = ''
WHERE id = ?)sql");
  if (!update) return std::unexpected(update.error());
  using Pointer = nlohmann::json::json_pointer;
  update->bind(1, utc_timestamp_now());
  if (maps_path)
    update->bind(2, *maps_path);
  else
    update->bind_null(2);
  if (report.is_null())
    update->bind_null(3);
  else
    update->bind(3, report.dump());
  update->bind(4, number_at(report, Pointer("/ground_truth/angular_error_deg/mean")));
  update->bind(5, number_at(report, Pointer("/residual/mean")));
  update->bind(6, number_at(report, Pointer("/height/range")));
  update->bind(7, number_at(report, Pointer("/timings_ms/total")));
  update->bind(8, id);
  return update->run();
}

Status Catalogue::mark_failed(std::int64_t id, ScanStatus status, ScanErrorCode code,
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

Status Catalogue::write_outcome(std::int64_t id, const Outcome& outcome) {
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

std::size_t Catalogue::flush_pending() {
  std::lock_guard flushing(flush_mutex_);
  return flush_pending_locked();
}

std::size_t Catalogue::flush_pending_locked() {
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

std::size_t Catalogue::pending_count() const {
  std::lock_guard lock(pending_mutex_);
  return pending_.size();
}

void Catalogue::inject_write_failure(std::optional<Error> error, int writes_first) {
  std::lock_guard lock(fault_mutex_);
  write_fault_ = std::move(error);
  writes_before_fault_ = writes_first;
}

void Catalogue::overlay_pending(CatalogueEntry& entry) const {
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

namespace {

CatalogueEntry read_entry(const Statement& row, const fs::path& root) {
  CatalogueEntry e;
  e.id = row.integer(0);
  e.sample_id = row.text(1);
  e.description = row.text(2);
  e.source = row.text(3);
  e.status = parse_scan_status(row.text(4)).value_or(ScanStatus::failed);
  e.created = row.text(5);
  e.started = row.text(6);
  e.finished = row.text(7);
  e.error_code = static_cast<ScanErrorCode>(row.integer(8));
  e.error_message = row.text(9);
  if (const auto scan = row.text(10); !scan.empty()) e.scan_directory = root / scan;
  if (const auto maps = row.text(11); !maps.empty()) e.maps_directory = root / maps;
  e.report = nlohmann::json::parse(row.text(12), nullptr, false);
  if (e.report.is_discarded()) e.report = nullptr;
  const auto tags = nlohmann::json::parse(row.text(13), nullptr, false);
  if (tags.is_array())
    for (const auto& tag : tags)
      if (tag.is_string()) e.tags.push_back(tag.get<std::string>());
  return e;
}

}  // namespace

Result<std::optional<CatalogueEntry>> Catalogue::get(std::int64_t id) const {
  std::optional<CatalogueEntry> entry;
  {
    std::lock_guard lock(mutex_);
    auto select = Statement::prepare(db_, std::string(kSelectEntry) + " WHERE s.id = ?");
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

namespace {

// A search's WHERE clause and the texts it binds, in order.
struct Filter {
  std::string where;
  std::vector<std::string> texts;
};

// `text` for LIKE, its own % and _ taken literally.
std::string like_pattern(const std::string& text) {
  std::string pattern = "%";
  for (const char c : text) {
    if (c == '%' || c == '_' || c == '\\') pattern += '\\';
    pattern += c;
  }
  return pattern + "%";
}

Filter filter_of(const CatalogueQuery& query) {
  Filter f;
  const auto condition = [&](const std::string& sql, std::initializer_list<std::string> values) {
    f.where += (f.where.empty() ? " WHERE " : " AND ") + sql;
    f.texts.insert(f.texts.end(), values);
  };
  if (query.text) {
    const std::string pattern = like_pattern(*query.text);
    condition(
        "(s.sample_id LIKE ? ESCAPE '\\' OR s.description LIKE ? ESCAPE '\\' OR EXISTS "
        "(SELECT 1 FROM scan_tags t WHERE t.scan_id = s.id AND t.tag LIKE ? ESCAPE '\\'))",
        {pattern, pattern, pattern});
  }
  if (query.sample_id) condition("s.sample_id = ?", {*query.sample_id});
  if (query.tag)
    condition("EXISTS (SELECT 1 FROM scan_tags t WHERE t.scan_id = s.id AND t.tag = ?)",
              {*query.tag});
  if (query.from) condition("s.created >= ?", {*query.from});
  if (query.to) condition("s.created <= ?", {*query.to});
  if (query.status) condition("s.status = ?", {to_string(*query.status)});
  for (const auto& range : query.fabric) {
    // Column names from the fixed list in CatalogueQuery, never the user's text.
    if (range.min)
      condition("s." + range.column + " >= CAST(? AS REAL)", {std::to_string(*range.min)});
    if (range.max)
      condition("s." + range.column + " <= CAST(? AS REAL)", {std::to_string(*range.max)});
  }
  return f;
}

}  // namespace

Result<std::int64_t> Catalogue::count(const CatalogueQuery& query) const {
  const Filter filter = filter_of(query);
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

Result<std::vector<CatalogueEntry>> Catalogue::search(const CatalogueQuery& query) const {
  const Filter filter = filter_of(query);
  const std::string& where = filter.where;
  const std::vector<std::string>& texts = filter.texts;

  std::vector<CatalogueEntry> entries;
  {
    std::lock_guard lock(mutex_);
    auto select = Statement::prepare(
        db_, std::string(kSelectEntry) + where + " ORDER BY s.id DESC LIMIT ? OFFSET ?");
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

Result<bool> Catalogue::remove(std::int64_t id) {
  auto entry = get(id);
  if (!entry) return std::unexpected(entry.error());
  if (!*entry) return false;
  // Files first: a row without files is a lie, files without a row are
  // what recover() and a technician can see and clean.
  for (const auto& directory : {(*entry)->maps_directory, (*entry)->scan_directory}) {
    const auto inside = inside_root(directory);
    if (!inside) continue;
    std::error_code ec;
    fs::remove_all(*inside, ec);
    if (ec) return std::unexpected(io_error(*inside, "cannot remove: " + ec.message()));
  }
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

Result<CatalogueRecovery> Catalogue::recover() {
  auto log = logger("catalogue");
  CatalogueRecovery recovery;
  std::vector<std::pair<std::int64_t, std::string>> unfinished;
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
      unfinished.emplace_back(select->integer(0), select->text(1));
    }
  }
  const auto remove_directory = [&](const fs::path& directory) {
    std::error_code failed;
    if (!fs::exists(fs::symlink_status(directory, failed))) return;
    fs::remove_all(directory, failed);
    if (failed) {
      log->warn("cannot remove {}: {}", directory.string(), failed.message());
      return;
    }
    recovery.removed_leftovers.push_back(directory);
    log->info("removed {}, left by an interrupted scan", directory.string());
  };
  std::error_code ec;
  for (const auto& [id, scan_path] : unfinished) {
    bool kept = false;
    if (const auto directory = inside_root(scan_path)) {
      // A scan directory is renamed into place whole, flushed, from its
      // staging directory: one that holds scan.json is a whole raw
      // capture, which cannot be repeated. It stays; only its maps, which
      // no row recorded and which may not have reached the disk, go.
      std::error_code type_ec;
      kept = !fs::is_symlink(*directory, type_ec) && fs::is_directory(*directory, type_ec) &&
             fs::is_regular_file(*directory / processing::scan_files::kDescription, type_ec);
      if (kept) {
        std::vector<fs::path> maps;
        for (fs::directory_iterator it(*directory, ec), end; !ec && it != end; it.increment(ec)) {
          const auto staging = AtomicDirectory::parse_staging(it->path());
          if (it->path().filename() == processing::scan_files::kMapsDirectory ||
              (staging && staging->target == processing::scan_files::kMapsDirectory))
            maps.push_back(it->path());
        }
        for (const auto& path : maps)
          remove_directory(path);
      } else {
        remove_directory(*directory);
      }
      // Its writer's staging directory, whoever's PID it carries: no scan
      // of this daemon is running yet.
      std::vector<fs::path> staging;
      for (fs::directory_iterator it(directory->parent_path(), ec), end; !ec && it != end;
           it.increment(ec))
        if (const auto name = AtomicDirectory::parse_staging(it->path());
            name && name->target == directory->filename())
          staging.push_back(it->path());
      for (const auto& path : staging)
        remove_directory(path);
    }
    const std::string message =
        kept ? "interrupted during processing; raw frames kept, reprocess with psrig process"
             : "interrupted: psrigd stopped before this scan finished";
    // A disk still full keeps the end pending (written at the next write)
    // rather than keeping the daemon from starting.
    if (auto ok = mark_failed(id, ScanStatus::failed, ScanErrorCode::internal, message, kept); !ok)
      log->error("scan {}: {}", id, ok.error().describe());
    recovery.interrupted.push_back(id);
    if (kept)
      log->warn("scan {} was interrupted by the last shutdown; marked failed, its raw frames kept",
                id);
    else
      log->warn("scan {} was interrupted by the last shutdown; marked failed", id);
  }
  // Other writers' staging directories, once their process is gone.
  std::vector<fs::path> abandoned;
  for (fs::directory_iterator it(root_, ec), end; !ec && it != end; it.increment(ec)) {
    const auto staging = AtomicDirectory::parse_staging(it->path());
    std::error_code type_ec;
    if (staging && staging->writer != ::getpid() && !process_alive(staging->writer) &&
        !it->is_symlink(type_ec) && it->is_directory(type_ec))
      abandoned.push_back(it->path());
  }
  for (const auto& path : abandoned)
    remove_directory(path);
  return recovery;
}

}  // namespace psrig::daemon
