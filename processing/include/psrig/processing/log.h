#pragma once
// One logger for the whole program with a category per module
// ("processing", "capture", ...). All categories share one stderr sink, so
// the format (and, for the daemon, journald priority prefixes) is set once.

#include <memory>
#include <string>

#include <spdlog/spdlog.h>

namespace psrig::processing {

// The logger of one category, created on first use.
std::shared_ptr<spdlog::logger> logger(const std::string& category);

// Sets the level of every category, present and future: "trace" … "off".
void set_log_level(spdlog::level::level_enum level);

}  // namespace psrig::processing
