// psrigd as the rig runs it: a real daemon process on loopback with the
// simulated rig at a small size, driven over HTTP as the kiosk, a
// technician's `psrig` or a script would.

#include <arpa/inet.h>
#include <chrono>
#include <fcntl.h>
#include <fstream>
#include <httplib.h>
#include <iterator>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "daemon_process.h"
#include "psrig/config/config_loader.h"
#include "psrig/lights/light_controller.h"
#include "psrig/rig/open_devices.h"
#include "raw_http.h"
#include "sim_modbus_driver.h"

namespace psrig::test {
namespace {

// A psrigd whose LEDs are on a simulated Modbus LED driver the test holds
// (modbus_lights with `modbus_extra`, then `edits`), started but not yet
// ready. The test asserts `driver` started before it uses `led_driver()` or
// `daemon()`, which exist only then.
struct DaemonOnLedDriver {
  explicit DaemonOnLedDriver(const std::string& modbus_extra = "", const Edits& edits = {}) {
    if (!driver) return;
    Edits all = {modbus_lights((*driver)->port(), modbus_extra)};
    all.insert(all.end(), edits.begin(), edits.end());
    config = daemon_config(temp, port, all);
    running.emplace(config, port, temp / "psrigd.log");
  }
  SimModbusDriver& led_driver() { return **driver; }
  Daemon& daemon() { return *running; }

  TempDir temp;
  Result<std::unique_ptr<SimModbusDriver>> driver = SimModbusDriver::start({});
  int port = free_port();
  fs::path config;
  std::optional<Daemon> running;
};

TEST(Psrigd, ScanRoundTripSearchDownloadAndDelete) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  const auto status = daemon.get("/v1/status");
  EXPECT_EQ(status["state"], "idle") << status.dump();
  EXPECT_TRUE(status["devices"]["open"].get<bool>()) << status.dump();
  EXPECT_EQ(status["queue_limit"], 16);

  const auto first = daemon.submit(
      {{"sample_id", "J-0042"}, {"description", "single jersey"}, {"tags", {"knit", "cotton"}}});
  const auto second = daemon.submit({{"sample_id", "W-7"}, {"tags", {"woven"}}});
  ASSERT_GT(first, 0);
  ASSERT_GT(second, first);
  const auto entry = daemon.wait_finished(first);
  ASSERT_EQ(entry["status"], "done") << entry.dump(2) << daemon.log();
  EXPECT_EQ(entry["sample_id"], "J-0042");
  EXPECT_EQ(entry["description"], "single jersey");
  EXPECT_EQ(entry["tags"], json({"knit", "cotton"}));
  EXPECT_TRUE(entry["error"].is_null());
  EXPECT_TRUE(entry["finished"].get<std::string>().ends_with("Z"));
  EXPECT_LE(entry["report"]["ground_truth"]["angular_error_deg"]["mean"].get<double>(), 2.0)
      << entry["report"].dump();
  for (const char* name : {"scan.json", "led0.png", "led2.png", "dark.png", "normal.png",
                           "albedo.png", "height.exr", "report.json"})
    EXPECT_NE(std::find(entry["files"].begin(), entry["files"].end(), name), entry["files"].end())
        << name << " " << entry["files"].dump();
  const fs::path scan_dir = entry["scan_directory"].get<std::string>();
  const fs::path maps_dir = entry["maps_directory"].get<std::string>();
  EXPECT_EQ(scan_dir.parent_path(), fs::weakly_canonical(temp / "scans"));
  EXPECT_EQ(json::parse(file_contents(scan_dir / "scan.json"))["sample"]["id"], "J-0042");

  // Downloads are the files on disk, byte for byte.
  for (const auto& [name, path] : {std::pair{"normal.png", maps_dir / "normal.png"},
                                   {"led1.png", scan_dir / "led1.png"},
                                   {"report.json", maps_dir / "report.json"},
                                   {"scan.json", scan_dir / "scan.json"}}) {
    auto res = daemon.http().Get("/v1/scans/" + std::to_string(first) + "/files/" + name);
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << name << ": " << res->body;
    EXPECT_EQ(res->body, file_contents(path)) << name;
    EXPECT_FALSE(res->body.empty());
  }
  EXPECT_EQ(daemon.get("/v1/scans/" + std::to_string(first) + "/files/catalogue.sqlite", 404)
                .value("error", ""),
            "no file named that; ask for scan.json, dark.png, led<k>.png, a map (albedo.png, "
            "normal.png, height.png, ...) or report.json");

  ASSERT_EQ(daemon.wait_finished(second)["status"], "done");
  const auto ids = [&](const std::string& query) {
    std::vector<std::int64_t> found;
    const json reply = daemon.get("/v1/scans" + query);  // kept: the loop reads into it
    for (const auto& scan : reply["scans"])
      found.push_back(scan["id"].get<std::int64_t>());
    return found;
  };
  using Ids = std::vector<std::int64_t>;
  EXPECT_EQ(ids(""), (Ids{second, first}));  // newest first
  EXPECT_EQ(ids("?sample_id=J-0042"), Ids{first});
  EXPECT_EQ(ids("?tag=woven"), Ids{second});
  EXPECT_EQ(ids("?tag=cotton&status=done"), Ids{first});
  EXPECT_EQ(ids("?status=failed"), Ids{});
  EXPECT_EQ(ids("?limit=1"), Ids{second});
  EXPECT_EQ(ids("?limit=1&offset=1"), Ids{first});
  EXPECT_EQ(ids("?from=2000-01-01&to=2999-12-31"), (Ids{second, first}));
  EXPECT_EQ(ids("?to=2000-01-01"), Ids{});
  EXPECT_TRUE(contains(daemon.get("/v1/scans?from=yesterday", 400).value("error", ""), "from"));
  EXPECT_TRUE(contains(daemon.get("/v1/scans?limit=0", 400).value("error", ""), "limit"));
  EXPECT_TRUE(contains(daemon.get("/v1/scans?colour=red", 400).value("error", ""), "colour"));
  // The simulated rig's jersey, about 7 wales per cm: "wales between 6 and 8 per cm".
  EXPECT_EQ(ids("?wales_min=6&wales_max=8"), (Ids{second, first}));
  EXPECT_EQ(ids("?wales_min=6&wales_max=8&courses_min=8.5&courses_max=9.5"), (Ids{second, first}));
  EXPECT_EQ(ids("?wales_min=100&wales_max=200"), Ids{});  // measured fabric density range
  EXPECT_TRUE(
      contains(daemon.get("/v1/scans?wales_min=six", 400).value("error", ""), "wales_min"));

