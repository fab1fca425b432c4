#pragma once
// The PLC's view of psrigd: a Modbus TCP server on its own thread, which
// polls every client without blocking, assembles each one's requests from
// its own buffer and has libmodbus answer only whole frames. It turns a
// rising edge of the trigger coil into one submitted scan and shows the
// daemon's status in discrete inputs and input registers. The register map
// is daemon/modbus-register-map.md; the numbers below are that map and,
// like ScanControl's enums, never move.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/daemon/scan_control.h"

namespace psrig::daemon {

// Coils (read/write, FC 1, 5, 15).
namespace modbus_coil {
inline constexpr int trigger = 0;     // rising edge: submit one scan
inline constexpr int lights_off = 1;  // rising edge: abort the scan, every LED off
inline constexpr int count = 2;
}  // namespace modbus_coil

// Discrete inputs (read-only bits, FC 2).
namespace modbus_input {
inline constexpr int ready = 0;     // idle or error, nothing queued: a trigger starts a scan now
inline constexpr int busy = 1;      // scanning, processing, or scans queued
inline constexpr int error = 2;     // the last scan failed, or the PLC's last command was refused
inline constexpr int scanning = 3;  // LEDs and camera in use: keep the swatch still
inline constexpr int count = 4;
}  // namespace modbus_input

// Input registers (read-only words, FC 4). 32-bit values take two registers,
// high word first (at the lower address).
namespace modbus_register {
inline constexpr int state = 0;            // DaemonState
inline constexpr int progress = 1;         // percent of the running scan, 0..100
inline constexpr int last_scan_id = 2;     // 32-bit, 0: none yet
inline constexpr int error_code = 4;       // ScanErrorCode while the error input is on, else 0
inline constexpr int scans_completed = 5;  // 32-bit, since start-up
inline constexpr int queue_length = 7;     // scans waiting, not counting the running one
inline constexpr int uptime_seconds = 8;   // 32-bit: the heartbeat, it moves while the daemon lives
inline constexpr int scans_failed = 10;    // 32-bit, since start-up
inline constexpr int current_scan_id = 12;    // 32-bit, 0: none running
inline constexpr int triggers_accepted = 14;  // 16-bit, wraps: edges that queued a scan
inline constexpr int triggers_refused = 15;   // 16-bit, wraps: edges the daemon refused
inline constexpr int triggered_scan_id = 16;  // 32-bit: the scan the last accepted edge queued
inline constexpr int count = 18;
}  // namespace modbus_register

struct ModbusServerOptions {
  std::string address = "127.0.0.1";  // an IPv4 address to listen on; "0.0.0.0" for all
  int port = 502;                     // 0: the kernel picks a free one (tests)
  int max_clients = 8;                // further connections are closed at once
  // How long one request may take to arrive whole from its first byte; a
  // client slower than that is dropped. Each client is read without
  // blocking, so a slow one never delays another.
  std::chrono::milliseconds request_timeout{200};
  // IPv4 addresses of the PLCs that may connect; empty: anyone. Others are
  // closed at accept.
  std::vector<std::string> allow = {};
};

// What the server has done, for the daemon's status page and the tests.
struct ModbusServerCounters {
  std::uint64_t connections = 0;  // accepted, ever
  std::uint64_t requests = 0;     // answered or refused with an exception
  std::uint64_t dropped = 0;      // connections closed for garbage, a stall or a hang-up
  std::uint64_t rejected = 0;     // connections over max_clients
  std::uint64_t denied = 0;       // connections from peers not in options.allow
  std::uint64_t triggers_accepted = 0;
  std::uint64_t triggers_refused = 0;
  std::uint64_t lights_off = 0;  // lights-off edges acted on
  int clients = 0;               // connected now
};

class ModbusServer {
 public:
  // Listens on options.address:options.port and serves on a thread of its
  // own until stop() or destruction. `control` must outlive the server.
  [[nodiscard]] static Result<std::unique_ptr<ModbusServer>> start(
      ScanControl& control, const ModbusServerOptions& options);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // Closes every connection and the listening socket and joins the thread;
  // returns at once (the thread waits only in poll, which stop() wakes).
  // Idempotent.
  void stop();

  // The port listened on (the chosen one when options.port was 0).
  [[nodiscard]] int port() const { return port_; }
  // "tcp 127.0.0.1:502": for the log and the status page.
  [[nodiscard]] std::string endpoint() const;
  [[nodiscard]] ModbusServerCounters counters() const;

 private:
  struct Impl;
  explicit ModbusServer(std::unique_ptr<Impl> impl, int port);
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

}  // namespace psrig::daemon
