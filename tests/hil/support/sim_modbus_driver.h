#pragma once
// A simulated Modbus LED driver: a real libmodbus server on its own thread,
// over loopback TCP or Modbus RTU on a pseudo-terminal pair, serving the
// register map of config::ModbusRegisters (lights/README.md). The
// real modbus backend talks to it exactly as to a driver on the bench, and
// tests inject faults into it to see the backend fail safely.
//
// Like a real driver it keeps at most one LED on: a write that would turn
// on a second LED is refused (exception 3, illegal data value), changes
// nothing, and sets the interlock bit in the status register. Writing 1 to
// the all-off coil clears every enable coil (and reads back 0); coil writes
// outside the enable coils and the all-off coil are refused (exception 2).

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"
#include "psrig/lights/switch_log.h"

namespace psrig::test {

// Bits of the status input register. Nonzero means "fault" to the host.
inline constexpr std::uint16_t kModbusStatusDriverFault = 0x0001;  // LED open/short, overheating
inline constexpr std::uint16_t kModbusStatusInterlock = 0x0002;    // refused a second LED on

// What the driver does with the next requests instead of serving them.
enum class ModbusFault {
  none,
  no_answer,        // ignores the request: nothing changes, the host times out
  lost_reply,       // carries the request out, but its reply never leaves
  exception,        // refuses the request with an exception response
  bad_crc,          // carries it out and replies with a broken CRC (TCP: wrong transaction id)
  drop_connection,  // closes the TCP connection unserved (RTU: as no_answer)
};

struct SimModbusDriverOptions {
  std::string transport = "tcp";  // "tcp": 127.0.0.1, ephemeral port; "rtu": a pty pair
  int slave = 1;                  // requests for other slaves go unanswered
  int channels = 3;
  config::ModbusRegisters registers;  // registers.device_id is what the id register reads
  std::uint16_t firmware = 0x0102;    // the version register: major << 8 | minor
};

class SimModbusDriver {
 public:
  // Called from the server thread for every LED change, in order (offs
  // before ons), before the reply leaves: `level` is the LED's intensity
  // register over the full scale. Shaped for sim::SimulatedLeds::set_led.
  using SwitchCallback =
      std::function<void(int channel, bool on, double level, lights::Clock::time_point time)>;

  [[nodiscard]] static Result<std::unique_ptr<SimModbusDriver>> start(
      const SimModbusDriverOptions& options, SwitchCallback on_switch = {});
  ~SimModbusDriver();
  SimModbusDriver(const SimModbusDriver&) = delete;
  SimModbusDriver& operator=(const SimModbusDriver&) = delete;

  // lights.modbus for a host that should talk to this driver: transport,
  // host and port or the pty's slave path, slave id, register map.
  [[nodiscard]] config::ModbusLights host_config() const;
  [[nodiscard]] int port() const { return port_; }                     // TCP
  [[nodiscard]] const std::string& device() const { return device_; }  // RTU

  // The driver's own view of its outputs.
  [[nodiscard]] std::vector<int> leds_on() const;
  [[nodiscard]] std::vector<std::uint16_t> intensities() const;  // raw register values
  [[nodiscard]] std::uint16_t status() const;
  void set_status(std::uint16_t status);  // e.g. kModbusStatusDriverFault
  // Every LED switch the driver made (its record of "never two on").
  [[nodiscard]] const lights::SwitchLog& log() const { return log_; }

  // The next `requests` requests addressed to this driver (-1: all, until
  // cleared) meet `fault`; `exception_code` for ModbusFault::exception
  // (4: server failure).
  void inject(ModbusFault fault, int requests = -1, int exception_code = 4);
  void clear_fault() { inject(ModbusFault::none, 0); }

  // Requests addressed to this driver, of one function code (-1: any).
  [[nodiscard]] int requests(int function = -1) const;
  [[nodiscard]] int interlock_refusals() const;
  [[nodiscard]] int connections() const;  // TCP connections accepted so far

 private:
  struct Link;  // libmodbus context, mapping, sockets
  SimModbusDriver(const SimModbusDriverOptions& options, SwitchCallback on_switch);
  [[nodiscard]] Status open();
  void serve();
  // Serves one request from `fd`; false when the connection should close.
  [[nodiscard]] bool serve_request(int fd, const std::uint8_t* query, int length);
  struct Change {
    int channel;
    bool on;
    double level;
  };
  // Carries a request out (mutex_ held) and returns its reply.
  [[nodiscard]] std::vector<std::uint8_t> apply(int fd, const std::uint8_t* query, int length,
                                                std::vector<Change>& changes);
  [[nodiscard]] std::vector<std::uint8_t> capture_exception(int fd, const std::uint8_t* query,
                                                            int code);
  [[nodiscard]] double level_locked(int channel) const;
  // The mapping's cells for a channel's enable coil and for the status register.
  [[nodiscard]] std::uint8_t& coil_locked(int channel) const;
  [[nodiscard]] std::uint16_t& status_locked() const;

  SimModbusDriverOptions options_;
  SwitchCallback on_switch_;
  std::unique_ptr<Link> link_;
  std::string device_;
  int port_ = 0;
  int first_coil_ = 0;   // the mapping's first coil address
  int first_input_ = 0;  // the mapping's first input register address
  std::thread thread_;
  std::atomic<bool> stopping_{false};

  mutable std::mutex mutex_;  // the mapping, the fault plan, the counters
  ModbusFault fault_ = ModbusFault::none;
  int fault_left_ = 0;  // -1: until cleared
  int exception_code_ = 4;
  std::vector<int> requests_by_function_ = std::vector<int>(256, 0);
  int interlock_refusals_ = 0;
  int connections_ = 0;
  lights::SwitchLog log_;
};

}  // namespace psrig::test
