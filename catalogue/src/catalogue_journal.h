#pragma once
// The shared catalogue's outbox on this machine's disk: the row writes the
// database could not take (it was away), oldest first, each kept until it
// is written. A small JSON file, replaced whole and flushed at every
// change, so a write it holds survives a crash of psrigd or of the
// machine; locked while a psrigd holds it, so two daemons cannot both
// claim to be one rig. Not thread-safe: its owner serialises.

#include <cstddef>
#include <deque>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"

namespace psrig::catalogue {

class CatalogueJournal {
 public:
  // Opens (creating the file and its directory) and locks it; an error
  // naming the file when another process holds it.
  [[nodiscard]] static Result<std::unique_ptr<CatalogueJournal>> open(
      const std::filesystem::path& file);
  ~CatalogueJournal();
  CatalogueJournal(const CatalogueJournal&) = delete;
  CatalogueJournal& operator=(const CatalogueJournal&) = delete;

  [[nodiscard]] const std::filesystem::path& file() const { return file_; }
  [[nodiscard]] const std::deque<nlohmann::json>& pending() const { return pending_; }
  [[nodiscard]] bool empty() const { return pending_.empty(); }

  // Adds a write at the end; on disk before it returns.
  [[nodiscard]] Status append(nlohmann::json write);
  // The oldest write has reached the database: forgets it.
  [[nodiscard]] Status pop_front();

 private:
  CatalogueJournal(std::filesystem::path file, int lock_fd, std::deque<nlohmann::json> pending);
  [[nodiscard]] Status save(const std::deque<nlohmann::json>& pending) const;

  std::filesystem::path file_;
  int lock_fd_;
  std::deque<nlohmann::json> pending_;
};

}  // namespace psrig::catalogue