  // Delete: the files go, then the row.
  auto deleted = daemon.http().Delete("/v1/scans/" + std::to_string(first));
  ASSERT_TRUE(deleted);
  EXPECT_EQ(deleted->status, 200) << deleted->body;
  EXPECT_FALSE(fs::exists(scan_dir));
  EXPECT_TRUE(contains(daemon.get("/v1/scans/" + std::to_string(first), 404).value("error", ""),
                       "no scan"));
  EXPECT_EQ(ids(""), Ids{second});
  auto again = daemon.http().Delete("/v1/scans/" + std::to_string(first));
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 404);

  EXPECT_EQ(daemon.get("/v1/status")["scans_completed"], 2);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, EventsFollowAScanToItsEnd) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  std::string stream;
  std::atomic<bool> connected{false};
  httplib::Client listener("127.0.0.1", port);
  listener.set_read_timeout(20s);
  std::thread reader([&] {
    (void)listener.Get("/v1/events", [&](const char* data, std::size_t length) {
      stream.append(data, length);
      connected = true;
      return !contains(stream, "event: done") && !contains(stream, "event: error");
    });
  });
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!connected && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  ASSERT_TRUE(connected);
  const auto id = daemon.submit({{"sample_id", "E-1"}});
  reader.join();

  ASSERT_TRUE(contains(stream, "event: done")) << stream;
  const auto light = stream.find("\"step\":\"light 1 of 3\"");
  const auto processing = stream.find("\"step\":\"processing\"");
  const auto done = stream.find("event: done");
  EXPECT_NE(light, std::string::npos) << stream;
  EXPECT_LT(light, processing) << stream;
  EXPECT_LT(processing, done) << stream;
  const auto data = stream.find("data: ", done);
  const auto event = json::parse(stream.substr(data + 6, stream.find('\n', data) - data - 6));
  EXPECT_EQ(event["id"], id);
  EXPECT_EQ(event["status"], "done");
  EXPECT_TRUE(contains(stream, "id: ")) << stream;  // resumable with Last-Event-ID

  // An open event stream does not hold the daemon up when it stops.
  std::thread idle_listener([&] {
    httplib::Client second("127.0.0.1", port);
    second.set_read_timeout(30s);
    (void)second.Get("/v1/events", [](const char*, std::size_t) { return true; });
  });
  std::this_thread::sleep_for(300ms);
  const auto before = std::chrono::steady_clock::now();
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
  EXPECT_LT(std::chrono::steady_clock::now() - before, 5s);
  idle_listener.join();
}

