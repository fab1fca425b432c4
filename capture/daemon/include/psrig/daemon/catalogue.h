#pragma once
// The daemon's record of every scan: one SQLite database (WAL) in the
// storage root, `catalogue.sqlite`, one row per scan. A row's id is the scan
// id everywhere (HTTP API, Modbus). The files come first: a row says `done`
// only after its scan and maps directories are whole on disk, so a crash
// leaves at worst files without a `done` row, which recover() removes (all
// but a whole raw scan, which it keeps with its row `failed`).
// A scan's end that cannot be written (the disk is full) is not lost: it is
// kept in memory, shown by get() and search(), and written before the next
// write and whenever flush_pending() is called; if the daemon ends first,
// recover() marks the row failed at the next start. So no row is left
// `queued` or `running` by a scan that has ended.
// Thread-safe (one connection behind a mutex).

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/daemon/scan_control.h"

struct sqlite3;

namespace psrig::daemon {

enum class ScanStatus { queued, running, done, failed, aborted };

[[nodiscard]] const char* to_string(ScanStatus status);
[[nodiscard]] std::optional<ScanStatus> parse_scan_status(const std::string& text);

struct CatalogueEntry {
  std::int64_t id = 0;
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

class Catalogue {
 public:
  inline static constexpr const char* kFileName = "catalogue.sqlite";
  // Space the catalogue sets aside beside its database (allocated, not
  // sparse) and gives back when SQLite finds the disk full, so that the
  // row of a scan that failed for want of space can still say so.
  inline static constexpr const char* kReserveFileName = "catalogue.sqlite-reserve";
  inline static constexpr std::uintmax_t kReserveBytes = 256 << 10;
  inline static constexpr int kSchemaVersion = 2;

  // Opens (creating the storage root and the database if need be) and
  // brings the schema up to date. A database newer than this program is
  // refused rather than misread.
  [[nodiscard]] static Result<std::unique_ptr<Catalogue>> open(
      const std::filesystem::path& storage_root);
  ~Catalogue();
  Catalogue(const Catalogue&) = delete;
  Catalogue& operator=(const Catalogue&) = delete;

  [[nodiscard]] const std::filesystem::path& storage_root() const { return root_; }

  // A new row, `queued`; its id.
  [[nodiscard]] Result<std::int64_t> add(const ScanSubmission& submission);
  // `running`, with the scan directory it is about to write (inside the
  // storage root), so that recover() knows what to clean after a crash.
  [[nodiscard]] Status mark_running(std::int64_t id, const std::filesystem::path& scan_directory);
  // `done`, with its maps directory (empty when not processed) and report.
  [[nodiscard]] Status mark_done(std::int64_t id, const std::filesystem::path& maps_directory,
                                 const nlohmann::json& report);
  // `failed` or `aborted`, with why. `keep_scan_directory` false forgets the
  // scan directory (its files were removed). When the row cannot be
  // written, the error, and the outcome is kept as pending (see above):
  // the caller need not retry.
  [[nodiscard]] Status mark_failed(std::int64_t id, ScanStatus status, ScanErrorCode code,
                                   const std::string& message, bool keep_scan_directory);

  // Writes the pending outcomes (each write does this first); what is
  // still pending.
  std::size_t flush_pending();
  [[nodiscard]] std::size_t pending_count() const;

  // A test's fault (never set in production): after `writes_first` more
  // writes succeed, every write fails with `error` before it reaches
  // SQLite, as on a full disk, until called again with nothing.
  void inject_write_failure(std::optional<Error> error, int writes_first = 0);

  [[nodiscard]] Result<std::optional<CatalogueEntry>> get(std::int64_t id) const;
  [[nodiscard]] Result<std::vector<CatalogueEntry>> search(const CatalogueQuery& query) const;
  // How many rows match the query, all pages together (limit and offset
  // ignored; rows whose end is still pending counted as written).
  [[nodiscard]] Result<std::int64_t> count(const CatalogueQuery& query) const;

