// The PLC's Modbus server against a real libmodbus client on loopback TCP,
// over a scripted ScanControl: the trigger coil's rising-edge rule, the
// status in discrete inputs and input registers (32-bit word order
// included), refusals as error codes, and a server that shrugs off clients
// that hang up, stall or send garbage, and stops promptly.

#include "psrig/daemon/modbus_server.h"

#include <algorithm>
#include <arpa/inet.h>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <modbus.h>
#include <mutex>
#include <netinet/in.h>
#include <poll.h>
#include <string>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace psrig::daemon {
namespace {

using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

DaemonStatus idle_status() {
  DaemonStatus status;
  status.state = DaemonState::idle;
  return status;
}

// A scanning service whose status the test scripts; it records what the
// server asked of it.
class FakeScanControl : public ScanControl {
 public:
  DaemonStatus status() const override {
    const std::scoped_lock lock(mutex_);
    return status_;
  }
  Result<std::int64_t> submit(catalogue::ScanSubmission submission) override {
    const std::scoped_lock lock(mutex_);
    submissions_.push_back(std::move(submission));
    // As ScanService refuses: a full queue names its key, a catalogue
    // that cannot write is a storage error.
    if (refuse_ && !storage_fails_)
      return std::unexpected(
          bad_input("rig.toml", "daemon.queue_limit", "queue full: 4 scans waiting")
              .with(ErrorCode::queue_full));
    if (refuse_) return std::unexpected(io_error("catalogue.sqlite", "database or disk is full"));
    ++status_.queue_length;
    return next_id_++;
  }
  Status lights_off() override {
    const std::scoped_lock lock(mutex_);
    ++lights_off_calls_;
    if (lights_fail_) return std::unexpected(internal_error("LED driver gone"));
    return {};
  }

  void script(const std::function<void(DaemonStatus&)>& change) {
    const std::scoped_lock lock(mutex_);
    change(status_);
  }
  void refuse(bool refuse, bool storage_fails = false) {
    const std::scoped_lock lock(mutex_);
    refuse_ = refuse;
    storage_fails_ = storage_fails;
  }
  void fail_lights(bool fail) {
    const std::scoped_lock lock(mutex_);
    lights_fail_ = fail;
  }
  void next_id(std::int64_t id) {
    const std::scoped_lock lock(mutex_);
    next_id_ = id;
  }
  std::vector<catalogue::ScanSubmission> submissions() const {
    const std::scoped_lock lock(mutex_);
    return submissions_;
  }
  int lights_off_calls() const {
    const std::scoped_lock lock(mutex_);
    return lights_off_calls_;
  }

 private:
  mutable std::mutex mutex_;
  DaemonStatus status_ = idle_status();
  std::vector<catalogue::ScanSubmission> submissions_;
  std::int64_t next_id_ = 1;
  bool refuse_ = false;
  bool storage_fails_ = false;
  bool lights_fail_ = false;
  int lights_off_calls_ = 0;
};

// The PLC: a libmodbus TCP client.
class Plc {
 public:
  explicit Plc(int port) : ctx_(modbus_new_tcp("127.0.0.1", port)) {
    modbus_set_response_timeout(ctx_, 2, 0);
    connected_ = modbus_connect(ctx_) == 0;
  }
  ~Plc() {
    modbus_close(ctx_);
    modbus_free(ctx_);
  }
  Plc(const Plc&) = delete;
  Plc& operator=(const Plc&) = delete;

  bool connected() const { return connected_; }
  bool write_coil(int address, bool value) { return modbus_write_bit(ctx_, address, value) == 1; }
  bool coil(int address) {
    std::uint8_t bit = 0xAA;
    EXPECT_EQ(modbus_read_bits(ctx_, address, 1, &bit), 1) << modbus_strerror(errno);
    return bit != 0;
  }
  std::vector<bool> inputs() {
    std::uint8_t bits[modbus_input::count] = {};
    EXPECT_EQ(modbus_read_input_bits(ctx_, 0, modbus_input::count, bits), modbus_input::count)
        << modbus_strerror(errno);
    return std::vector<bool>(bits, bits + modbus_input::count);
  }
  std::vector<std::uint16_t> registers() {
    std::vector<std::uint16_t> words(modbus_register::count, 0xDEAD);
    EXPECT_EQ(modbus_read_input_registers(ctx_, 0, modbus_register::count, words.data()),
              modbus_register::count)
        << modbus_strerror(errno);
    return words;
  }
  modbus_t* ctx() { return ctx_; }