TEST(Psrigd, BadRequestsGetA4xxWithAMessage) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto post = [&](const std::string& body) {
    auto res = daemon.http().Post("/v1/scans", body, "application/json");
    EXPECT_TRUE(res);
    return res ? std::pair{res->status, json::parse(res->body, nullptr, false)}
               : std::pair{-1, json()};
  };
  for (const auto& [body, must_name] : std::vector<std::pair<std::string, std::string>>{
           {"{\"sample_id\": ", "malformed JSON"},
           {"[1, 2]", "object"},
           {"{\"sample_id\": 42}", "sample_id"},
           {"{\"tags\": \"knit\"}", "tags"},
           {"{\"tags\": [1]}", "tags"},
           {"{\"sample_id\": \"" + std::string(200, 'x') + "\"}", "sample_id"},
           {"{\"colour\": \"red\"}", "colour"},
       }) {
    const auto [status, reply] = post(body);
    EXPECT_EQ(status, 400) << body;
    ASSERT_TRUE(reply.is_object()) << body;
    EXPECT_TRUE(contains(reply.value("error", ""), must_name)) << body << " -> " << reply.dump();
  }
  // Too large: refused from the headers, before a byte of the body is read.
  const auto [too_large, answer] = raw_http(
      port,
      "POST /v1/scans HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: "
      "10000000\r\nConnection: close\r\n\r\n{\"sample_id\": \"");
  EXPECT_EQ(too_large, 413) << answer;
  EXPECT_TRUE(
      contains(json::parse(body_of(answer), nullptr, false).value("error", ""), "larger than"))
      << answer;
  // An oversized body sent whole gets the same.
  auto big = daemon.http().Post(
      "/v1/scans", "{\"description\": \"" + std::string(100000, 'x') + "\"}", "application/json");
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413);

  EXPECT_EQ(daemon.get("/v1/scans/12345", 404).value("error", ""), "no scan 12345");
  EXPECT_EQ(daemon.get("/v1/scans/abc", 404).value("error", ""), "no such scan");
  EXPECT_EQ(daemon.get("/v1/nothing", 404).value("error", ""), "no such endpoint");
  // Dates and times that are not real ones, naming the parameter.
  for (const auto& [query, must_name] : std::vector<std::pair<std::string, std::string>>{
           {"from=2026-02-30", "from: "},
           {"to=9999-12-31T99:99:99Z", "to: "},
           {"from=2026-05-04T24:00:00Z", "from: "},
           {"to=2027-02-29", "to: "},
       })
    EXPECT_TRUE(contains(daemon.get("/v1/scans?" + query, 400).value("error", ""), must_name))
        << query;
  EXPECT_EQ(daemon.get("/v1/scans?from=2028-02-29&to=9999-12-31T23:59:59Z")["scans"].size(), 0U);
  // httplib's bounds: a request line up to 8192 bytes (414 past it), each
  // header line up to 8192 (400 past it).
  const auto request_line = [&](std::size_t value) {
    return raw_http(port, "GET /v1/scans?sample_id=" + std::string(value, 'a') +
                              " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  };
  const auto [long_query, long_answer] = request_line(9000);
  EXPECT_EQ(long_query, 414) << long_answer;
  EXPECT_TRUE(contains(body_of(long_answer), "URI too long")) << long_answer;
  EXPECT_EQ(request_line(8000).first, 200);
  const auto [long_header, header_answer] =
      raw_http(port, "GET /v1/status HTTP/1.1\r\nHost: x\r\nX-Long: " + std::string(9000, 'a') +
                         "\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(long_header, 400) << header_answer;
  // A GET's body, which httplib does not read, is not taken for a request:
  // one answer (413), then the connection is closed.
  const std::string smuggled = "DELETE /v1/scans/1 HTTP/1.1\r\nHost: x\r\n\r\n";
  const auto start = std::chrono::steady_clock::now();
  const std::string get_answer =
      raw_http_until_closed(port, "GET /v1/status HTTP/1.1\r\nHost: x\r\nContent-Length: " +
                                      std::to_string(smuggled.size()) + "\r\n\r\n" + smuggled);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
  EXPECT_TRUE(get_answer.starts_with("HTTP/1.1 413")) << get_answer;
  EXPECT_EQ(get_answer.find("HTTP/1.1", 1), std::string::npos) << get_answer;
  auto res = daemon.http().Delete("/v1/scans/99999999999999999999999");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 404);
  EXPECT_EQ(json::parse(daemon.get("/v1/scans").dump())["scans"].size(), 0U);  // nothing queued
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, PathTraversalIsRefused) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port);
  std::ofstream(temp / "secret.txt") << "the secret";
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto id = std::to_string(daemon.submit({{"sample_id", "T"}}));
  ASSERT_EQ(daemon.wait_finished(std::stoll(id))["status"], "done");

  const std::string scan = "/v1/scans/" + id + "/files/";
  for (const std::string& path :
       {scan + "../../../secret.txt", scan + "..%2f..%2f..%2fsecret.txt",
        scan + "%2e%2e/%2e%2e/%2e%2e/secret.txt", scan + "%2e%2e%2f%2e%2e%2f%2e%2e%2fsecret.txt",
        scan + "/etc/passwd", scan + "%2fetc%2fpasswd", scan + temp.path().string() + "/secret.txt",
        scan + "..", scan + "maps%2f..%2f..%2f..%2fsecret.txt", scan + "scan.json%00.png",
        "/v1/scans/" + id + "/../../secret.txt", "/v1/scans/..%2f" + id + "/files/scan.json",
        "/v1/scans/" + id + "/files/../../catalogue.sqlite"}) {
    const auto [status, answer] =
        raw_http(port, "GET " + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_GE(status, 400) << path << "\n" << answer;
    EXPECT_LT(status, 500) << path << "\n" << answer;
    EXPECT_FALSE(contains(answer, "the secret")) << path;
    EXPECT_FALSE(contains(answer, "root:")) << path;
    EXPECT_FALSE(contains(answer, "SQLite format")) << path;
  }
  // The same request, well-formed, works: the refusals above were not luck.
  const auto [ok, answer] =
      raw_http(port, "GET " + scan + "scan.json HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(ok, 200) << answer;
  EXPECT_TRUE(contains(answer, "psrig-scan/1"));
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, OffLoopbackItNeedsAToken) {
  TempDir temp;
  const int port = free_port();
  {
    // No token: refused at start, naming the key.
    const auto config = daemon_config(
        temp, port, {{"listen_address = \"127.0.0.1\"", "listen_address = \"0.0.0.0\""}});
    Daemon daemon(config, port, temp / "refused.log");
    EXPECT_FALSE(daemon.wait_ready());
    EXPECT_EQ(daemon.exit_code(), 2) << daemon.log();
    EXPECT_TRUE(contains(daemon.log(), "daemon.token")) << daemon.log();
  }
  const auto config = daemon_config(temp, port,
                                    {{"listen_address = \"127.0.0.1\"",
                                      "listen_address = \"0.0.0.0\"\ntoken = \"" + kToken + "\""}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();  // with the token
  for (const std::string& authorization : std::vector<std::string>{
           std::string(), "Authorization: Bearer wrong\r\n",
           "Authorization: Bearer " + kToken + "x\r\n", "Authorization: " + kToken + "\r\n",
           "Authorization: Basic " + kToken + "\r\n"}) {
    for (const std::string request :
         {"GET /v1/status", "POST /v1/lights/off", "GET /v1/scans", "DELETE /v1/scans/1"}) {
      const auto [status, answer] =
          raw_http(port, request + " HTTP/1.1\r\nHost: x\r\n" + authorization +
                             "Content-Length: 0\r\nConnection: close\r\n\r\n");
      EXPECT_EQ(status, 401) << request << " with '" << authorization << "'\n" << answer;
      EXPECT_TRUE(contains(answer, "bearer token")) << answer;
    }
  }
  const auto [status, answer] =
      raw_http(port, "GET /v1/status HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
                         "\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status, 200) << answer;

  auto without = run_program("psrig", {"status", "--url", daemon.url()});
  EXPECT_EQ(without.exit_code, 2) << without.err;
  EXPECT_TRUE(contains(without.err, "--token")) << without.err;
  auto with = run_program("psrig", {"status", "--url", daemon.url(), "--token", kToken});
  EXPECT_EQ(with.exit_code, 0) << with.err;
  EXPECT_TRUE(contains(with.out, "idle")) << with.out;
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// SIGTERM while an LED is lit, with the LEDs on a (simulated) Modbus driver
// the test holds, so it sees from outside what the LEDs did.
TEST(Psrigd, SigtermMidScanTurnsEveryLedOffAndExitsZero) {
  DaemonOnLedDriver setup("", {{"exposure_us = 20000", "exposure_us = 200000"}});  // a slow scan
  ASSERT_TRUE(setup.driver) << setup.driver.error().describe();
  SimModbusDriver& driver = setup.led_driver();
  Daemon& daemon = setup.daemon();
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto id = daemon.submit({{"sample_id", "S-1"}});
  const auto deadline = std::chrono::steady_clock::now() + 15s;
  while (driver.leds_on().empty() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  ASSERT_FALSE(driver.leds_on().empty()) << "no LED came on\n" << daemon.log();

  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
  EXPECT_TRUE(driver.leds_on().empty());
  EXPECT_FALSE(driver.log().overlap());
  EXPECT_TRUE(driver.log().on_now().empty());
  EXPECT_TRUE(contains(daemon.log(), "aborted")) << daemon.log();
  // Nothing half-made is left, and the row says what happened.
  for (const auto& name : list_directory(setup.temp / "scans"))
    EXPECT_TRUE(name.starts_with("catalogue.sqlite")) << name;
  Daemon again(setup.config, setup.port, setup.temp / "psrigd.log");
  ASSERT_TRUE(again.wait_ready()) << again.log();
  const auto entry = again.get("/v1/scans/" + std::to_string(id));
  EXPECT_EQ(entry["status"], "aborted") << entry.dump();
  EXPECT_EQ(entry["error"]["code_name"], "aborted") << entry.dump();
  EXPECT_EQ(again.signal_and_wait(SIGTERM), 0);
}

TEST(Psrigd, CancelQueuedAbortRunningAndLightsOff) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port, {{"exposure_us = 20000", "exposure_us = 150000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto running = daemon.submit({{"sample_id", "R"}});
  const auto queued = daemon.submit({{"sample_id", "Q"}});
  const auto last = daemon.submit({{"sample_id", "L"}});
  ASSERT_TRUE(daemon.wait_status([&](const json& s) { return s["current_scan"] == running; }));

  auto cancel = daemon.http().Delete("/v1/scans/" + std::to_string(queued));
  ASSERT_TRUE(cancel);
  EXPECT_EQ(cancel->status, 200) << cancel->body;
  auto abort = daemon.http().Delete("/v1/scans/" + std::to_string(running));
  ASSERT_TRUE(abort);
  EXPECT_EQ(abort->status, 202) << abort->body;
  EXPECT_EQ(daemon.wait_finished(running)["status"], "aborted");
  EXPECT_EQ(daemon.wait_finished(queued)["status"], "aborted");
  EXPECT_EQ(daemon.wait_finished(queued)["error"]["message"], "cancelled before it started");

  // lights/off stops the next one too.
  ASSERT_TRUE(daemon.wait_status([&](const json& s) { return s["current_scan"] == last; }));
  auto off = daemon.http().Post("/v1/lights/off", "", "application/json");
  ASSERT_TRUE(off);
  EXPECT_EQ(off->status, 200) << off->body;
  const auto stopped = daemon.wait_finished(last);
  EXPECT_EQ(stopped["status"], "aborted") << stopped.dump();
  EXPECT_TRUE(stopped["scan_directory"].is_null());
  const auto status = daemon.get("/v1/status");
  EXPECT_EQ(status["state"], "idle") << status.dump();
  EXPECT_EQ(status["last_error"]["code_name"], "aborted") << status.dump();
  for (const auto& name : list_directory(temp / "scans"))
    EXPECT_TRUE(name.starts_with("catalogue.sqlite")) << name;
  EXPECT_EQ(daemon.signal_and_wait(SIGINT), 0) << daemon.log();
}

// POST .../cancel stops what has not finished and never deletes what has:
// a client giving up (Ctrl-C) just as its scan ends keeps the scan.
TEST(Psrigd, CancelStopsAnUnfinishedScanAndKeepsAFinishedOne) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port, {{"exposure_us = 20000", "exposure_us = 150000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto first = daemon.submit({{"sample_id", "F"}});
  ASSERT_EQ(daemon.wait_finished(first)["status"], "done");
  auto kept =
      daemon.http().Post("/v1/scans/" + std::to_string(first) + "/cancel", "", "application/json");
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->status, 409) << kept->body;
  EXPECT_EQ(daemon.get("/v1/scans/" + std::to_string(first))["status"], "done");

  const auto running = daemon.submit({{"sample_id", "R"}});
  const auto queued = daemon.submit({{"sample_id", "Q"}});
  ASSERT_TRUE(daemon.wait_status([&](const json& s) { return s["current_scan"] == running; }));
  auto cancelled =
      daemon.http().Post("/v1/scans/" + std::to_string(queued) + "/cancel", "", "application/json");
  ASSERT_TRUE(cancelled);
  EXPECT_EQ(cancelled->status, 200) << cancelled->body;
  auto aborting = daemon.http().Post("/v1/scans/" + std::to_string(running) + "/cancel", "",
                                     "application/json");
  ASSERT_TRUE(aborting);
  EXPECT_EQ(aborting->status, 202) << aborting->body;
  EXPECT_EQ(daemon.wait_finished(running)["status"], "aborted");
  EXPECT_EQ(daemon.wait_finished(queued)["status"], "aborted");
  auto unknown = daemon.http().Post("/v1/scans/999999/cancel", "", "application/json");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status, 404);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// The directory a scan is about to write appears meanwhile (a `psrig scan`
// by hand): the scan fails, and the other scan is left alone.
TEST(Psrigd, AScanNeverRemovesADirectoryItDidNotWrite) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port, {{"exposure_us = 20000", "exposure_us = 150000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto id = daemon.submit({{"sample_id", "X-1"}});
  ASSERT_TRUE(daemon.wait_status([&](const json& s) {
    return s["current_scan"] == id && s["step"].get<std::string>().starts_with("light");
  })) << daemon.log();
  const auto running = daemon.get("/v1/scans/" + std::to_string(id));
  ASSERT_TRUE(running["scan_directory"].is_string()) << running.dump();
  const fs::path directory = running["scan_directory"].get<std::string>();
  fs::create_directories(directory);
  std::ofstream(directory / "scan.json") << R"({"format": "psrig-scan/1"})";

  const auto failed = daemon.wait_finished(id);
  EXPECT_EQ(failed["status"], "failed") << failed.dump();
  EXPECT_TRUE(contains(failed["error"]["message"].get<std::string>(), "already exists"))
      << failed.dump();
  EXPECT_TRUE(failed["scan_directory"].is_null()) << failed.dump();
  EXPECT_TRUE(fs::exists(directory / "scan.json")) << daemon.log();
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// The storage root reached through a symlink (/var/lib/psrig -> /data, say).
TEST(Psrigd, AStorageRootBehindASymlinkTakesScans) {
  TempDir temp;
  fs::create_directories(temp / "data");
  fs::create_directory_symlink("data", temp / "scans");
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto entry = daemon.wait_finished(daemon.submit({{"sample_id", "L-1"}}));
  EXPECT_EQ(entry["status"], "done") << entry.dump() << daemon.log();
  ASSERT_TRUE(entry["scan_directory"].is_string()) << entry.dump();
  const fs::path directory = entry["scan_directory"].get<std::string>();
  EXPECT_TRUE(fs::exists(temp / "data" / directory.filename() / "scan.json")) << entry.dump();
  // SIGHUP with the same file: the root is the same root.
  ::kill(daemon.pid(), SIGHUP);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!contains(daemon.log(), "SIGHUP") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  EXPECT_EQ(daemon.wait_finished(daemon.submit({{"sample_id", "L-2"}}))["status"], "done")
      << daemon.log();
  EXPECT_FALSE(contains(daemon.log(), "storage.root changed")) << daemon.log();
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// Lights-off means stop: the queue does not start its next scan (which
// would switch an LED on again at once).
TEST(Psrigd, LightsOffAbortsTheQueuedScansToo) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port, {{"exposure_us = 20000", "exposure_us = 150000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto running = daemon.submit({{"sample_id", "R"}});
  const auto queued = daemon.submit({{"sample_id", "Q1"}});
  const auto also_queued = daemon.submit({{"sample_id", "Q2"}});
  ASSERT_TRUE(daemon.wait_status([&](const json& s) { return s["current_scan"] == running; }));
  auto off = daemon.http().Post("/v1/lights/off", "", "application/json");
  ASSERT_TRUE(off);
  EXPECT_EQ(off->status, 200) << off->body;
  EXPECT_EQ(daemon.get("/v1/status")["queue_length"], 0);
  EXPECT_EQ(daemon.wait_finished(running)["status"], "aborted");
  for (const auto id : {queued, also_queued}) {
    const auto entry = daemon.wait_finished(id);
    EXPECT_EQ(entry["status"], "aborted") << entry.dump();
    EXPECT_EQ(entry["error"]["message"], "lights off requested") << entry.dump();
  }
  EXPECT_TRUE(daemon.wait_status([](const json& s) { return s["state"] == "idle"; }));
  EXPECT_EQ(daemon.get("/v1/status")["scans_completed"], 0);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, QueueLimitAndReloadOnSighup) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(
      temp, port,
      {{"queue_limit = 16", "queue_limit = 1"}, {"exposure_us = 20000", "exposure_us = 150000"}});
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto first = daemon.submit(json::object());
  ASSERT_TRUE(daemon.wait_status([&](const json& s) { return s["current_scan"] == first; }));
  (void)daemon.submit(json::object());  // waits
  auto full = daemon.http().Post("/v1/scans", "{}", "application/json");
  ASSERT_TRUE(full);
  EXPECT_EQ(full->status, 503) << full->body;
  EXPECT_TRUE(contains(full->body, "queue full")) << full->body;
  EXPECT_EQ(daemon.get("/v1/status")["last_error"]["code"], 6);  // queue_full, as the PLC reads it

  // A broken file is logged and the running configuration kept.
  const std::string good = file_contents(config);
  std::ofstream(config) << "[daemon\nqueue_limit = ";
  ::kill(daemon.pid(), SIGHUP);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!contains(daemon.log(), "keeping the running configuration") &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(20ms);
  EXPECT_TRUE(contains(daemon.log(), "keeping the running configuration")) << daemon.log();
  EXPECT_EQ(daemon.get("/v1/status")["queue_limit"], 1);

  std::string larger = good;
  larger.replace(larger.find("queue_limit = 1"), 15, "queue_limit = 4");
  std::ofstream(config) << larger;
  ::kill(daemon.pid(), SIGHUP);
  EXPECT_TRUE(daemon.wait_status([](const json& s) { return s["queue_limit"] == 4; }))
      << daemon.log();
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, KilledWhileSavingThenRestartedLeavesNoHalfScan) {
  TempDir temp;
  const int port = free_port();
  // Full size, so that processing takes long enough to be caught in.
  auto config = daemon_config(temp, port);
  {
    std::string text = file_contents(config);
    text.replace(text.find("width = 160"), 11, "width = 960");
    text.replace(text.find("height = 120"), 12, "height = 720");
    std::ofstream(config) << text;
  }
  std::int64_t id = 0;
  {
    Daemon daemon(config, port, temp / "psrigd.log");
    ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
    id = daemon.submit({{"sample_id", "K-9"}});
    ASSERT_TRUE(daemon.wait_status([](const json& s) { return s["state"] == "processing"; }))
        << daemon.log();
    EXPECT_EQ(daemon.signal_and_wait(SIGKILL), 128 + SIGKILL);
  }
  // The scan directory was written before processing began: the kill left
  // it (and a staging directory of maps) without a `done` row.
  const auto leftovers = list_directory(temp / "scans");
  EXPECT_GT(leftovers.size(), 1U);

  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto entry = daemon.get("/v1/scans/" + std::to_string(id));
  EXPECT_EQ(entry["status"], "failed") << entry.dump();
  EXPECT_TRUE(contains(entry["error"]["message"].get<std::string>(), "interrupted"))
      << entry.dump();
  // No half scan: the raw frames were whole (they cannot be taken again)
  // and stay, named by the row; the maps being made when it died do not.
  EXPECT_TRUE(contains(entry["error"]["message"].get<std::string>(), "raw frames kept"))
      << entry.dump();
  ASSERT_TRUE(entry["scan_directory"].is_string()) << entry.dump();
  EXPECT_TRUE(entry["maps_directory"].is_null()) << entry.dump();
  const fs::path kept = entry["scan_directory"].get<std::string>();
  EXPECT_TRUE(fs::exists(kept / "scan.json"));
  for (const auto& name : list_directory(kept))
    EXPECT_TRUE(name != "maps" && !name.starts_with(".")) << "no half maps: " << name;
  for (const auto& name : list_directory(temp / "scans"))
    EXPECT_TRUE(name.starts_with("catalogue.sqlite") || name == kept.filename().string())
        << "no half scan: " << name;
  // And it serves on.
  const auto next = daemon.submit({{"sample_id", "K-10"}});
  EXPECT_EQ(daemon.wait_finished(next, 60s)["status"], "done") << daemon.log();
  EXPECT_EQ(daemon.get("/v1/scans?status=done")["scans"].size(), 1U);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// A fault fails its scan, names the device, and leaves the daemon serving:
// the next scan opens the rig again.
TEST(Psrigd, AnLedDriverFaultFailsTheScanNotTheDaemon) {
  DaemonOnLedDriver setup(", retries = 0");
  ASSERT_TRUE(setup.driver) << setup.driver.error().describe();
  SimModbusDriver& driver = setup.led_driver();
  Daemon& daemon = setup.daemon();
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  driver.inject(ModbusFault::exception);
  const auto failed = daemon.wait_finished(daemon.submit({{"sample_id", "F-1"}}));
  EXPECT_EQ(failed["status"], "failed") << failed.dump();
  EXPECT_EQ(failed["error"]["code"], 2) << failed.dump();  // lights, as the PLC reads it
  const auto status = daemon.get("/v1/status");
  EXPECT_EQ(status["state"], "error") << status.dump();
  EXPECT_EQ(status["last_error"]["code_name"], "lights") << status.dump();
  EXPECT_TRUE(driver.leds_on().empty());

  driver.clear_fault();
  const auto next = daemon.wait_finished(daemon.submit({{"sample_id", "F-2"}}));
  EXPECT_EQ(next["status"], "done") << next.dump() << daemon.log();
  EXPECT_EQ(daemon.get("/v1/status")["state"], "idle");
  EXPECT_FALSE(driver.log().overlap());
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// An LED driver fault closes the rig; lights-off then still reaches the
// driver (the light backend opened alone), says when it cannot, and the
// failure to switch off on closing is shown, not dropped.
TEST(Psrigd, LightsOffWithTheRigClosedReachesTheLedDriver) {
  DaemonOnLedDriver setup(", retries = 0");
  ASSERT_TRUE(setup.driver) << setup.driver.error().describe();
  SimModbusDriver& driver = setup.led_driver();
  Daemon& daemon = setup.daemon();
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  driver.inject(ModbusFault::exception);
  const auto failed = daemon.wait_finished(daemon.submit({{"sample_id", "F-1"}}));
  EXPECT_EQ(failed["error"]["code_name"], "lights") << failed.dump();
  ASSERT_TRUE(daemon.wait_status([](const json& s) { return s["devices"]["open"] == false; }));
  const auto devices = daemon.get("/v1/status")["devices"];
  EXPECT_TRUE(contains(devices["error"].get<std::string>(), "switching every LED off"))
      << devices.dump() << daemon.log();

  // The driver still refuses: lights-off says so, naming the device.
  auto refused = daemon.http().Post("/v1/lights/off", "", "application/json");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 500) << refused->body;
  EXPECT_TRUE(contains(refused->body, "modbus")) << refused->body;

  // An LED left on behind the closed rig's back is switched off.
  driver.clear_fault();
  auto rig = config::load_config(setup.config);
  ASSERT_TRUE(rig) << rig.error().describe();
  // (another client of the driver, held open: its own closing would
  // switch the LED off)
  auto stuck = psrig::rig::open_lights(*rig);
  ASSERT_TRUE(stuck) << stuck.error().describe();
  ASSERT_TRUE((*stuck)->turn_on(1));
  ASSERT_EQ(driver.leds_on(), std::vector<int>{1});
  auto off = daemon.http().Post("/v1/lights/off", "", "application/json");
  ASSERT_TRUE(off);
  EXPECT_EQ(off->status, 200) << off->body;
  EXPECT_TRUE(driver.leds_on().empty());
  EXPECT_EQ(daemon.get("/v1/status")["devices"]["error"], "") << daemon.log();
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// A POST with no body and no Content-Length (curl -X POST URL) has an empty
// body: answered at once, not after httplib's read timeout with a 400.
TEST(Psrigd, BodilessPostsAreAnsweredAtOnce) {
  DaemonOnLedDriver setup("", {{"exposure_us = 20000", "exposure_us = 150000"}});  // slow scans
  ASSERT_TRUE(setup.driver) << setup.driver.error().describe();
  SimModbusDriver& driver = setup.led_driver();
  Daemon& daemon = setup.daemon();
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto bodiless = [&](const std::string& path) {
    const auto start = std::chrono::steady_clock::now();
    auto answer = raw_http(daemon.port(), "POST " + path + " HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_LT(std::chrono::steady_clock::now() - start, 1s) << path;
    return std::pair{answer.first, json::parse(body_of(answer.second), nullptr, false)};
  };
  // POST /v1/scans: a scan with the defaults.
  const auto [first_status, first] = bodiless("/v1/scans");
  ASSERT_EQ(first_status, 202) << first.dump();
  const auto [second_status, second] = bodiless("/v1/scans");
  ASSERT_EQ(second_status, 202) << second.dump();
  const auto running = first.value("id", std::int64_t{-1});
  const auto queued = second.value("id", std::int64_t{-1});
  EXPECT_EQ(daemon.get("/v1/scans/" + std::to_string(queued))["sample_id"], "");
  ASSERT_TRUE(daemon.wait_status([&](const json& s) { return s["current_scan"] == running; }));
  // Cancel.
  const auto [cancel_status, cancelled] =
      bodiless("/v1/scans/" + std::to_string(queued) + "/cancel");
  EXPECT_EQ(cancel_status, 200) << cancelled.dump();
  EXPECT_EQ(cancelled["status"], "aborted") << cancelled.dump();
  // Lights off, mid-scan and then with an LED left on behind the daemon's back.
  const auto [off_status, off] = bodiless("/v1/lights/off");
  EXPECT_EQ(off_status, 200) << off.dump();
  EXPECT_EQ(daemon.wait_finished(running)["status"], "aborted");
  EXPECT_TRUE(driver.leds_on().empty());
  auto rig = config::load_config(setup.config);
  ASSERT_TRUE(rig) << rig.error().describe();
  auto stuck = psrig::rig::open_lights(*rig);
  ASSERT_TRUE(stuck) << stuck.error().describe();
  ASSERT_TRUE((*stuck)->turn_on(2));
  ASSERT_EQ(driver.leds_on(), std::vector<int>{2});
  const auto [again_status, again] = bodiless("/v1/lights/off");
  EXPECT_EQ(again_status, 200) << again.dump();
  EXPECT_TRUE(driver.leds_on().empty());
  // DELETE the same way (curl -X DELETE): at once too.
  const auto start = std::chrono::steady_clock::now();
  const auto [deleted, answer] =
      raw_http(daemon.port(),
               "DELETE /v1/scans/" + std::to_string(running) + " HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(deleted, 200) << answer;
  EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// A chunked body is held to the same limit as one with a Content-Length:
// 8 MiB of it is refused (413, or the connection closed) without the
// daemon growing, with a token and without; one under the limit is taken.
TEST(Psrigd, AChunkedBodyIsBoundedLikeAnyOther) {
  for (const bool with_token : {false, true}) {
    SCOPED_TRACE(with_token ? "with a token" : "without a token");
    TempDir temp;
    const int port = free_port();
    Edits edits;
    if (with_token)
      edits.push_back({"listen_address = \"127.0.0.1\"",
                       "listen_address = \"127.0.0.1\"\ntoken = \"" + kToken + "\""});
    Daemon daemon(daemon_config(temp, port, edits), port, temp / "psrigd.log");
    ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
    const std::string authorization =
        with_token ? "Authorization: Bearer " + kToken + "\r\n" : std::string();
    // Under the limit, chunked: taken.
    const auto [small, small_answer] = chunked_http(
        port, "POST /v1/scans HTTP/1.1\r\nHost: x\r\nConnection: close\r\n" + authorization, 0, 1);
    EXPECT_EQ(small, 202) << small_answer;
    // (finished before the daemon is measured: a scan takes memory of its own)
    daemon.wait_finished(
        json::parse(body_of(small_answer), nullptr, false).value("id", std::int64_t{-1}));
    const std::vector<std::string> requests = {
        "POST /v1/scans HTTP/1.1\r\nHost: x\r\n" + authorization,
        "POST /v1/lights/off HTTP/1.1\r\nHost: x\r\n" + authorization,
        "POST /v1/nothing HTTP/1.1\r\nHost: x\r\n" + authorization,
        "DELETE /v1/scans/1 HTTP/1.1\r\nHost: x\r\n" + authorization,
        "POST /v1/scans HTTP/1.1\r\nHost: x\r\n",  // no token where one is needed
    };
    for (const auto& request : requests) {
      // The peak where it can be had: a body read whole, then freed, leaves
      // the resident set as it was.
      const bool peak = reset_peak_resident(daemon.pid());
      const long before = process_status_kb(daemon.pid(), "VmRSS");
      ASSERT_GT(before, 0);
      const auto [status, answer] = chunked_http(port, request, 8 << 20, 64 << 10);
      const long after = process_status_kb(daemon.pid(), peak ? "VmHWM" : "VmRSS");
      const int expected = with_token && !contains(request, "Authorization") ? 401 : 413;
      if (status != -1) {  // -1: closed before the answer was read
        EXPECT_EQ(status, expected) << request << answer;
      }
      EXPECT_LT(after - before, 10 * 1024) << request << before << " kB, then " << after << " kB";
      std::cerr << request.substr(0, request.find(' ', 6)) << (with_token ? " (token)" : "")
                << ": HTTP " << status << ", VmRSS " << before << " kB, then "
                << (peak ? "peak " : "") << after << " kB\n";
    }
    EXPECT_EQ(daemon.get("/v1/status")["state"], "idle");  // still serving
    EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
  }
}

// A camera that stops delivering frames (the simulated sensor slowed to one
// frame in 5 s against a 300 ms grab timeout): the scan fails as a camera
// timeout with every LED off, and the daemon serves on.
TEST(Psrigd, ACameraTimeoutFailsTheScanWithTheLedsOff) {
  DaemonOnLedDriver setup(
      "", {{"timeout_ms = 2000", "timeout_ms = 300"},
           {"readout_us = 15000", "readout_us = 15000\nframe_interval_us = 5000000"}});
  ASSERT_TRUE(setup.driver) << setup.driver.error().describe();
  SimModbusDriver& driver = setup.led_driver();
  Daemon& daemon = setup.daemon();
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto failed = daemon.wait_finished(daemon.submit({{"sample_id", "T"}}));
  EXPECT_EQ(failed["status"], "failed") << failed.dump();
  EXPECT_EQ(failed["error"]["code_name"], "camera") << failed.dump();
  EXPECT_TRUE(contains(failed["error"]["message"].get<std::string>(), "camera.timeout_ms"))
      << failed.dump();
  EXPECT_TRUE(driver.leds_on().empty());
  EXPECT_FALSE(driver.log().overlap());
  for (const auto& name : list_directory(setup.temp / "scans"))
    EXPECT_TRUE(name.starts_with("catalogue.sqlite")) << "no half scan: " << name;

  // The camera back to its pace: once the daemon has read the file again
  // (its main loop takes SIGHUP within 200 ms; the worker applies it before
  // the next scan), it scans again.
  daemon_config(setup.temp, setup.port, {modbus_lights(driver.port())});
  ::kill(daemon.pid(), SIGHUP);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!contains(daemon.log(), "SIGHUP") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  ASSERT_TRUE(contains(daemon.log(), "SIGHUP")) << daemon.log();
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(daemon.wait_finished(daemon.submit({{"sample_id", "T"}}))["status"], "done")
      << daemon.log();
  EXPECT_TRUE(driver.leds_on().empty());
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, AMissingCameraFailsEachScanUntilAReloadFixesIt) {
  TempDir temp;
  const int port = free_port();
  const auto config = daemon_config(temp, port);
  const std::string good = file_contents(config);
  std::string broken = good;
  broken.replace(broken.find("backend = \"sim\"\nexposure_us"), 28,
                 "backend = \"v4l2\"\ndevice = \"/dev/video77\"\nexposure_us");
  std::ofstream(config) << broken;
  Daemon daemon(config, port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto devices = daemon.get("/v1/status")["devices"];
  EXPECT_FALSE(devices["open"].get<bool>());
  EXPECT_TRUE(contains(devices["error"].get<std::string>(), "/dev/video77")) << devices.dump();
  for (int attempt = 0; attempt < 2; ++attempt) {
    const auto failed = daemon.wait_finished(daemon.submit({{"sample_id", "C"}}));
    EXPECT_EQ(failed["status"], "failed") << failed.dump();
    EXPECT_EQ(failed["error"]["code_name"], "camera") << failed.dump();
    EXPECT_TRUE(contains(failed["error"]["message"].get<std::string>(), "camera.device"))
        << failed.dump();
  }
  std::ofstream(config) << good;
  ::kill(daemon.pid(), SIGHUP);
  ASSERT_TRUE(daemon.wait_status([](const json& s) { return s["devices"]["open"] == true; }))
      << daemon.log();
  EXPECT_EQ(daemon.wait_finished(daemon.submit({{"sample_id", "C"}}))["status"], "done");
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

TEST(Psrigd, PsrigStatusAndRemoteScan) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  auto status = run_program("psrig", {"status", "--url", daemon.url()});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  EXPECT_TRUE(contains(status.out, "psrigd at " + daemon.url() + ": idle")) << status.out;
  EXPECT_TRUE(contains(status.out, "simulated camera")) << status.out;

  auto scan = run_program("psrig", {"scan", "--remote", daemon.url(), "--sample-id", "R-1",
                                    "--description", "remote", "--tag", "a", "--tag", "b"});
  ASSERT_EQ(scan.exit_code, 0) << scan.err;
  EXPECT_TRUE(contains(scan.err, "scan 1 done")) << scan.err;
  EXPECT_TRUE(contains(scan.out, "maps: ")) << scan.out;
  EXPECT_TRUE(contains(scan.err, "queued")) << scan.err;
  const auto entry = daemon.get("/v1/scans/1");
  EXPECT_EQ(entry["sample_id"], "R-1");
  EXPECT_EQ(entry["tags"], json({"a", "b"}));
  EXPECT_EQ(entry["source"], "http");

  auto json_status = run_program("psrig", {"status", "--url", daemon.url(), "--json"});
  ASSERT_EQ(json_status.exit_code, 0);
  EXPECT_EQ(json::parse(json_status.out)["scans_completed"], 1);

  // Usage mistakes and an absent daemon.
  EXPECT_EQ(run_program("psrig", {"scan"}).exit_code, 2);
  EXPECT_EQ(
      run_program("psrig", {"scan", "--remote", daemon.url(), "--config", "x.toml"}).exit_code, 2);
  EXPECT_EQ(run_program("psrig", {"scan", "--config", "x.toml", "--tag", "a"}).exit_code, 2);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
  auto gone = run_program("psrig", {"status", "--url", daemon.url()});
  EXPECT_EQ(gone.exit_code, 1);
  EXPECT_TRUE(contains(gone.err, "cannot reach psrigd")) << gone.err;
  auto nowhere = run_program("psrig", {"scan", "--remote", daemon.url()});
  EXPECT_EQ(nowhere.exit_code, 1);
}

// Ctrl-C on `psrig scan --remote` cancels the scan on the daemon.
TEST(Psrigd, InterruptingARemoteScanCancelsIt) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port, {{"exposure_us = 20000", "exposure_us = 200000"}}), port,
                temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const ProgramCommand psrig("psrig", {"scan", "--remote", daemon.url(), "-q"});
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, psrig.file().c_str(), nullptr, nullptr, psrig.argv(), environ), 0);
  ASSERT_TRUE(daemon.wait_status([](const json& s) { return s["state"] == "scanning"; }));
  ::kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  EXPECT_EQ(daemon.wait_finished(1)["status"], "aborted");
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

}  // namespace
}  // namespace psrig::test
