#pragma once
// The daemon's record of every scan, one row per scan, behind one
// interface with two backends (open_catalogue() picks by catalogue.url):
// the embedded SQLite file in the storage root (sqlite_catalogue.h, the
// default: one rig, no set-up) and a PostgreSQL database every rig of a
// lab shares (postgres_catalogue.h). A row's id is the scan id everywhere
// (HTTP API, Modbus), never reused. The files come first: a row says
// `done` only after its scan and maps directories are whole on disk, so a
// crash leaves at worst files without a `done` row, which recover()
// removes (all but a whole raw scan, which it keeps with its row `failed`).
// Every row names the rig that wrote it; recover() touches only this
// rig's. A row write the backend cannot make now (SQLite: a full disk;
// PostgreSQL: the database away) is not lost: it is kept (in memory, or in
// a journal on this machine's disk), shown by get() and search() where the
// backend can, and written before the next write and whenever
// flush_pending() is called, once. So no row is left `queued` or
// `running` by a scan that has ended. Thread-safe.

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/catalogue/scan_submission.h"
#include "psrig/config/rig_config.h"

namespace psrig::catalogue {

enum class ScanStatus { queued, running, done, failed, aborted };

[[nodiscard]] const char* to_string(ScanStatus status);
[[nodiscard]] std::optional<ScanStatus> parse_scan_status(const std::string& text);

struct CatalogueEntry {
  std::int64_t id = 0;
  std::string rig;  // the rig that scanned it (daemon.rig_name)
  std::string sample_id;
  std::string description;
  std::vector<std::string> tags;
  std::string source;  // "http", "modbus", ...
  ScanStatus status = ScanStatus::queued;
  // UTC, ISO-8601 ("2026-05-04T09:12:33Z"); empty until it happens.
  std::string created;
  std::string started;
  std::string finished;
  ScanErrorCode error_code = ScanErrorCode::none;
  std::string error_message;
  // Absolute; empty until known. The maps directory is set once `done`.
  std::filesystem::path scan_directory;
  std::filesystem::path maps_directory;
  nlohmann::json report;  // the maps' report.json; null until `done`
};

// A search: every field given must match; newest first.
struct CatalogueQuery {
  std::optional<std::string> text;       // in the sample id, description or a tag, any case
  std::optional<std::string> sample_id;  // exact
  std::optional<std::string> tag;        // exact, one of the scan's tags
  std::optional<std::string> rig;        // exact, the rig that scanned it
  std::optional<std::string> from;       // created at or after (ISO-8601 date or date-time, UTC)
  std::optional<std::string> to;         // created at or before; a date alone means its whole day
  std::optional<ScanStatus> status;
  // Measured fabric densities per cm within [min, max] (report.json's
  // fabric): column is one of kFabricColumns.
  struct FabricRange {
    std::string column;
    std::optional<double> min;
    std::optional<double> max;
  };
  inline static constexpr const char* kFabricColumns[] = {"wales_per_cm", "courses_per_cm",
                                                          "ends_per_cm", "picks_per_cm"};
  std::vector<FabricRange> fabric;
  int limit = 50;
  int offset = 0;
};

// What start-up found of an interrupted run.
struct CatalogueRecovery {
  std::vector<std::int64_t> interrupted;                 // rows now `failed`
  std::vector<std::filesystem::path> removed_leftovers;  // directories deleted
};

// A rig as the catalogue's rigs list knows it: what its psrigd last said
// of itself (RigPresence writes it every few seconds).
struct RigRecord {
  std::string name;
  std::string api_url;  // where its psrigd's API answers (daemon.public_url)
  std::string token;    // its API's bearer token, for forwarding; never shown by the API
  nlohmann::json status = nlohmann::json::object();  // state, step, queue, counts, calibration
  std::string last_seen;          // UTC ISO-8601, the database's clock
  double seen_seconds_ago = 0;    // by the database's clock
};

// How a catalogue is opened: config::RigConfig's storage, [catalogue] and
// daemon.rig_name (catalogue_options()).
struct CatalogueOptions {
  // What every row's paths are relative to: storage.shared_root.
  std::filesystem::path storage_root;
  // This rig's own directory (storage.root): the scans and the staging
  // directories recover() may clean. Empty: storage_root.
  std::filesystem::path rig_root;
  std::string url;        // catalogue.url: empty or "sqlite", or "postgresql://…"
  std::string rig_name;   // written in every row this catalogue adds
  std::filesystem::path journal;  // PostgreSQL: catalogue.journal
  // PostgreSQL: how long open() waits for a database that does not answer.
  std::chrono::seconds start_patience{20};
};

[[nodiscard]] CatalogueOptions catalogue_options(const config::RigConfig& config);

class Catalogue {
 public:
  virtual ~Catalogue() = default;
  Catalogue(const Catalogue&) = delete;
  Catalogue& operator=(const Catalogue&) = delete;