 private:
  modbus_t* ctx_;
  bool connected_ = false;
};

// A 32-bit value as the register map documents it: high word first.
std::uint32_t u32(const std::vector<std::uint16_t>& words, int address) {
  return (std::uint32_t{words[address]} << 16) | words[address + 1];
}

// A raw TCP connection, for clients libmodbus would never be.
int raw_connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  return fd;
}

void send_bytes(int fd, const std::vector<std::uint8_t>& bytes) {
  EXPECT_EQ(::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL),
            static_cast<ssize_t>(bytes.size()));
}

// What arrives on `fd` within `timeout`: an answer, or empty once the server
// closed the connection (or nothing came).
std::vector<std::uint8_t> receive_within(int fd, milliseconds timeout, bool* closed = nullptr) {
  std::vector<std::uint8_t> bytes;
  if (closed) *closed = false;
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return bytes;
  std::uint8_t buffer[300];
  const ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
  if (n > 0)
    bytes.assign(buffer, buffer + n);
  else if (closed)
    *closed = true;
  return bytes;
}

// The 99th percentile of `samples` (sorted in place).
std::int64_t p99_us(std::vector<std::chrono::microseconds>& samples) {
  std::sort(samples.begin(), samples.end());
  const std::size_t index = (samples.size() * 99 + 99) / 100 - 1;
  return samples[std::min(index, samples.size() - 1)].count();
}

class ModbusServerTest : public ::testing::Test {
 protected:
  void SetUp() override { start(); }

  void start(ModbusServerOptions options = {}) {
    server_.reset();
    options.port = 0;
    auto started = ModbusServer::start(control_, options);
    ASSERT_TRUE(started.has_value()) << started.error().describe();
    server_ = std::move(*started);
    ASSERT_GT(server_->port(), 0);
  }

  FakeScanControl control_;
  std::unique_ptr<ModbusServer> server_;
};

