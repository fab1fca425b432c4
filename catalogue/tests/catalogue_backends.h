#pragma once
// The catalogue's two backends, for the tests that run on both (TEST_P over
// CatalogueBackendTest, instantiated with kBothBackends): the embedded
// SQLite file in a storage root, and the shared PostgreSQL catalogue on a
// database of the test's own (a throwaway server per test program,
// postgres_server.h). Where PostgreSQL's server programs are not
// installed, its half skips saying so; scripts/install-deps installs them.

#include <filesystem>
#include <memory>
#include <sqlite3.h>
#include <string>

#include <gtest/gtest.h>

#include "postgres_server.h"
#include "psrig/catalogue/catalogue.h"
#include "test_support.h"

namespace psrig::test {

enum class Backend { sqlite, postgresql };

inline const auto kBothBackends = ::testing::Values(Backend::sqlite, Backend::postgresql);

inline std::string backend_name(const ::testing::TestParamInfo<Backend>& info) {
  return info.param == Backend::sqlite ? "Sqlite" : "Postgres";
}

class CatalogueBackendTest : public ::testing::TestWithParam<Backend> {
 protected:
  static constexpr const char* kRig = "rig-a";

  void SetUp() override {
    if (GetParam() != Backend::postgresql) return;
    std::string why_not;
    server_ = shared_postgres(why_not);
    if (!server_) GTEST_SKIP() << "no PostgreSQL server for the shared catalogue: " << why_not;
    url_ = server_->create_database();
  }

  [[nodiscard]] bool postgres() const { return GetParam() == Backend::postgresql; }
  [[nodiscard]] PostgresServer& server() { return *server_; }
  [[nodiscard]] const std::string& url() const { return url_; }

  // How `rig` opens the catalogue of `root` (the shared storage root).
  [[nodiscard]] catalogue::CatalogueOptions options(const std::filesystem::path& root,
                                                    const std::string& rig = kRig) const {
    catalogue::CatalogueOptions o;
    o.storage_root = root;
    o.rig_name = rig;
    if (postgres()) {
      o.url = url_;
      o.rig_root = root / rig;
      o.journal = temp.path() / ("journal-" + rig) / "catalogue-journal.json";
    }
    return o;
  }
  [[nodiscard]] Result<std::unique_ptr<catalogue::Catalogue>> try_open(
      const std::filesystem::path& root, const std::string& rig = kRig) {
    last_root_ = root;
    return catalogue::open_catalogue(options(root, rig));
  }
  [[nodiscard]] std::unique_ptr<catalogue::Catalogue> open(const std::filesystem::path& root,
                                                           const std::string& rig = kRig) {
    auto catalogue = try_open(root, rig);
    EXPECT_TRUE(catalogue) << catalogue.error().describe();
    return catalogue ? std::move(*catalogue) : nullptr;
  }
  // Where `rig` writes its scans in `root`: the root itself for the
  // embedded catalogue, its own directory of it for the shared one.
  [[nodiscard]] std::filesystem::path rig_dir(const std::filesystem::path& root,
                                              const std::string& rig = kRig) const {
    return postgres() ? root / rig : root;
  }

  // `statement` on the backend's database, as someone at its prompt would
  // (the last storage root opened, for SQLite).
  void sql(const std::string& statement) {
    if (postgres()) {
      const std::string failed = execute_sql(url_, statement);
      EXPECT_TRUE(failed.empty()) << statement << ": " << failed;
      return;
    }
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((last_root_ / "catalogue.sqlite").c_str(), &db), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db, statement.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
        << statement << ": " << sqlite3_errmsg(db);
    sqlite3_close(db);
  }
  // Sets a row's created time, for date searches.
  void set_created(std::int64_t id, const std::string& when) {
    sql("UPDATE scans SET created = '" + when + "' WHERE id = " + std::to_string(id));
  }
  void set_schema_version(int version) {
    sql(postgres() ? "UPDATE psrig_schema SET version = " + std::to_string(version)
                   : "PRAGMA user_version = " + std::to_string(version));
  }

  TempDir temp;

 private:
  PostgresServer* server_ = nullptr;
  std::string url_;
  std::filesystem::path last_root_;
};

}  // namespace psrig::test
