#pragma once
// psrigd's connection to the shared catalogue's PostgreSQL database
// (libpqxx): each call one transaction; a connection that is lost, or a
// server that is away, is an error of that call (ErrorCode::unavailable),
// never an exception out of here, and the connection is made again at a
// later call, no sooner than a back-off that doubles from 0.2 s to 5 s, so
// an outage costs each caller one quick error, not a wait. Thread-safe
// (one connection behind a mutex).

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <pqxx/pqxx>
#include <string>

#include "psrig/base/error.h"

namespace psrig::catalogue {

class PostgresLink {
 public:
  // `url` is libpq's URI (catalogue.url); `name` tells the server who is
  // connected (its application_name).
  PostgresLink(std::string url, const std::string& name);
  ~PostgresLink();
  PostgresLink(const PostgresLink&) = delete;
  PostgresLink& operator=(const PostgresLink&) = delete;

  // Runs `work` in one transaction, committed when it returns. Errors:
  // ErrorCode::unavailable when the database is away or the connection
  // broke (the work may have been committed: writes must be idempotent),
  // else an io error with the server's message.
  [[nodiscard]] Status transact(const std::function<void(pqxx::dbtransaction&)>& work);
  // As transact(), trying again with back-off for up to `patience` while
  // the database is away (start-up).
  [[nodiscard]] Status transact_patiently(const std::function<void(pqxx::dbtransaction&)>& work,
                                          std::chrono::seconds patience);
  // The URL without its password, for messages.
  [[nodiscard]] const std::string& where() const { return where_; }

 private:
  using Clock = std::chrono::steady_clock;
  // The connection drops and the back-off grows; the error to return.
  [[nodiscard]] Error away(const std::string& what);
  [[nodiscard]] Error away_error() const;

  std::string connection_string_;
  std::string where_;
  std::mutex mutex_;
  std::unique_ptr<pqxx::connection> connection_;
  Clock::time_point next_attempt_{};
  Clock::duration backoff_{};
  std::string last_problem_;
};

}  // namespace psrig::catalogue