TEST_F(ModbusServerTest, TriggerCoilSubmitsOnceOnEachRisingEdge) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  EXPECT_FALSE(plc.coil(modbus_coil::trigger));

  // The acknowledgement of the write means the edge has acted.
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  ASSERT_EQ(control_.submissions().size(), 1u);
  EXPECT_EQ(control_.submissions()[0].source, "modbus");
  EXPECT_TRUE(plc.coil(modbus_coil::trigger));  // reads back as written

  // Held high, or written high again: no further scan.
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  EXPECT_EQ(plc.registers()[modbus_register::triggers_accepted], 1);
  EXPECT_EQ(control_.submissions().size(), 1u);

  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, false));
  EXPECT_FALSE(plc.coil(modbus_coil::trigger));
  EXPECT_EQ(control_.submissions().size(), 1u);
  control_.next_id(70'000);
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  EXPECT_EQ(control_.submissions().size(), 2u);

  // Write Multiple Coils (FC 15) counts the same; a second client shares the coil.
  Plc other(server_->port());
  ASSERT_TRUE(other.connected());
  EXPECT_TRUE(other.coil(modbus_coil::trigger));
  const std::uint8_t low[2] = {0, 0};
  const std::uint8_t high[2] = {1, 0};
  ASSERT_EQ(modbus_write_bits(other.ctx(), 0, 2, low), 2);
  ASSERT_EQ(modbus_write_bits(other.ctx(), 0, 2, high), 2);
  EXPECT_EQ(control_.submissions().size(), 3u);
  EXPECT_EQ(control_.lights_off_calls(), 0);

  const auto words = plc.registers();
  EXPECT_EQ(words[modbus_register::triggers_accepted], 3);
  EXPECT_EQ(words[modbus_register::triggers_refused], 0);
  EXPECT_EQ(u32(words, modbus_register::triggered_scan_id), 70'001u);
  EXPECT_EQ(words[modbus_register::queue_length], 3);
  const auto counters = server_->counters();
  EXPECT_EQ(counters.triggers_accepted, 3u);
  EXPECT_EQ(counters.clients, 2);
}

TEST_F(ModbusServerTest, StatusFollowsTheScanThroughInputsAndRegisters) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  control_.script([](DaemonStatus& s) { s.uptime = std::chrono::seconds(90'000); });
  auto inputs = plc.inputs();
  auto words = plc.registers();
  EXPECT_THAT(inputs, ::testing::ElementsAre(true, false, false, false));  // ready
  EXPECT_EQ(words[modbus_register::state], static_cast<int>(DaemonState::idle));
  EXPECT_EQ(u32(words, modbus_register::last_scan_id), 0u);
  EXPECT_EQ(u32(words, modbus_register::uptime_seconds), 90'000u);

  control_.script([](DaemonStatus& s) {
    s.state = DaemonState::scanning;
    s.progress_percent = 40;
    s.current_scan = 0x0001'2345;
    s.queue_length = 1;
  });
  inputs = plc.inputs();
  words = plc.registers();
  EXPECT_THAT(inputs, ::testing::ElementsAre(false, true, false, true));  // busy, scanning
  EXPECT_EQ(words[modbus_register::state], static_cast<int>(DaemonState::scanning));
  EXPECT_EQ(words[modbus_register::progress], 40);
  EXPECT_EQ(words[modbus_register::current_scan_id], 0x0001);  // high word first
  EXPECT_EQ(words[modbus_register::current_scan_id + 1], 0x2345);
  EXPECT_EQ(words[modbus_register::queue_length], 1);

  control_.script([](DaemonStatus& s) {
    s.state = DaemonState::processing;
    s.progress_percent = 180;  // clamped
    s.queue_length = 0;
  });
  inputs = plc.inputs();
  words = plc.registers();
  EXPECT_THAT(inputs, ::testing::ElementsAre(false, true, false, false));  // the swatch may move
  EXPECT_EQ(words[modbus_register::state], static_cast<int>(DaemonState::processing));
  EXPECT_EQ(words[modbus_register::progress], 100);

  control_.script([](DaemonStatus& s) {
    s.state = DaemonState::idle;
    s.progress_percent = 0;
    s.current_scan.reset();
    s.last_scan = 0x0001'2345;  // 74565: past one register
    s.scans_completed = 0x0002'0003;
    s.scans_failed = 7;
    s.uptime = std::chrono::seconds(90'061);
  });
  inputs = plc.inputs();
  words = plc.registers();
  EXPECT_THAT(inputs, ::testing::ElementsAre(true, false, false, false));
  EXPECT_EQ(words[modbus_register::last_scan_id], 0x0001);
  EXPECT_EQ(words[modbus_register::last_scan_id + 1], 0x2345);
  EXPECT_EQ(u32(words, modbus_register::last_scan_id), 74'565u);
  EXPECT_EQ(words[modbus_register::scans_completed], 0x0002);
  EXPECT_EQ(words[modbus_register::scans_completed + 1], 0x0003);
  EXPECT_EQ(u32(words, modbus_register::scans_failed), 7u);
  EXPECT_EQ(u32(words, modbus_register::current_scan_id), 0u);
  EXPECT_EQ(u32(words, modbus_register::uptime_seconds), 90'061u);
  EXPECT_EQ(words[modbus_register::error_code], 0);

  // A failed scan: the error input, and why.
  control_.script([](DaemonStatus& s) {
    s.state = DaemonState::error;
    s.last_error_code = catalogue::ScanErrorCode::camera;
    s.last_error = "camera: no frame within 2000 ms";
  });
  inputs = plc.inputs();
  words = plc.registers();
  EXPECT_THAT(inputs, ::testing::ElementsAre(true, false, true, false));  // ready again, error
  EXPECT_EQ(words[modbus_register::state], static_cast<int>(DaemonState::error));
  EXPECT_EQ(words[modbus_register::error_code], static_cast<int>(catalogue::ScanErrorCode::camera));

  // Starting up or stopping: neither ready nor busy.
  control_.script([](DaemonStatus& s) { s.state = DaemonState::stopping; });
  EXPECT_THAT(plc.inputs(), ::testing::ElementsAre(false, false, false, false));
  EXPECT_EQ(plc.registers()[modbus_register::error_code], 0);
}

TEST_F(ModbusServerTest, RefusedTriggerShowsAsErrorCodeUntilOneIsAccepted) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  control_.refuse(true);
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  EXPECT_EQ(control_.submissions().size(), 1u);
  auto words = plc.registers();
  EXPECT_TRUE(plc.inputs()[modbus_input::error]);
  EXPECT_EQ(words[modbus_register::error_code],
            static_cast<int>(catalogue::ScanErrorCode::queue_full));
  EXPECT_EQ(words[modbus_register::triggers_refused], 1);
  EXPECT_EQ(words[modbus_register::triggers_accepted], 0);

  // Refused because the daemon is on its way out.
  control_.script([](DaemonStatus& s) { s.state = DaemonState::stopping; });
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, false));
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  words = plc.registers();
  EXPECT_EQ(words[modbus_register::error_code],
            static_cast<int>(catalogue::ScanErrorCode::aborted));
  EXPECT_EQ(words[modbus_register::triggers_refused], 2);

  // Refused because the catalogue cannot write (a full disk): storage, not the queue.
  control_.script([](DaemonStatus& s) { s.state = DaemonState::idle; });
  control_.refuse(true, true);
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, false));
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  words = plc.registers();
  EXPECT_EQ(words[modbus_register::error_code],
            static_cast<int>(catalogue::ScanErrorCode::storage));
  EXPECT_EQ(words[modbus_register::triggers_refused], 3);

  control_.script([](DaemonStatus& s) { s.state = DaemonState::idle; });
  control_.refuse(false);
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, false));
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));
  EXPECT_FALSE(plc.inputs()[modbus_input::error]);
  words = plc.registers();
  EXPECT_EQ(words[modbus_register::error_code], 0);
  EXPECT_EQ(words[modbus_register::triggers_accepted], 1);
  EXPECT_EQ(u32(words, modbus_register::triggered_scan_id), 1u);
  EXPECT_EQ(control_.submissions().size(), 4u);
}

