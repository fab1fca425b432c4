#include "psrig/processing/log.h"

#include <mutex>

#include <spdlog/sinks/stdout_sinks.h>

namespace psrig::processing {
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

}  // namespace psrig::processing
