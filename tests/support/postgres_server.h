#pragma once
// A throwaway PostgreSQL server for the tests and benchmarks of the shared
// catalogue: Debian's initdb and pg_ctl into a temporary directory, the
// server listening on a Unix socket there only (no TCP port to collide
// on), run as an unprivileged user when the tests run as root (postgres
// refuses root: the `postgres` user Debian's package makes), stopped and
// removed with the object. Each test takes a database of its own.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "test_support.h"

namespace psrig::test {

// Where initdb and pg_ctl are ($PSRIG_POSTGRES_BIN, else the newest
// /usr/lib/postgresql/*/bin, else PATH), or nothing when they are missing.
[[nodiscard]] std::optional<std::filesystem::path> postgres_bin_dir();

class PostgresServer {
 public:
  struct Options {
    // Off for the tests (nothing to survive a power cut); on for the
    // benchmark, whose row-write latency is a real server's.
    bool fsync = false;
  };
  // Started, or nothing and `why_not` says why (the binaries missing, or
  // the server failing to start: its log).
  [[nodiscard]] static std::unique_ptr<PostgresServer> start(Options options, std::string& why_not);
  ~PostgresServer();
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // A new, empty database: its URL (libpq's URI over the socket).
  [[nodiscard]] std::string create_database();
  [[nodiscard]] std::string url(const std::string& database) const;

  // pg_ctl stop -m fast (every connection ends) and start again on the
  // same socket: an outage of the catalogue's database.
  [[nodiscard]] bool stop();
  [[nodiscard]] bool start_again();
  [[nodiscard]] std::string log() const;

 private:
  PostgresServer() = default;
  [[nodiscard]] bool pg_ctl(const std::string& action);

  std::unique_ptr<TempDir> temp_;
  std::filesystem::path bin_;
  std::filesystem::path data_;
  std::filesystem::path socket_;
  Options options_;
  int databases_ = 0;
};

// One server for the whole test program, started at first use (and
// stopped when the program ends); nothing when it cannot start, with why.
[[nodiscard]] PostgresServer* shared_postgres(std::string& why_not);

// Runs `sql` (no result wanted) on the database at `url`; the error's
// text, or empty.
[[nodiscard]] std::string execute_sql(const std::string& url, const std::string& sql);

}  // namespace psrig::test
