#include "catalogue_journal.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <sys/file.h>
#include <unistd.h>

namespace psrig::catalogue {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFormat = "psrig-catalogue-journal/1";

// Writes `text` to `file` whole or not at all: a temporary file beside it,
// flushed, renamed over it, the directory flushed.
Status replace_file(const fs::path& file, const std::string& text) {
  const fs::path temporary = file.string() + ".new";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0)
    return std::unexpected(io_error(temporary, std::string("cannot write: ") + std::strerror(errno)));
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  const bool flushed = written == text.size() && ::fsync(fd) == 0;
  const int write_errno = errno;
  ::close(fd);
  if (!flushed || ::rename(temporary.c_str(), file.c_str()) != 0) {
    ::unlink(temporary.c_str());
    return std::unexpected(
        io_error(file, std::string("cannot write the catalogue journal: ") +
                           std::strerror(flushed ? errno : write_errno))
            .with(write_errno == ENOSPC ? ErrorCode::disk_full : ErrorCode::unspecified));
  }
  if (const int dir = ::open(file.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
      dir >= 0) {
    (void)::fsync(dir);
    ::close(dir);
  }
  return {};
}

}  // namespace

CatalogueJournal::CatalogueJournal(fs::path file, int lock_fd, std::deque<nlohmann::json> pending)
    : file_(std::move(file)), lock_fd_(lock_fd), pending_(std::move(pending)) {}

CatalogueJournal::~CatalogueJournal() {
  ::close(lock_fd_);
}

Result<std::unique_ptr<CatalogueJournal>> CatalogueJournal::open(const fs::path& file) {
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  if (ec)
    return std::unexpected(io_error(file.parent_path(), "cannot create the directory of the "
                                                        "catalogue journal: " +
                                                            ec.message()));
  // The lock lives on a file of its own: the journal itself is replaced
  // by rename at every change.
  const fs::path lock_file = file.string() + ".lock";
  const int lock_fd = ::open(lock_file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640);
  if (lock_fd < 0)
    return std::unexpected(io_error(lock_file, std::string("cannot open: ") + std::strerror(errno)));
  if (::flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(lock_fd);
    return std::unexpected(bad_input(file, "catalogue.journal",
                                     "another psrigd holds this rig's catalogue journal; each rig "
                                     "needs its own daemon.rig_name (and journal)"));
  }
  std::deque<nlohmann::json> pending;
  if (fs::exists(file, ec)) {
    std::ifstream in(file);
    std::stringstream text;
    text << in.rdbuf();
    const auto document = nlohmann::json::parse(text.str(), nullptr, false);
    if (!document.is_object() || document.value("format", "") != kFormat ||
        !document.contains("pending") || !document["pending"].is_array()) {
      ::close(lock_fd);
      return std::unexpected(bad_input(
          file, "catalogue.journal",
          std::string("is not a psrig catalogue journal (") + kFormat +
              "); it holds row writes not yet in the database: move it aside to look at it, "
              "then start psrigd again"));
    }
    for (const auto& write : document["pending"])
      pending.push_back(write);
  }
  return std::unique_ptr<CatalogueJournal>(
      new CatalogueJournal(file, lock_fd, std::move(pending)));
}

Status CatalogueJournal::save(const std::deque<nlohmann::json>& pending) const {
  nlohmann::json writes = nlohmann::json::array();
  for (const auto& write : pending)
    writes.push_back(write);
  return replace_file(file_, nlohmann::json{{"format", kFormat}, {"pending", writes}}.dump() + "\n");
}

Status CatalogueJournal::append(nlohmann::json write) {
  auto next = pending_;
  next.push_back(std::move(write));
  if (auto ok = save(next); !ok) return ok;
  pending_ = std::move(next);
  return {};
}

Status CatalogueJournal::pop_front() {
  if (pending_.empty()) return {};
  auto next = pending_;
  next.pop_front();
  if (auto ok = save(next); !ok) return ok;
  pending_ = std::move(next);
  return {};
}

}  // namespace psrig::catalogue
