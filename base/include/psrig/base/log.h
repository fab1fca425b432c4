#pragma once
// One logger for the whole program with a category per module
// ("processing", "capture", ...). All categories share one stderr sink, so
// the format (and, for the daemon, journald priority prefixes) is set once.

#include <memory>
#include <string>

#include <spdlog/spdlog.h>

namespace psrig {

// The logger of one category, created on first use.
std::shared_ptr<spdlog::logger> logger(const std::string& category);

// Sets the level of every category, present and future: "trace" … "off".
void set_log_level(spdlog::level::level_enum level);

// For psrigd: every line on stderr starts with its syslog priority, "<3>"
// for errors, "<4>" warnings, "<6>" info, "<7>" debug and trace
// (sd-daemon(3)), which journald stores as the entry's priority, so the
// level name is left out. The command line keeps its "name: level: text".
void log_to_stderr_for_journal();

// Whether stderr is the journal's stream (JOURNAL_STREAM names its device
// and inode), so the daemon adds the prefixes only where they are read.
[[nodiscard]] bool stderr_is_journal();

// The formatter log_to_stderr_for_journal() sets: "<N>name: text".
[[nodiscard]] std::unique_ptr<spdlog::formatter> journal_formatter();

}  // namespace psrig
