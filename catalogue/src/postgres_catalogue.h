#pragma once
// The shared catalogue: one PostgreSQL database that every rig of a lab
// writes its rows to and every psrigd reads (catalogue.h says what every
// catalogue promises). Each row names its rig; each rig writes under its
// own directory of the shared storage root and recovers only its own rows.
//
// Ids come from one sequence, taken a few at a time ahead of need, so a
// row's id is known before it is written. Every row write is idempotent (an
// insert of that id, an update to given values), so one that may or may
// not have reached the database can be written again. A write the
// database cannot take now (it is away) goes to the rig's journal on this
// machine's disk (catalogue_journal.h); later writes queue behind it, and
// the journal is written out in order once the database answers again
// (flush_pending(), which the scan worker calls every idle second, and
// before every write and read): every row once, none lost, none twice.
// A database still away at start-up is waited for a little, then the open
// fails naming it (systemd starts psrigd again).

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "catalogue_journal.h"
#include "postgres_link.h"
#include "psrig/catalogue/catalogue.h"

namespace psrig::catalogue {

class PostgresCatalogue final : public Catalogue {
 public:
  inline static constexpr int kSchemaVersion = 1;

  [[nodiscard]] static Result<std::unique_ptr<Catalogue>> open(const CatalogueOptions& options);
  ~PostgresCatalogue() override;

  [[nodiscard]] const char* backend() const override { return "postgresql"; }
  [[nodiscard]] const std::filesystem::path& storage_root() const override { return root_; }
  [[nodiscard]] const std::filesystem::path& rig_root() const override { return rig_root_; }
  [[nodiscard]] const std::string& rig_name() const override { return rig_; }

  [[nodiscard]] Result<std::int64_t> add(const ScanSubmission& submission) override;
  [[nodiscard]] Status mark_running(std::int64_t id,
                                    const std::filesystem::path& scan_directory) override;
  [[nodiscard]] Status mark_done(std::int64_t id, const std::filesystem::path& maps_directory,
                                 const nlohmann::json& report) override;
  [[nodiscard]] Status mark_failed(std::int64_t id, ScanStatus status, ScanErrorCode code,
                                   const std::string& message, bool keep_scan_directory) override;
  std::size_t flush_pending() override;
  [[nodiscard]] std::size_t pending_count() const override;
  void inject_write_failure(std::optional<Error> error, int writes_first = 0) override;
  [[nodiscard]] Result<std::optional<CatalogueEntry>> get(std::int64_t id) const override;
  [[nodiscard]] Result<std::vector<CatalogueEntry>> search(
      const CatalogueQuery& query) const override;
  [[nodiscard]] Result<std::int64_t> count(const CatalogueQuery& query) const override;
  [[nodiscard]] Result<bool> remove(std::int64_t id) override;
  [[nodiscard]] Result<CatalogueRecovery> recover() override;
  [[nodiscard]] Status announce(const RigRecord& rig) override;
  [[nodiscard]] Result<std::vector<RigRecord>> rigs() const override;

 private:
  PostgresCatalogue(const CatalogueOptions& options, std::filesystem::path root,
                    std::filesystem::path rig_root, std::unique_ptr<CatalogueJournal> journal);
  // Brings the schema up to date, waiting up to `patience` for the database.
  [[nodiscard]] Status migrate(std::chrono::seconds patience);
  // A row write (a JSON description of it, as the journal keeps it):
  // straight to the database when nothing waits before it, else, or when
  // the database is away, into the journal. An error only when it can be
  // neither written nor kept, or the database refused it outright.
  // write_locked() with write_mutex_ held.
  [[nodiscard]] Status write(const nlohmann::json& change);
  [[nodiscard]] Status write_locked(const nlohmann::json& change);
  // One row write, in one transaction, idempotent.
  [[nodiscard]] Status apply(const nlohmann::json& change);
  // flush_pending() with write_mutex_ held.
  std::size_t flush_locked();
  // Scan ids taken from the sequence ahead of need (write_mutex_ held).
  [[nodiscard]] Status refill_ids();
  // `path` relative to the storage root, if inside it.
  [[nodiscard]] std::optional<std::string> relative(const std::filesystem::path& path) const;

  std::filesystem::path root_;
  std::filesystem::path rig_root_;
  std::string rig_;
  // Mutable: reading is a transaction too.
  mutable PostgresLink link_;
  // Held while a write is made or kept and while the journal is written
  // out, so writes reach the database in the order they were made.
  mutable std::mutex write_mutex_;
  std::unique_ptr<CatalogueJournal> journal_;  // none: a catalogue-only psrigd, which writes no scans
  std::deque<std::int64_t> ids_;
  std::mutex fault_mutex_;
  std::optional<Error> write_fault_;
  int writes_before_fault_ = 0;
};

}  // namespace psrig::catalogue
