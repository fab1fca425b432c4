#include "postgres_link.h"

#include <pqxx/pqxx>
#include <regex>
#include <thread>

#include "psrig/base/log.h"

namespace psrig::catalogue {
namespace {

constexpr auto kFirstBackoff = std::chrono::milliseconds(200);
constexpr auto kLongestBackoff = std::chrono::seconds(5);

// libpq's own settings the catalogue wants unless the URL says otherwise:
// a bounded connect, a peer gone silent noticed within 6 s (a row write
// holds the scan worker, and psrigd's status waits on a scan's end), no
// statement waiting for ever on a lock.
std::string with_defaults(std::string url, const std::string& name) {
  const auto add = [&](const std::string& key, const std::string& value) {
    if (url.find(key + "=") != std::string::npos) return;
    url += (url.find('?') == std::string::npos ? "?" : "&") + key + "=" + value;
  };
  add("connect_timeout", "3");
  add("application_name", name);
  add("keepalives_idle", "3");
  add("keepalives_interval", "1");
  add("keepalives_count", "3");
  add("tcp_user_timeout", "6000");
  add("options", "-c%20statement_timeout%3D15000");
  return url;
}

// postgresql://user:secret@host/db -> postgresql://user@host/db
std::string without_password(const std::string& url) {
  static const std::regex password(R"(^([a-z]+://[^:/@]*):[^@/]*@)");
  return std::regex_replace(url, password, "$1@");
}

// Whether the server's SQLSTATE says "away, try later" rather than "wrong".
bool transient_state(const std::string& state) {
  return state.starts_with("08") ||                                       // connection exception
         state == "57P01" || state == "57P02" || state == "57P03" ||      // shutting down, starting
         state == "53300" || state == "40001" || state == "40P01";        // too many, serialisation
}

}  // namespace

PostgresLink::PostgresLink(std::string url, const std::string& name)
    : connection_string_(with_defaults(url, name)), where_(without_password(url)) {}

PostgresLink::~PostgresLink() = default;

Error PostgresLink::away_error() const {
  return io_error(where_, "the catalogue database is away (" + last_problem_ +
                              "); psrigd tries again by itself: is PostgreSQL running there?")
      .with(ErrorCode::unavailable);
}

Error PostgresLink::away(const std::string& what) {
  connection_.reset();
  backoff_ = backoff_ == Clock::duration{} ? Clock::duration(kFirstBackoff)
                                           : std::min<Clock::duration>(2 * backoff_, kLongestBackoff);
  next_attempt_ = Clock::now() + backoff_;
  if (what != last_problem_)
    logger("catalogue")->warn("the catalogue database at {} is away: {}", where_, what);
  last_problem_ = what;
  return away_error();
}

Status PostgresLink::transact(const std::function<void(pqxx::dbtransaction&)>& work) {
  std::lock_guard lock(mutex_);
  if (!connection_ && Clock::now() < next_attempt_) return std::unexpected(away_error());
  try {
    if (!connection_) {
      connection_ = std::make_unique<pqxx::connection>(connection_string_);
      if (!last_problem_.empty())
        logger("catalogue")->info("the catalogue database at {} is back", where_);
      last_problem_.clear();
      backoff_ = {};
    }
    pqxx::work transaction(*connection_);
    work(transaction);
    transaction.commit();
    return {};
  } catch (const pqxx::broken_connection& e) {
    return std::unexpected(away(e.what()));
  } catch (const pqxx::in_doubt_error& e) {
    return std::unexpected(away(e.what()));
  } catch (const pqxx::transaction_rollback& e) {
    return std::unexpected(away(e.what()));
  } catch (const pqxx::sql_error& e) {
    if (transient_state(e.sqlstate())) return std::unexpected(away(e.what()));
    return std::unexpected(io_error(where_, std::string("the catalogue database refused: ") +
                                                e.what()));
  } catch (const pqxx::failure& e) {
    // A failure libpqxx does not classify further (a connection it found
    // closed, say): the connection is suspect, so it goes.
    return std::unexpected(away(e.what()));
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("catalogue: ") + e.what()));
  }
}

Status PostgresLink::transact_patiently(const std::function<void(pqxx::dbtransaction&)>& work,
                                        std::chrono::seconds patience) {
  const auto deadline = Clock::now() + patience;
  for (;;) {
    auto done = transact(work);
    if (done || done.error().code != ErrorCode::unavailable || Clock::now() >= deadline)
      return done;
    Clock::time_point next;
    {
      std::lock_guard lock(mutex_);
      next = next_attempt_;
    }
    std::this_thread::sleep_until(std::min(next, deadline));
  }
}

}  // namespace psrig::catalogue
