#pragma once
// A scan as it is asked for, and why one failed: what the catalogue keeps
// of every scan, and the codes the PLC reads (never renumber them).

#include <cstdint>
#include <string>
#include <vector>

namespace psrig::catalogue {

// Why the last scan failed, as the PLC reads it. Never renumber.
enum class ScanErrorCode : std::uint16_t {
  none = 0,
  camera = 1,      // no frame, timeout, device gone
  lights = 2,      // LED backend failed
  storage = 3,     // disk full, permission, catalogue write
  processing = 4,  // frames could not be turned into maps
  aborted = 5,     // stopped by DELETE, SIGTERM or lights-off
  queue_full = 6,  // a submission refused
  config = 7,      // the configuration cannot drive the rig
  internal = 8,
};

[[nodiscard]] const char* to_string(ScanErrorCode code);

struct ScanSubmission {
  std::string sample_id;  // may be empty
  std::string description;
  std::vector<std::string> tags;
  std::string source;  // "http", "modbus", "cli": for the log and the catalogue
  // Not a scan but a calibration (CalibrationJobs' id): it queues with the
  // scans because it needs the rig. 0: a scan.
  std::int64_t calibration = 0;
};

}  // namespace psrig::catalogue
