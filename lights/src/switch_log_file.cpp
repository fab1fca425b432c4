#include "psrig/lights/switch_log_file.h"

#include <cerrno>
#include <charconv>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "psrig/base/log.h"

namespace psrig::lights {

Result<std::unique_ptr<SwitchLogFile>> SwitchLogFile::open(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0)
    return std::unexpected(io_error(path, std::string("cannot open the switch log "
                                                      "(lights.sim.switch_log) for appending: ") +
                                              std::strerror(errno)));
  return std::unique_ptr<SwitchLogFile>(new SwitchLogFile(path, fd));
}

SwitchLogFile::~SwitchLogFile() {
  ::close(fd_);
}

void SwitchLogFile::record(int channel, bool on, Clock::time_point at) const {
  const auto monotonic =
      std::chrono::duration_cast<std::chrono::nanoseconds>(at.time_since_epoch()).count();
  const auto realtime = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
  const std::string line = std::to_string(monotonic) + " " + std::to_string(realtime) + " " +
                           std::to_string(::getpid()) + " " +
                           (channel < 0 ? std::string("all") : std::to_string(channel)) +
                           (on ? " on\n" : " off\n");
  // One write: O_APPEND puts the whole line at the end, whoever else appends.
  const auto written = ::write(fd_, line.data(), line.size());
  if (written != static_cast<ssize_t>(line.size()))
    logger("lights")->warn("{}: cannot append to the switch log: {}", path_.string(),
                           written < 0 ? std::strerror(errno) : "short write");
}

Result<std::vector<LoggedSwitch>> read_switch_log_file(const std::filesystem::path& path) {
  std::vector<LoggedSwitch> switches;
  std::ifstream file(path);
  if (!file) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return switches;
    return std::unexpected(io_error(path, "cannot read the switch log"));
  }
  std::string line;
  for (int number = 1; std::getline(file, line); ++number) {
    std::istringstream words(line);
    long long monotonic = 0, realtime = 0;
    long pid = 0;
    std::string channel, state, extra;
    if (!(words >> monotonic >> realtime >> pid >> channel >> state) || (words >> extra) ||
        (state != "on" && state != "off")) {
      Error error = bad_input(path, "", "malformed switch log line: \"" + line + "\"");
      error.line = number;
      return std::unexpected(error);
    }
    LoggedSwitch s;
    s.event.time = Clock::time_point(std::chrono::nanoseconds(monotonic));
    s.event.on = state == "on";
    s.wall = std::chrono::system_clock::time_point(
        std::chrono::duration_cast<std::chrono::system_clock::duration>(
            std::chrono::nanoseconds(realtime)));
    s.pid = static_cast<pid_t>(pid);
    if (channel == "all") {
      s.event.channel = -1;
    } else {
      const auto [end, failed] =
          std::from_chars(channel.data(), channel.data() + channel.size(), s.event.channel);
      if (failed != std::errc() || end != channel.data() + channel.size() || s.event.channel < 0) {
        Error error = bad_input(path, "", "malformed channel in switch log line: \"" + line + "\"");
        error.line = number;
        return std::unexpected(error);
      }
    }
    if (s.event.channel < 0 && s.event.on) {
      Error error = bad_input(path, "", "\"all on\" in switch log line: \"" + line + "\"");
      error.line = number;
      return std::unexpected(error);
    }
    switches.push_back(s);
  }
  return switches;
}

void replay(const std::vector<LoggedSwitch>& switches, SwitchLog& log) {
  for (const auto& s : switches)
    log.record(s.event);
}

}  // namespace psrig::lights
