#include "psrig/formats/atomic_directory.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <random>
#include <signal.h>
#include <stdio.h>
#include <string>
#include <string_view>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>

namespace psrig::formats {
namespace {

namespace fs = std::filesystem;

std::string errno_text(int error) {
  return std::strerror(error);
}

bool sync_path(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
}

// Staging directories are ".NAME.partial-PID-RANDOM" beside the target NAME.
constexpr std::string_view kStagingMark = ".partial-";

std::string staging_name(const std::string& name, unsigned random) {
  return "." + name + std::string(kStagingMark) + std::to_string(::getpid()) + "-" +
         std::to_string(random);
}

bool all_digits(std::string_view text) {
  return !text.empty() &&
         std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// Staging directories of runs that were killed (their process is gone).
void remove_abandoned_staging(const fs::path& parent, const std::string& name) {
  std::error_code ec;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const auto staging = AtomicDirectory::parse_staging(it->path());
    if (!staging || staging->target != name) continue;
    if (::kill(staging->writer, 0) != 0 && errno == ESRCH) {
      std::error_code ignored;
      fs::remove_all(it->path(), ignored);
    }
  }
}

}  // namespace

Result<AtomicDirectory> AtomicDirectory::create(const fs::path& target) {
  std::error_code ec;
  fs::path absolute = fs::absolute(target, ec).lexically_normal();
  if (ec) return std::unexpected(io_error(target, "cannot resolve the path: " + ec.message()));
  if (absolute.filename().empty()) absolute = absolute.parent_path();  // "maps/" names "maps"
  const fs::path parent = absolute.parent_path();
  const std::string name = absolute.filename().string();
  if (name.empty() || name == "." || name == "..")
    return std::unexpected(bad_input(target, "", "not a usable directory name"));
  if (!fs::is_directory(parent, ec))
    return std::unexpected(
        bad_input(target, "", "parent directory " + parent.string() + " does not exist"));
  remove_abandoned_staging(parent, name);

  std::random_device random;
  for (int attempt = 0; attempt < 100; ++attempt) {
    fs::path staging = parent / staging_name(name, random());
    if (::mkdir(staging.c_str(), 0755) == 0) return AtomicDirectory(absolute, staging);
    if (errno != EEXIST)
      return std::unexpected(
          errno == EACCES || errno == EROFS || errno == EPERM
              ? bad_input(parent, "", "cannot write here: " + errno_text(errno))
              : io_error(parent, "cannot create a directory: " + errno_text(errno)));
  }
  return std::unexpected(io_error(parent, "cannot create a unique staging directory"));
}

std::optional<AtomicDirectory::StagingName> AtomicDirectory::parse_staging(const fs::path& path) {
  const std::string name = path.filename().string();
  const auto mark = name.rfind(kStagingMark);
  if (!name.starts_with('.') || mark == std::string::npos || mark < 2) return std::nullopt;
  const std::string_view numbers = std::string_view(name).substr(mark + kStagingMark.size());
  const auto dash = numbers.find('-');
  if (dash == std::string_view::npos) return std::nullopt;
  const std::string_view pid = numbers.substr(0, dash);
  if (!all_digits(pid) || pid.size() > 9 || !all_digits(numbers.substr(dash + 1)))
    return std::nullopt;
  const long writer = std::strtol(std::string(pid).c_str(), nullptr, 10);
  if (writer <= 0) return std::nullopt;
  return StagingName{name.substr(1, mark - 1), static_cast<pid_t>(writer)};
}

AtomicDirectory::AtomicDirectory(fs::path target, fs::path staging)
    : target_(std::move(target)), staging_(std::move(staging)) {}

AtomicDirectory::AtomicDirectory(AtomicDirectory&& other) noexcept
    : target_(std::move(other.target_)),
      staging_(std::move(other.staging_)),
      committed_(other.committed_) {
  other.committed_ = true;  // the moved-from object owns nothing
}

AtomicDirectory::~AtomicDirectory() {
  if (committed_ || staging_.empty()) return;
  std::error_code ignored;
  fs::remove_all(staging_, ignored);
}

Status AtomicDirectory::commit(Existing existing, bool durable) {
  if (durable) {
    for (const auto& entry : fs::directory_iterator(staging_))
      if (!sync_path(entry.path()))
        return std::unexpected(
            io_error(entry.path(), "cannot flush to disk: " + errno_text(errno)));
    if (!sync_path(staging_))
      return std::unexpected(io_error(staging_, "cannot flush to disk: " + errno_text(errno)));
  }

  std::error_code ec;
  const bool exists = fs::exists(fs::symlink_status(target_, ec));
  if (exists && existing == Existing::replace) {
    // Swap old and new in one step so a reader sees one or the other.
    if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) != 0)
      return std::unexpected(io_error(target_, "cannot replace: " + errno_text(errno)));
    committed_ = true;
    fs::remove_all(staging_, ec);  // now holds the old contents
    if (ec)
      return std::unexpected(
          io_error(staging_, "replaced, but cannot remove the old contents: " + ec.message()));
  } else {
    if (::rename(staging_.c_str(), target_.c_str()) != 0) {
      const int error = errno;
      if (error == ENOTEMPTY || error == EEXIST || error == ENOTDIR)
        return std::unexpected(
            bad_input(target_, "", "already exists; choose another name or remove it first"));
      return std::unexpected(io_error(target_, "cannot rename into place: " + errno_text(error)));
    }
    committed_ = true;
  }
  if (durable && !sync_path(target_.parent_path()))
    return std::unexpected(
        io_error(target_.parent_path(), "cannot flush to disk: " + errno_text(errno)));
  return {};
}

}  // namespace psrig::formats
