// Several psrigd on the simulated rig sharing one PostgreSQL catalogue and
// one storage root, as the rigs of a lab do: every scan once and
// searchable from any of them, a rig killed mid-scan failing only its own
// scan when it starts again, the database going away during a scan and
// its rows written once it is back, and a catalogue-only psrigd that
// starts scans on a chosen rig through that rig's own daemon.

#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "daemon_process.h"
#include "postgres_server.h"

namespace psrig::test {
namespace {

using nlohmann::json;

// One throwaway PostgreSQL database and shared storage root, and the
// psrigd of each rig on them.
class SharedCatalogueDaemons : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why_not;
    server_ = shared_postgres(why_not);
    if (!server_) GTEST_SKIP() << "no PostgreSQL server for the shared catalogue: " << why_not;
    url_ = server_->create_database();
  }

  // config/sim.toml for `rig` on the shared catalogue (`role` "catalogue":
  // no rig), with `edits`.
  fs::path config(const std::string& rig, int port, const std::string& role = "rig",
                  Edits edits = {}) {
    auto& dir = dirs_.emplace_back(std::make_unique<TempDir>("psrig-" + rig));
    edits.push_back({"root = \"scans\"", "root = \"" + shared().string() + "\""});
    edits.push_back({"modbus_port = 0", "modbus_port = 0\nrig_name = \"" + rig + "\"\nrole = \"" +
                                            role + "\"\n\n[catalogue]\nurl = \"" + url_ + "\""});
    return daemon_config(*dir, port, edits);
  }
  std::unique_ptr<Daemon> start(const std::string& rig, const fs::path& config_file, int port) {
    auto daemon = std::make_unique<Daemon>(config_file, port, config_file.parent_path() / (rig + ".log"));
    EXPECT_TRUE(daemon->wait_ready()) << daemon->log();
    return daemon;
  }
  [[nodiscard]] fs::path shared() const { return temp_.path() / "shared"; }
  PostgresServer& server() { return *server_; }

  // Polls `daemon`'s row of scan `id` until `done` holds of it.
  template <class Predicate>
  json wait_row(Daemon& daemon, std::int64_t id, Predicate done, std::chrono::seconds limit = 30s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    json row;
    while (std::chrono::steady_clock::now() < deadline) {
      if (auto res = daemon.http().Get("/v1/scans/" + std::to_string(id)); res && res->status == 200) {
        row = json::parse(res->body);
        if (done(row)) return row;
      }
      std::this_thread::sleep_for(50ms);
    }
    ADD_FAILURE() << "scan " << id << ": " << row.dump();
    return row;
  }

 private:
  PostgresServer* server_ = nullptr;
  std::string url_;
  TempDir temp_{"psrig-shared"};
  std::vector<std::unique_ptr<TempDir>> dirs_;
};

bool finished(const json& row) {
  const std::string status = row.value("status", "");
  return status == "done" || status == "failed" || status == "aborted";
}