  // Removes the scan's files (only inside the storage root), then its row.
  // False when there is no such row.
  [[nodiscard]] Result<bool> remove(std::int64_t id);

  // Start-up: rows left `queued` or `running` by a run that ended without
  // finishing them become `failed` ("interrupted"); a row that cannot be
  // written now stays pending rather than stopping the start. A scan directory that
  // was written whole (it holds scan.json) is kept, minus its unrecorded
  // maps, and its row keeps naming it (reprocess with psrig process);
  // anything less is removed, as are the scan writer's staging directories
  // of dead processes in the storage root. Never a `done` scan's files, never anything
  // outside the storage root, never a directory no row names (a scan
  // `psrig scan` put there by hand stays).
  [[nodiscard]] Result<CatalogueRecovery> recover();

 private:
  Catalogue(std::filesystem::path root, sqlite3* db);
  [[nodiscard]] Status execute(const std::string& sql) const;
  [[nodiscard]] Status migrate();
  // Runs a write after the pending outcomes (older news first); when
  // SQLite finds the disk full, gives the reserve back and tries once
  // more. Sets the reserve aside again when there is room.
  template <class Write>
  auto with_room(Write&& write) -> decltype(write());
  // with_room() without writing the pending outcomes first.
  template <class Write>
  auto write_with_room(Write&& write) -> decltype(write());
  // A scan's end as it will be written.
  struct Outcome {
    ScanStatus status = ScanStatus::failed;
    ScanErrorCode code = ScanErrorCode::none;
    std::string message;
    bool keep_scan_directory = false;
    std::string finished;  // when it ended, not when it was written
    bool operator==(const Outcome&) const = default;
  };
  [[nodiscard]] Status write_outcome(std::int64_t id, const Outcome& outcome);
  // flush_pending() with flush_mutex_ held.
  std::size_t flush_pending_locked();
  // `entry` as its pending outcome says, if it has one.
  void overlay_pending(CatalogueEntry& entry) const;
  void hold_reserve();
  [[nodiscard]] Result<std::int64_t> add_row(const ScanSubmission& submission);
  [[nodiscard]] Status mark_done_row(std::int64_t id, const std::optional<std::string>& maps_path,
                                     const nlohmann::json& report);
  [[nodiscard]] bool release_reserve();
  // `path` made absolute under the storage root, if it lies inside it.
  [[nodiscard]] std::optional<std::filesystem::path> inside_root(
      const std::filesystem::path& path) const;

  std::filesystem::path root_;
  sqlite3* db_;
  mutable std::mutex mutex_;
  std::mutex reserve_mutex_;
  bool reserve_held_ = false;
  // Scans' ends the disk refused, by id (kept in memory: nowhere else to
  // keep them while the disk is full; a handful at most, as a full disk
  // refuses new scans). flush_mutex_ is held while they are written and
  // while mark_failed() writes one, so each goes once and none overwrites
  // a newer one; it is taken before the other locks, never after.
  // pending_mutex_ guards the map alone, briefly.
  std::mutex flush_mutex_;
  mutable std::mutex pending_mutex_;
  std::map<std::int64_t, Outcome> pending_;
  mutable std::mutex fault_mutex_;
  std::optional<Error> write_fault_;
  int writes_before_fault_ = 0;
};

// The UTC time now as the catalogue writes it: "2026-05-04T09:12:33Z".
[[nodiscard]] std::string utc_timestamp_now();
// A date ("2026-05-04") or date-time ("2026-05-04T09:12:33Z", "…+00:00" and
// fractions accepted) as the catalogue compares them; nothing if malformed
// or not a real one: a day of the calendar (2026-02-30 is not; 2028-02-29
// is), hours 00-23, minutes and seconds 00-59.
// `end_of_day` makes a bare date mean its last second.
[[nodiscard]] std::optional<std::string> normalise_timestamp(const std::string& text,
                                                             bool end_of_day);

}  // namespace psrig::daemon