TEST_F(ModbusServerTest, LightsOffCoilActsOnItsRisingEdge) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  ASSERT_TRUE(plc.write_coil(modbus_coil::lights_off, true));
  EXPECT_EQ(control_.lights_off_calls(), 1);
  ASSERT_TRUE(plc.write_coil(modbus_coil::lights_off, true));
  EXPECT_EQ(control_.lights_off_calls(), 1);
  EXPECT_TRUE(control_.submissions().empty());
  EXPECT_FALSE(plc.inputs()[modbus_input::error]);

  control_.fail_lights(true);
  ASSERT_TRUE(plc.write_coil(modbus_coil::lights_off, false));
  ASSERT_TRUE(plc.write_coil(modbus_coil::lights_off, true));
  EXPECT_EQ(control_.lights_off_calls(), 2);
  EXPECT_TRUE(plc.inputs()[modbus_input::error]);
  EXPECT_EQ(plc.registers()[modbus_register::error_code],
            static_cast<int>(catalogue::ScanErrorCode::lights));
  EXPECT_EQ(server_->counters().lights_off, 1u);
}

TEST_F(ModbusServerTest, AddressesOutsideTheMapAreRefusedWithAnException) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  std::uint16_t words[4] = {};
  EXPECT_EQ(modbus_read_registers(plc.ctx(), 0, 1, words), -1);  // no holding registers
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_EQ(modbus_read_input_registers(plc.ctx(), modbus_register::count - 1, 2, words), -1);
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_EQ(modbus_write_bit(plc.ctx(), modbus_coil::count, 1), -1);
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_EQ(modbus_write_register(plc.ctx(), 0, 1), -1);
  EXPECT_EQ(errno, EMBXILADD);
  EXPECT_TRUE(control_.submissions().empty());
  // The connection is still good.
  EXPECT_EQ(plc.registers()[modbus_register::state], static_cast<int>(DaemonState::idle));
}