TEST_F(SharedCatalogueDaemons, TwoRigsScanIntoOneCatalogueEachScanOnceSearchableFromEither) {
  const int port_a = free_port(), port_b = free_port();
  auto a = start("rig-a", config("rig-a", port_a), port_a);
  auto b = start("rig-b", config("rig-b", port_b), port_b);
  std::vector<std::int64_t> ids;
  for (int i = 0; i < 3; ++i) {
    ids.push_back(a->submit({{"sample_id", "A-" + std::to_string(i)}}));
    ids.push_back(b->submit({{"sample_id", "B-" + std::to_string(i)}}));
  }
  EXPECT_EQ(std::set<std::int64_t>(ids.begin(), ids.end()).size(), ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    Daemon& rig = i % 2 == 0 ? *a : *b;
    EXPECT_EQ(rig.wait_finished(ids[i])["status"], "done");
  }
  for (Daemon* reader : {a.get(), b.get()}) {
    const json all = reader->get("/v1/scans?limit=100");
    EXPECT_EQ(all["total"], 6) << all.dump();
    std::multiset<std::int64_t> seen;
    for (const auto& row : all["scans"]) {
      seen.insert(row["id"].get<std::int64_t>());
      const std::string rig = row["rig"];
      EXPECT_EQ(rig, row["sample_id"].get<std::string>()[0] == 'A' ? "rig-a" : "rig-b");
      // Under its own rig's directory of the shared root, whole.
      EXPECT_EQ(fs::path(row["scan_directory"].get<std::string>()).parent_path(), shared() / rig);
      EXPECT_TRUE(fs::exists(fs::path(row["maps_directory"].get<std::string>()) / "report.json"));
    }
    for (const auto id : ids)
      EXPECT_EQ(seen.count(id), 1U) << "scan " << id << " once";
    EXPECT_EQ(reader->get("/v1/scans?rig=rig-b")["total"], 3);
    EXPECT_EQ(reader->get("/v1/scans?q=B-1")["total"], 1);
  }
  // One rig's scan, served whole by the other from the shared storage.
  auto thumbnail = b->http().Get("/v1/scans/" + std::to_string(ids[0]) + "/thumbnail");
  ASSERT_TRUE(thumbnail);
  EXPECT_EQ(thumbnail->status, 200);
  // Each rig in the rigs list, online, with its state.
  const json rigs = a->get("/v1/rigs");
  ASSERT_EQ(rigs["rigs"].size(), 2U) << rigs.dump();
  for (const auto& rig : rigs["rigs"]) {
    EXPECT_TRUE(rig["online"].get<bool>()) << rig.dump();
    EXPECT_EQ(rig["this"].get<bool>(), rig["name"] == "rig-a");
    EXPECT_FALSE(rig.contains("token"));
    EXPECT_TRUE(rig["status"].contains("state")) << rig.dump();
  }
}

// kill -9 during a scan: at its next start the rig fails that scan, and
// the other rig's scans, running or done, are not touched.
TEST_F(SharedCatalogueDaemons, ARigKilledMidScanFailsOnlyItsOwnScanWhenItStartsAgain) {
  const int port_a = free_port(), port_b = free_port();
  // Long exposures: rig A's scan is still acquiring when it is killed.
  const fs::path config_a =
      config("rig-a", port_a, "rig", {{"exposure_us = 20000", "exposure_us = 400000"}});
  auto a = start("rig-a", config_a, port_a);
  auto b = start("rig-b", config("rig-b", port_b), port_b);
  const auto before_b = b->submit({{"sample_id", "B-before"}});
  EXPECT_EQ(b->wait_finished(before_b)["status"], "done");
  const auto interrupted = a->submit({{"sample_id", "A-killed"}});
  // Its row says running (seen from the other rig), its frames still coming.
  wait_row(*b, interrupted, [](const json& r) { return r["status"] == "running"; });
  ASSERT_EQ(a->get("/v1/status")["state"], "scanning");
  const auto during_b = b->submit({{"sample_id", "B-during"}});
  ::kill(a->pid(), SIGKILL);
  ASSERT_EQ(a->signal_and_wait(0), 128 + SIGKILL);
  EXPECT_EQ(b->wait_finished(during_b)["status"], "done");
  EXPECT_EQ(b->get("/v1/scans/" + std::to_string(interrupted))["status"], "running");

  a = start("rig-a", config_a, port_a);
  const json row = a->get("/v1/scans/" + std::to_string(interrupted));
  EXPECT_EQ(row["status"], "failed") << row.dump();
  EXPECT_NE(row["error"]["message"].get<std::string>().find("interrupted"), std::string::npos);
  for (const auto id : {before_b, during_b}) {
    const json other = b->get("/v1/scans/" + std::to_string(id));
    EXPECT_EQ(other["status"], "done") << other.dump();
    EXPECT_TRUE(fs::exists(fs::path(other["scan_directory"].get<std::string>()) / "scan.json"));
  }
  EXPECT_EQ(a->get("/v1/scans")["total"], 3);
}

