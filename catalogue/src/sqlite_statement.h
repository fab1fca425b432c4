#pragma once
// One prepared SQLite statement, finalised however the scope ends, with
// binding by position and reading by column; errors as Results.

#include <cstdint>
#include <optional>
#include <sqlite3.h>
#include <string>

#include "psrig/base/error.h"

namespace psrig::catalogue::sqlite {

// What a failed call's result code means to the caller: a full disk is
// the one the catalogue acts on.
inline ErrorCode error_code(int result) {
  return (result & 0xff) == SQLITE_FULL ? ErrorCode::disk_full : ErrorCode::unspecified;
}

inline Error error(sqlite3* db, int result, const std::string& what) {
  return io_error("catalogue", what + ": " + sqlite3_errmsg(db)).with(error_code(result));
}

class Statement {
 public:
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement(Statement&& other) noexcept : db_(other.db_), statement_(other.statement_) {
    other.statement_ = nullptr;
  }
  Statement& operator=(Statement&&) = delete;
  ~Statement() { sqlite3_finalize(statement_); }

  [[nodiscard]] static Result<Statement> prepare(sqlite3* db, const std::string& sql) {
    sqlite3_stmt* statement = nullptr;
    const int result = sqlite3_prepare_v2(db, sql.c_str(), -1, &statement, nullptr);
    if (result != SQLITE_OK) return std::unexpected(error(db, result, "preparing \"" + sql + "\""));
    return Statement(db, statement);
  }

  // Parameters are 1-based, as SQLite counts them.
  void bind(int index, const std::string& value) {
    sqlite3_bind_text(statement_, index, value.c_str(), static_cast<int>(value.size()),
                      SQLITE_TRANSIENT);
  }
  void bind(int index, std::int64_t value) { sqlite3_bind_int64(statement_, index, value); }
  void bind(int index, double value) { sqlite3_bind_double(statement_, index, value); }
  void bind_null(int index) { sqlite3_bind_null(statement_, index); }
  void bind(int index, const std::optional<double>& value) {
    if (value)
      bind(index, *value);
    else
      bind_null(index);
  }

  // True while there is a row to read; false once done.
  [[nodiscard]] Result<bool> step() {
    const int rc = sqlite3_step(statement_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    return std::unexpected(
        error(db_, rc, "running \"" + std::string(sqlite3_sql(statement_)) + "\""));
  }
  // Runs a statement that returns no rows.
  [[nodiscard]] Status run() {
    auto stepped = step();
    if (!stepped) return std::unexpected(stepped.error());
    return {};
  }

  [[nodiscard]] std::string text(int column) const {
    const auto* value = sqlite3_column_text(statement_, column);
    return value ? std::string(reinterpret_cast<const char*>(value),
                               static_cast<std::size_t>(sqlite3_column_bytes(statement_, column)))
                 : std::string();
  }
  [[nodiscard]] std::int64_t integer(int column) const {
    return sqlite3_column_int64(statement_, column);
  }
  [[nodiscard]] double real(int column) const { return sqlite3_column_double(statement_, column); }
  [[nodiscard]] bool is_null(int column) const {
    return sqlite3_column_type(statement_, column) == SQLITE_NULL;
  }

 private:
  Statement(sqlite3* db, sqlite3_stmt* statement) : db_(db), statement_(statement) {}
  sqlite3* db_;
  sqlite3_stmt* statement_;
};

}  // namespace psrig::catalogue::sqlite
