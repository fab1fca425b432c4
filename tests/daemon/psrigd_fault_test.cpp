// A full disk under psrigd: its storage root on a small tmpfs in the
// daemon's own mount namespace (gone with the daemon, however the test
// ends), filled by the test through /proc/PID/root. The scan fails with the
// storage code, leaves nothing half-written, the LEDs end off, and once
// there is room again the daemon scans as before.

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "daemon_process.h"
#include "sim_modbus_driver.h"

namespace psrig::test {
namespace {

// Room for the catalogue and a few 160x120 scans, not for many more.
constexpr const char* kTmpfsOptions = "size=4m";

// Appends to `file` until it holds `bytes` more or the disk is full; the
// bytes written.
std::uintmax_t fill(const fs::path& file, std::uintmax_t bytes) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  EXPECT_GE(fd, 0) << file << ": " << std::strerror(errno);
  if (fd < 0) return 0;
  const std::vector<char> block(64 << 10, 'x');
  std::uintmax_t written = 0;
  while (written < bytes) {
    const auto n =
        ::write(fd, block.data(), std::min<std::uintmax_t>(block.size(), bytes - written));
    if (n <= 0) break;  // ENOSPC
    written += static_cast<std::uintmax_t>(n);
  }
  ::close(fd);
  return written;
}

std::uintmax_t free_bytes(const fs::path& directory) {
  std::error_code ec;
  const auto space = fs::space(directory, ec);
  EXPECT_FALSE(ec) << directory << ": " << ec.message();
  return ec ? 0 : space.available;
}

int led_on_switches(const SimModbusDriver& driver) {
  int ons = 0;
  for (const auto& event : driver.log().events())
    ons += event.on ? 1 : 0;
  return ons;
}

// The storage root holds the catalogue's files, the filler, and the
// directories of the `done` scans: never a half scan or a staging directory.
void expect_only(const fs::path& storage, const std::vector<std::string>& scans) {
  for (const auto& name : list_directory(storage)) {
    const bool allowed = name.starts_with("catalogue.sqlite") || name == "filler" ||
                         std::find(scans.begin(), scans.end(), name) != scans.end();
    EXPECT_TRUE(allowed) << name << " left in the storage root";
  }
}

class PsrigdFullDisk : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(temp_ / "scans");
    if (auto why = private_tmpfs_unavailable(temp_ / "scans")) GTEST_SKIP() << *why;
    auto driver = SimModbusDriver::start({});
    ASSERT_TRUE(driver) << driver.error().describe();
    driver_ = std::move(*driver);
    port_ = free_port();
  }
  // config/sim.toml with the LEDs on the test's Modbus driver, `edits` on top.
  fs::path config(Edits edits = {}) {
    edits.insert(edits.begin(), modbus_lights(driver_->port()));
    return daemon_config(temp_, port_, edits);
  }
  std::unique_ptr<Daemon> start(const fs::path& config) {
    auto daemon = std::make_unique<Daemon>(config, port_, temp_ / "psrigd.log",
                                           PrivateTmpfs{temp_ / "scans", kTmpfsOptions});
    EXPECT_TRUE(daemon->wait_ready()) << "exit code " << daemon->exit_code() << "\n"
                                      << daemon->log();
    return daemon;
  }
  void expect_leds_safe() {
    EXPECT_FALSE(driver_->log().overlap()) << *driver_->log().overlap();
    EXPECT_TRUE(driver_->log().on_now().empty());
    EXPECT_TRUE(driver_->leds_on().empty());
  }

  TempDir temp_;
  std::unique_ptr<SimModbusDriver> driver_;
  int port_ = 0;
};

// The disk is nearly full before the scan: refused before any LED goes on,
// with the directory and the free and needed bytes in the message.
TEST_F(PsrigdFullDisk, ANearlyFullDiskFailsTheScanBeforeAnyLed) {
  auto daemon = start(config());
  ASSERT_FALSE(daemon->exited());
  const fs::path storage = daemon->seen_by_daemon(temp_ / "scans");
  ASSERT_GT(free_bytes(storage), 0U);
  ASSERT_LT(free_bytes(storage), 8U << 20) << "not on the test's tmpfs: " << storage;
  // 256 KiB left: the catalogue can still write, a scan (~1 MiB) cannot.
  fill(storage / "filler", free_bytes(storage) - (256 << 10));

  const auto failed = daemon->wait_finished(daemon->submit({{"sample_id", "FULL-1"}}));
  EXPECT_EQ(failed["status"], "failed") << failed.dump();
  EXPECT_EQ(failed["error"]["code_name"], "storage") << failed.dump();
  const std::string message = failed["error"]["message"].get<std::string>();
  EXPECT_TRUE(contains(message, (temp_ / "scans").filename().string())) << message;
  EXPECT_TRUE(contains(message, "free")) << message;
  EXPECT_TRUE(contains(message, "KiB")) << message;
  EXPECT_TRUE(failed["scan_directory"].is_null()) << failed.dump();
  EXPECT_EQ(led_on_switches(*driver_), 0) << "an LED went on for a scan with nowhere to go";
  EXPECT_EQ(daemon->get("/v1/status")["last_error"]["code_name"], "storage");
  expect_only(storage, {});

  fs::remove(storage / "filler");
  const auto next = daemon->wait_finished(daemon->submit({{"sample_id", "FULL-2"}}));
  EXPECT_EQ(next["status"], "done") << next.dump() << daemon->log();
  EXPECT_EQ(led_on_switches(*driver_), 3);
  expect_leds_safe();
  EXPECT_EQ(daemon->signal_and_wait(SIGTERM), 0) << daemon->log();
}

