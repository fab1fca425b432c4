#pragma once
// A directory that appears whole or not at all: its files are written into
// a hidden sibling, which commit() renames into place. Until then, and if
// anything fails, the target is untouched and the sibling is removed.

#include <filesystem>
#include <optional>
#include <string>
#include <sys/types.h>

#include "psrig/base/error.h"

namespace psrig::formats {

class AtomicDirectory {
 public:
  // What a staging directory's name says: the target it becomes and the
  // process that was writing it (gone, it was abandoned).
  struct StagingName {
    std::string target;  // the target's file name
    pid_t writer = 0;
  };

  enum class Existing {
    refuse,   // the target must not exist (or be an empty directory)
    replace,  // an existing target is swapped out and removed
  };

  // Creates the hidden sibling of `target` (whose parent must exist).
  [[nodiscard]] static Result<AtomicDirectory> create(const std::filesystem::path& target);

  AtomicDirectory(AtomicDirectory&& other) noexcept;
  AtomicDirectory& operator=(AtomicDirectory&&) = delete;
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;
  ~AtomicDirectory();

  // Whether `path` names a staging directory (by its file name alone),
  // and whose, for what: others clean up what a killed writer left.
  [[nodiscard]] static std::optional<StagingName> parse_staging(const std::filesystem::path& path);

  // Where to write the files.
  [[nodiscard]] const std::filesystem::path& path() const { return staging_; }
  [[nodiscard]] const std::filesystem::path& target() const { return target_; }

  // Flushes the files to disk when `durable` (raw captures: they cannot be
  // made again), then renames the staging directory to the target.
  [[nodiscard]] Status commit(Existing existing, bool durable);

 private:
  AtomicDirectory(std::filesystem::path target, std::filesystem::path staging);

  std::filesystem::path target_;
  std::filesystem::path staging_;
  bool committed_ = false;
};

}  // namespace psrig::formats
