#include "psrig/base/log.h"

#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string_view>
#include <sys/stat.h>
#include <unistd.h>

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_sinks.h>

namespace psrig {
namespace {

std::mutex& registry_mutex() {
  static std::mutex mutex;
  return mutex;
}

spdlog::sink_ptr shared_sink() {
  static auto sink = [] {
    auto s = std::make_shared<spdlog::sinks::stderr_sink_mt>();
    s->set_pattern("%n: %l: %v");
    return s;
  }();
  return sink;
}

spdlog::level::level_enum& current_level() {
  static spdlog::level::level_enum level = spdlog::level::info;
  return level;
}

// "%*": the syslog priority of the message's level, as sd-daemon.h's SD_ERR etc.
class JournalPriorityFlag : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&,
              spdlog::memory_buf_t& dest) override {
    const std::string_view prefix = [&] {
      switch (msg.level) {
        case spdlog::level::critical:
          return "<2>";
        case spdlog::level::err:
          return "<3>";
        case spdlog::level::warn:
          return "<4>";
        case spdlog::level::info:
          return "<6>";
        default:
          return "<7>";  // debug, trace
      }
    }();
    dest.append(prefix.data(), prefix.data() + prefix.size());
  }
  [[nodiscard]] std::unique_ptr<custom_flag_formatter> clone() const override {
    return std::make_unique<JournalPriorityFlag>();
  }
};

}  // namespace

std::shared_ptr<spdlog::logger> logger(const std::string& category) {
  std::lock_guard lock(registry_mutex());
  if (auto existing = spdlog::get(category)) return existing;
  auto created = std::make_shared<spdlog::logger>(category, shared_sink());
  created->set_level(current_level());
  spdlog::register_logger(created);
  return created;
}

void set_log_level(spdlog::level::level_enum level) {
  std::lock_guard lock(registry_mutex());
  current_level() = level;
  spdlog::apply_all([level](const std::shared_ptr<spdlog::logger>& l) { l->set_level(level); });
}

std::unique_ptr<spdlog::formatter> journal_formatter() {
  auto formatter = std::make_unique<spdlog::pattern_formatter>();
  formatter->add_flag<JournalPriorityFlag>('*').set_pattern("%*%n: %v");
  return formatter;
}

void log_to_stderr_for_journal() {
  shared_sink()->set_formatter(journal_formatter());
}

bool stderr_is_journal() {
  const char* stream = std::getenv("JOURNAL_STREAM");
  if (!stream) return false;
  unsigned long long device = 0;
  unsigned long long inode = 0;
  if (std::sscanf(stream, "%llu:%llu", &device, &inode) != 2) return false;
  struct stat info {};
  if (::fstat(STDERR_FILENO, &info) != 0) return false;
  return info.st_dev == device && info.st_ino == inode;
}

}  // namespace psrig