TEST_F(ModbusServerTest, BrokenClientsDoNotStopTheServerServingOthers) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, true));

  // Half a request, then hang up.
  int fd = raw_connect(server_->port());
  send_bytes(fd, {0x00, 0x01, 0x00, 0x00, 0x00});
  ::close(fd);
  // A Write Multiple Registers claiming more data than a frame can hold.
  fd = raw_connect(server_->port());
  send_bytes(fd, {0x00, 0x02, 0x00, 0x00, 0x00, 0xFF, 0x01, 0x10, 0x00, 0x00, 0x00, 0x7F, 0xFE,
                  0x01, 0x02, 0x03});
  const int garbage = fd;
  // Plain noise with a function code no Modbus device knows.
  const int noise = raw_connect(server_->port());
  send_bytes(noise, {0x12, 0x34, 0x56, 0x78, 0x00, 0x02, 0x09, 0x77});
  // Half a request, then silence: dropped after request_timeout.
  const int staller = raw_connect(server_->port());
  send_bytes(staller, {0x00, 0x03, 0x00});

  // Meanwhile the PLC is served as before, on its old connection and a new one.
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(plc.registers()[modbus_register::triggers_accepted], 1);
    std::this_thread::sleep_for(milliseconds(60));
  }
  ASSERT_TRUE(plc.write_coil(modbus_coil::trigger, false));
  Plc fresh(server_->port());
  ASSERT_TRUE(fresh.connected());
  ASSERT_TRUE(fresh.write_coil(modbus_coil::trigger, true));
  EXPECT_EQ(control_.submissions().size(), 2u);
  EXPECT_TRUE(plc.coil(modbus_coil::trigger));

  // The noise got an exception (illegal function) or was dropped; either way it did no harm.
  std::uint8_t answer[64];
  const ssize_t n = ::recv(noise, answer, sizeof answer, MSG_DONTWAIT);
  if (n >= 9) {
    EXPECT_EQ(answer[7], 0x77 | 0x80);
  }
  const auto deadline = Clock::now() + std::chrono::seconds(3);
  while (server_->counters().dropped < 3 && Clock::now() < deadline)
    std::this_thread::sleep_for(milliseconds(10));
  EXPECT_GE(server_->counters().dropped, 3u);  // the hang-up, the garbage, the staller
  for (const int open : {garbage, noise, staller})
    ::close(open);
}

TEST_F(ModbusServerTest, ConnectionsBeyondTheLimitAreClosed) {
  ModbusServerOptions options;
  options.max_clients = 2;
  start(options);
  Plc first(server_->port());
  Plc second(server_->port());
  ASSERT_TRUE(first.connected() && second.connected());
  EXPECT_EQ(first.registers()[modbus_register::state], static_cast<int>(DaemonState::idle));
  EXPECT_EQ(second.registers()[modbus_register::state], static_cast<int>(DaemonState::idle));
  Plc third(server_->port());  // the kernel accepts; the server closes it
  std::uint16_t word = 0;
  modbus_set_response_timeout(third.ctx(), 0, 500'000);
  EXPECT_EQ(modbus_read_input_registers(third.ctx(), 0, 1, &word), -1);
  EXPECT_EQ(server_->counters().rejected, 1u);
  EXPECT_EQ(first.registers()[modbus_register::state], static_cast<int>(DaemonState::idle));
}

TEST_F(ModbusServerTest, StopReturnsPromptlyAndClosesEveryConnection) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  EXPECT_EQ(plc.registers()[modbus_register::state], static_cast<int>(DaemonState::idle));
  const int staller = raw_connect(server_->port());
  send_bytes(staller, {0x00, 0x03, 0x00});
  const auto began = Clock::now();
  server_->stop();
  EXPECT_LT(Clock::now() - began, milliseconds(500));
  server_->stop();  // idempotent

  std::uint16_t word = 0;
  modbus_set_response_timeout(plc.ctx(), 0, 300'000);
  EXPECT_EQ(modbus_read_input_registers(plc.ctx(), 0, 1, &word), -1);
  Plc late(server_->port());
  EXPECT_FALSE(late.connected());
  ::close(staller);
  const auto destroyed = Clock::now();
  server_.reset();
  EXPECT_LT(Clock::now() - destroyed, milliseconds(500));
}

TEST_F(ModbusServerTest, DestructorStopsAServerInTheMiddleOfServing) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  std::atomic<bool> done = false;
  std::thread poller([&] {
    std::uint16_t word = 0;
    while (!done && modbus_read_input_registers(plc.ctx(), 0, 1, &word) == 1) {
    }
  });
  std::this_thread::sleep_for(milliseconds(50));
  const auto began = Clock::now();
  server_.reset();
  EXPECT_LT(Clock::now() - began, milliseconds(500));
  done = true;
  poller.join();
}