// Something else fills the disk while the LEDs are on: writing the frames
// fails, the scan fails with the storage code, its staging directory goes,
// and the daemon scans again once there is room.
TEST_F(PsrigdFullDisk, ADiskFillingMidScanFailsItAndLeavesNoHalfScan) {
  auto daemon = start(config({{"exposure_us = 20000", "exposure_us = 100000"}}));
  ASSERT_FALSE(daemon->exited());
  const fs::path storage = daemon->seen_by_daemon(temp_ / "scans");
  const auto id = daemon->submit({{"sample_id", "MID-1"}});
  const auto deadline = std::chrono::steady_clock::now() + 15s;
  while (driver_->leds_on().empty() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  ASSERT_FALSE(driver_->leds_on().empty()) << "no LED came on\n" << daemon->log();
  fill(storage / "filler", UINTMAX_MAX);
  EXPECT_EQ(free_bytes(storage), 0U);

  const auto failed = daemon->wait_finished(id);
  EXPECT_EQ(failed["status"], "failed") << failed.dump() << daemon->log();
  EXPECT_EQ(failed["error"]["code_name"], "storage") << failed.dump();
  EXPECT_TRUE(contains(failed["error"]["message"].get<std::string>(), "No space left"))
      << failed.dump();
  EXPECT_TRUE(failed["scan_directory"].is_null()) << failed.dump();
  expect_leds_safe();
  expect_only(storage, {});
  const auto status = daemon->get("/v1/status");
  EXPECT_EQ(status["last_error"]["code_name"], "storage") << status.dump();

  fs::remove(storage / "filler");
  const auto next = daemon->wait_finished(daemon->submit({{"sample_id", "MID-2"}}));
  ASSERT_EQ(next["status"], "done") << next.dump() << daemon->log();
  expect_leds_safe();
  expect_only(storage, {fs::path(next["scan_directory"].get<std::string>()).filename().string()});
  EXPECT_EQ(daemon->signal_and_wait(SIGTERM), 0) << daemon->log();
}

// Not a byte free when the scan is asked for: the catalogue gives back its
// reserve to record the scan and why it failed; once even that is spent,
// new scans are refused with a message naming the catalogue, and the
// daemon still answers.
TEST_F(PsrigdFullDisk, AFullDiskIsRecordedThenRefusedAndTheDaemonServesOn) {
  auto daemon = start(config());
  ASSERT_FALSE(daemon->exited());
  const fs::path storage = daemon->seen_by_daemon(temp_ / "scans");
  ASSERT_TRUE(fs::exists(storage / "catalogue.sqlite-reserve"));
  fill(storage / "filler", UINTMAX_MAX);
  ASSERT_EQ(free_bytes(storage), 0U);

  const auto failed = daemon->wait_finished(daemon->submit({{"sample_id", "NONE-1"}}));
  EXPECT_EQ(failed["status"], "failed") << failed.dump() << daemon->log();
  EXPECT_EQ(failed["error"]["code_name"], "storage") << failed.dump();
  EXPECT_TRUE(contains(failed["error"]["message"].get<std::string>(), "KiB free")) << failed.dump();
  EXPECT_TRUE(contains(daemon->log(), "gave back the catalogue's reserve")) << daemon->log();

  // Each further scan is recorded as failed while the WAL has room, then refused.
  std::string refusal;
  for (int n = 0; n < 100 && refusal.empty(); ++n) {
    auto res = daemon->http().Post("/v1/scans", "{}", "application/json");
    ASSERT_TRUE(res);
    if (res->status == 202) {
      const auto id = json::parse(res->body)["id"].get<std::int64_t>();
      EXPECT_EQ(daemon->wait_finished(id, 10s)["status"], "failed");
      continue;
    }
    EXPECT_EQ(res->status, 503) << res->body;
    refusal = json::parse(res->body, nullptr, false).value("error", "");
  }
  EXPECT_TRUE(contains(refusal, "catalogue.sqlite")) << refusal;
  EXPECT_TRUE(contains(refusal, "disk is full")) << refusal;
  EXPECT_EQ(daemon->get("/v1/status")["last_error"]["code_name"], "storage");
  EXPECT_EQ(led_on_switches(*driver_), 0);

  fs::remove(storage / "filler");
  const auto next = daemon->wait_finished(daemon->submit({{"sample_id", "NONE-2"}}));
  EXPECT_EQ(next["status"], "done") << next.dump() << daemon->log();
  EXPECT_TRUE(fs::exists(storage / "catalogue.sqlite-reserve")) << "the reserve is set aside again";
  // No accepted scan was left `queued` or `running` (issue 14): an end the
  // disk refused was written before the new row.
  for (const char* status : {"queued", "running"})
    EXPECT_TRUE(daemon->get(std::string("/v1/scans?status=") + status)["scans"].empty())
        << status << "\n"
        << daemon->log();
  expect_leds_safe();
  EXPECT_EQ(daemon->signal_and_wait(SIGTERM), 0) << daemon->log();
}

}  // namespace
}  // namespace psrig::test
