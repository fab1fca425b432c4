#include "postgres_catalogue.h"

#include <pqxx/pqxx>

#include "catalogue_rows.h"
#include "psrig/base/log.h"
#include "scan_leftovers.h"

namespace psrig::catalogue {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Values = std::vector<std::optional<std::string>>;

// Each step takes the schema from version N to N + 1; psrig_schema says
// how many have run. Append, never edit: databases in the field have run
// the old ones. Times are UTC ISO-8601 text, as in the embedded
// catalogue, so both compare and search them alike.
const char* const kPostgresMigrations[] = {
    R"sql(
CREATE SEQUENCE scan_ids;  -- never reused: rigs take ids from it ahead of need
CREATE TABLE scans (
  id BIGINT PRIMARY KEY,
  rig TEXT NOT NULL,
  sample_id TEXT NOT NULL DEFAULT '',
  description TEXT NOT NULL DEFAULT '',
  source TEXT NOT NULL DEFAULT '',
  status TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed', 'aborted')),
  created TEXT NOT NULL,
  started TEXT,
  finished TEXT,
  error_code INTEGER NOT NULL DEFAULT 0,
  error_message TEXT NOT NULL DEFAULT '',
  scan_path TEXT,  -- relative to the shared storage root
  maps_path TEXT,
  angular_error_deg DOUBLE PRECISION,  -- report metrics worth searching and sorting on
  residual_mean DOUBLE PRECISION,
  height_range DOUBLE PRECISION,
  total_ms DOUBLE PRECISION,
  report JSONB,  -- the maps' report.json
  -- The fabric's measured densities (report.json's fabric section), to search by range.
  wales_per_cm DOUBLE PRECISION GENERATED ALWAYS AS (CASE WHEN jsonb_typeof(report #> '{fabric,wales_per_cm}') = 'number' THEN (report #>> '{fabric,wales_per_cm}')::double precision END) STORED,
  courses_per_cm DOUBLE PRECISION GENERATED ALWAYS AS (CASE WHEN jsonb_typeof(report #> '{fabric,courses_per_cm}') = 'number' THEN (report #>> '{fabric,courses_per_cm}')::double precision END) STORED,
  ends_per_cm DOUBLE PRECISION GENERATED ALWAYS AS (CASE WHEN jsonb_typeof(report #> '{fabric,ends_per_cm}') = 'number' THEN (report #>> '{fabric,ends_per_cm}')::double precision END) STORED,
  picks_per_cm DOUBLE PRECISION GENERATED ALWAYS AS (CASE WHEN jsonb_typeof(report #> '{fabric,picks_per_cm}') = 'number' THEN (report #>> '{fabric,picks_per_cm}')::double precision END) STORED,
  construction TEXT GENERATED ALWAYS AS (report #>> '{fabric,construction}') STORED
);
CREATE INDEX scans_sample_id ON scans (sample_id);
CREATE INDEX scans_created ON scans (created);
CREATE INDEX scans_status ON scans (status);
CREATE INDEX scans_rig_status ON scans (rig, status);
CREATE TABLE scan_tags (
  scan_id BIGINT NOT NULL REFERENCES scans (id) ON DELETE CASCADE,
  position INTEGER NOT NULL,  -- the order they were given in
  tag TEXT NOT NULL,
  PRIMARY KEY (scan_id, tag)
);
CREATE INDEX scan_tags_tag ON scan_tags (tag);
CREATE TABLE rigs (
  name TEXT PRIMARY KEY,
  api_url TEXT NOT NULL DEFAULT '',
  token TEXT NOT NULL DEFAULT '',  -- for forwarding a scan to the rig; the API never shows it
  status JSONB NOT NULL DEFAULT '{}',
  last_seen TIMESTAMPTZ NOT NULL
);
)sql",
};
static_assert(std::size(kPostgresMigrations) == PostgresCatalogue::kSchemaVersion);

// catalogue_rows.h's columns.
constexpr const char* kPostgresSelectEntry = R"sql(
SELECT s.id, s.rig, s.sample_id, s.description, s.source, s.status, s.created,
       s.started, s.finished, s.error_code, s.error_message, s.scan_path, s.maps_path,
       s.report::text,
       coalesce((SELECT json_agg(t.tag ORDER BY t.position) FROM scan_tags t
                 WHERE t.scan_id = s.id), '[]')::text
FROM scans s)sql";

// A key for pg_advisory_xact_lock: one psrigd migrates at a time.
constexpr std::int64_t kMigrationLock = 0x70737269'67000001;

// How many scan ids a rig holds ahead of need, and when it takes more:
// enough to go on queueing scans through an outage of a few minutes.
constexpr std::size_t kIdStock = 16;
constexpr std::size_t kIdStockLow = 4;

// Runs `sql` with text parameters, each NULL when absent.
pqxx::result run(pqxx::dbtransaction& transaction, const std::string& sql, const Values& values) {
  std::vector<const char*> texts;
  for (const auto& value : values)
    texts.push_back(value ? value->c_str() : nullptr);
  return transaction.exec_params(sql, pqxx::prepare::make_dynamic_params(texts));
}

std::optional<std::string> text_of(const std::optional<double>& number) {
  if (!number) return std::nullopt;
  return nlohmann::json(*number).dump();
}

CatalogueEntry read_entry(const pqxx::row& row, const fs::path& root) {
  std::vector<std::optional<std::string>> columns;
  for (int i = 0; i < rows::kEntryColumns; ++i)
    columns.push_back(row[i].is_null() ? std::nullopt : std::optional<std::string>(row[i].c_str()));
  return rows::entry_from(columns, root);
}

std::optional<std::string> optional_text(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  return std::nullopt;
}

}  // namespace

PostgresCatalogue::PostgresCatalogue(const CatalogueOptions& options, fs::path root,
                                     fs::path rig_root, std::unique_ptr<CatalogueJournal> journal)
    : root_(std::move(root)),
      rig_root_(std::move(rig_root)),
      rig_(options.rig_name),
      link_(options.url, "psrigd-" + options.rig_name),
      journal_(std::move(journal)) {}

PostgresCatalogue::~PostgresCatalogue() {
  // A last try; what still waits stays in the journal for the next start.
  if (const std::size_t waiting = flush_pending(); waiting > 0)
    logger("catalogue")
        ->warn("{} row write(s) wait in {} for the catalogue database; the next start writes them",
               waiting, journal_->file().string());
}

Result<std::unique_ptr<Catalogue>> PostgresCatalogue::open(const CatalogueOptions& options) {
  const fs::path rig_root = options.rig_root.empty() ? options.storage_root : options.rig_root;
  std::error_code ec;
  fs::create_directories(rig_root, ec);
  if (ec) return std::unexpected(io_error(rig_root, "cannot create the storage root: " + ec.message()));
  const fs::path root = fs::weakly_canonical(options.storage_root, ec);
  if (ec) return std::unexpected(io_error(options.storage_root, "cannot resolve: " + ec.message()));
  std::unique_ptr<CatalogueJournal> journal;
  if (!options.journal.empty()) {
    auto opened = CatalogueJournal::open(options.journal);
    if (!opened) return std::unexpected(opened.error());
    journal = std::move(*opened);
  }
  std::unique_ptr<PostgresCatalogue> catalogue(new PostgresCatalogue(
      options, root, fs::weakly_canonical(rig_root, ec), std::move(journal)));
  if (auto ok = catalogue->migrate(options.start_patience); !ok) return std::unexpected(ok.error());
  // What an earlier run kept for the database goes first: recover() then
  // sees this rig's rows as that run left them.
  if (const std::size_t waiting = catalogue->flush_pending(); waiting > 0)
    return std::unexpected(io_error(catalogue->journal_->file(),
                                    std::to_string(waiting) +
                                        " row write(s) from the last run cannot be written to the "
                                        "catalogue database yet; psrigd starts once they can"));
  // Ids in reserve from the start: scans can be queued through an outage
  // that begins before the first one.
  {
    std::lock_guard lock(catalogue->write_mutex_);
    (void)catalogue->refill_ids();
  }
  return std::unique_ptr<Catalogue>(std::move(catalogue));
}

Status PostgresCatalogue::migrate(std::chrono::seconds patience) {
  int found = 0;
  auto migrated = link_.transact_patiently(
      [&](pqxx::dbtransaction& t) {
        t.exec("SELECT pg_advisory_xact_lock(" + std::to_string(kMigrationLock) + ")");
        t.exec("CREATE TABLE IF NOT EXISTS psrig_schema (version INTEGER NOT NULL)");
        const auto version = t.exec("SELECT version FROM psrig_schema");
        if (version.empty()) t.exec("INSERT INTO psrig_schema (version) VALUES (0)");
        found = version.empty() ? 0 : version[0][0].as<int>();
        if (found > kSchemaVersion) return;
        for (int step = found; step < kSchemaVersion; ++step) {
          t.exec(kPostgresMigrations[step]);
          t.exec("UPDATE psrig_schema SET version = " + std::to_string(step + 1));
        }
      },
      patience);
  if (!migrated) {
    Error error = migrated.error();
    error.key = "catalogue.url";
    if (error.code == ErrorCode::unavailable)
      error.message = "cannot reach the catalogue database: " + error.message +
                      " (check catalogue.url, and that the server takes connections)";
    return std::unexpected(std::move(error));
  }
  if (found > kSchemaVersion)
    return std::unexpected(io_error(link_.where(), "schema version " + std::to_string(found) +
                                                      " is newer than this psrigd understands (" +
                                                      std::to_string(kSchemaVersion) +
                                                      "); run a newer psrigd"));
  return {};
}

std::optional<std::string> PostgresCatalogue::relative(const fs::path& path) const {
  const auto inside = rows::inside_root(root_, path);
  if (!inside) return std::nullopt;
  return inside->lexically_relative(root_).generic_string();
}

Status PostgresCatalogue::apply(const json& change) {
  {
    std::lock_guard lock(fault_mutex_);
    if (write_fault_) {
      if (writes_before_fault_ > 0)
        --writes_before_fault_;
      else
        return std::unexpected(Error(*write_fault_).with(ErrorCode::unavailable));
    }
  }
  const std::string kind = change.at("write").get<std::string>();
  const std::string id = std::to_string(change.at("id").get<std::int64_t>());
  return link_.transact([&](pqxx::dbtransaction& t) {
    if (kind == "add") {
      // ON CONFLICT: written before, its answer lost; the same row again.
      run(t,
          "INSERT INTO scans (id, rig, sample_id, description, source, status, created) "
          "VALUES ($1::bigint, $2, $3, $4, $5, 'queued', $6) ON CONFLICT (id) DO NOTHING",
          {id, change.at("rig").get<std::string>(), change.at("sample_id").get<std::string>(),
           change.at("description").get<std::string>(), change.at("source").get<std::string>(),
           change.at("created").get<std::string>()});
      int position = 0;
      for (const auto& tag : change.at("tags"))
        run(t,
            "INSERT INTO scan_tags (scan_id, position, tag) VALUES ($1::bigint, $2::integer, $3) "
            "ON CONFLICT DO NOTHING",
            {id, std::to_string(position++), tag.get<std::string>()});
    } else if (kind == "running") {
      run(t, "UPDATE scans SET status = 'running', started = $2, scan_path = $3 WHERE id = $1::bigint",
          {id, change.at("started").get<std::string>(), change.at("scan_path").get<std::string>()});
    } else if (kind == "done") {
      const json& report = change.at("report");
      const rows::ReportFigures figures = rows::figures_of(report);
      run(t, R"sql(
UPDATE scans SET status = 'done', finished = $2, maps_path = $3, report = $4::jsonb,
  angular_error_deg = $5::double precision, residual_mean = $6::double precision,
  height_range = $7::double precision, total_ms = $8::double precision,
  error_code = 0, error_message = ''
WHERE id = $1::bigint)sql",
          {id, change.at("finished").get<std::string>(), optional_text(change.at("maps_path")),
           report.is_null() ? std::nullopt : std::optional(report.dump()),
           text_of(figures.angular_error_deg), text_of(figures.residual_mean),
           text_of(figures.height_range), text_of(figures.total_ms)});
    } else if (kind == "end") {
      run(t,
          std::string("UPDATE scans SET status = $2, finished = $3, error_code = $4::integer, "
                      "error_message = $5") +
              (change.at("keep").get<bool>() ? "" : ", scan_path = NULL, maps_path = NULL") +
              " WHERE id = $1::bigint",
          {id, change.at("status").get<std::string>(), change.at("finished").get<std::string>(),
           std::to_string(change.at("code").get<int>()), change.at("message").get<std::string>()});
    } else {
      throw std::invalid_argument("unknown row write \"" + kind + "\"");
    }
  });
}

Status PostgresCatalogue::write(const json& change) {
  std::lock_guard lock(write_mutex_);
  return write_locked(change);
}

Status PostgresCatalogue::write_locked(const json& change) {
  (void)flush_locked();
  if (!journal_ || journal_->empty()) {
    auto applied = apply(change);
    if (applied || applied.error().code != ErrorCode::unavailable || !journal_) return applied;
  }
  // The database is away (or older writes still wait for it): this one
  // waits behind them, on disk.
  if (auto kept = journal_->append(change); !kept) {
    Error error = kept.error();
    error.message += "; the catalogue database is away too: scan " +
                     std::to_string(change.at("id").get<std::int64_t>()) +
                     "'s row cannot be recorded";
    return std::unexpected(std::move(error));
  }
  logger("catalogue")
      ->warn("scan {}: its row write ({}) waits in {} until the catalogue database is back",
             change.at("id").get<std::int64_t>(), change.at("write").get<std::string>(),
             journal_->file().string());
  return {};
}

std::size_t PostgresCatalogue::flush_pending() {
  std::lock_guard lock(write_mutex_);
  return flush_locked();
}

std::size_t PostgresCatalogue::flush_locked() {
  if (!journal_) return 0;
  auto log = logger("catalogue");
  while (!journal_->empty()) {
    const json change = journal_->pending().front();
    const auto id = change.at("id").get<std::int64_t>();
    auto applied = apply(change);
    if (!applied && applied.error().code == ErrorCode::unavailable) break;
    if (applied)
      log->info("scan {}: its row write ({}) is in the catalogue database now", id,
                change.at("write").get<std::string>());
    else
      // Refused outright, it would be refused for ever and hold up every
      // later write: it goes, and the next start's recovery sees the row.
      log->error("scan {}: the catalogue database refuses its row write ({}); dropped: {}", id,
                 change.at("write").get<std::string>(), applied.error().describe());
    if (auto popped = journal_->pop_front(); !popped) {
      log->error("{}", popped.error().describe());
      break;  // written again later: every write is idempotent
    }
  }
  return journal_->pending().size();
}

std::size_t PostgresCatalogue::pending_count() const {
  std::lock_guard lock(write_mutex_);
  return journal_ ? journal_->pending().size() : 0;
}

void PostgresCatalogue::inject_write_failure(std::optional<Error> error, int writes_first) {
  std::lock_guard lock(fault_mutex_);
  write_fault_ = std::move(error);
  writes_before_fault_ = writes_first;
}

Status PostgresCatalogue::refill_ids() {
  const std::size_t wanted = kIdStock - ids_.size();
  return link_.transact([&](pqxx::dbtransaction& t) {
    for (const auto& row : run(t, "SELECT nextval('scan_ids') FROM generate_series(1, $1::integer)",
                               {std::to_string(wanted)}))
      ids_.push_back(row[0].as<std::int64_t>());
  });
}

Result<std::int64_t> PostgresCatalogue::add(const ScanSubmission& submission) {
  std::lock_guard lock(write_mutex_);
  if (ids_.empty())
    if (auto filled = refill_ids(); !filled) {
      Error error = filled.error();
      error.message += "; no scan ids are left in this rig's reserve to queue a scan meanwhile";
      return std::unexpected(std::move(error));
    }
  const std::int64_t id = ids_.front();
  ids_.pop_front();
  json tags = json::array();
  for (const auto& tag : submission.tags)
    tags.push_back(tag);
  if (auto ok = write_locked({{"write", "add"},
                              {"id", id},
                              {"rig", rig_},
                              {"sample_id", submission.sample_id},
                              {"description", submission.description},
                              {"source", submission.source},
                              {"tags", tags},
                              {"created", utc_timestamp_now()}});
      !ok)
    return std::unexpected(ok.error());
  // Ahead of need, while the database answers; an outage keeps what is left.
  if (ids_.size() < kIdStockLow && (!journal_ || journal_->empty())) (void)refill_ids();
  return id;
}

Status PostgresCatalogue::mark_running(std::int64_t id, const fs::path& scan_directory) {
  const auto path = relative(scan_directory);
  if (!path)
    return std::unexpected(internal_error("scan directory " + scan_directory.string() +
                                          " is outside the storage root " + root_.string()));
  return write({{"write", "running"}, {"id", id}, {"started", utc_timestamp_now()}, {"scan_path", *path}});
}

Status PostgresCatalogue::mark_done(std::int64_t id, const fs::path& maps_directory,
                                    const json& report) {
  json maps_path = nullptr;
  if (!maps_directory.empty()) {
    const auto path = relative(maps_directory);
    if (!path)
      return std::unexpected(internal_error("maps directory " + maps_directory.string() +
                                            " is outside the storage root"));
    maps_path = *path;
  }
  return write({{"write", "done"},
                {"id", id},
                {"finished", utc_timestamp_now()},
                {"maps_path", maps_path},
                {"report", report}});
}

Status PostgresCatalogue::mark_failed(std::int64_t id, ScanStatus status, ScanErrorCode code,
                                      const std::string& message, bool keep_scan_directory) {
  return write({{"write", "end"},
                {"id", id},
                {"status", to_string(status)},
                {"code", static_cast<int>(code)},
                {"message", message},
                {"keep", keep_scan_directory},
                {"finished", utc_timestamp_now()}});
}

Result<std::optional<CatalogueEntry>> PostgresCatalogue::get(std::int64_t id) const {
  std::optional<CatalogueEntry> entry;
  auto read = link_.transact([&](pqxx::dbtransaction& t) {
    const auto found = run(t, std::string(kPostgresSelectEntry) + " WHERE s.id = $1::bigint",
                           {std::to_string(id)});
    if (!found.empty()) entry = read_entry(found[0], root_);
  });
  if (!read) return std::unexpected(read.error());
  return entry;
}

Result<std::vector<CatalogueEntry>> PostgresCatalogue::search(const CatalogueQuery& query) const {
  rows::Filter filter = rows::filter_of(query, rows::postgres_dialect());
  const auto limit = static_cast<int>(filter.texts.size()) + 1;
  std::vector<CatalogueEntry> entries;
  Values values(filter.texts.begin(), filter.texts.end());
  values.push_back(std::to_string(query.limit));
  values.push_back(std::to_string(query.offset));
  auto read = link_.transact([&](pqxx::dbtransaction& t) {
    // Newest first: ids are taken ahead of need, a few per rig, so time
    // orders them across rigs; the id within one second.
    for (const auto& row :
         run(t,
             std::string(kPostgresSelectEntry) + filter.where +
                 " ORDER BY s.created DESC, s.id DESC LIMIT $" + std::to_string(limit) +
                 "::bigint OFFSET $" + std::to_string(limit + 1) + "::bigint",
             values))
      entries.push_back(read_entry(row, root_));
  });
  if (!read) return std::unexpected(read.error());
  return entries;
}

Result<std::int64_t> PostgresCatalogue::count(const CatalogueQuery& query) const {
  const rows::Filter filter = rows::filter_of(query, rows::postgres_dialect());
  std::int64_t total = 0;
  auto read = link_.transact([&](pqxx::dbtransaction& t) {
    total = run(t, "SELECT count(*) FROM scans s" + filter.where,
                Values(filter.texts.begin(), filter.texts.end()))[0][0]
                .as<std::int64_t>();
  });
  if (!read) return std::unexpected(read.error());
  return total;
}

Result<bool> PostgresCatalogue::remove(std::int64_t id) {
  (void)flush_pending();
  auto entry = get(id);
  if (!entry) return std::unexpected(entry.error());
  if (!*entry) return false;
  // Files first: a row without files is a lie, files without a row are
  // what recover() and a technician can see and clean.
  if (auto ok = remove_scan_files(root_, {(*entry)->maps_directory, (*entry)->scan_directory}); !ok)
    return std::unexpected(ok.error());
  auto erased = link_.transact([&](pqxx::dbtransaction& t) {
    run(t, "DELETE FROM scans WHERE id = $1::bigint", {std::to_string(id)});
  });
  if (!erased) return std::unexpected(erased.error());
  return true;
}

Result<CatalogueRecovery> PostgresCatalogue::recover() {
  auto log = logger("catalogue");
  (void)flush_pending();
  std::vector<UnfinishedScan> unfinished;
  auto read = link_.transact([&](pqxx::dbtransaction& t) {
    for (const auto& row : run(t,
                               "SELECT id, coalesce(scan_path, '') FROM scans WHERE rig = $1 AND "
                               "status IN ('queued', 'running') ORDER BY id",
                               {rig_}))
      unfinished.push_back({row[0].as<std::int64_t>(), row[1].c_str()});
  });
  if (!read) return std::unexpected(read.error());
  CatalogueRecovery recovery;
  for (const auto& scan :
       clean_interrupted_scans(root_, rig_root_, unfinished, recovery.removed_leftovers)) {
    if (auto ok = mark_failed(scan.id, ScanStatus::failed, ScanErrorCode::internal, scan.message,
                              scan.kept);
        !ok)
      log->error("scan {}: {}", scan.id, ok.error().describe());
    recovery.interrupted.push_back(scan.id);
    log->warn("scan {} of rig {} was interrupted by the last shutdown; marked failed{}", scan.id,
              rig_, scan.kept ? ", its raw frames kept" : "");
  }
  return recovery;
}

Status PostgresCatalogue::announce(const RigRecord& rig) {
  return link_.transact([&](pqxx::dbtransaction& t) {
    run(t, R"sql(
INSERT INTO rigs (name, api_url, token, status, last_seen) VALUES ($1, $2, $3, $4::jsonb, now())
ON CONFLICT (name) DO UPDATE SET api_url = excluded.api_url, token = excluded.token,
  status = excluded.status, last_seen = excluded.last_seen)sql",
        {rig.name, rig.api_url, rig.token, rig.status.dump()});
  });
}

Result<std::vector<RigRecord>> PostgresCatalogue::rigs() const {
  std::vector<RigRecord> rigs;
  auto read = link_.transact([&](pqxx::dbtransaction& t) {
    for (const auto& row : t.exec(R"sql(
SELECT name, api_url, token, status::text,
       to_char(last_seen AT TIME ZONE 'UTC', 'YYYY-MM-DD"T"HH24:MI:SS"Z"'),
       extract(epoch FROM now() - last_seen)::double precision
FROM rigs ORDER BY name)sql")) {
      RigRecord rig{row[0].c_str(), row[1].c_str(), row[2].c_str(),
                    json::parse(row[3].c_str(), nullptr, false), row[4].c_str(),
                    row[5].as<double>()};
      if (!rig.status.is_object()) rig.status = json::object();
      rigs.push_back(std::move(rig));
    }
  });
  if (!read) return std::unexpected(read.error());
  return rigs;
}

}  // namespace psrig::catalogue