// The database stops during a scan and another is queued while it is
// away: both scans run, psrigd answers throughout, and once the database
// is back each row is written, once.
TEST_F(SharedCatalogueDaemons, ScansGoOnWhileTheDatabaseIsAwayAndTheirRowsAreWrittenOnceItIsBack) {
  const int port = free_port();
  auto a = start("rig-a", config("rig-a", port), port);
  const auto first = a->submit({{"sample_id", "OUTAGE-1"}});
  ASSERT_TRUE(server().stop()) << server().log();
  const auto second = a->submit({{"sample_id", "OUTAGE-2"}});  // an id from the rig's reserve
  ASSERT_GT(second, first);
  ASSERT_TRUE(a->wait_status([](const json& s) { return s["scans_completed"] == 2; }, 30s))
      << a->log();
  // Away: reads fail as such (503), the daemon stays up.
  auto away = a->http().Get("/v1/scans/" + std::to_string(first));
  ASSERT_TRUE(away);
  EXPECT_EQ(away->status, 503) << away->body;
  EXPECT_FALSE(a->exited());

  ASSERT_TRUE(server().start_again()) << server().log();
  for (const auto id : {first, second}) {
    const json row = wait_row(*a, id, [](const json& r) { return r["status"] == "done"; });
    EXPECT_TRUE(fs::exists(fs::path(row["maps_directory"].get<std::string>()) / "report.json"));
  }
  const json all = a->get("/v1/scans?q=OUTAGE");
  EXPECT_EQ(all["total"], 2) << "each row once: " << all.dump();
  EXPECT_TRUE(contains(a->log(), "is in the catalogue database now")) << a->log();
}

// A psrigd with no rig serves every rig's scans and starts one on the rig
// named, through that rig's psrigd and with that rig's token.
TEST_F(SharedCatalogueDaemons, ACatalogueOnlyPsrigdStartsScansOnTheRigNamed) {
  const int port_a = free_port(), port_c = free_port();
  const fs::path config_a = config(
      "rig-a", port_a, "rig",
      {{"listen_address = \"127.0.0.1\"", "listen_address = \"127.0.0.1\"\ntoken = \"" + kToken + "\""}});
  auto a = start("rig-a", config_a, port_a);
  auto c = start("catalogue", config("catalogue", port_c, "catalogue"), port_c);
  const json status = c->get("/v1/status");
  EXPECT_EQ(status["role"], "catalogue") << status.dump();
  EXPECT_EQ(status["catalogue"], "postgresql");

  // Without a rig named, it has none to scan with.
  httplib::Client plain("127.0.0.1", port_c);  // no token: the catalogue wants none
  auto refused = plain.Post("/v1/scans", R"({"sample_id": "X"})", "application/json");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 400) << refused->body;
  EXPECT_TRUE(contains(refused->body, "rig")) << refused->body;
  auto unknown = plain.Post("/v1/scans", R"({"rig": "rig-z"})", "application/json");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status, 404) << unknown->body;
  EXPECT_TRUE(contains(unknown->body, "rig-a")) << "names the rigs there are: " << unknown->body;

  auto started = plain.Post("/v1/scans", R"({"rig": "rig-a", "sample_id": "VIA-C", "tags": ["lab"]})",
                            "application/json");
  ASSERT_TRUE(started);
  ASSERT_EQ(started->status, 202) << started->body;
  const json answer = json::parse(started->body);
  EXPECT_EQ(answer["rig"], "rig-a");
  const auto id = answer["id"].get<std::int64_t>();
  const json row = wait_row(*c, id, finished);
  EXPECT_EQ(row["status"], "done") << row.dump();
  EXPECT_EQ(row["rig"], "rig-a");
  EXPECT_EQ(row["tags"], json::array({"lab"}));
  EXPECT_EQ(a->get("/v1/scans/" + std::to_string(id))["sample_id"], "VIA-C");

  const json rigs = c->get("/v1/rigs");
  ASSERT_EQ(rigs["rigs"].size(), 1U) << rigs.dump();
  EXPECT_EQ(rigs["rigs"][0]["name"], "rig-a");
  EXPECT_TRUE(rigs["rigs"][0]["online"].get<bool>());
  EXPECT_FALSE(contains(rigs.dump(), kToken)) << "the rig's token never leaves the catalogue";

  // A finished scan of rig A: cancelling is refused there, deleting done there.
  auto cancel = plain.Post("/v1/scans/" + std::to_string(id) + "/cancel", "", "application/json");
  ASSERT_TRUE(cancel);
  EXPECT_EQ(cancel->status, 409) << cancel->body;
  auto removed = plain.Delete("/v1/scans/" + std::to_string(id));
  ASSERT_TRUE(removed);
  EXPECT_EQ(removed->status, 200) << removed->body;
  EXPECT_EQ(a->get("/v1/scans")["total"], 0);
  EXPECT_FALSE(fs::exists(fs::path(row["scan_directory"].get<std::string>())));
}

}  // namespace
}  // namespace psrig::test
