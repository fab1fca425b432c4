#pragma once
// The embedded catalogue: one SQLite database (WAL) in the storage root,
// `catalogue.sqlite`, this rig's alone (catalogue.h says what every
// catalogue promises). A scan's end that cannot be written (the disk is
// full) is kept in memory, shown by get() and search(), and written before
// the next write; if the daemon ends first, recover() marks the row failed
// at the next start. One connection behind a mutex.

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "psrig/catalogue/catalogue.h"

struct sqlite3;

namespace psrig::catalogue {

class SqliteCatalogue final : public Catalogue {
 public:
  inline static constexpr const char* kFileName = "catalogue.sqlite";
  // Space the catalogue sets aside beside its database (allocated, not
  // sparse) and gives back when SQLite finds the disk full, so that the
  // row of a scan that failed for want of space can still say so.
  inline static constexpr const char* kReserveFileName = "catalogue.sqlite-reserve";
  inline static constexpr std::uintmax_t kReserveBytes = 256 << 10;
  inline static constexpr int kSchemaVersion = 3;

  // Opens (creating the storage root and the database if need be) and
  // brings the schema up to date; rows written before rows had a rig are
  // this rig's.
  [[nodiscard]] static Result<std::unique_ptr<Catalogue>> open(
      const std::filesystem::path& storage_root, const std::string& rig_name);
  ~SqliteCatalogue() override;

  [[nodiscard]] const char* backend() const override { return "sqlite"; }
  [[nodiscard]] const std::filesystem::path& storage_root() const override { return root_; }
  [[nodiscard]] const std::filesystem::path& rig_root() const override { return root_; }
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
  // The embedded catalogue has one writer: every unfinished row is its.
  [[nodiscard]] Result<CatalogueRecovery> recover() override;
  // The rigs list of an embedded catalogue is its own rig alone, as it
  // last announced itself: kept in memory (no one else reads the file),
  // so the presence's beat costs the disk nothing.
  [[nodiscard]] Status announce(const RigRecord& rig) override;
  [[nodiscard]] Result<std::vector<RigRecord>> rigs() const override;

 private:
  SqliteCatalogue(std::filesystem::path root, std::string rig, sqlite3* db);
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

  std::filesystem::path root_;
  std::string rig_;
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
  mutable std::mutex rig_mutex_;
  std::optional<RigRecord> announced_;
  std::chrono::steady_clock::time_point announced_at_;
};

}  // namespace psrig::catalogue