TEST_F(ModbusServerTest, FunctionsNotServedGetIllegalFunctionAtOnce) {
  const int fd = raw_connect(server_->port());
  // 7 (read exception status), which libmodbus never answers; 17 (report
  // server id), outside the map; 0x41, which no Modbus device knows.
  std::uint8_t transaction = 0;
  for (const std::uint8_t function : std::vector<std::uint8_t>{0x07, 0x11, 0x41}) {
    ++transaction;
    const auto began = Clock::now();
    send_bytes(fd, {0x00, transaction, 0x00, 0x00, 0x00, 0x02, 0x01, function});
    const auto answer = receive_within(fd, milliseconds(1000));
    const auto took = Clock::now() - began;
    EXPECT_LT(took, milliseconds(100)) << "function " << int{function};
    ASSERT_EQ(answer.size(), 9u) << "function " << int{function};
    EXPECT_EQ(answer[1], transaction);
    EXPECT_EQ(answer[5], 3);  // length: unit, function, code
    EXPECT_EQ(answer[6], 0x01);
    EXPECT_EQ(answer[7], function | 0x80);
    EXPECT_EQ(answer[8], MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
  }
  // A served function whose PDU is the wrong size: illegal data value, at once.
  const auto began = Clock::now();
  send_bytes(fd, {0x00, 0x09, 0x00, 0x00, 0x00, 0x03, 0x01, 0x04, 0x00});
  const auto answer = receive_within(fd, milliseconds(1000));
  EXPECT_LT(Clock::now() - began, milliseconds(100));
  ASSERT_EQ(answer.size(), 9u);
  EXPECT_EQ(answer[7], 0x84);
  EXPECT_EQ(answer[8], MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
  // A bad count of values (libmodbus's own check): also at once.
  const auto counted = Clock::now();
  send_bytes(fd, {0x00, 0x0A, 0x00, 0x00, 0x00, 0x06, 0x01, 0x04, 0x00, 0x00, 0x00, 0x00});
  const auto zero_count = receive_within(fd, milliseconds(1000));
  EXPECT_LT(Clock::now() - counted, milliseconds(100));
  ASSERT_EQ(zero_count.size(), 9u);
  EXPECT_EQ(zero_count[8], MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
  // Two reads in one segment: both answered, in order; the connection stays.
  send_bytes(fd, {0x00, 0x0B, 0x00, 0x00, 0x00, 0x06, 0x01, 0x04, 0x00, 0x00, 0x00, 0x01,
                  0x00, 0x0C, 0x00, 0x00, 0x00, 0x06, 0x01, 0x04, 0x00, 0x00, 0x00, 0x01});
  std::vector<std::uint8_t> both;
  const auto deadline = Clock::now() + milliseconds(1000);
  while (both.size() < 22 && Clock::now() < deadline) {
    const auto more = receive_within(fd, milliseconds(100));
    both.insert(both.end(), more.begin(), more.end());
  }
  ASSERT_EQ(both.size(), 22u);  // 2 x (7 + function + byte count + one register)
  EXPECT_EQ(both[1], 0x0B);
  EXPECT_EQ(both[12], 0x0C);
  EXPECT_EQ(both[10], static_cast<int>(DaemonState::idle));
  EXPECT_EQ(server_->counters().dropped, 0u);
  ::close(fd);
}

TEST_F(ModbusServerTest, BadMbapHeadersAreDroppedAtOnce) {
  const std::vector<std::vector<std::uint8_t>> bad = {
      {0x00, 0x01, 0x00, 0x01, 0x00, 0x06, 0x01, 0x04, 0x00, 0x00, 0x00, 0x01},  // protocol 1
      {0x00, 0x01, 0x12, 0x34, 0x00, 0x06, 0x01, 0x04, 0x00, 0x00, 0x00, 0x01},  // protocol 0x1234
      {0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x01},                                // length 1
      {0x00, 0x01, 0x00, 0x00, 0x01, 0x00, 0x01, 0x04},                          // length 256
  };
  std::uint64_t dropped = 0;
  for (const auto& request : bad) {
    const int fd = raw_connect(server_->port());
    const auto began = Clock::now();
    send_bytes(fd, request);
    bool closed = false;
    const auto answer = receive_within(fd, milliseconds(1000), &closed);
    EXPECT_TRUE(closed) << answer.size() << " bytes came back";
    EXPECT_LT(Clock::now() - began, milliseconds(100));
    ::close(fd);
    ++dropped;
  }
  EXPECT_EQ(server_->counters().dropped, dropped);
  EXPECT_EQ(server_->counters().requests, 0u);
  Plc plc(server_->port());
  EXPECT_EQ(plc.registers()[modbus_register::state], static_cast<int>(DaemonState::idle));
}

TEST_F(ModbusServerTest, ARequestMayArriveInPiecesWithinTheTimeoutFromItsFirstByte) {
  const int fd = raw_connect(server_->port());
  send_bytes(fd, {0x00, 0x01, 0x00, 0x00});
  std::this_thread::sleep_for(milliseconds(60));
  send_bytes(fd, {0x00, 0x06, 0x01, 0x04, 0x00});
  std::this_thread::sleep_for(milliseconds(60));
  send_bytes(fd, {0x00, 0x00, 0x01});
  const auto answer = receive_within(fd, milliseconds(1000));
  ASSERT_EQ(answer.size(), 11u);
  EXPECT_EQ(answer[7], 0x04);
  // A byte every 150 ms: not whole 200 ms after its first byte, dropped,
  // though no gap between bytes reaches the timeout.
  const auto began = Clock::now();
  bool closed = false;
  for (const std::uint8_t byte : std::vector<std::uint8_t>{0x00, 0x02, 0x00, 0x00, 0x00, 0x06}) {
    if (::send(fd, &byte, 1, MSG_NOSIGNAL) != 1) break;
    receive_within(fd, milliseconds(150), &closed);
    if (closed) break;
  }
  EXPECT_TRUE(closed);
  EXPECT_LT(Clock::now() - began, milliseconds(400));
  ::close(fd);
}

TEST_F(ModbusServerTest, DrippingClientsDoNotDelayThePlc) {
  Plc plc(server_->port());
  ASSERT_TRUE(plc.connected());
  // 100 reads of the whole input-register map, one every 10 ms.
  const auto measure = [&] {
    std::vector<std::chrono::microseconds> latencies;
    std::uint16_t words[modbus_register::count] = {};
    for (int i = 0; i < 100; ++i) {
      const auto began = Clock::now();
      const int read = modbus_read_input_registers(plc.ctx(), 0, modbus_register::count, words);
      latencies.push_back(
          std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - began));
      EXPECT_EQ(read, modbus_register::count) << modbus_strerror(errno);
      std::this_thread::sleep_for(milliseconds(10));
    }
    return latencies;
  };
  auto alone = measure();

  // Three clients each dripping a read one byte every 150 ms, connecting
  // again whenever the server drops them.
  std::atomic<bool> done = false;
  std::vector<std::thread> drippers;
  for (int d = 0; d < 3; ++d)
    drippers.emplace_back([&] {
      const std::uint8_t request[] = {0x00, 0x01, 0x00, 0x00, 0x00, 0x06,
                                      0x01, 0x04, 0x00, 0x00, 0x00, 0x01};
      while (!done) {
        const int fd = raw_connect(server_->port());
        for (const std::uint8_t byte : request) {
          if (done || ::send(fd, &byte, 1, MSG_NOSIGNAL) != 1) break;
          bool closed = false;
          receive_within(fd, milliseconds(150), &closed);
          if (closed) break;
        }
        ::close(fd);
      }
    });
  std::this_thread::sleep_for(milliseconds(100));  // the drippers are mid-request
  auto dripped = measure();
  done = true;
  for (auto& dripper : drippers)
    dripper.join();

  const auto p99_alone = p99_us(alone);
  const auto p99_dripped = p99_us(dripped);
  std::printf("PLC read p99: %lld us alone, %lld us beside 3 drippers\n",
              static_cast<long long>(p99_alone), static_cast<long long>(p99_dripped));
  RecordProperty("plc_read_p99_us_alone", std::to_string(p99_alone));
  RecordProperty("plc_read_p99_us_dripped", std::to_string(p99_dripped));
  EXPECT_LE(p99_dripped, 100'000);
  EXPECT_GE(server_->counters().dropped, 3u);  // the drippers, each past its deadline
}

// A connection to the server from `source`, a loopback address of this machine.
int connect_from(const char* source, int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  EXPECT_EQ(::inet_pton(AF_INET, source, &from.sin_addr), 1);
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof from), 0) << source;
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to), 0);
  return fd;
}

