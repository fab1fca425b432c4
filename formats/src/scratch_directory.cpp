#include "psrig/formats/scratch_directory.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace psrig::formats {
namespace fs = std::filesystem;

Result<ScratchDirectory> ScratchDirectory::create(const std::string& purpose) {
  std::error_code ec;
  const fs::path root = fs::temp_directory_path(ec);
  if (ec)
    return std::unexpected(io_error("$TMPDIR", "no temporary directory: " + ec.message() +
                                                   "; set TMPDIR to a writable directory"));
  const std::string pattern = (root / ("psrig-" + purpose + "-XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  if (::mkdtemp(name.data()) == nullptr)
    return std::unexpected(io_error(root, std::string("cannot create a scratch directory: ") +
                                              std::strerror(errno) +
                                              "; set TMPDIR to a writable directory"));
  return ScratchDirectory(fs::path(name.data()));
}

ScratchDirectory::ScratchDirectory(ScratchDirectory&& other) noexcept
    : path_(std::move(other.path_)) {
  other.path_.clear();
}

ScratchDirectory::~ScratchDirectory() {
  if (path_.empty()) return;
  std::error_code ec;
  fs::remove_all(path_, ec);  // best effort: a destructor cannot report
}

}  // namespace psrig::formats