  // The embedded catalogue in `storage_root` (SQLite), rows named for this
  // host: what psrigd opens without a [catalogue] url.
  [[nodiscard]] static Result<std::unique_ptr<Catalogue>> open(
      const std::filesystem::path& storage_root);

  // "sqlite" or "postgresql".
  [[nodiscard]] virtual const char* backend() const = 0;
  // The shared storage root every row's paths are relative to, resolved.
  [[nodiscard]] virtual const std::filesystem::path& storage_root() const = 0;
  // This rig's directory in it (its scans), resolved.
  [[nodiscard]] virtual const std::filesystem::path& rig_root() const = 0;
  [[nodiscard]] virtual const std::string& rig_name() const = 0;

  // A new row, `queued`, for this rig; its id.
  [[nodiscard]] virtual Result<std::int64_t> add(const ScanSubmission& submission) = 0;
  // `running`, with the scan directory it is about to write (inside the
  // storage root), so that recover() knows what to clean after a crash.
  [[nodiscard]] virtual Status mark_running(std::int64_t id,
                                            const std::filesystem::path& scan_directory) = 0;
  // `done`, with its maps directory (empty when not processed) and report.
  [[nodiscard]] virtual Status mark_done(std::int64_t id,
                                         const std::filesystem::path& maps_directory,
                                         const nlohmann::json& report) = 0;
  // `failed` or `aborted`, with why. `keep_scan_directory` false forgets the
  // scan directory (its files were removed). When the row cannot be
  // written now, its end is kept (see above): the caller need not retry.
  [[nodiscard]] virtual Status mark_failed(std::int64_t id, ScanStatus status, ScanErrorCode code,
                                           const std::string& message,
                                           bool keep_scan_directory) = 0;

  // Writes the kept row writes (each write does this first); how many are
  // still waiting.
  virtual std::size_t flush_pending() = 0;
  [[nodiscard]] virtual std::size_t pending_count() const = 0;

  // A test's fault (never set in production): after `writes_first` more
  // writes succeed, every write fails with `error` before it reaches the
  // database (SQLite: as on a full disk; PostgreSQL: as when the
  // connection is lost), until called again with nothing.
  virtual void inject_write_failure(std::optional<Error> error, int writes_first = 0) = 0;

  [[nodiscard]] virtual Result<std::optional<CatalogueEntry>> get(std::int64_t id) const = 0;
  [[nodiscard]] virtual Result<std::vector<CatalogueEntry>> search(
      const CatalogueQuery& query) const = 0;
  // How many rows match the query, all pages together (limit and offset
  // ignored).
  [[nodiscard]] virtual Result<std::int64_t> count(const CatalogueQuery& query) const = 0;

  // Removes the scan's files (only inside the storage root), then its row.
  // False when there is no such row.
  [[nodiscard]] virtual Result<bool> remove(std::int64_t id) = 0;

  // Start-up: this rig's rows left `queued` or `running` by a run that
  // ended without finishing them become `failed` ("interrupted"); a row
  // that cannot be written now stays pending rather than stopping the
  // start. A scan directory that was written whole (it holds scan.json) is
  // kept, minus its unrecorded maps, and its row keeps naming it
  // (reprocess with psrig process); anything less is removed, as are the
  // scan writer's staging directories of dead processes in this rig's
  // directory. Never a `done` scan's files, never another rig's rows or
  // files, never anything outside the storage root, never a directory no
  // row names (a scan `psrig scan` put there by hand stays).
  [[nodiscard]] virtual Result<CatalogueRecovery> recover() = 0;

  // This rig's entry in the rigs list, written now (its last_seen the
  // database's time).
  [[nodiscard]] virtual Status announce(const RigRecord& rig) = 0;
  // Every rig that has announced itself, by name.
  [[nodiscard]] virtual Result<std::vector<RigRecord>> rigs() const = 0;

 protected:
  Catalogue() = default;
};

// The catalogue `options` name: SQLite in the storage root, or the shared
// PostgreSQL database (waiting for it a little at start-up; an error
// naming the URL's host and the fix when it does not answer). Brings its
// schema up to date; a schema newer than this program is refused rather
// than misread.
[[nodiscard]] Result<std::unique_ptr<Catalogue>> open_catalogue(const CatalogueOptions& options);

// The UTC time now as the catalogue writes it: "2026-05-04T09:12:33Z".
[[nodiscard]] std::string utc_timestamp_now();
// A date ("2026-05-04") or date-time ("2026-05-04T09:12:33Z", "…+00:00" and
// fractions accepted) as the catalogue compares them; nothing if malformed
// or not a real one: a day of the calendar (2026-02-30 is not; 2028-02-29
// is), hours 00-23, minutes and seconds 00-59.
// `end_of_day` makes a bare date mean its last second.
[[nodiscard]] std::optional<std::string> normalise_timestamp(const std::string& text,
                                                             bool end_of_day);

}  // namespace psrig::catalogue
