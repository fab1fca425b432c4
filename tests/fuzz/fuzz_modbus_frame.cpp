// Modbus TCP, as psrigd's PLC server takes it: ModbusServer::start() on
// 127.0.0.1 (port 0: the kernel picks) over a stand-in ScanControl, started
// once; each input is written on a new connection as it is (one or more
// MBAP frames, or garbage), the writing side is shut, and the answer read
// until the server closes (a short deadline otherwise). The stand-in's state
// moves with every call, so the status registers, the trigger and the
// lights-off edges see every DaemonState, queue lengths, and refusals.
//
// Besides crashes and sanitizer reports (the server's thread included),
// one oracle: what the server sends is whole Modbus TCP frames, protocol
// id 0, each answering a function code the client could have sent (the code,
// or the code with 0x80 for an exception).

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "fuzz_support.h"
#include "psrig/daemon/modbus_server.h"

namespace {

using namespace psrig::daemon;
using namespace psrig::catalogue;

class StandInControl final : public ScanControl {
 public:
  DaemonStatus status() const override {
    const auto n = calls_.fetch_add(1);
    DaemonStatus s;
    s.state = static_cast<DaemonState>(n % 6);
    s.step = "light 2 of 3";
    s.progress_percent = static_cast<int>(n % 101);
    if (n % 3 == 0) s.current_scan = static_cast<std::int64_t>(n);
    if (n % 4 != 0) s.last_scan = static_cast<std::int64_t>(n % 5 == 0 ? 0xFFFFFFFFFFLL : n);
    s.last_error_code = static_cast<ScanErrorCode>(n % 9);
    s.scans_completed = n * 0x10001;
    s.scans_failed = n / 2;
    s.queue_length = n % 5;
    s.uptime = std::chrono::seconds(n);
    return s;
  }
  psrig::Result<std::int64_t> submit(ScanSubmission) override {
    const auto n = calls_.fetch_add(1);
    if (n % 3 == 0) {
      return std::unexpected(
          psrig::internal_error("the queue is full").with(psrig::ErrorCode::queue_full));
    }
    return static_cast<std::int64_t>(n);
  }
  psrig::Status lights_off() override {
    if (calls_.fetch_add(1) % 2) return std::unexpected(psrig::internal_error("lights backend failed").with(psrig::ErrorCode::lights));
    return {};
  }

 private:
  mutable std::atomic<std::uint64_t> calls_{0};
};

struct Fixture {
  StandInControl control;
  std::unique_ptr<ModbusServer> server;
  Fixture() {
    ModbusServerOptions options;
    options.address = "127.0.0.1";
    options.port = 0;
    options.request_timeout = std::chrono::milliseconds(50);
    auto started = ModbusServer::start(control, options);
    if (!started) {
      std::fprintf(stderr, "fuzz_modbus_frame: %s\n", started.error().describe().c_str());
      std::abort();
    }
    server = std::move(*started);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void check_frames(const std::string& answer) {
  std::size_t at = 0;
  while (answer.size() - at >= 8) {
    const auto byte = [&](std::size_t i) { return static_cast<unsigned>(static_cast<unsigned char>(answer[at + i])); };
    const unsigned protocol = byte(2) << 8 | byte(3);
    const unsigned length = byte(4) << 8 | byte(5);
    const unsigned function = byte(7);
    if (protocol != 0 || length < 2 || length > 254 || function == 0 || function == 0x80) {
      std::fprintf(stderr,
                   "fuzz_modbus_frame: answer frame at byte %zu: protocol %u, length %u, function %u\n",
                   at, protocol, length, function);
      std::abort();
    }
    at += 6 + length;
  }
}

// Exit (libFuzzer's, or the replay's) destroys statics in the reverse order
// of their making, and the server's threads make some of their own while
// they work (a logger, the lights' emergency-stop registry), after the
// fixture was made: destroyed first, under threads still running. So the
// servers are stopped by an exit handler registered anew with every input,
// which therefore runs before any static made while the inputs ran is
// destroyed. (One small entry per input; the second run finds nothing to stop.)
void stop_servers() {
  fixture().server.reset();  // stops and destroys it while everything it uses is alive
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  psrig::fuzz::quiet_logs();
  (void)fixture();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::atexit(stop_servers);
  static const int port = fixture().server->port();
  check_frames(psrig::fuzz::exchange(port, data, size, 500));
  return 0;
}
