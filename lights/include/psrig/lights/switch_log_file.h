#pragma once
// The simulated lights' switches in a file (`[lights.sim] switch_log`), so
// that they outlive the process that made them: a test can kill -9 psrigd
// with an LED lit and read from outside how long it stayed on, and who
// switched it off (the unit's `psrig lights --off`, another process).
//
// One line per switch, appended with one write(2) on an O_APPEND file, so
// lines from several processes never interleave and a line is in the file
// once the switch returns:
//
//   MONOTONIC_NS REALTIME_NS PID CHANNEL STATE
//   12474019735512 1795000000123456789 4242 1 on
//   12474219803370 1795000000323524647 4242 all off
//
// MONOTONIC_NS is CLOCK_MONOTONIC (std::chrono::steady_clock here), the
// same for every process on the machine; REALTIME_NS is CLOCK_REALTIME, for
// people; CHANNEL is 0-based, or `all` (only with `off`).

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <sys/types.h>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/lights/switch_log.h"

namespace psrig::lights {

class SwitchLogFile {
 public:
  // Opens `path` for appending, creating it (mode 0644) if need be.
  [[nodiscard]] static Result<std::unique_ptr<SwitchLogFile>> open(
      const std::filesystem::path& path);
  ~SwitchLogFile();
  SwitchLogFile(const SwitchLogFile&) = delete;
  SwitchLogFile& operator=(const SwitchLogFile&) = delete;

  // Appends one line (channel -1: all). A failed write is logged, not
  // returned: the log is for looking at, the LEDs must switch regardless.
  void record(int channel, bool on, Clock::time_point at = Clock::now()) const;

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  SwitchLogFile(std::filesystem::path path, int fd) : path_(std::move(path)), fd_(fd) {}
  std::filesystem::path path_;
  int fd_;
};

// One line of the file.
struct LoggedSwitch {
  SwitchEvent event;  // time: the monotonic stamp, comparable with Clock::now()
  std::chrono::system_clock::time_point wall;
  pid_t pid = 0;
};

// The file's lines in order; a malformed line is an error naming the file
// and the line. A missing file is no switches.
[[nodiscard]] Result<std::vector<LoggedSwitch>> read_switch_log_file(
    const std::filesystem::path& path);
// The switches as a SwitchLog, for overlap() and on_now().
void replay(const std::vector<LoggedSwitch>& switches, SwitchLog& log);

}  // namespace psrig::lights