TEST_F(ModbusServerTest, TheAllowListRefusesOtherPeersAtAccept) {
  ModbusServerOptions options;
  options.allow = {"192.0.2.10", "127.0.0.1"};
  start(options);
  const std::vector<std::uint8_t> read = {0x00, 0x01, 0x00, 0x00, 0x00, 0x06,
                                          0x01, 0x04, 0x00, 0x00, 0x00, 0x01};

  const int stranger = connect_from("127.0.0.2", server_->port());
  send_bytes(stranger, read);
  bool closed = false;
  const auto nothing = receive_within(stranger, milliseconds(1000), &closed);
  EXPECT_TRUE(closed) << nothing.size() << " bytes came back";
  ::close(stranger);
  EXPECT_EQ(server_->counters().denied, 1u);
  EXPECT_EQ(server_->counters().connections, 0u);
  EXPECT_EQ(server_->counters().requests, 0u);

  const int plc = connect_from("127.0.0.1", server_->port());
  send_bytes(plc, read);
  const auto answer = receive_within(plc, milliseconds(1000));
  ASSERT_EQ(answer.size(), 11u);
  EXPECT_EQ(answer[7], 0x04);
  ::close(plc);
  EXPECT_EQ(server_->counters().denied, 1u);
  EXPECT_EQ(server_->counters().connections, 1u);
}

