#pragma once
// A private directory under the system's temporary directory ($TMPDIR),
// removed with everything in it when the object goes: for files a step
// needs only while it runs (an export's tile cut for it alone), so that
// nothing is written beside the data it reads.

#include <filesystem>
#include <string>

#include "psrig/base/error.h"

namespace psrig::formats {

class ScratchDirectory {
 public:
  // `purpose` names it (psrig-PURPOSE-XXXXXX), for whoever finds one left
  // by a killed process.
  [[nodiscard]] static Result<ScratchDirectory> create(const std::string& purpose);

  ScratchDirectory(ScratchDirectory&& other) noexcept;
  ScratchDirectory& operator=(ScratchDirectory&&) = delete;
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  ~ScratchDirectory();

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  explicit ScratchDirectory(std::filesystem::path path) : path_(std::move(path)) {}
  std::filesystem::path path_;  // empty once moved from
};

}  // namespace psrig::formats
