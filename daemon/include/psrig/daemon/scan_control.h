#pragma once
// What the daemon's front ends (the HTTP API, the PLC's Modbus server, the
// systemd status line) see of the scanning service: its state, and the two
// things they may ask of it. One scan runs at a time; submissions queue.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/catalogue/scan_submission.h"

namespace psrig::daemon {

// Numbered because the PLC reads them as register values: never renumber.
enum class DaemonState : std::uint16_t {
  starting = 0,
  idle = 1,
  scanning = 2,    // LEDs and camera in use
  processing = 3,  // frames written, maps being computed
  error = 4,       // the last scan failed; the next submission clears it
  stopping = 5,
};

[[nodiscard]] const char* to_string(DaemonState state);

struct DaemonStatus {
  DaemonState state = DaemonState::starting;
  std::string step;                          // the running scan's step, e.g. "light 2 of 3"
  int progress_percent = 0;                  // of the running scan, 0..100
  std::optional<std::int64_t> current_scan;  // catalogue id of the running scan
  std::optional<std::int64_t> last_scan;     // catalogue id of the last finished (or failed) one
  catalogue::ScanErrorCode last_error_code = catalogue::ScanErrorCode::none;
  std::string last_error;             // message of the last failure, empty if none
  std::uint64_t scans_completed = 0;  // since start-up
  std::uint64_t scans_failed = 0;
  std::size_t queue_length = 0;  // waiting, not counting the running scan
  std::chrono::steady_clock::duration uptime{};
};

class ScanControl {
 public:
  virtual ~ScanControl() = default;
  [[nodiscard]] virtual DaemonStatus status() const = 0;
  // Queues a scan; its catalogue id at once (the row exists, status
  // "queued"), or an error (stopping; a full queue, the service's state
  // rather than the request's fault, says ErrorCode::queue_full).
  [[nodiscard]] virtual Result<std::int64_t> submit(catalogue::ScanSubmission submission) = 0;
  // Aborts the running scan (if any) and the queued ones, and turns every
  // LED off.
  [[nodiscard]] virtual Status lights_off() = 0;
};

}  // namespace psrig::daemon