TEST(ModbusServerOptionsTest, AnAllowListEntryThatIsNoIpv4AddressIsAnError) {
  FakeScanControl control;
  ModbusServerOptions options;
  options.port = 0;
  options.allow = {"192.0.2.10", "plc.local"};
  auto started = ModbusServer::start(control, options);
  ASSERT_FALSE(started.has_value());
  EXPECT_EQ(started.error().key, "daemon.modbus_allow");
  EXPECT_THAT(started.error().message, ::testing::HasSubstr("plc.local"));
}

TEST(ModbusServerOptionsTest, BadAddressPortAndBusyPortAreErrorsNamingTheKey) {
  FakeScanControl control;
  ModbusServerOptions options;
  options.address = "plc.local";
  auto started = ModbusServer::start(control, options);
  ASSERT_FALSE(started.has_value());
  EXPECT_EQ(started.error().key, "daemon.modbus_address");
  EXPECT_THAT(started.error().message, ::testing::HasSubstr("plc.local"));

  options.address = "127.0.0.1";
  options.port = 70'000;
  started = ModbusServer::start(control, options);
  ASSERT_FALSE(started.has_value());
  EXPECT_EQ(started.error().key, "daemon.modbus_port");

  options.port = 0;
  auto first = ModbusServer::start(control, options);
  ASSERT_TRUE(first.has_value()) << first.error().describe();
  EXPECT_EQ((*first)->endpoint(), "tcp 127.0.0.1:" + std::to_string((*first)->port()));
  options.port = (*first)->port();
  started = ModbusServer::start(control, options);
  ASSERT_FALSE(started.has_value());
  EXPECT_EQ(started.error().key, "daemon.modbus_port");
  EXPECT_THAT(started.error().message,
              ::testing::AllOf(::testing::HasSubstr("cannot listen for the PLC"),
                               ::testing::HasSubstr(std::to_string(options.port))));
}

}  // namespace
}  // namespace psrig::daemon
