// psrigd with its PLC and its service manager, as on a production line: a
// Modbus TCP client raises the trigger coil of a real daemon and follows the
// scan through the input registers to its result; the daemon's notify
// messages arrive on a NOTIFY_SOCKET as systemd would read them.

#include <array>
#include <cstdint>
#include <modbus.h>
#include <set>
#include <sys/un.h>

#include "daemon_process.h"
#include "psrig/daemon/modbus_server.h"
#include "psrig/daemon/scan_control.h"

namespace psrig::test {
namespace {

using daemon::DaemonState;
namespace coil = daemon::modbus_coil;
namespace input = daemon::modbus_input;
namespace reg = daemon::modbus_register;

// A PLC: a libmodbus TCP client with the daemon's register map.
class Plc {
 public:
  explicit Plc(int port) : context_(modbus_new_tcp("127.0.0.1", port)) {}
  ~Plc() {
    if (context_ == nullptr) return;
    modbus_close(context_);
    modbus_free(context_);
  }
  Plc(const Plc&) = delete;
  Plc& operator=(const Plc&) = delete;

  [[nodiscard]] bool connect() {
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (std::chrono::steady_clock::now() < deadline) {
      if (context_ != nullptr && modbus_connect(context_) == 0) return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }
  bool write_coil(int address, bool on) {
    return modbus_write_bit(context_, address, on ? 1 : 0) == 1;
  }
  [[nodiscard]] std::array<std::uint16_t, reg::count> registers() {
    std::array<std::uint16_t, reg::count> words{};
    EXPECT_EQ(modbus_read_input_registers(context_, 0, reg::count, words.data()), reg::count)
        << modbus_strerror(errno);
    return words;
  }
  [[nodiscard]] std::array<std::uint8_t, input::count> inputs() {
    std::array<std::uint8_t, input::count> bits{};
    EXPECT_EQ(modbus_read_input_bits(context_, 0, input::count, bits.data()), input::count)
        << modbus_strerror(errno);
    return bits;
  }

 private:
  modbus_t* context_;
};

std::uint32_t word32(const std::array<std::uint16_t, reg::count>& words, int at) {
  return (std::uint32_t{words[static_cast<std::size_t>(at)]} << 16) |
         words[static_cast<std::size_t>(at + 1)];
}

fs::path plc_config(const TempDir& temp, int http_port, int modbus_port) {
  return daemon_config(temp, http_port,
                       {{"modbus_port = 0", "modbus_port = " + std::to_string(modbus_port)},
                        {"exposure_us = 20000", "exposure_us = 60000"}});  // long enough to watch
}

TEST(PsrigdPlc, ARisingEdgeScansAndTheRegistersFollowItToTheEnd) {
  TempDir temp;
  const int http_port = free_port(), modbus_port = free_port();
  Daemon daemon(plc_config(temp, http_port, modbus_port), http_port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  Plc plc(modbus_port);
  ASSERT_TRUE(plc.connect()) << daemon.log();

  auto words = plc.registers();
  auto bits = plc.inputs();
  EXPECT_EQ(words[reg::state], static_cast<std::uint16_t>(DaemonState::idle));
  EXPECT_TRUE(bits[input::ready]);
  EXPECT_FALSE(bits[input::busy]);
  EXPECT_EQ(word32(words, reg::last_scan_id), 0u);

  // The edge: 0 -> 1. Holding the coil at 1 must not queue a second scan.
  ASSERT_TRUE(plc.write_coil(coil::trigger, false));
  ASSERT_TRUE(plc.write_coil(coil::trigger, true));
  ASSERT_TRUE(plc.write_coil(coil::trigger, true));
  words = plc.registers();
  const std::uint32_t id = word32(words, reg::triggered_scan_id);
  ASSERT_GT(id, 0u);
  EXPECT_EQ(words[reg::triggers_accepted], 1);

  // Follow it as a PLC would: busy and scanning while it runs, progress
  // never falling, then ready with the scan as the last one.
  std::set<std::uint16_t> states;
  bool seen_busy = false;
  int last_progress = 0;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < deadline) {
    words = plc.registers();
    bits = plc.inputs();
    states.insert(words[reg::state]);
    seen_busy = seen_busy || bits[input::busy];
    if (word32(words, reg::current_scan_id) == id) {
      EXPECT_GE(words[reg::progress], last_progress);
      last_progress = words[reg::progress];
    }
    if (word32(words, reg::last_scan_id) == id && bits[input::ready]) break;
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_EQ(word32(words, reg::last_scan_id), id) << daemon.log();
  EXPECT_TRUE(seen_busy);
  EXPECT_TRUE(states.contains(static_cast<std::uint16_t>(DaemonState::scanning)));
  EXPECT_EQ(words[reg::state], static_cast<std::uint16_t>(DaemonState::idle));
  EXPECT_EQ(words[reg::error_code], 0);
  EXPECT_FALSE(bits[input::error]);
  EXPECT_EQ(word32(words, reg::scans_completed), 1u);
  EXPECT_EQ(word32(words, reg::scans_failed), 0u);

  // The same scan over HTTP: done, with its maps, and the source recorded.
  const auto entry = daemon.get("/v1/scans/" + std::to_string(id));
  EXPECT_EQ(entry["status"], "done") << entry.dump();
  const auto all = daemon.get("/v1/scans");
  EXPECT_EQ(all["scans"].size(), 1u) << "one edge, one scan";

  // Drop and raise again: a second scan.
  ASSERT_TRUE(plc.write_coil(coil::trigger, false));
  ASSERT_TRUE(plc.write_coil(coil::trigger, true));
  words = plc.registers();
  EXPECT_GT(word32(words, reg::triggered_scan_id), id);
  EXPECT_EQ(words[reg::triggers_accepted], 2);
  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
}

// A datagram socket standing in for systemd's notify socket.
class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::snprintf(address.sun_path, sizeof address.sun_path, "%s", path.c_str());
    bound_ = ::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    timeval timeout{0, 100'000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  }
  ~NotifySocket() { ::close(fd_); }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;

  [[nodiscard]] bool bound() const { return bound_; }
  // Every message that arrives within `wait`, collected into `messages`.
  void drain(std::vector<std::string>& messages, std::chrono::milliseconds wait) {
    const auto deadline = std::chrono::steady_clock::now() + wait;
    char buffer[4096];
    while (std::chrono::steady_clock::now() < deadline) {
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n > 0) messages.emplace_back(buffer, static_cast<std::size_t>(n));
    }
  }

 private:
  fs::path path_;
  int fd_ = -1;
  bool bound_ = false;
};

bool any_starts_with(const std::vector<std::string>& messages, const std::string& prefix) {
  return std::any_of(messages.begin(), messages.end(),
                     [&](const std::string& m) { return m.starts_with(prefix); });
}

TEST(PsrigdSystemd, NotifiesReadyStatusWatchdogReloadAndStopping) {
  TempDir temp;
  NotifySocket socket(temp / "notify");
  ASSERT_TRUE(socket.bound());
  const int port = free_port();
  const fs::path config = daemon_config(temp, port);
  // What systemd sets for a Type=notify unit with WatchdogSec=1s.
  ::setenv("NOTIFY_SOCKET", (temp / "notify").c_str(), 1);
  ::setenv("WATCHDOG_USEC", "1000000", 1);
  ::unsetenv("WATCHDOG_PID");  // psrigd's pid is not known before the spawn: any pid may ping
  Daemon daemon(config, port, temp / "psrigd.log");
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();

  std::vector<std::string> messages;
  socket.drain(messages, 1500ms);  // three watchdog intervals (half of WatchdogSec)
  EXPECT_TRUE(any_starts_with(messages, "READY=1")) << daemon.log();
  EXPECT_TRUE(any_starts_with(messages, "STATUS=idle")) << ::testing::PrintToString(messages);
  EXPECT_GE(std::count(messages.begin(), messages.end(), "WATCHDOG=1"), 2)
      << ::testing::PrintToString(messages);

  ::kill(daemon.pid(), SIGHUP);
  socket.drain(messages, 500ms);
  EXPECT_TRUE(any_starts_with(messages, "RELOADING=1")) << ::testing::PrintToString(messages);

  const auto id = daemon.submit({{"sample_id", "N-1"}});
  EXPECT_EQ(daemon.wait_finished(id)["status"], "done");
  socket.drain(messages, 400ms);
  EXPECT_TRUE(any_starts_with(messages, "STATUS=idle; 0 queued; 1 done"))
      << ::testing::PrintToString(messages);

  EXPECT_EQ(daemon.signal_and_wait(SIGTERM), 0) << daemon.log();
  socket.drain(messages, 200ms);
  EXPECT_TRUE(any_starts_with(messages, "STOPPING=1")) << ::testing::PrintToString(messages);
}

}  // namespace
}  // namespace psrig::test
